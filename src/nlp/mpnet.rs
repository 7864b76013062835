//! The sentence encoder all-mpnet-base-v2 as sentence-transformers runs it:
//! tokenise (truncating at the model's maximum sequence length), run MPNet on
//! length-sorted batches packed end to end (never padded, so that a
//! sentence's embedding does not depend on its companions), mean-pool over
//! the tokens and L2-normalise. Embeddings are cached per sentence for the life of
//! the encoder.

mod gelu;
mod model;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use candle_core::{DType, Device};
use candle_nn::VarBuilder;
use serde::Deserialize;
use tokenizers::{Tokenizer, TruncationParams};

use crate::metrics::{ModelError, SentenceEncoder};
use model::{Mpnet, MpnetConfig, TokenBatch};

/// The revision of the encoder's arithmetic, part of every stored
/// embedding's key: bump it with any change that can move an embedding's
/// bits (batching, kernels, pooling), so no older vector is served.
pub const REVISION: u32 = 2;

/// The number of sentences run through the network together by default.
pub const DEFAULT_BATCH_SIZE: usize = 32;

/// Why the sentence encoder could not be loaded or could not embed.
#[derive(Debug, thiserror::Error)]
pub enum MpnetError {
    /// A file of the model folder is missing or unreadable.
    #[error(
        "cannot read {}: {source}; run `mapvlm models fetch` to install the model pack, or point --models-dir at it",
        path.display()
    )]
    Unreadable {
        /// The file that could not be read.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A file of the model folder is there but not what the encoder expects.
    #[error(
        "{} is damaged or not an all-mpnet-base-v2 file ({reason}); run `mapvlm models verify` to check the model pack and `mapvlm models fetch` to repair it",
        path.display()
    )]
    Corrupt {
        /// The offending file.
        path: PathBuf,
        /// What was wrong with it.
        reason: String,
    },
    /// The tokenizer rejected a sentence.
    #[error("cannot tokenise the sentences: {0}")]
    Tokenize(String),
    /// The network failed while running.
    #[error("the sentence encoder failed: {0}")]
    Inference(#[from] candle_core::Error),
}

/// How the encoder batches and caches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MpnetOptions {
    /// Sentences per forward pass (at least 1).
    pub batch_size: usize,
    /// Whether to keep every embedding for reuse by later calls.
    pub cache: bool,
}

impl Default for MpnetOptions {
    fn default() -> Self {
        Self {
            batch_size: DEFAULT_BATCH_SIZE,
            cache: true,
        }
    }
}

/// Where the embedding of one requested sentence comes from.
enum Slot {
    /// Already in the cache.
    Cached(Arc<[f32]>),
    /// The embedding at this index of the sentences embedded now.
    Fresh(usize),
}

/// The part of `sentence_bert_config.json` the encoder reads.
#[derive(Debug, Deserialize)]
struct SentenceBertConfig {
    max_seq_length: usize,
}

/// all-mpnet-base-v2 on the CPU: unit-length 768-dimensional sentence
/// embeddings, identical (to float rounding) to sentence-transformers'.
pub struct MpnetEncoder {
    tokenizer: Tokenizer,
    model: Mpnet,
    options: MpnetOptions,
    cache: Mutex<HashMap<String, Arc<[f32]>>>,
}

impl std::fmt::Debug for MpnetEncoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MpnetEncoder")
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

impl MpnetEncoder {
    /// Loads the encoder from an `all-mpnet-base-v2` folder (config.json,
    /// tokenizer.json, model.safetensors, sentence_bert_config.json) with the
    /// default options.
    pub fn load(dir: &Path) -> Result<Self, MpnetError> {
        Self::load_with(dir, MpnetOptions::default())
    }

    /// Loads the encoder from an `all-mpnet-base-v2` folder with `options`.
    pub fn load_with(dir: &Path, options: MpnetOptions) -> Result<Self, MpnetError> {
        let config: MpnetConfig = read_json(&dir.join("config.json"))?;
        let sentence_config: SentenceBertConfig =
            read_json(&dir.join("sentence_bert_config.json"))?;
        let weights_path = dir.join("model.safetensors");
        check_readable(&weights_path)?;
        let corrupt_weights = |err: candle_core::Error| MpnetError::Corrupt {
            path: weights_path.clone(),
            reason: err.to_string(),
        };
        // SAFETY: the weights are copied out of the mapping while loading and
        // the mapping is dropped before this function returns; the model pack
        // is not modified while mapvlm runs.
        let vb = unsafe {
            VarBuilder::from_mmaped_safetensors(&[&weights_path], DType::F32, &Device::Cpu)
        }
        .map_err(corrupt_weights)?;
        let model = Mpnet::load(vb, &config).map_err(corrupt_weights)?;
        let max_tokens = sentence_config.max_seq_length.min(model.max_tokens());
        let tokenizer = load_tokenizer(&dir.join("tokenizer.json"), max_tokens)?;
        Ok(Self {
            tokenizer,
            model,
            options: MpnetOptions {
                batch_size: options.batch_size.max(1),
                ..options
            },
            cache: Mutex::new(HashMap::new()),
        })
    }

