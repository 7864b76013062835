//! A pure-Rust reproduction of spaCy's `en_core_web_sm` 3.8.0 pipeline
//! (tokenizer, tok2vec, tagger, parser, attribute ruler), reading the
//! model's own files.

mod attribute_ruler;
mod layers;
mod lexeme;
mod parser;
mod strings;
mod symbols;
mod tok2vec;
pub mod tokenizer;
mod weights;

use std::collections::HashMap;
use std::path::Path;

use rmpv::Value;

use crate::metrics::{FramingParser, ModelError};
use crate::nlp::Token;
use attribute_ruler::{AttributeRuler, TokenAttrs};
use layers::{argmax, Linear};
use lexeme::{prefix, py_str_isspace, suffix, word_shape, Norms};
use parser::Parser;
use strings::string_id;
use tok2vec::{Tok2Vec, N_FEATURES, WIDTH};
use tokenizer::{RawToken, Tokenizer};
use weights::{get, read_msgpack, ThincModel};

/// The English pipeline: tokenizer, tok2vec, tagger, parser and attribute
/// ruler of en_core_web_sm 3.8.0, run as spaCy runs them.
pub struct EnPipeline {
    tokenizer: Tokenizer,
    norms: Norms,
    tok2vec: Tok2Vec,
    tagger: Linear,
    tags: Vec<String>,
    parser: Parser,
    ruler: AttributeRuler,
}

impl EnPipeline {
    /// Loads the pipeline from the model's folder
    /// (`.../en_core_web_sm-3.8.0`).
    pub fn load(dir: &Path) -> Result<Self, EnError> {
        let tagger_path = dir.join("tagger").join("model");
        let tagger_model = ThincModel::load(&tagger_path)?;
        let softmax = tagger_model
            .named("softmax")
            .into_iter()
            .next()
            .ok_or_else(|| EnError::corrupt(&tagger_path, "no softmax layer"))?;
        let tags = load_tag_labels(&dir.join("tagger").join("cfg"))?;
        let tagger = Linear::from_node(&tagger_model, softmax, tags.len(), WIDTH)?;
        Ok(Self {
            tokenizer: Tokenizer::load(&dir.join("tokenizer"))?,
            norms: load_norms(&dir.join("vocab").join("lookups.bin"))?,
            tok2vec: Tok2Vec::load(&dir.join("tok2vec").join("model"))?,
            tagger,
            tags,
            parser: Parser::load(&dir.join("parser"))?,
            ruler: AttributeRuler::load(&dir.join("attribute_ruler").join("patterns"))?,
        })
    }

    /// Tokenises, tags and parses one text.
    pub fn analyse(&self, text: &str) -> Vec<Token> {
        let raw = self.tokenizer.tokenize(text);
        if raw.is_empty() {
            return Vec::new();
        }
        let features: Vec<[u64; N_FEATURES]> = raw.iter().map(|t| self.features(t)).collect();
        let vectors = self.tok2vec.forward(&features);
        let mut scores = vec![0f32; raw.len() * self.tags.len()];
        self.tagger.apply_rows(&vectors, raw.len(), &mut scores);
        let is_space: Vec<bool> = raw.iter().map(|t| py_str_isspace(&t.text)).collect();
        let arcs = self.parser.parse(&vectors, &is_space);
        let mut attrs: Vec<TokenAttrs> = raw
            .iter()
            .zip(scores.chunks_exact(self.tags.len()))
            .zip(&arcs)
            .zip(&is_space)
            .map(|(((token, scores), arc), &is_space)| TokenAttrs {
                text: token.text.clone(),
                tag: self.tags[argmax(scores)].clone(),
                pos: String::new(),
                dep: arc.dep.clone(),
                is_space,
            })
            .collect();
        self.ruler.apply(&mut attrs);
        raw.into_iter()
            .zip(attrs)
            .zip(arcs)
            .map(|((token, attrs), arc)| Token {
                text: token.text,
                ws: if token.spacy {
                    " ".into()
                } else {
                    String::new()
                },
                tag: attrs.tag,
                pos: attrs.pos,
                dep: attrs.dep,
                head: arc.head,
            })
            .collect()
    }

    /// The six feature ids tok2vec embeds for a token.
    fn features(&self, token: &RawToken) -> [u64; N_FEATURES] {
        let text = token.text.as_str();
        let norm = match &token.norm {
            Some(norm) => string_id(norm),
            None => string_id(&self.norms.norm(text)),
        };
        [
            norm,
            string_id(prefix(text)),
            string_id(suffix(text)),
            string_id(&word_shape(text)),
            u64::from(token.spacy),
            u64::from(py_str_isspace(text)),
        ]
    }
}

impl FramingParser for EnPipeline {
    fn parse(&self, text: &str) -> Result<Vec<Token>, ModelError> {
        Ok(self.analyse(text))
    }
}

fn load_tag_labels(path: &Path) -> Result<Vec<String>, EnError> {
    let text = std::fs::read_to_string(path).map_err(|e| EnError::missing(path, &e))?;
    let cfg: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| EnError::corrupt(path, &e.to_string()))?;
    cfg.get("labels")
        .and_then(serde_json::Value::as_array)
        .and_then(|labels| {
            labels
                .iter()
                .map(|l| l.as_str().map(str::to_string))
                .collect::<Option<Vec<_>>>()
        })
        .filter(|labels| !labels.is_empty())
        .ok_or_else(|| EnError::corrupt(path, "no tag labels"))
}

fn load_norms(path: &Path) -> Result<Norms, EnError> {
    let root = read_msgpack(path)?;
    let mut table = get(&root, "lexeme_norm")
        .cloned()
        .ok_or_else(|| EnError::corrupt(path, "no lexeme_norm table"))?;
    if let Value::Binary(bytes) = &table {
        table = rmpv::decode::read_value(&mut bytes.as_slice())
            .map_err(|_| EnError::corrupt(path, "lexeme_norm is not msgpack"))?;
    }
    if let Some(inner) = get(&table, "dict") {
        table = inner.clone();
    }
    let map = table
        .as_map()
        .ok_or_else(|| EnError::corrupt(path, "lexeme_norm is not a map"))?;
    let mut norms = HashMap::with_capacity(map.len());
    for (k, v) in map {
        if let (Some(k), Some(v)) = (k.as_u64(), weights::as_text(v)) {
            norms.insert(k, v.to_string());
        }
    }
    Ok(Norms::new(norms))
}

/// Why the English pipeline could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum EnError {
    /// A model file could not be read.
    #[error("cannot read {path}: {reason}; run `mapvlm models fetch` to install the model pack")]
    Missing {
        /// The file.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// A model file was read but is not what the pipeline expects.
    #[error("{path} is not a usable en_core_web_sm-3.8.0 file: {reason}; run `mapvlm models fetch` to reinstall the model pack")]
    Corrupt {
        /// The file.
        path: String,
        /// What is wrong with it.
        reason: String,
    },
}

impl EnError {
    fn missing(path: &Path, err: &std::io::Error) -> Self {
        Self::Missing {
            path: path.display().to_string(),
            reason: err.to_string(),
        }
    }

    fn corrupt(path: &Path, reason: &str) -> Self {
        Self::Corrupt {
            path: path.display().to_string(),
            reason: reason.to_string(),
        }
    }
}
