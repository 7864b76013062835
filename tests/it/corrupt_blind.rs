//! `corrupt --blind`: the copy annotators get hides which plan is corrupt
//! and how, keeps families apart in `annotate`'s order, and `agree --key`
//! over judgements made on it equals `agree` over the same judgements made
//! on the original file (the golden set).

use crate::common;

use std::collections::{BTreeSet, HashMap};
use std::path::Path;

use common::{mapvlm, stderr};
use mapvlm::annotate::order::{pairwise_units, single_units, Unit};
use mapvlm::corrupt::blind::KeyEntry;
use mapvlm::corrupt::Kind;
use mapvlm::dataset::Pair;

fn golden(part: &str) -> String {
    common::shared()
        .join(format!("golden/agree.dev.{part}"))
        .to_string_lossy()
        .into_owned()
}

fn lines(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(String::from)
        .collect()
}

/// No two neighbours of the order share a family (`family` of an index).
fn families_apart(units: &[Unit], family: impl Fn(usize) -> String) -> bool {
    let first = |u: &Unit| match *u {
        Unit::Single(i) | Unit::Pair(i, _) => i,
    };
    units
        .windows(2)
        .all(|w| family(first(&w[0])) != family(first(&w[1])))
}

/// `corrupt --items GOLDEN --blind DIR --key KEY`.
fn blind_golden(blind: &Path, key: &Path) -> std::process::Output {
    mapvlm(&[
        "corrupt",
        "--items",
        &golden("items.jsonl"),
        "--blind",
        &blind.to_string_lossy(),
        "--key",
        &key.to_string_lossy(),
    ])
}

#[test]
fn the_blind_copy_hides_provenance_and_agree_maps_judgements_back() {
    let dir = tempfile::tempdir().unwrap();
    let blind = dir.path().join("for-annotators");
    let key = dir.path().join("key.jsonl");
    let run = blind_golden(&blind, &key);
    assert!(run.status.success(), "{}", stderr(&run));

    let original: Vec<Pair> = lines(Path::new(&golden("items.jsonl")))
        .iter()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let text = std::fs::read_to_string(blind.join("items.jsonl")).unwrap();
    assert!(!text.contains('~'), "a `~` in the blind copy");
    for field in ["\"source\"", "\"corruption\"", "\"touches_task\""] {
        assert!(!text.contains(field), "{field} in the blind copy");
    }
    let copies: Vec<Pair> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(copies.len(), original.len());
    let entries: Vec<KeyEntry> = lines(&key)
        .iter()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let back: HashMap<&str, &KeyEntry> = entries.iter().map(|e| (e.blind.as_str(), e)).collect();
    let by_id: HashMap<&str, &Pair> = original.iter().map(|p| (p.id.as_str(), p)).collect();
    let mut images = 0;
    for copy in &copies {
        let group = copy.group.as_deref().unwrap();
        for name in [copy.id.as_str(), group] {
            assert!(
                Kind::ALL.iter().all(|k| !name.contains(k.name())),
                "{name} names a kind"
            );
            assert!(original.iter().all(|p| !name.contains(&p.id)), "{name}");
        }
        let entry = back[copy.id.as_str()];
        let source = by_id[entry.item.as_str()];
        assert_eq!((&copy.pred, &copy.task), (&source.pred, &source.task));
        assert_eq!(entry.family, source.family());
        if let Some(image) = &copy.image {
            assert!(Path::new(image).is_relative(), "{image}");
            assert!(blind.join(image).is_file(), "{image}");
            images += 1;
        }
    }
    assert_eq!(
        images,
        original.iter().filter(|p| p.image.is_some()).count()
    );
    // One group per family, and a group is not the family's name.
    let families: BTreeSet<(&str, &str)> = entries
        .iter()
        .map(|e| (e.group.as_str(), e.family.as_str()))
        .collect();
    let groups: BTreeSet<&str> = entries.iter().map(|e| e.group.as_str()).collect();
    assert_eq!(families.len(), groups.len());
    assert!(groups.len() < entries.len());

    // `annotate`'s order keeps the families apart on the copy as on the original.
    let family_of_copy = |i: usize| back[copies[i].id.as_str()].family.clone();
    let family_of_original = |i: usize| original[i].family().to_string();
    for annotator in ["ana", "bo", "chen"] {
        assert!(families_apart(
            &single_units(&copies, annotator),
            family_of_copy
        ));
        assert!(families_apart(
            &single_units(&original, annotator),
            family_of_original
        ));
        assert_eq!(
            pairwise_units(&copies, annotator).len(),
            pairwise_units(&original, annotator).len()
        );
    }

    // The golden judgements, made on the copy: agree through the key gives
    // the document agree gives on the original.
    let to_blind: HashMap<&str, &str> = entries
        .iter()
        .map(|e| (e.item.as_str(), e.blind.as_str()))
        .collect();
    let mut blind_lines = String::new();
    for line in lines(Path::new(&golden("annotations.jsonl"))) {
        let mut value: serde_json::Value = serde_json::from_str(&line).unwrap();
        if let Some(item) = value.get("item").and_then(|v| v.as_str()) {
            let id = to_blind.get(item).copied().unwrap_or(item).to_string();
            value["item"] = id.into();
        }
        blind_lines.push_str(&serde_json::to_string(&value).unwrap());
        blind_lines.push('\n');
    }
    let blind_annotations = blind.join("items.annotations.jsonl");
    std::fs::write(&blind_annotations, blind_lines).unwrap();
    let agree = |annotations: &str, key: Option<&Path>| {
        let mut args = vec![
            "agree".to_string(),
            "--items".into(),
            golden("items.jsonl"),
            "--scores".into(),
            golden("scores.jsonl"),
            "--annotations".into(),
            annotations.into(),
            "--json".into(),
        ];
        if let Some(k) = key {
            args.extend(["--key".to_string(), k.to_string_lossy().into_owned()]);
        }
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = mapvlm(&refs);
        assert!(out.status.success(), "{}", stderr(&out));
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let on_original = agree(&golden("annotations.jsonl"), None);
    let on_blind = agree(&blind_annotations.to_string_lossy(), Some(&key));
    assert_eq!(on_blind, on_original);
    assert!(on_original["items"].as_u64().unwrap() > 10);
}

#[test]
fn a_key_inside_the_blind_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let blind = dir.path().join("b");
    let out = blind_golden(&blind, &blind.join("key.jsonl"));
    common::assert_one_line_failure(&out, "annotators get");
}
