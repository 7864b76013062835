//! The MPNet network behind all-mpnet-base-v2, written with candle: token and
//! position embeddings, a stack of post-norm transformer layers sharing one
//! relative position bias, and mean pooling of the last hidden states.

use candle_core::{Device, Module, Tensor};
use candle_nn::{Embedding, VarBuilder};
use serde::Deserialize;

use super::gelu::GeluErf;

/// The largest relative distance the position buckets tell apart (fixed in
/// MPNet, not part of its `config.json`).
const MAX_RELATIVE_DISTANCE: usize = 128;

/// The fields of a Hugging Face MPNet `config.json` the network needs.
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct MpnetConfig {
    /// Rows of the word embedding table.
    pub vocab_size: usize,
    /// Width of the hidden states.
    pub hidden_size: usize,
    /// Number of transformer layers.
    pub num_hidden_layers: usize,
    /// Number of attention heads per layer.
    pub num_attention_heads: usize,
    /// Width of the feed-forward block.
    pub intermediate_size: usize,
    /// Activation of the feed-forward block; only `gelu` is supported.
    pub hidden_act: String,
    /// Rows of the position embedding table.
    pub max_position_embeddings: usize,
    /// Epsilon of every layer norm.
    pub layer_norm_eps: f64,
    /// The padding token id, also the position offset.
    pub pad_token_id: u32,
    /// Number of relative position buckets.
    pub relative_attention_num_buckets: usize,
}

/// Token id rows packed end to end, never padded: the dense layers run on
/// every token of the batch at once, attention runs on each run of rows of
/// one length. A row's sums then have the same length and order whatever
/// rows share its batch, so its embedding has the same bits alone and in
/// any batch.
#[derive(Debug, Clone)]
pub(crate) struct TokenBatch {
    /// The token ids of every row, end to end.
    pub ids: Vec<u32>,
    /// Each run of consecutive rows of one length: (length, rows).
    pub runs: Vec<(usize, usize)>,
}

impl TokenBatch {
    /// Packs `rows`, in order, into runs of equal length (sort the rows by
    /// length first for few runs).
    pub fn pack(rows: &[&[u32]]) -> Self {
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for row in rows {
            match runs.last_mut() {
                Some((length, count)) if *length == row.len() => *count += 1,
                _ => runs.push((row.len(), 1)),
            }
        }
        Self {
            ids: rows.concat(),
            runs,
        }
    }

    /// Each run with the index of its first token: (first token, length, rows).
    fn spans(&self) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
        self.runs.iter().scan(0, |start, &(length, count)| {
            let first = *start;
            *start += length * count;
            Some((first, length, count))
        })
    }
}

/// A dense layer `x · Wᵀ + b` on 2-D inputs.
#[derive(Debug, Clone)]
struct Dense {
    weight: Tensor,
    bias: Tensor,
}

impl Dense {
    fn load(vb: VarBuilder, inputs: usize, outputs: usize) -> candle_core::Result<Self> {
        Ok(Self {
            weight: vb.get((outputs, inputs), "weight")?,
            bias: vb.get(outputs, "bias")?,
        })
    }

    fn forward(&self, xs: &Tensor) -> candle_core::Result<Tensor> {
        xs.matmul(&self.weight.t()?)?.broadcast_add(&self.bias)
    }
}

/// A layer norm over the last dimension.
#[derive(Debug, Clone)]
struct Norm {
    weight: Tensor,
    bias: Tensor,
    eps: f32,
}

impl Norm {
    fn load(vb: VarBuilder, size: usize, eps: f64) -> candle_core::Result<Self> {
        Ok(Self {
            weight: vb.get(size, "weight")?,
            bias: vb.get(size, "bias")?,
            eps: eps as f32,
        })
    }

    fn forward(&self, xs: &Tensor) -> candle_core::Result<Tensor> {
        candle_nn::ops::layer_norm(xs, &self.weight, &self.bias, self.eps)
    }
}

