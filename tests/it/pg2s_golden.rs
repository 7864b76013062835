//! `mapvlm score --pairs --json` on the golden pairs equals the reference's
//! PG2S explanation field by field: S_plan and the sentence matches, the
//! framed actions, the action matches, S_goal, PG2S and KAS.

use crate::common;

use serde_json::Value;

/// Cosines are float32 sums whose order differs from PyTorch's.
const COSINE_TOLERANCE: f64 = 1e-5;
/// Scores are means of matches, exact when the matches are.
const SCORE_TOLERANCE: f64 = 1e-9;

fn number_eq(got: &Value, want: &Value, tolerance: f64) -> bool {
    match (got.as_f64(), want.as_f64()) {
        (Some(a), Some(b)) => (a - b).abs() <= tolerance,
        _ => got.is_null() && want.is_null(),
    }
}

#[test]
fn score_pairs_equals_the_golden_explanation_on_every_pair() {
    let pairs = common::shared().join("golden/pairs.dev.jsonl");
    let output = common::mapvlm_command()
        .args(["score", "--json", "--pairs"])
        .arg(&pairs)
        .output()
        .expect("run mapvlm score");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let golden = common::golden("pg2s.dev.jsonl");
    let lines: Vec<Value> = String::from_utf8(output.stdout)
        .expect("UTF-8 output")
        .lines()
        .map(|line| serde_json::from_str(line).expect("a JSON line"))
        .collect();
    assert_eq!(lines.len(), golden.len());
    let mut worst_cosine: f64 = 0.0;
    for (got, want) in lines.iter().zip(&golden) {
        let id = &want["id"];
        assert_eq!(got["id"], *id);
        for field in ["gt_actions", "pred_actions", "action_matches"] {
            assert_eq!(got[field], want[field], "{id}: {field}");
        }
        for field in ["s_plan", "s_goal", "pg2s", "kas"] {
            assert!(
                number_eq(&got[field], &want[field], SCORE_TOLERANCE),
                "{id}: {field} {} vs {}",
                got[field],
                want[field]
            );
        }
        let got_matches = got["sentence_matches"].as_array().expect("matches");
        let want_matches = want["sentence_matches"].as_array().expect("matches");
        assert_eq!(got_matches.len(), want_matches.len(), "{id}");
        for (g, w) in got_matches.iter().zip(want_matches) {
            assert_eq!((&g[0], &g[1]), (&w[0], &w[1]), "{id}: sentence match");
            assert!(
                number_eq(&g[2], &w[2], COSINE_TOLERANCE),
                "{id}: cosine {} vs {}",
                g[2],
                w[2]
            );
            if let (Some(a), Some(b)) = (g[2].as_f64(), w[2].as_f64()) {
                worst_cosine = worst_cosine.max((a - b).abs());
            }
        }
    }
    println!("largest cosine difference from the golden file: {worst_cosine:e}");
}
