//! Plan metrics: PG2S and KAS, pure functions over plans, plus the traits
//! for the models PG2S needs.

pub mod kas;
pub mod pg2s;

use crate::nlp::Token;

/// A score as every view writes it for a person (the workbench, `score
/// --explain`): three decimals, `n/a` when it could not be computed, so the
/// same number reads the same everywhere.
pub fn shown(score: Option<f64>) -> String {
    score.map_or_else(|| "n/a".to_string(), |v| format!("{v:.3}"))
}

/// The error a model behind one of the metric traits may report.
pub type ModelError = Box<dyn std::error::Error + Send + Sync>;

/// Turns sentences into L2-normalised sentence embeddings (all-mpnet-base-v2
/// by default), one vector per sentence, in input order.
pub trait SentenceEncoder: Send + Sync {
    /// Embeds every sentence; the vectors have unit length.
    fn encode(&self, sentences: &[&str]) -> Result<Vec<Vec<f32>>, ModelError>;
}

/// Word vectors for S_goal's word similarity.
pub trait WordVectors: Send + Sync {
    /// The cosine of the vectors of `a` and `b`, computed in f32 as NumPy
    /// does; 0 when either word has no vector. Lookups are case-sensitive.
    fn similarity(&self, a: &str, b: &str) -> f32;
}

/// A dependency parser compatible with spaCy's en_core_web_sm, used to frame
/// plan steps into actions.
pub trait FramingParser: Send + Sync {
    /// Tokenises, tags and parses one text.
    fn parse(&self, text: &str) -> Result<Vec<Token>, ModelError>;
}