/// One transformer layer: self-attention with the relative position bias,
/// then the GELU feed-forward block, each followed by residual + layer norm.
#[derive(Debug, Clone)]
struct Layer {
    /// q, k and v fused into one projection; q is pre-scaled by 1/√d_head.
    qkv: Dense,
    out: Dense,
    attention_norm: Norm,
    up: Dense,
    down: Dense,
    output_norm: Norm,
    heads: usize,
}

impl Layer {
    fn load(vb: VarBuilder, config: &MpnetConfig) -> candle_core::Result<Self> {
        let hidden = config.hidden_size;
        let attn = vb.pp("attention.attn");
        let q = Dense::load(attn.pp("q"), hidden, hidden)?;
        let k = Dense::load(attn.pp("k"), hidden, hidden)?;
        let v = Dense::load(attn.pp("v"), hidden, hidden)?;
        let scale = 1.0 / ((hidden / config.num_attention_heads) as f64).sqrt();
        let qkv = Dense {
            weight: Tensor::cat(&[(q.weight * scale)?, k.weight, v.weight], 0)?,
            bias: Tensor::cat(&[(q.bias * scale)?, k.bias, v.bias], 0)?,
        };
        Ok(Self {
            qkv,
            out: Dense::load(attn.pp("o"), hidden, hidden)?,
            attention_norm: Norm::load(
                vb.pp("attention.LayerNorm"),
                hidden,
                config.layer_norm_eps,
            )?,
            up: Dense::load(
                vb.pp("intermediate.dense"),
                hidden,
                config.intermediate_size,
            )?,
            down: Dense::load(vb.pp("output.dense"), config.intermediate_size, hidden)?,
            output_norm: Norm::load(vb.pp("output.LayerNorm"), hidden, config.layer_norm_eps)?,
            heads: config.num_attention_heads,
        })
    }

    /// `hidden`: `(tokens, hidden)`, the rows of `batch` end to end;
    /// `biases`: the relative position bias `(1, heads, length, length)` of
    /// each run of `batch`.
    fn forward(
        &self,
        hidden: &Tensor,
        batch: &TokenBatch,
        biases: &[Tensor],
    ) -> candle_core::Result<Tensor> {
        let width = hidden.dim(1)?;
        let head_width = width / self.heads;
        let qkv = self.qkv.forward(hidden)?;
        let contexts = batch
            .spans()
            .zip(biases)
            .map(|((first, length, rows), bias)| {
                let qkv = qkv
                    .narrow(0, first, length * rows)?
                    .reshape((rows, length, 3, self.heads, head_width))?
                    .permute((2, 0, 3, 1, 4))?
                    .contiguous()?;
                let (q, k, v) = (qkv.get(0)?, qkv.get(1)?, qkv.get(2)?);
                let scores = q.matmul(&k.t()?)?.broadcast_add(bias)?;
                let probs = candle_nn::ops::softmax_last_dim(&scores)?;
                probs
                    .matmul(&v)?
                    .transpose(1, 2)?
                    .reshape((rows * length, width))
            })
            .collect::<candle_core::Result<Vec<_>>>()?;
        let context = Tensor::cat(&contexts, 0)?;
        let attended = self
            .attention_norm
            .forward(&(self.out.forward(&context)? + hidden)?)?;
        let expanded = self.up.forward(&attended)?.apply_op1_no_bwd(&GeluErf)?;
        self.output_norm
            .forward(&(self.down.forward(&expanded)? + attended)?)
    }
}

/// The MPNet encoder with mean pooling.
#[derive(Debug, Clone)]
pub(crate) struct Mpnet {
    word_embeddings: Embedding,
    position_embeddings: Embedding,
    embedding_norm: Norm,
    layers: Vec<Layer>,
    relative_attention_bias: Embedding,
    config: MpnetConfig,
    device: Device,
}

