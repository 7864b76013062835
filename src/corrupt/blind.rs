//! The blind copy of an items file for annotators (`corrupt --blind`): the
//! same plans under opaque ids, without `source` or `corruption`, each with
//! an opaque `group` shared by a plan and everything derived from it, in an
//! order that says nothing; and the key that maps ids and groups back, which
//! stays with the researcher.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::dataset::Pair;

/// One line of a key file: a blind id and what it stands for.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct KeyEntry {
    /// The id in the blind copy.
    pub blind: String,
    /// The id in the original items file.
    pub item: String,
    /// The group in the blind copy.
    pub group: String,
    /// The family it stands for: the original plan's id.
    pub family: String,
}

/// A blind copy and its key.
#[derive(Debug, Clone, PartialEq)]
pub struct Blinded {
    /// The items as annotators get them, ordered by their opaque ids.
    pub items: Vec<Pair>,
    /// One entry per item, in the same order.
    pub key: Vec<KeyEntry>,
}

/// Why a blind copy cannot be made.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BlindError {
    /// Two items share an id, so judgements could not be mapped back.
    #[error("item id {0:?} appears twice; a blind copy needs unique ids")]
    DuplicateId(String),
}

/// A secret of this run from the operating system's randomness (std's
/// randomly keyed hasher) and the clock, so that blind ids and groups cannot
/// be made again from the original ids.
pub fn fresh_secret() -> [u8; 32] {
    use std::hash::{BuildHasher, Hasher};
    let mut hash = Sha256::new();
    for k in 0u64..4 {
        let mut h = std::collections::hash_map::RandomState::new().build_hasher();
        h.write_u64(k);
        hash.update(h.finish().to_le_bytes());
    }
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or_default();
    hash.update(now.to_le_bytes());
    hash.update(std::process::id().to_le_bytes());
    hash.finalize().into()
}

/// A 16-hex-digit name of `what` under `secret`.
fn opaque(secret: &[u8; 32], purpose: &str, what: &str) -> String {
    let mut hash = Sha256::new();
    hash.update(secret);
    hash.update(purpose.as_bytes());
    hash.update([0]);
    hash.update(what.as_bytes());
    hash.finalize()[..8]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The blind copy of `items` under `secret`: every item keeps its plans,
/// task and image, loses `source` and `corruption`, gets an opaque id and
/// the opaque `group` of its family ([`Pair::family`]).
pub fn blind(items: &[Pair], secret: &[u8; 32]) -> Result<Blinded, BlindError> {
    let mut seen: HashMap<&str, ()> = HashMap::new();
    let mut rows: BTreeMap<String, (Pair, KeyEntry)> = BTreeMap::new();
    for item in items {
        if seen.insert(item.id.as_str(), ()).is_some() {
            return Err(BlindError::DuplicateId(item.id.clone()));
        }
        let mut id = opaque(secret, "item", &item.id);
        let mut n = 0u32;
        while rows.contains_key(&id) {
            n += 1;
            id = opaque(secret, &format!("item{n}"), &item.id);
        }
        let family = item.family().to_string();
        let group = opaque(secret, "group", &family);
        let copy = Pair {
            id: id.clone(),
            gt: item.gt.clone(),
            pred: item.pred.clone(),
            task: item.task.clone(),
            image: item.image.clone(),
            source: None,
            corruption: None,
            group: Some(group.clone()),
        };
        let entry = KeyEntry {
            blind: id.clone(),
            item: item.id.clone(),
            group,
            family,
        };
        rows.insert(id, (copy, entry));
    }
    let (items, key) = rows.into_values().unzip();
    Ok(Blinded { items, key })
}

/// A key file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    /// The file cannot be read.
    #[error("cannot read the key file {}: {error}", path.display())]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// A line is not a key entry.
    #[error("{}:{line}: not a key line ({message}); a key file is written by `mapvlm corrupt --blind`", path.display())]
    Line {
        /// The file.
        path: std::path::PathBuf,
        /// The 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Reads a key file: blind id → original id.
pub fn read_key(path: &Path) -> Result<HashMap<String, String>, KeyError> {
    let text = std::fs::read_to_string(path).map_err(|error| KeyError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    let mut map = HashMap::new();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let entry: KeyEntry = serde_json::from_str(line).map_err(|e| KeyError::Line {
            path: path.to_path_buf(),
            line: n + 1,
            message: e.to_string(),
        })?;
        map.insert(entry.blind, entry.item);
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn items() -> Vec<Pair> {
        let mut a = Pair::new("t1", vec!["A.".into()], vec!["A.".into()]);
        a.task = Some("Do A".into());
        let mut b = a.clone();
        b.id = "t1~drop".into();
        b.source = Some("t1".into());
        let c = Pair::new("t2", vec![], vec!["B.".into()]);
        vec![a, b, c]
    }

    #[test]
    fn the_copy_hides_provenance_and_keeps_families_together() {
        let secret = [7u8; 32];
        let blinded = blind(&items(), &secret).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(blinded.items.len(), 3);
        let by_item: HashMap<&str, &KeyEntry> =
            blinded.key.iter().map(|k| (k.item.as_str(), k)).collect();
        assert_eq!(by_item["t1"].group, by_item["t1~drop"].group);
        assert_ne!(by_item["t1"].group, by_item["t2"].group);
        for (item, key) in blinded.items.iter().zip(&blinded.key) {
            assert_eq!(item.id, key.blind);
            assert_eq!(item.group.as_deref(), Some(key.group.as_str()));
            assert!(item.source.is_none() && item.corruption.is_none());
            assert!(!item.id.contains('~') && !item.id.contains(&key.item));
        }
        let other = blind(&items(), &[8u8; 32]).unwrap_or_else(|e| panic!("{e}"));
        assert_ne!(other.key[0].blind, blinded.key[0].blind);
        let mut twice = items();
        twice.push(twice[0].clone());
        assert_eq!(
            blind(&twice, &secret).map(|_| ()),
            Err(BlindError::DuplicateId("t1".into()))
        );
    }
}
