//! The language models behind the metrics.

pub mod embedding_cache;
pub mod en;
pub mod mpnet;
pub mod wordvec;

use serde::{Deserialize, Serialize};

/// One token of a parsed sentence, with the fields spaCy reports.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Token {
    /// The token's text, exactly as in the input.
    pub text: String,
    /// The whitespace after the token (empty or one space, as spaCy).
    pub ws: String,
    /// Fine-grained (Penn Treebank) tag, e.g. `VB`.
    pub tag: String,
    /// Coarse universal part of speech, e.g. `VERB`.
    pub pos: String,
    /// Dependency label, e.g. `dobj`.
    pub dep: String,
    /// Index of the token's head in the sentence (the root is its own head).
    pub head: usize,
}
