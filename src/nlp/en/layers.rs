//! The dense layers the pipeline needs, in f32 like thinc: affine maps,
//! maxout with layer normalisation, and argmax.

use super::weights::{Node, ThincModel};
use super::EnError;

/// The dot product of two equal-length slices, with eight running sums.
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; 8];
    let chunks_a = a.chunks_exact(8);
    let chunks_b = b.chunks_exact(8);
    let tail: f32 = chunks_a
        .remainder()
        .iter()
        .zip(chunks_b.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (ca, cb) in chunks_a.zip(chunks_b) {
        for k in 0..8 {
            acc[k] += ca[k] * cb[k];
        }
    }
    acc.iter().sum::<f32>() + tail
}

/// The index of the first largest value (0 when empty).
pub fn argmax(values: &[f32]) -> usize {
    let mut best = 0;
    for (i, &v) in values.iter().enumerate() {
        if v > values[best] {
            best = i;
        }
    }
    best
}

/// An affine layer `y = W x + b` with `W` of shape (n_out, n_in).
pub struct Linear {
    weights: Vec<f32>,
    bias: Vec<f32>,
    n_in: usize,
}

impl Linear {
    /// Reads a thinc `linear` or `softmax` node's `W` and `b`.
    pub fn from_node(
        model: &ThincModel,
        node: &Node,
        n_out: usize,
        n_in: usize,
    ) -> Result<Self, EnError> {
        Ok(Self {
            weights: model.param(node, "W", &[n_out, n_in])?.data.clone(),
            bias: model.param(node, "b", &[n_out])?.data.clone(),
            n_in,
        })
    }

    /// Applies the layer to one input vector, writing into `out`.
    pub fn apply(&self, input: &[f32], out: &mut [f32]) {
        for ((o, row), b) in out
            .iter_mut()
            .zip(self.weights.chunks_exact(self.n_in))
            .zip(&self.bias)
        {
            *o = dot(row, input) + b;
        }
    }
}

/// thinc's `Maxout(nO, nI, nP)` followed by `LayerNorm(nO)`.
pub struct MaxoutNorm {
    weights: Vec<f32>,
    bias: Vec<f32>,
    gain: Vec<f32>,
    shift: Vec<f32>,
    n_out: usize,
    n_pieces: usize,
    n_in: usize,
}

impl MaxoutNorm {
    /// Reads a `maxout` node and the `layernorm` node after it.
    pub fn from_nodes(
        model: &ThincModel,
        maxout: &Node,
        norm: &Node,
        n_out: usize,
        n_pieces: usize,
        n_in: usize,
    ) -> Result<Self, EnError> {
        Ok(Self {
            weights: model
                .param(maxout, "W", &[n_out, n_pieces, n_in])?
                .data
                .clone(),
            bias: model.param(maxout, "b", &[n_out, n_pieces])?.data.clone(),
            gain: model.param(norm, "G", &[n_out])?.data.clone(),
            shift: model.param(norm, "b", &[n_out])?.data.clone(),
            n_out,
            n_pieces,
            n_in,
        })
    }

    /// Applies maxout then layer norm to one input vector.
    pub fn apply(&self, input: &[f32], out: &mut [f32]) {
        let piece_rows = self.weights.chunks_exact(self.n_in);
        let mut best = f32::NEG_INFINITY;
        for (k, (row, b)) in piece_rows.zip(&self.bias).enumerate() {
            let value = dot(row, input) + b;
            let piece = k % self.n_pieces;
            if piece == 0 || value > best {
                best = value;
            }
            if piece == self.n_pieces - 1 {
                out[k / self.n_pieces] = best;
            }
        }
        layer_norm(&mut out[..self.n_out], &self.gain, &self.shift);
    }
}

fn layer_norm(x: &mut [f32], gain: &[f32], shift: &[f32]) {
    let n = x.len() as f32;
    let mean = x.iter().sum::<f32>() / n;
    let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / n + 1e-8;
    let scale = var.powf(-0.5);
    for ((v, g), b) in x.iter_mut().zip(gain).zip(shift) {
        *v = (*v - mean) * scale * g + b;
    }
}
