//! The sentence encoder against the reference embeddings of
//! `shared/golden/embed.dev.jsonl`, and its batching, caching and limits.

use std::io::Read;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use mapvlm::metrics::SentenceEncoder;
use mapvlm::models::MPNET;
use mapvlm::nlp::mpnet::{MpnetEncoder, MpnetError, MpnetOptions};
use serde::Deserialize;

const GOLDEN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/golden/embed.dev.jsonl"
);

use crate::common;

/// The encoder folder of the model pack.
fn encoder_dir() -> PathBuf {
    common::model_dir(MPNET)
}

/// One shared encoder for the tests that do not look at the cache.
fn shared_encoder() -> &'static MpnetEncoder {
    static ENCODER: OnceLock<MpnetEncoder> = OnceLock::new();
    ENCODER.get_or_init(|| {
        let dir = encoder_dir();
        MpnetEncoder::load(&dir).unwrap_or_else(|err| panic!("loading {}: {err}", dir.display()))
    })
}

#[derive(Deserialize)]
struct GoldenEmbedding {
    text: String,
    embedding: Vec<f32>,
}

fn golden() -> Vec<GoldenEmbedding> {
    let text = std::fs::read_to_string(GOLDEN).expect("golden embeddings");
    text.lines()
        .map(|line| serde_json::from_str(line).expect("golden line"))
        .collect()
}

fn cosine(a: &[f32], b: &[f32]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| *x as f64 * *y as f64).sum();
    let norm = |v: &[f32]| v.iter().map(|x| *x as f64 * *x as f64).sum::<f64>().sqrt();
    dot / (norm(a) * norm(b))
}

fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn embeddings_match_the_reference() {
    let encoder = shared_encoder();
    let golden = golden();
    assert_eq!(golden.len(), 64);
    let sentences: Vec<&str> = golden.iter().map(|g| g.text.as_str()).collect();
    let ours = encoder.encode(&sentences).expect("encode");
    let mut min_cosine = f64::INFINITY;
    let mut max_diff = 0f32;
    for (g, v) in golden.iter().zip(&ours) {
        assert_eq!(v.len(), 768);
        let c = cosine(&g.embedding, v);
        assert!(c >= 0.99999, "cosine {c} for {:?}", g.text);
        min_cosine = min_cosine.min(c);
        max_diff = max_diff.max(max_abs_diff(&g.embedding, v));
    }
    eprintln!(
        "over {} sentences: min cosine to the reference 1 - {:.3e}, largest component difference {max_diff:.2e}",
        golden.len(),
        1.0 - min_cosine
    );
}

/// The bits of each vector, to compare embeddings exactly.
fn bits(vectors: &[Arc<[f32]>]) -> Vec<Vec<u32>> {
    vectors
        .iter()
        .map(|v| v.iter().map(|x| x.to_bits()).collect())
        .collect()
}

#[test]
fn a_sentence_embeds_to_the_same_bits_alone_and_in_any_batch() {
    // Sixteen of the golden sentences, every fourth by length, the longest
    // (48 words) among them, so every batch pads short ones to a long one;
    // the reference test covers all 64.
    let golden = golden();
    let mut by_length: Vec<&str> = golden.iter().map(|g| g.text.as_str()).collect();
    by_length.sort_by_key(|s| s.split_whitespace().count());
    let mut sentences: Vec<&str> = by_length.iter().rev().step_by(4).copied().collect();
    sentences.reverse();
    let encoder = |batch_size| {
        let options = MpnetOptions {
            batch_size,
            cache: false,
        };
        MpnetEncoder::load_with(&encoder_dir(), options).expect("load")
    };
    let default = encoder(MpnetOptions::default().batch_size);
    let alone: Vec<Vec<u32>> = sentences
        .iter()
        .map(|s| bits(&default.embed(&[s]).expect("alone")).remove(0))
        .collect();
    let reversed: Vec<&str> = sentences.iter().rev().copied().collect();
    let odd: Vec<&str> = sentences.iter().skip(1).step_by(2).copied().collect();
    let arrangements: [(&MpnetEncoder, Vec<&str>); 4] = [
        (&default, sentences.clone()),
        (&default, reversed),
        (&default, odd),
        (&encoder(3), sentences.clone()),
    ];
    for (encoder, batch) in &arrangements {
        let together = bits(&encoder.embed(batch).expect("batch"));
        for (sentence, vector) in batch.iter().zip(&together) {
            let index = sentences.iter().position(|s| s == sentence).expect("known");
            assert!(
                *vector == alone[index],
                "{sentence:?} embeds differently in a batch of {} than alone",
                batch.len()
            );
        }
    }
}

