//! Parity of the English pipeline with spaCy en_core_web_sm 3.8.0 on the
//! golden parses, and its behaviour on awkward input.

use crate::common;
use mapvlm::metrics::FramingParser;

use mapvlm::models::EN_CORE_WEB_SM;
use mapvlm::nlp::en::EnPipeline;
use mapvlm::nlp::Token;

const GOLDEN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/golden/parse.dev.jsonl"
);

fn pipeline() -> EnPipeline {
    EnPipeline::load(&common::model_dir(EN_CORE_WEB_SM)).expect("the model pack loads")
}

#[derive(serde::Deserialize)]
struct Golden {
    text: String,
    tokens: Vec<Token>,
}

fn golden() -> Vec<Golden> {
    std::fs::read_to_string(GOLDEN)
        .expect("golden parses")
        .lines()
        .map(|l| serde_json::from_str(l).expect("golden line"))
        .collect()
}

/// The framed actions of pg2s.md: each VERB with its dobj/nsubj children.
fn frame(tokens: &[Token]) -> Vec<Vec<String>> {
    let mut actions = Vec::new();
    for (i, token) in tokens.iter().enumerate() {
        if token.pos != "VERB" {
            continue;
        }
        let args: Vec<String> = tokens
            .iter()
            .enumerate()
            .filter(|(j, t)| *j != i && t.head == i && (t.dep == "dobj" || t.dep == "nsubj"))
            .map(|(_, t)| t.text.clone())
            .collect();
        if !args.is_empty() {
            let mut action = vec![token.text.clone()];
            action.extend(args);
            actions.push(action);
        }
    }
    actions
}

#[test]
fn golden_parses_agree() {
    let nlp = pipeline();
    let golden = golden();
    let (mut total, mut tag, mut pos, mut dep, mut head) = (0, 0, 0, 0, 0);
    for g in &golden {
        let got = nlp.parse(&g.text).expect("parse");
        let texts: Vec<(&str, &str)> = got.iter().map(|t| (&*t.text, &*t.ws)).collect();
        let want: Vec<(&str, &str)> = g.tokens.iter().map(|t| (&*t.text, &*t.ws)).collect();
        assert_eq!(texts, want, "tokens of {:?}", g.text);
        assert_eq!(frame(&got), frame(&g.tokens), "framing of {:?}", g.text);
        for (a, b) in got.iter().zip(&g.tokens) {
            total += 1;
            tag += usize::from(a.tag == b.tag);
            pos += usize::from(a.pos == b.pos);
            dep += usize::from(a.dep == b.dep);
            head += usize::from(a.head == b.head);
        }
    }
    let least = total * 999 / 1000;
    eprintln!("tokens {total}: tag {tag} pos {pos} dep {dep} head {head}");
    assert!(tag >= least && pos >= least && dep >= least && head >= least);
}

#[test]
fn the_documented_quirk_frames_as_spacy() {
    let nlp = pipeline();
    let tokens = nlp
        .parse("put on the snug left shoe carefully.")
        .expect("parse");
    assert_eq!(frame(&tokens), vec![vec!["left", "put", "shoe"]]);
}

#[test]
fn awkward_input_does_not_panic() {
    let nlp = pipeline();
    let long = "walk to the kitchen and pick up the red apple . ".repeat(1000);
    let cases = [
        "",
        " ",
        "   \n\t ",
        "!!!???...",
        "\u{0}\u{1}\u{7f}\u{1c}",
        "😀 put the 🍎 in the fridge 👍🏽",
        "Mischen Sie 牛奶 и хлеб with اللبن",
        "http://example.com/a?b=c#d e-mail me@x.org",
        long.as_str(),
    ];
    for case in cases {
        let tokens = nlp.parse(case).expect("parse");
        let rebuilt: String = tokens
            .iter()
            .map(|t| format!("{}{}", t.text, t.ws))
            .collect();
        assert_eq!(rebuilt, case, "text round trip");
        assert!(tokens.iter().all(|t| t.head < tokens.len()));
    }
}

#[test]
fn a_missing_model_folder_names_the_file() {
    let Err(err) = EnPipeline::load(std::path::Path::new("/nonexistent/en")) else {
        panic!("loading from a missing folder must fail");
    };
    let message = err.to_string();
    assert!(message.contains("/nonexistent/en"), "{message}");
    assert!(message.contains("mapvlm models fetch"), "{message}");
}

mod arbitrary_text {
    use std::sync::OnceLock;

    use proptest::prelude::*;

    use super::*;

    fn shared() -> &'static EnPipeline {
        static NLP: OnceLock<EnPipeline> = OnceLock::new();
        NLP.get_or_init(pipeline)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn any_text_round_trips(text in "\\PC{0,40}|[ a-zA-Z.,!?'\"()\\-\\n\\t]{0,60}|.{0,30}") {
            let tokens = shared().parse(&text).expect("parse");
            let rebuilt: String = tokens.iter().map(|t| format!("{}{}", t.text, t.ws)).collect();
            prop_assert_eq!(rebuilt, text);
            prop_assert!(tokens.iter().all(|t| t.head < tokens.len() && !t.text.is_empty()));
        }
    }
}