impl Mpnet {
    /// Loads the weights of a Hugging Face `MPNetModel` (tensor names as in
    /// all-mpnet-base-v2's `model.safetensors`).
    pub fn load(vb: VarBuilder, config: &MpnetConfig) -> candle_core::Result<Self> {
        if config.hidden_act != "gelu" {
            candle_core::bail!(
                "unsupported activation {:?} (only \"gelu\")",
                config.hidden_act
            );
        }
        if config.num_attention_heads == 0 || config.hidden_size % config.num_attention_heads != 0 {
            candle_core::bail!(
                "hidden size {} is not a multiple of the {} attention heads",
                config.hidden_size,
                config.num_attention_heads
            );
        }
        let hidden = config.hidden_size;
        let embeddings = vb.pp("embeddings");
        let embedding = |name: &str, rows: usize| -> candle_core::Result<Embedding> {
            Ok(Embedding::new(
                embeddings.get((rows, hidden), &format!("{name}.weight"))?,
                hidden,
            ))
        };
        let encoder = vb.pp("encoder");
        let layers = (0..config.num_hidden_layers)
            .map(|index| Layer::load(encoder.pp(format!("layer.{index}")), config))
            .collect::<candle_core::Result<Vec<_>>>()?;
        let relative_attention_bias = Embedding::new(
            encoder.get(
                (
                    config.relative_attention_num_buckets,
                    config.num_attention_heads,
                ),
                "relative_attention_bias.weight",
            )?,
            config.num_attention_heads,
        );
        Ok(Self {
            word_embeddings: embedding("word_embeddings", config.vocab_size)?,
            position_embeddings: embedding("position_embeddings", config.max_position_embeddings)?,
            embedding_norm: Norm::load(embeddings.pp("LayerNorm"), hidden, config.layer_norm_eps)?,
            layers,
            relative_attention_bias,
            config: config.clone(),
            device: vb.device().clone(),
        })
    }

    /// The longest row the position table allows.
    pub fn max_tokens(&self) -> usize {
        self.config
            .max_position_embeddings
            .saturating_sub(self.config.pad_token_id as usize + 1)
    }

    /// The mean of the last hidden states over the tokens of each row:
    /// `(rows, hidden)`, not normalised.
    pub fn mean_pooled(&self, batch: &TokenBatch) -> candle_core::Result<Tensor> {
        let tokens = batch.ids.len();
        let ids = Tensor::from_slice(&batch.ids, (tokens,), &self.device)?;
        let positions = Tensor::from_vec(self.position_ids(batch), (tokens,), &self.device)?;
        let embedded = (self.word_embeddings.forward(&ids)?
            + self.position_embeddings.forward(&positions)?)?;
        let mut hidden = self.embedding_norm.forward(&embedded)?;
        let biases = batch
            .runs
            .iter()
            .map(|&(length, _)| self.position_bias(length))
            .collect::<candle_core::Result<Vec<_>>>()?;
        for layer in &self.layers {
            hidden = layer.forward(&hidden, batch, &biases)?;
        }
        let means = batch
            .spans()
            .map(|(first, length, rows)| {
                hidden
                    .narrow(0, first, length * rows)?
                    .reshape((rows, length, self.config.hidden_size))?
                    .sum(1)?
                    .broadcast_div(&Tensor::new(length.max(1) as f32, &self.device)?)
            })
            .collect::<candle_core::Result<Vec<_>>>()?;
        Tensor::cat(&means, 0)
    }

    /// The floating-point operations of the matrix products of one forward
    /// pass over `batch`: per layer and row of length T, the q, k, v and
    /// output projections (4·2·T·H²), the feed-forward block (2·2·T·H·I)
    /// and the attention products (2·2·T²·H).
    pub fn flops(&self, batch: &TokenBatch) -> u64 {
        let h = self.config.hidden_size as u64;
        let i = self.config.intermediate_size as u64;
        let per_row = |t: u64| 4 * 2 * t * h * h + 2 * 2 * t * h * i + 2 * 2 * t * t * h;
        let per_pass: u64 = batch
            .runs
            .iter()
            .map(|&(length, rows)| per_row(length as u64) * rows as u64)
            .sum();
        per_pass * self.config.num_hidden_layers as u64
    }

