//! The event-stream parser and both providers' stream decoders on any body:
//! nothing panics; the events do not depend on how the body is cut into
//! network pieces; and the API key never survives into the answer's text,
//! its pieces or what is shown, however the events spell or split it.
#![no_main]

use std::sync::Mutex;

use libfuzzer_sys::fuzz_target;
use mapvlm::agents::provider::{Assembler, EventDecoder, SseEvent, SseParser, StreamStep};
use mapvlm::agents::{anthropic, openai, Secret};

const KEY: &str = "sk-fuzz-0123456789";

/// The events of a body cut into `pieces`, and whether it was refused as
/// too long (the events before the refusal are kept).
fn events(pieces: &[&[u8]]) -> (Vec<SseEvent>, bool) {
    let mut parser = SseParser::default();
    let mut events = Vec::new();
    for piece in pieces {
        if parser.feed(piece, &mut events).is_err() {
            return (events, true);
        }
    }
    events.extend(parser.finish());
    (events, false)
}

fn decode(events: &[SseEvent], decoder: EventDecoder) {
    let shown = Mutex::new(String::new());
    let sink = |piece: &str| {
        if let Ok(mut all) = shown.lock() {
            all.push_str(piece);
        }
    };
    let mut answer = Assembler::new(&sink, Secret::new(KEY));
    for event in events {
        match decoder(event, &mut answer) {
            Ok(StreamStep::Done) | Err(_) => break,
            Ok(_) => {}
        }
    }
    if let Ok(done) = answer.finish("fuzz", "m") {
        assert!(!done.text.contains(KEY), "the key in the text");
        assert!(done.chunks.iter().all(|c| !c.text.contains(KEY)));
        let joined: String = done.chunks.iter().map(|c| c.text.as_str()).collect();
        assert_eq!(joined, done.text, "the pieces are the text");
    }
    let shown = shown.lock().map(|s| s.clone()).unwrap_or_default();
    assert!(!shown.contains(KEY), "the key shown");
}

fuzz_target!(|input: &[u8]| {
    let Some((&cut, body)) = input.split_first() else {
        return;
    };
    let whole = events(&[body]);
    let size = usize::from(cut % 16) + 1;
    let pieces: Vec<&[u8]> = body.chunks(size).collect();
    assert_eq!(events(&pieces), whole, "cut into pieces of {size}");
    let (whole, _) = whole;
    decode(&whole, openai::apply_event);
    decode(&whole, anthropic::apply_event);
});
