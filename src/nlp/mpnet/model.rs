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

/// A batch of token id rows, padded on the right to a common length.
#[derive(Debug, Clone)]
pub(crate) struct TokenBatch {
    /// `rows × seq_len` token ids, row-major, padded with the pad id.
    pub ids: Vec<u32>,
    /// The number of real (non-padding) tokens of each row.
    pub lengths: Vec<usize>,
    /// The padded length of every row.
    pub seq_len: usize,
}

impl TokenBatch {
    /// Pads `rows` on the right with `pad_id` to the longest row.
    pub fn pad(rows: &[&[u32]], pad_id: u32) -> Self {
        let seq_len = rows.iter().map(|row| row.len()).max().unwrap_or(0);
        let mut ids = Vec::with_capacity(rows.len() * seq_len);
        for row in rows {
            ids.extend_from_slice(row);
            ids.resize(ids.len() + seq_len - row.len(), pad_id);
        }
        let lengths = rows.iter().map(|row| row.len()).collect();
        Self {
            ids,
            lengths,
            seq_len,
        }
    }

    /// The number of rows.
    pub fn rows(&self) -> usize {
        self.lengths.len()
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

    /// `hidden`: `(rows·seq_len, hidden)`; `bias`: `(rows, heads, seq_len,
    /// seq_len)`, the position bias plus the padding mask.
    fn forward(&self, hidden: &Tensor, bias: &Tensor) -> candle_core::Result<Tensor> {
        let (rows, _, seq_len, _) = bias.dims4()?;
        let width = hidden.dim(1)?;
        let head_width = width / self.heads;
        let qkv = self
            .qkv
            .forward(hidden)?
            .reshape((rows, seq_len, 3, self.heads, head_width))?
            .permute((2, 0, 3, 1, 4))?
            .contiguous()?;
        let (q, k, v) = (qkv.get(0)?, qkv.get(1)?, qkv.get(2)?);
        let scores = (q.matmul(&k.t()?)? + bias)?;
        let probs = candle_nn::ops::softmax_last_dim(&scores)?;
        let context = probs
            .matmul(&v)?
            .transpose(1, 2)?
            .reshape((rows * seq_len, width))?;
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

    /// The mean of the last hidden states over the real tokens of each row:
    /// `(rows, hidden)`, not normalised.
    pub fn mean_pooled(&self, batch: &TokenBatch) -> candle_core::Result<Tensor> {
        let (rows, seq_len) = (batch.rows(), batch.seq_len);
        let ids = Tensor::from_slice(&batch.ids, (rows * seq_len,), &self.device)?;
        let positions =
            Tensor::from_vec(self.position_ids(batch), (rows * seq_len,), &self.device)?;
        let embedded = (self.word_embeddings.forward(&ids)?
            + self.position_embeddings.forward(&positions)?)?;
        let mut hidden = self.embedding_norm.forward(&embedded)?;
        let bias = self.attention_bias(batch)?;
        for layer in &self.layers {
            hidden = layer.forward(&hidden, &bias)?;
        }
        let mask = Tensor::from_vec(
            self.token_mask(batch, 1.0, 0.0),
            (rows, seq_len, 1),
            &self.device,
        )?;
        let summed = hidden
            .reshape((rows, seq_len, self.config.hidden_size))?
            .broadcast_mul(&mask)?
            .sum(1)?;
        let counts = mask.sum(1)?.clamp(1e-9, f32::MAX)?;
        summed.broadcast_div(&counts)
    }

    /// The floating-point operations of the matrix products of one forward
    /// pass over `batch`: per layer and row of padded length T, the q, k, v
    /// and output projections (4·2·T·H²), the feed-forward block (2·2·T·H·I)
    /// and the attention products (2·2·T²·H).
    pub fn flops(&self, batch: &TokenBatch) -> u64 {
        let (t, h) = (batch.seq_len as u64, self.config.hidden_size as u64);
        let i = self.config.intermediate_size as u64;
        let per_row = 4 * 2 * t * h * h + 2 * 2 * t * h * i + 2 * 2 * t * t * h;
        per_row * batch.rows() as u64 * self.config.num_hidden_layers as u64
    }

    /// Position ids as Hugging Face's `create_position_ids_from_input_ids`:
    /// the running count of non-padding tokens, zero on padding, plus the pad id.
    fn position_ids(&self, batch: &TokenBatch) -> Vec<u32> {
        let pad = self.config.pad_token_id;
        batch
            .ids
            .chunks(batch.seq_len.max(1))
            .flat_map(|row| {
                row.iter().scan(0, move |seen, &id| {
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

    /// `(rows·seq_len)` values: `real` on the real tokens, `padding` after them.
    fn token_mask(&self, batch: &TokenBatch, real: f32, padding: f32) -> Vec<f32> {
        batch
            .lengths
            .iter()
            .flat_map(|&length| {
                (0..batch.seq_len)
                    .map(move |position| if position < length { real } else { padding })
            })
            .collect()
    }

    /// The relative position bias of every head plus the padding mask,
    /// `(rows, heads, seq_len, seq_len)`, computed once for all layers.
    fn attention_bias(&self, batch: &TokenBatch) -> candle_core::Result<Tensor> {
        let (rows, seq_len) = (batch.rows(), batch.seq_len);
        let buckets = self.config.relative_attention_num_buckets;
        let bucket_ids: Vec<u32> = (0..seq_len)
            .flat_map(|query| {
                (0..seq_len).map(move |key| relative_position_bucket(query, key, buckets))
            })
            .collect();
        let bucket_ids = Tensor::from_vec(bucket_ids, (seq_len * seq_len,), &self.device)?;
        let position_bias = self
            .relative_attention_bias
            .forward(&bucket_ids)?
            .reshape((1, seq_len, seq_len, self.config.num_attention_heads))?
            .permute((0, 3, 1, 2))?;
        let padding = Tensor::from_vec(
            self.token_mask(batch, 0.0, f32::MIN),
            (rows, 1, 1, seq_len),
            &self.device,
        )?;
        position_bias.broadcast_add(&padding)?.contiguous()
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
    fn padding_keeps_real_tokens_and_pads_right() {
        let batch = TokenBatch::pad(&[&[0, 5, 2], &[0, 2]], 1);
        assert_eq!(batch.ids, vec![0, 5, 2, 0, 2, 1]);
        assert_eq!(batch.lengths, vec![3, 2]);
        assert_eq!(batch.seq_len, 3);
    }
}
