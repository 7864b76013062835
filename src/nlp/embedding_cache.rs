//! Sentence embeddings kept on disk across runs, so that no sentence is ever
//! run through the encoder twice: `score`, `eval`, the workbench (and anything
//! else built on [`crate::cli`]'s scorer) share one store under
//! `$XDG_CACHE_HOME/mapvlm/embeddings`.
//!
//! An entry is addressed by the model's identity as its verification stamp
//! records it (the SHA-256 of each key file; the weights are never hashed at
//! start), the encoder's [`REVISION`], and the exact text. It holds the text
//! and the vector's bits, so a warm result is the cold one, bit for bit. The
//! encoder itself is loaded only when a sentence misses, so a fully warm run
//! never reads the weights.

use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use crate::metrics::{ModelError, SentenceEncoder};
use crate::models::{default_pack, quick_status, stamped_sha256, QuickStatus};
use crate::nlp::mpnet::REVISION;
use crate::store::DiskStore;
use crate::store::EntryKey;

/// The sentences kept in memory between calls (about 3 KB each). A call
/// that would take the working set past this drops it first, so the
/// sentences of the latest call (e.g. a warm-up of many pairs) stay for the
/// calls that follow; the disk store still has them all.
const WORKING_SET: usize = 16_384;

/// Marks the layout of an entry.
const ENTRY_MAGIC: &[u8; 4] = b"MVE1";

/// Loads the encoder the first time a sentence misses.
pub type EncoderLoader =
    Box<dyn Fn() -> Result<Arc<dyn SentenceEncoder>, ModelError> + Send + Sync>;

/// How many sentences were served from where, for `--verbose` lines and tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CacheCounts {
    /// Served from the disk store.
    pub disk_hits: u64,
    /// Run through the encoder.
    pub encoded: u64,
}

/// A [`SentenceEncoder`] in front of another one: sentences are served from
/// memory, then from the disk store, and only the rest are encoded (and
/// stored).
pub struct CachedEncoder {
    store: Option<(DiskStore, String)>,
    loader: EncoderLoader,
    encoder: Mutex<Option<Arc<dyn SentenceEncoder>>>,
    working: Mutex<HashMap<String, Arc<[f32]>>>,
    disk_hits: AtomicU64,
    encoded: AtomicU64,
    /// Whether a failed store was already said: once a run, not once a sentence.
    store_failed: AtomicBool,
}

impl std::fmt::Debug for CachedEncoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CachedEncoder")
            .field("store", &self.store.as_ref().map(|(s, _)| s.dir()))
            .finish_non_exhaustive()
    }
}

impl CachedEncoder {
    /// An encoder loaded by `loader` when first needed, with the disk store
    /// `store` for the model whose identity is `model` (see
    /// [`stamped_identity`]), or memory only when `store` is `None`.
    pub fn new(store: Option<(DiskStore, String)>, loader: EncoderLoader) -> Self {
        Self {
            store,
            loader,
            encoder: Mutex::new(None),
            working: Mutex::new(HashMap::new()),
            disk_hits: AtomicU64::new(0),
            encoded: AtomicU64::new(0),
            store_failed: AtomicBool::new(false),
        }
    }

    /// How many sentences came from the disk and from the encoder so far.
    pub fn counts(&self) -> CacheCounts {
        CacheCounts {
            disk_hits: self.disk_hits.load(Ordering::Relaxed),
            encoded: self.encoded.load(Ordering::Relaxed),
        }
    }

    fn key(model: &str, text: &str) -> EntryKey {
        EntryKey::of(&[
            b"sentence-embedding",
            model.as_bytes(),
            &REVISION.to_le_bytes(),
            text.as_bytes(),
        ])
    }

    fn stored(&self, text: &str) -> Option<Arc<[f32]>> {
        let (store, model) = self.store.as_ref()?;
        let vector = decode(&store.get(&Self::key(model, text))?, text)?;
        self.disk_hits.fetch_add(1, Ordering::Relaxed);
        Some(vector.into())
    }