    /// Position ids as Hugging Face's `create_position_ids_from_input_ids`:
    /// in each row the running count of non-padding tokens, plus the pad id
    /// (the pad id itself on a padding token).
    fn position_ids(&self, batch: &TokenBatch) -> Vec<u32> {
        let pad = self.config.pad_token_id;
        batch
            .spans()
            .flat_map(|(first, length, rows)| {
                (0..rows).map(move |row| first + row * length..first + (row + 1) * length)
            })
            .flat_map(|range| {
                batch.ids[range].iter().scan(0, move |seen, &id| {
                    if id == pad {
                        Some(pad)
                    } else {
                        *seen += 1;
                        Some(*seen + pad)
                    }
                })
            })
            .collect()
    }

    /// The relative position bias of every head for rows of `length`
    /// tokens, `(1, heads, length, length)`, computed once for all layers.
    fn position_bias(&self, length: usize) -> candle_core::Result<Tensor> {
        let buckets = self.config.relative_attention_num_buckets;
        let bucket_ids: Vec<u32> = (0..length)
            .flat_map(|query| {
                (0..length).map(move |key| relative_position_bucket(query, key, buckets))
            })
            .collect();
        let bucket_ids = Tensor::from_vec(bucket_ids, (length * length,), &self.device)?;
        self.relative_attention_bias
            .forward(&bucket_ids)?
            .reshape((1, length, length, self.config.num_attention_heads))?
            .permute((0, 3, 1, 2))?
            .contiguous()
    }
}

/// MPNet's bidirectional relative position bucket of a query and a key
/// position: half the buckets for keys after the query, half for the rest;
/// exact below a quarter of the buckets, then logarithmic up to
/// [`MAX_RELATIVE_DISTANCE`]. Computed in f32 as the reference does.
fn relative_position_bucket(query: usize, key: usize, buckets: usize) -> u32 {
    let half = buckets / 2;
    let exact = half / 2;
    let offset = if key > query { half } else { 0 };
    let distance = query.abs_diff(key);
    let bucket = if distance < exact {
        distance
    } else {
        let ratio = (distance as f32 / exact as f32).ln()
            / ((MAX_RELATIVE_DISTANCE as f64 / exact as f64).ln() as f32)
            * (half - exact) as f32;
        (exact + ratio as usize).min(half - 1)
    };
    (offset + bucket) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buckets_are_exact_near_and_logarithmic_far() {
        assert_eq!(relative_position_bucket(5, 5, 32), 0);
        assert_eq!(relative_position_bucket(7, 0, 32), 7);
        assert_eq!(relative_position_bucket(0, 7, 32), 23);
        assert_eq!(relative_position_bucket(11, 0, 32), 8);
        assert_eq!(relative_position_bucket(12, 0, 32), 9);
        assert_eq!(relative_position_bucket(0, 16, 32), 26);
        assert_eq!(relative_position_bucket(127, 0, 32), 15);
        assert_eq!(relative_position_bucket(0, 500, 32), 31);
    }

    #[test]
    fn packing_keeps_the_rows_end_to_end_in_runs_of_one_length() {
        let batch = TokenBatch::pack(&[&[0, 2], &[0, 7, 2], &[0, 5, 2], &[0, 2]]);
        assert_eq!(batch.ids, vec![0, 2, 0, 7, 2, 0, 5, 2, 0, 2]);
        assert_eq!(batch.runs, vec![(2, 1), (3, 2), (2, 1)]);
        let spans: Vec<_> = batch.spans().collect();
        assert_eq!(spans, vec![(0, 2, 1), (2, 3, 2), (8, 2, 1)]);
    }
}
