//! KAS equals the reference on every golden pair, chunks included.

use crate::common;

use mapvlm::metrics::kas::kas;

#[test]
fn kas_matches_the_golden_file_on_every_pair() {
    let golden = common::golden("pg2s.dev.jsonl");
    assert_eq!(golden.len(), 124);
    let mut nulls = 0;
    for g in &golden {
        let gt = common::strings(&g["gt"]);
        let pred = common::strings(&g["pred"]);
        let report = kas(&gt, &pred);
        let chunks = serde_json::to_value(&report.chunks).unwrap_or_default();
        assert_eq!(chunks, g["kas_chunks"], "{}", g["id"]);
        match g["kas"].as_f64() {
            None => {
                nulls += 1;
                assert_eq!(report.kas, None, "{}", g["id"]);
                assert!(report.reason.is_some());
            }
            Some(expected) => {
                let got = report.kas.unwrap_or(f64::NAN);
                assert!(
                    (got - expected).abs() <= 1e-9,
                    "{}: {got} vs {expected}",
                    g["id"]
                );
            }
        }
    }
    assert_eq!(nulls, 26);
}