    fn keep(&self, text: &str, vector: &[f32]) {
        if let Some((store, model)) = &self.store {
            if let Err(err) = store.put(&Self::key(model, text), &encode_entry(text, vector)) {
                if !self.store_failed.swap(true, Ordering::Relaxed) {
                    tracing::warn!(
                        dir = %store.dir().display(),
                        %err,
                        "cannot store embeddings, so they will be computed again next time"
                    );
                }
            }
        }
    }

    fn encoder(&self) -> Result<Arc<dyn SentenceEncoder>, ModelError> {
        let mut slot = self.encoder.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(encoder) = slot.as_ref() {
            return Ok(Arc::clone(encoder));
        }
        let encoder = (self.loader)()?;
        *slot = Some(Arc::clone(&encoder));
        Ok(encoder)
    }
}

impl SentenceEncoder for CachedEncoder {
    fn encode(&self, sentences: &[&str]) -> Result<Vec<Vec<f32>>, ModelError> {
        let mut working = self.working.lock().unwrap_or_else(PoisonError::into_inner);
        let fresh = sentences
            .iter()
            .filter(|s| !working.contains_key(**s))
            .count();
        if working.len() + fresh > WORKING_SET {
            working.clear();
        }
        let mut missing: Vec<&str> = Vec::new();
        for &sentence in sentences {
            if working.contains_key(sentence) || missing.contains(&sentence) {
                continue;
            }
            match self.stored(sentence) {
                Some(vector) => {
                    working.insert(sentence.to_owned(), vector);
                }
                None => missing.push(sentence),
            }
        }
        if !missing.is_empty() {
            let fresh = self.encoder()?.encode(&missing)?;
            self.encoded
                .fetch_add(missing.len() as u64, Ordering::Relaxed);
            for (sentence, vector) in missing.iter().zip(fresh) {
                self.keep(sentence, &vector);
                working.insert((*sentence).to_owned(), vector.into());
            }
        }
        let out = sentences
            .iter()
            .map(|s| working.get(*s).map(|v| v.to_vec()).unwrap_or_default())
            .collect();
        Ok(out)
    }
}