#[test]
fn results_come_back_in_input_order_whatever_the_lengths() {
    let encoder = shared_encoder();
    let long = "pick up the red apple from the kitchen counter and put it in the fridge";
    let short = "go left";
    let forward = encoder.embed(&[long, short]).expect("forward");
    let backward = encoder.embed(&[short, long]).expect("backward");
    assert_eq!(forward[0], backward[1]);
    assert_eq!(forward[1], backward[0]);
    assert!(cosine(&forward[0], &forward[1]) < 0.9);
}

#[test]
fn a_cached_sentence_returns_the_identical_vector() {
    let dir = encoder_dir();
    let encoder = MpnetEncoder::load(&dir).expect("load");
    let first = encoder
        .embed(&["open the fridge", "open the fridge", "close it"])
        .expect("first");
    assert_eq!(encoder.cached(), 2);
    assert!(Arc::ptr_eq(&first[0], &first[1]));
    let again = encoder
        .embed(&["close it", "open the fridge"])
        .expect("again");
    assert_eq!(encoder.cached(), 2);
    assert!(Arc::ptr_eq(&again[0], &first[2]));
    assert!(Arc::ptr_eq(&again[1], &first[0]));
}

#[test]
fn long_input_is_truncated_at_384_tokens() {
    let encoder = shared_encoder();
    let words: Vec<String> = (0..600).map(|i| format!("word{i}")).collect();
    let long = words.join(" ");
    let prefix_longer = format!("{long} and then something else entirely different");
    let vectors = encoder.embed(&[&long, &prefix_longer]).expect("long input");
    assert_eq!(vectors[0].len(), 768);
    let norm: f32 = vectors[0].iter().map(|x| x * x).sum::<f32>().sqrt();
    assert!((norm - 1.0).abs() < 1e-5);
    // Both are cut within the shared prefix, so they embed the same tokens.
    assert!(max_abs_diff(&vectors[0], &vectors[1]) < 1e-6);
}

#[test]
fn the_empty_string_embeds_to_a_unit_vector() {
    let encoder = shared_encoder();
    let vectors = encoder.embed(&["", "walk to the door"]).expect("empty");
    let norm: f32 = vectors[0].iter().map(|x| x * x).sum::<f32>().sqrt();
    assert!((norm - 1.0).abs() < 1e-5);
    assert!(vectors[0].iter().all(|x| x.is_finite()));
}

#[test]
fn a_missing_pack_names_the_file_and_the_fix() {
    let empty = tempfile::tempdir().expect("tempdir");
    let err = MpnetEncoder::load(empty.path()).expect_err("nothing to load");
    assert!(matches!(err, MpnetError::Unreadable { .. }));
    let message = err.to_string();
    assert!(message.contains("config.json"), "{message}");
    assert!(message.contains("mapvlm models fetch"), "{message}");
}

#[test]
fn a_truncated_weights_file_is_reported_as_corrupt() {
    let dir = encoder_dir();
    let broken = tempfile::tempdir().expect("tempdir");
    for name in ["config.json", "tokenizer.json", "sentence_bert_config.json"] {
        std::fs::copy(dir.join(name), broken.path().join(name)).expect("copy");
    }
    let mut head = Vec::new();
    std::fs::File::open(dir.join("model.safetensors"))
        .expect("weights")
        .take(4096)
        .read_to_end(&mut head)
        .expect("read weights");
    std::fs::write(broken.path().join("model.safetensors"), head).expect("write");
    let err = MpnetEncoder::load(broken.path()).expect_err("truncated weights");
    let message = err.to_string();
    assert!(matches!(err, MpnetError::Corrupt { .. }), "{message}");
    assert!(message.contains("model.safetensors"), "{message}");
    assert!(message.contains("mapvlm models verify"), "{message}");
}