    /// Embeds `sentences`, returning one unit vector per sentence in input
    /// order. With the cache on, a sentence seen before (in this call or an
    /// earlier one) is not run through the network again.
    pub fn embed(&self, sentences: &[&str]) -> Result<Vec<Arc<[f32]>>, MpnetError> {
        if !self.options.cache {
            return self.embed_uncached(sentences);
        }
        let mut cache = self.cache.lock().unwrap_or_else(PoisonError::into_inner);
        let mut missing: Vec<&str> = Vec::new();
        let mut fresh_index: HashMap<&str, usize> = HashMap::new();
        let slots: Vec<Slot> = sentences
            .iter()
            .map(|&sentence| match cache.get(sentence) {
                Some(vector) => Slot::Cached(Arc::clone(vector)),
                None => Slot::Fresh(*fresh_index.entry(sentence).or_insert_with(|| {
                    missing.push(sentence);
                    missing.len() - 1
                })),
            })
            .collect();
        let fresh = self.embed_uncached(&missing)?;
        for (sentence, vector) in missing.iter().zip(&fresh) {
            cache.insert((*sentence).to_owned(), Arc::clone(vector));
        }
        Ok(slots
            .into_iter()
            .map(|slot| match slot {
                Slot::Cached(vector) => vector,
                Slot::Fresh(index) => Arc::clone(&fresh[index]),
            })
            .collect())
    }

    /// Runs every sentence through the network, shortest first in batches,
    /// and returns the vectors in input order.
    fn embed_uncached(&self, sentences: &[&str]) -> Result<Vec<Arc<[f32]>>, MpnetError> {
        let mut vectors: Vec<(usize, Arc<[f32]>)> = Vec::with_capacity(sentences.len());
        for (indices, batch) in self.batches(sentences)? {
            let pooled = self.model.mean_pooled(&batch)?.to_vec2::<f32>()?;
            for (index, row) in indices.into_iter().zip(pooled) {
                vectors.push((index, normalized(row).into()));
            }
        }
        vectors.sort_unstable_by_key(|(index, _)| *index);
        Ok(vectors.into_iter().map(|(_, vector)| vector).collect())
    }

    /// Tokenises `sentences` and groups them, shortest first, into batches
    /// of at most `batch_size` rows, each with the input indices of its
    /// rows. Nothing is padded (see [`TokenBatch`]): padding would change
    /// the length of the sums in attention and with it the rounding, and a
    /// sentence would embed to other bits beside other companions.
    fn batches(&self, sentences: &[&str]) -> Result<Vec<(Vec<usize>, TokenBatch)>, MpnetError> {
        let encodings = self
            .tokenizer
            .encode_batch(sentences.to_vec(), true)
            .map_err(|err| MpnetError::Tokenize(err.to_string()))?;
        let mut order: Vec<usize> = (0..encodings.len()).collect();
        order.sort_by_key(|&index| encodings[index].get_ids().len());
        Ok(order
            .chunks(self.options.batch_size)
            .map(|group| {
                let rows: Vec<&[u32]> = group
                    .iter()
                    .map(|&index| encodings[index].get_ids())
                    .collect();
                (group.to_vec(), TokenBatch::pack(&rows))
            })
            .collect())
    }

    /// The floating-point operations of the matrix products the network
    /// runs to embed `sentences` (padding included), for benchmarks.
    pub fn batch_flops(&self, sentences: &[&str]) -> Result<u64, MpnetError> {
        Ok(self
            .batches(sentences)?
            .iter()
            .map(|(_, batch)| self.model.flops(batch))
            .sum())
    }

    /// The number of sentences whose embedding is cached.
    pub fn cached(&self) -> usize {
        self.cache
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .len()
    }
}

impl SentenceEncoder for MpnetEncoder {
    fn encode(&self, sentences: &[&str]) -> Result<Vec<Vec<f32>>, ModelError> {
        Ok(self
            .embed(sentences)?
            .iter()
            .map(|vector| vector.to_vec())
            .collect())
    }
}

/// Divides `vector` by its Euclidean norm (kept above 1e-12, as PyTorch's
/// `normalize`).
fn normalized(mut vector: Vec<f32>) -> Vec<f32> {
    let norm = vector.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
    vector.iter_mut().for_each(|x| *x /= norm);
    vector
}

/// Loads `tokenizer.json` without its own padding (batches are packed, not
/// padded) and truncating at `max_tokens` tokens, special
/// tokens included.
fn load_tokenizer(path: &Path, max_tokens: usize) -> Result<Tokenizer, MpnetError> {
    check_readable(path)?;
    let corrupt = |reason: String| MpnetError::Corrupt {
        path: path.to_owned(),
        reason,
    };
    let mut tokenizer = Tokenizer::from_file(path).map_err(|err| corrupt(err.to_string()))?;
    tokenizer.with_padding(None);
    tokenizer
        .with_truncation(Some(TruncationParams {
            max_length: max_tokens,
            ..TruncationParams::default()
        }))
        .map_err(|err| corrupt(err.to_string()))?;
    Ok(tokenizer)
}

/// Fails with [`MpnetError::Unreadable`] unless `path` is a readable file.
fn check_readable(path: &Path) -> Result<(), MpnetError> {
    std::fs::File::open(path)
        .map(drop)
        .map_err(|source| MpnetError::Unreadable {
            path: path.to_owned(),
            source,
        })
}

/// Reads and parses a JSON file of the model folder.
fn read_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T, MpnetError> {
    let text = std::fs::read_to_string(path).map_err(|source| MpnetError::Unreadable {
        path: path.to_owned(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|err| MpnetError::Corrupt {
        path: path.to_owned(),
        reason: err.to_string(),
    })
}