/// An entry: magic, the text's length and bytes, the vector's length and
/// its f32 values, little-endian.
fn encode_entry(text: &str, vector: &[f32]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(12 + text.len() + 4 * vector.len());
    bytes.extend_from_slice(ENTRY_MAGIC);
    bytes.extend_from_slice(&(text.len() as u32).to_le_bytes());
    bytes.extend_from_slice(text.as_bytes());
    bytes.extend_from_slice(&(vector.len() as u32).to_le_bytes());
    for x in vector {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    bytes
}

/// The vector of an entry for `text`; `None` for an entry of another layout
/// or text (a miss, as if absent).
fn decode(bytes: &[u8], text: &str) -> Option<Vec<f32>> {
    let rest = bytes.strip_prefix(ENTRY_MAGIC)?;
    let (len, rest) = split_u32(rest)?;
    let (stored, rest) = rest.split_at_checked(len)?;
    if stored != text.as_bytes() {
        return None;
    }
    let (dim, rest) = split_u32(rest)?;
    if rest.len() != 4 * dim {
        return None;
    }
    Some(
        rest.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
    )
}

fn split_u32(bytes: &[u8]) -> Option<(usize, &[u8])> {
    let (head, rest) = bytes.split_at_checked(4)?;
    let value = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
    Some((value as usize, rest))
}

/// The identity of model `folder` in the pack `models_dir` as its
/// verification stamp records it (each key file's path and SHA-256), when the
/// stamp is current; `None` for a model that is not verified as it is now,
/// whose embeddings are then not kept.
pub fn stamped_identity(models_dir: &Path, folder: &str) -> Option<String> {
    let spec = default_pack().into_iter().find(|s| s.folder == folder)?;
    if quick_status(models_dir, &spec) != QuickStatus::Verified {
        return None;
    }
    let model = models_dir.join(folder);
    let files = spec
        .key_files
        .iter()
        .map(|f| stamped_sha256(&model, &f.path).map(|sha| format!("{}={sha}", f.path)))
        .collect::<Option<Vec<_>>>()?;
    Some(files.join(";"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stand-in for the network that counts its calls.
    struct Counting(AtomicU64);

    impl SentenceEncoder for Counting {
        fn encode(&self, sentences: &[&str]) -> Result<Vec<Vec<f32>>, ModelError> {
            self.0.fetch_add(sentences.len() as u64, Ordering::Relaxed);
            Ok(sentences
                .iter()
                .map(|s| vec![s.len() as f32 / 7.0, f32::MIN_POSITIVE, -0.0])
                .collect())
        }
    }

    fn cached(dir: &Path, network: &Arc<Counting>) -> CachedEncoder {
        let network = Arc::clone(network);
        CachedEncoder::new(
            Some((DiskStore::new(dir, 1 << 20), "model=abc".into())),
            Box::new(move || Ok(Arc::clone(&network) as Arc<dyn SentenceEncoder>)),
        )
    }

    #[test]
    fn a_second_process_reads_the_bits_the_first_stored() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let network = Arc::new(Counting(AtomicU64::new(0)));
        let first = cached(dir.path(), &network);
        let cold = first
            .encode(&["Walk to the sink.", "Open it.", "Walk to the sink."])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(network.0.load(Ordering::Relaxed), 2);
        let second = cached(dir.path(), &network);
        let warm = second
            .encode(&["Walk to the sink.", "Open it.", "Walk to the sink."])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            network.0.load(Ordering::Relaxed),
            2,
            "nothing encoded again"
        );
        let bits = |v: &[Vec<f32>]| -> Vec<Vec<u32>> {
            v.iter()
                .map(|r| r.iter().map(|x| x.to_bits()).collect())
                .collect()
        };
        assert_eq!(bits(&cold), bits(&warm));
        assert_eq!(
            second.counts(),
            CacheCounts {
                disk_hits: 2,
                encoded: 0
            }
        );
    }

    #[test]
    fn a_warm_run_never_loads_the_encoder() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let network = Arc::new(Counting(AtomicU64::new(0)));
        cached(dir.path(), &network)
            .encode(&["Pick up the cup."])
            .unwrap_or_else(|e| panic!("{e}"));
        let refusing = CachedEncoder::new(
            Some((DiskStore::new(dir.path(), 1 << 20), "model=abc".into())),
            Box::new(|| Err("the encoder was loaded".into())),
        );
        assert!(refusing.encode(&["Pick up the cup."]).is_ok());
        assert!(refusing.encode(&["Something new."]).is_err());
    }

    #[test]
    fn another_model_or_text_misses() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let network = Arc::new(Counting(AtomicU64::new(0)));
        cached(dir.path(), &network)
            .encode(&["Open the fridge."])
            .unwrap_or_else(|e| panic!("{e}"));
        let other = Arc::clone(&network);
        let other_model = CachedEncoder::new(
            Some((DiskStore::new(dir.path(), 1 << 20), "model=def".into())),
            Box::new(move || Ok(Arc::clone(&other) as Arc<dyn SentenceEncoder>)),
        );
        other_model
            .encode(&["Open the fridge.", "open the fridge."])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(network.0.load(Ordering::Relaxed), 3);
    }

    #[test]
    fn an_entry_for_other_text_or_truncated_is_a_miss() {
        let entry = encode_entry("a", &[1.0, 2.0]);
        assert_eq!(decode(&entry, "a"), Some(vec![1.0, 2.0]));
        assert_eq!(decode(&entry, "b"), None);
        assert_eq!(decode(&entry[..entry.len() - 1], "a"), None);
        assert_eq!(decode(b"MVE", "a"), None);
    }
}
