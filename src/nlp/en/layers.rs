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

/// `out = X · Wᵀ` for `X` (n × k) and `W` (m × k), all row-major.
pub fn matmul_transposed(x: &[f32], w: &[f32], n: usize, k: usize, m: usize, out: &mut [f32]) {
    assert!(x.len() >= n * k && w.len() >= m * k && out.len() >= n * m);
    if n == 0 || m == 0 {
        return;
    }
    // SAFETY: the assertion above keeps every index the kernel touches
    // within the three slices, and `out` does not alias the inputs.
    unsafe {
        matrixmultiply::sgemm(
            n,
            k,
            m,
            1.0,
            x.as_ptr(),
            k as isize,
            1,
            w.as_ptr(),
            1,
            k as isize,
            0.0,
            out.as_mut_ptr(),
            m as isize,
            1,
        );
    }
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

    /// Applies the layer to `n` input rows at once, writing `n` output rows.
    pub fn apply_rows(&self, input: &[f32], n: usize, out: &mut [f32]) {
        let m = self.bias.len();
        matmul_transposed(input, &self.weights, n, self.n_in, m, out);
        for row in out[..n * m].chunks_exact_mut(m) {
            row.iter_mut().zip(&self.bias).for_each(|(o, b)| *o += b);
        }
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

    /// Applies maxout then layer norm to `n` input rows, writing `n` rows
    /// of width `n_out` into `out`.
    pub fn apply_rows(&self, input: &[f32], n: usize, out: &mut [f32]) {
        let width = self.n_out * self.n_pieces;
        let mut pieces = vec![0f32; n * width];
        matmul_transposed(input, &self.weights, n, self.n_in, width, &mut pieces);
        for (row, out_row) in pieces
            .chunks_exact(width)
            .zip(out.chunks_exact_mut(self.n_out))
        {
            for ((o, piece), bias) in out_row
                .iter_mut()
                .zip(row.chunks_exact(self.n_pieces))
                .zip(self.bias.chunks_exact(self.n_pieces))
            {
                let mut best = piece[0] + bias[0];
                for (v, b) in piece.iter().zip(bias).skip(1) {
                    if v + b > best {
                        best = v + b;
                    }
                }
                *o = best;
            }
            layer_norm(out_row, &self.gain, &self.shift);
        }
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
