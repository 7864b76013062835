//! Word vectors for S_goal: the default GloVe 6B 50-d pack (an `.npy` matrix
//! and a parquet word index) and the standard word2vec binary and text
//! formats, with the cosine NumPy computes in the reference.
//!
//! Large files are memory-mapped: vectors stay in the map and are read on
//! lookup, so a 3.6 GB GoogleNews file costs only its word index in memory.

mod cosine;
mod glove;
mod keyed_vectors;
mod npy;
mod word2vec;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use memmap2::Mmap;

use crate::metrics::WordVectors;

pub use cosine::numpy_cosine;

/// What can go wrong loading word vectors; every message names the file and
/// the place in it.
#[derive(Debug, thiserror::Error)]
pub enum WordVectorError {
    /// The file could not be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not in the expected format.
    #[error("{}: {at}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// Where in the file, e.g. `line 3` or `byte 1024`.
        at: String,
        /// What was wrong and what was expected.
        message: String,
    },
    /// The parquet word index could not be read.
    #[error("cannot read the word index {}: {source}", path.display())]
    Parquet {
        /// The file.
        path: PathBuf,
        /// The parquet error.
        source: parquet::errors::ParquetError,
    },
}

impl WordVectorError {
    fn format(path: &Path, at: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Format {
            path: path.to_path_buf(),
            at: at.into(),
            message: message.into(),
        }
    }

    fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| Self::Io { path, source }
    }
}

/// Where the vectors are kept.
enum Storage {
    /// In a memory-mapped file: component `j` of row `i` is the little-endian
    /// f32 at byte `starts.get(i) + j * stride`.
    Mapped {
        map: Mmap,
        starts: RowStarts,
        stride: usize,
    },
    /// In memory, row-major.
    Owned(Vec<f32>),
}

/// Byte offsets of rows in a mapped file.
enum RowStarts {
    /// Row `i` starts at `base + i * step`.
    Linear { base: usize, step: usize },
    /// Row `i` starts at `starts[i]`.
    Listed(Vec<usize>),
}

impl RowStarts {
    fn get(&self, row: usize) -> usize {
        match self {
            Self::Linear { base, step } => base + row * step,
            Self::Listed(starts) => starts[row],
        }
    }
}

/// Word → row of its vector.
type WordRows = HashMap<Box<str>, usize>;

/// A table of word vectors: exact, case-sensitive word lookup; when a word
/// occurs twice, the later row wins (as a Python dict built in row order).
pub struct WordVectorTable {
    rows: WordRows,
    dim: usize,
    storage: Storage,
}

impl WordVectorTable {
    /// Loads the default pack folder (`glove-6b-50d/`): `glove_6B_50d_emb.npy`
    /// and `glove_6B_index.parquet`.
    pub fn load_glove_pack(dir: &Path) -> Result<Self, WordVectorError> {
        glove::load(dir)
    }

    /// Loads gensim KeyedVectors saved with `KeyedVectors.save(PATH)`: the
    /// pickled vocabulary at `path` and the matrix at `PATH.vectors.npy`,
    /// memory-mapped (e.g. `word2vec-google-news-300.model`, the paper's
    /// GoogleNews vectors as the Hub keeps them).
    pub fn load_keyed_vectors(path: &Path) -> Result<Self, WordVectorError> {
        keyed_vectors::load(path)
    }

    /// Loads a word2vec file, binary (e.g. GoogleNews-vectors-negative300.bin,
    /// memory-mapped) or text, telling the two apart from the first record.
    pub fn load_word2vec(path: &Path) -> Result<Self, WordVectorError> {
        word2vec::load(path)
    }

    /// The number of components of every vector.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The number of distinct words.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether the table has no words.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The vector of `word`, if it has one.
    pub fn vector(&self, word: &str) -> Option<Vec<f32>> {
        let row = *self.rows.get(word)?;
        Some(match &self.storage {
            Storage::Owned(values) => values[row * self.dim..(row + 1) * self.dim].to_vec(),
            Storage::Mapped {
                map,
                starts,
                stride,
            } => {
                let start = starts.get(row);
                (0..self.dim)
                    .map(|j| read_f32(map, start + j * stride))
                    .collect()
            }
        })
    }
}

impl WordVectors for WordVectorTable {
    fn similarity(&self, a: &str, b: &str) -> f32 {
        match (self.vector(a), self.vector(b)) {
            (Some(x), Some(y)) => numpy_cosine(&x, &y),
            _ => 0.0,
        }
    }
}

/// The little-endian f32 at byte `at` of `bytes` (bounds checked at load).
fn read_f32(bytes: &[u8], at: usize) -> f32 {
    let mut raw = [0u8; 4];
    raw.copy_from_slice(&bytes[at..at + 4]);
    f32::from_le_bytes(raw)
}

/// Maps `path` read-only.
fn map_file(path: &Path) -> Result<Mmap, WordVectorError> {
    let file = std::fs::File::open(path).map_err(WordVectorError::io(path))?;
    // SAFETY: the map is read-only; like every reader of model files we
    // assume the file is not truncated or rewritten while it is in use.
    unsafe { Mmap::map(&file) }.map_err(WordVectorError::io(path))
}
