//! `mapvlm corrupt` as a user runs it, with the real models: alfred30's
//! published plans under every kind, the same bytes for the same seed,
//! edits that reproduce the corrupted plans, an output `score --pairs`
//! reads, user vocabularies, and bad input in one clear line.

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Output;

use common::{mapvlm, stderr};
use mapvlm::corrupt::apply_edits;
use mapvlm::dataset::Pair;

fn read_items(path: &Path) -> Vec<Pair> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// The lowercase words of a plan.
fn words_of(plan: &[String]) -> BTreeSet<String> {
    plan.iter()
        .flat_map(|s| s.split(|c: char| !c.is_alphanumeric()))
        .filter(|w| !w.is_empty())
        .map(str::to_lowercase)
        .collect()
}

/// An items file `items.jsonl` in `dir` holding `text`.
fn items_file(dir: &Path, text: &str) -> std::path::PathBuf {
    let items = dir.join("items.jsonl");
    std::fs::write(&items, text).unwrap_or_else(|e| panic!("{e}"));
    items
}

fn corrupt_alfred30(out: &Path, seed: &str) -> Output {
    let dataset = common::shared().join("data/alfred30");
    let out = mapvlm(&[
        "corrupt",
        "--dataset",
        &dataset.to_string_lossy(),
        "--seed",
        seed,
        "--out",
        &out.to_string_lossy(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    out
}

#[test]
fn alfred30_every_kind_applies_deterministically_with_edits_that_fit() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (a, b, c) = (
        dir.path().join("a.jsonl"),
        dir.path().join("b.jsonl"),
        dir.path().join("c.jsonl"),
    );
    let run = corrupt_alfred30(&a, "7");
    corrupt_alfred30(&b, "7");
    corrupt_alfred30(&c, "8");
    let bytes = |p: &Path| std::fs::read(p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(bytes(&a), bytes(&b), "the same seed gives the same bytes");

    let items = read_items(&a);
    let originals: BTreeMap<&str, &Pair> = items
        .iter()
        .filter(|i| i.source.is_none())
        .map(|i| (i.id.as_str(), i))
        .collect();
    assert_eq!(originals.len(), 30);
    let mut per_kind: BTreeMap<String, usize> = BTreeMap::new();
    for item in items.iter().filter(|i| i.source.is_some()) {
        let record = item
            .corruption
            .as_ref()
            .unwrap_or_else(|| panic!("{}", item.id));
        let source = originals[item.source.as_deref().unwrap_or_default()];
        assert_eq!(item.id, format!("{}~{}", source.id, record.kind));
        assert_eq!((&item.gt, &item.task), (&source.gt, &source.task));
        assert_eq!(item.image, source.image);
        let image = item
            .image
            .as_deref()
            .unwrap_or_else(|| panic!("{}", item.id));
        assert!(dir.path().join(image).is_file(), "{image}");
        assert_eq!(record.seed, 7);
        assert_ne!(item.pred, source.pred, "{}", item.id);
        assert_eq!(
            apply_edits(&source.pred, &record.edits).as_ref(),
            Ok(&item.pred),
            "{}",
            item.id
        );
        match record.kind.as_str() {
            "object-swap" | "place-swap" | "verb-swap" => {
                let words = record
                    .words
                    .as_ref()
                    .unwrap_or_else(|| panic!("{}", item.id));
                assert!(record.similarity.is_some_and(f64::is_finite), "{}", item.id);
                let first = |w: &str| w.split(' ').next().unwrap_or_default().to_string();
                let (from, to) = (first(&words.from), first(&words.to));
                assert!(words_of(&source.pred).contains(&from), "{}", item.id);
                assert!(words_of(&item.pred).contains(&to), "{}", item.id);
                if record.kind != "verb-swap" {
                    assert!(!words_of(&source.pred).contains(&to), "{}", item.id);
                    assert!(!words_of(&item.pred).contains(&from), "{}", item.id);
                }
            }
            "reorder" => {
                let [x, y] = &record.edits[..] else {
                    panic!("{}: {:?}", item.id, record.edits)
                };
                assert_ne!(x.from, y.from);
            }
            "truncate" => assert_eq!(item.pred.len(), source.pred.len() / 2),
            _ => {}
        }
        *per_kind.entry(record.kind.clone()).or_default() += 1;
    }
    for kind in [
        "object-swap",
        "reorder",
        "drop",
        "duplicate",
        "insert",
        "truncate",
    ] {
        assert!(
            per_kind.get(kind).copied().unwrap_or(0) >= 28,
            "{kind}: {per_kind:?}"
        );
    }
    for kind in ["place-swap", "verb-swap"] {
        assert!(
            per_kind.get(kind).copied().unwrap_or(0) >= 10,
            "{kind}: {per_kind:?}"
        );
    }
    let skipped = stderr(&run)
        .lines()
        .filter(|l| l.ends_with("; skipped"))
        .count();
    assert_eq!(skipped + per_kind.values().sum::<usize>(), 30 * 8);

    let other = read_items(&c);
    for kind in ["object-swap", "reorder", "drop", "insert"] {
        let of = |items: &[Pair]| -> Vec<Vec<String>> {
            items
                .iter()
                .filter(|i| i.id.ends_with(&format!("~{kind}")))
                .map(|i| i.pred.clone())
                .collect()
        };
        assert_ne!(
            of(&items),
            of(&other),
            "{kind}: another seed, other corruptions"
        );
    }

    let scored = mapvlm(&[
        "score",
        "--pairs",
        &a.to_string_lossy(),
        "--json",
        "--metrics",
        "kas",
    ]);
    assert!(scored.status.success(), "{}", stderr(&scored));
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&scored.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    assert_eq!(lines.len(), items.len());
    assert_eq!(lines[1]["id"], items[1].id.as_str());
}

#[test]
fn items_files_user_vocabularies_and_what_cannot_be_corrupted() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let items = items_file(
        dir.path(),
        concat!(
            r#"{"id": "h", "gt": ["Pick up the harmonica."], "pred": ["Walk to the desk.", "Pick up the harmonica."], "task": "Get it.", "image": "scene.jpg"}"#,
            "\n{broken\n",
            r#"{"id": "one", "gt": ["Stop."], "pred": ["Stop."]}"#,
            "\n"
        ),
    );
    std::fs::write(dir.path().join("scene.jpg"), b"not really").unwrap_or_else(|e| panic!("{e}"));
    let vocabulary = dir.path().join("vocab");
    std::fs::create_dir(&vocabulary).unwrap_or_else(|e| panic!("{e}"));
    let out = dir.path().join("out/items.jsonl");
    let run = |vocab: &Path| {
        mapvlm(&[
            "corrupt",
            "--items",
            &items.to_string_lossy(),
            "--kinds",
            "object-swap,drop",
            "--vocabulary",
            &vocab.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
        ])
    };

    let plain = run(&vocabulary);
    let err = stderr(&plain);
    assert!(
        !plain.status.success(),
        "a broken line fails the run: {err}"
    );
    assert!(err.contains("items.jsonl:2:"), "{err}");
    assert!(
        err.contains("h: object-swap cannot corrupt it: no object noun"),
        "{err}"
    );
    assert!(err.contains("one: drop cannot corrupt it"), "{err}");
    let written = read_items(&out);
    let ids: Vec<&str> = written.iter().map(|i| i.id.as_str()).collect();
    assert_eq!(ids, ["h", "h~drop", "one"], "skipped kinds are not copied");
    assert_eq!(written[1].image.as_deref(), Some("../scene.jpg"));

    std::fs::write(vocabulary.join("objects.txt"), "harmonica\n").unwrap_or_else(|e| panic!("{e}"));
    let extended = run(&vocabulary);
    let written = read_items(&out);
    let swapped = written
        .iter()
        .find(|i| i.id == "h~object-swap")
        .unwrap_or_else(|| panic!("{}", stderr(&extended)));
    let record = swapped
        .corruption
        .as_ref()
        .unwrap_or_else(|| panic!("no record"));
    assert_eq!(
        record.words.as_ref().map(|w| w.from.as_str()),
        Some("harmonica")
    );
    assert_eq!(record.edits.len(), 1);
    assert_eq!(record.edits[0].step, 1);

    let help = mapvlm(&["corrupt", "--help"]);
    assert!(String::from_utf8_lossy(&help.stdout).contains("mapvlm/corrupt/"));
}

#[test]
fn an_unwritable_output_or_an_empty_items_file_is_one_line() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let file = dir.path().join("file");
    std::fs::write(&file, "").unwrap_or_else(|e| panic!("{e}"));
    for (items, out, needle) in [
        (&file, file.join("out.jsonl"), "--out"),
        (&file, dir.path().join("out.jsonl"), "no item with a plan"),
    ] {
        let run = mapvlm(&[
            "corrupt",
            "--items",
            &items.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
        ]);
        let err = stderr(&run);
        assert!(!run.status.success());
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{needle}: {err}");
    }
}

/// Runs `mapvlm ARGS` under the umask `mask` (set by a shell that then
/// becomes the binary), as a user's login shell would have it.
fn mapvlm_under_umask(mask: &str, args: &[&str]) -> Output {
    common::mapvlm_command_program("sh")
        .arg("-c")
        .arg(format!("umask {mask} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_mapvlm"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running sh: {e}"))
}

#[test]
fn an_items_file_gets_the_umask_mode_and_a_replaced_one_keeps_its_own() {
    use std::os::unix::fs::PermissionsExt as _;
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let items = items_file(
        dir.path(),
        r#"{"id": "a", "gt": ["Pick up the mug.", "Put the mug in the sink."], "pred": ["Pick up the mug.", "Put the mug in the sink."]}"#,
    );
    let mode = |p: &Path| {
        std::fs::metadata(p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .permissions()
            .mode()
            & 0o777
    };
    let corrupt = |out: &Path| {
        let run = mapvlm_under_umask(
            "022",
            &[
                "corrupt",
                "--items",
                &items.to_string_lossy(),
                "--kinds",
                "reorder",
                "--out",
                &out.to_string_lossy(),
            ],
        );
        assert!(run.status.success(), "{}", stderr(&run));
    };
    let fresh = dir.path().join("fresh.jsonl");
    corrupt(&fresh);
    assert_eq!(mode(&fresh), 0o644, "a new items file is 0666 & !umask");
    assert_eq!(read_items(&fresh).len(), 2);
    let shared = dir.path().join("group.jsonl");
    std::fs::write(&shared, "").unwrap_or_else(|e| panic!("{e}"));
    std::fs::set_permissions(&shared, std::fs::Permissions::from_mode(0o664))
        .unwrap_or_else(|e| panic!("{e}"));
    corrupt(&shared);
    assert_eq!(mode(&shared), 0o664, "a replaced file keeps its mode");
}
