//! The shared token-to-vector layer: hash embeddings of six lexical
//! features, a maxout + layer-norm mixer and four residual window encoders.

use std::path::Path;

use super::layers::{add_into, MaxoutNorm};
use super::strings::thinc_hash;
use super::weights::ThincModel;
use super::EnError;

/// The width of every token vector.
pub const WIDTH: usize = 96;
/// The number of feature columns (NORM, PREFIX, SUFFIX, SHAPE, SPACY, IS_SPACE).
pub const N_FEATURES: usize = 6;
const PIECES: usize = 3;
const DEPTH: usize = 4;
/// Zero rows thinc puts around each document before the encoder.
const PAD: usize = DEPTH;

struct HashEmbed {
    seed: u32,
    rows: usize,
    table: Vec<f32>,
}

/// The tok2vec component.
pub struct Tok2Vec {
    embeds: Vec<HashEmbed>,
    mixer: MaxoutNorm,
    encoders: Vec<MaxoutNorm>,
}

impl Tok2Vec {
    /// Loads `tok2vec/model`.
    pub fn load(path: &Path) -> Result<Self, EnError> {
        let model = ThincModel::load(path)?;
        let bad = |what: &str| EnError::corrupt(path, what);
        let mut embeds: Vec<(u64, HashEmbed)> = Vec::new();
        for node in model.named("hashembed") {
            let seed = node.attrs.get("seed").and_then(|v| v.as_u64());
            let column = node.attrs.get("column").and_then(|v| v.as_u64());
            let rows = node.dims.get("nV").copied();
            let (Some(seed), Some(column), Some(rows)) = (seed, column, rows) else {
                return Err(bad("a hashembed lacks seed, column or nV"));
            };
            let rows = rows as usize;
            let table = model.param(node, "E", &[rows, WIDTH])?.data.clone();
            embeds.push((
                column,
                HashEmbed {
                    seed: seed as u32,
                    rows,
                    table,
                },
            ));
        }
        embeds.sort_by_key(|(column, _)| *column);
        if embeds.len() != N_FEATURES || embeds.iter().enumerate().any(|(i, (c, _))| *c != i as u64)
        {
            return Err(bad("expected six hash embeddings for columns 0..6"));
        }
        let maxouts = model.named("maxout");
        let norms = model.named("layernorm");
        if maxouts.len() != DEPTH + 1 || norms.len() != DEPTH + 1 {
            return Err(bad("expected five maxout and layernorm layers"));
        }
        let mixer = MaxoutNorm::from_nodes(
            &model,
            maxouts[0],
            norms[0],
            WIDTH,
            PIECES,
            WIDTH * N_FEATURES,
        )?;
        let encoders = maxouts[1..]
            .iter()
            .zip(&norms[1..])
            .map(|(m, n)| MaxoutNorm::from_nodes(&model, m, n, WIDTH, PIECES, WIDTH * 3))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            embeds: embeds.into_iter().map(|(_, e)| e).collect(),
            mixer,
            encoders,
        })
    }

    /// The token vectors (n × 96, row-major) of one document's features.
    pub fn forward(&self, features: &[[u64; N_FEATURES]]) -> Vec<f32> {
        let n = features.len();
        if n == 0 {
            return Vec::new();
        }
        let padded = n + 2 * PAD;
        let concat_width = WIDTH * N_FEATURES;
        let mut concat = vec![0f32; n * concat_width];
        for (feats, row) in features.iter().zip(concat.chunks_exact_mut(concat_width)) {
            for ((embed, &key), out) in self
                .embeds
                .iter()
                .zip(feats)
                .zip(row.chunks_exact_mut(WIDTH))
            {
                for h in thinc_hash(key, embed.seed) {
                    let r = (h as usize) % embed.rows;
                    let src = &embed.table[r * WIDTH..(r + 1) * WIDTH];
                    add_into(out, src);
                }
            }
        }
        let mut x = vec![0f32; padded * WIDTH];
        self.mixer
            .apply_rows(&concat, n, &mut x[PAD * WIDTH..(PAD + n) * WIDTH]);
        let mut windows = vec![0f32; padded * WIDTH * 3];
        let mut y = vec![0f32; padded * WIDTH];
        // Layer `l` only needs rows that can still reach a real token in the
        // layers after it; the other pad rows are skipped (the real tokens'
        // vectors are the same as over the full padding).
        for (l, encoder) in self.encoders.iter().enumerate() {
            let margin = DEPTH - 1 - l;
            let (lo, hi) = (PAD - margin, PAD + n + margin);
            let rows = hi - lo;
            for (i, window) in windows.chunks_exact_mut(WIDTH * 3).take(rows).enumerate() {
                let r = lo + i;
                for (k, part) in window.chunks_exact_mut(WIDTH).enumerate() {
                    match (r + k).checked_sub(1).filter(|&src| src < padded) {
                        Some(src) => part.copy_from_slice(&x[src * WIDTH..(src + 1) * WIDTH]),
                        None => part.fill(0.0),
                    }
                }
            }
            encoder.apply_rows(&windows, rows, &mut y);
            add_into(&mut x[lo * WIDTH..hi * WIDTH], &y);
        }
        x[PAD * WIDTH..(PAD + n) * WIDTH].to_vec()
    }
}
