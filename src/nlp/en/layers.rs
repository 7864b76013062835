//! The dense layers the pipeline needs, in f32 like thinc: affine maps,
//! maxout with layer normalisation, and argmax.

use super::weights::{Node, ThincModel};
use super::EnError;

/// The dot product of two equal-length slices, with eight running sums.
///
/// With AVX the eight sums are one register, each lane adding its products
/// in the same order as the plain loop, so both give the same bits; the
/// plain loop is the fallback (at the tests' opt-level its iterator calls
/// were a quarter of the English pipeline's time).
pub fn dot(a: &[f32], b: &[f32]) -> f32 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the processor has AVX (checked above).
            return unsafe { simd::dot(a, b) };
        }
    }
    plain_dot(a, b)
}

/// [`dot`] without SIMD: the fallback, and what the SIMD path must equal.
fn plain_dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; 8];
    let chunks_a = a.chunks_exact(8);
    let chunks_b = b.chunks_exact(8);
    let tail = tail_dot(chunks_a.remainder(), chunks_b.remainder());
    for (ca, cb) in chunks_a.zip(chunks_b) {
        for k in 0..8 {
            acc[k] += ca[k] * cb[k];
        }
    }
    acc.iter().sum::<f32>() + tail
}

/// The products of the last, fewer than eight, values, summed in order.
fn tail_dot(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Adds `src` to `dst` value by value (the parser's feature sums).
pub fn add_into(dst: &mut [f32], src: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the processor has AVX (checked above).
            unsafe { simd::add_into(dst, src) };
            return;
        }
    }
    plain_add_into(dst, src);
}

/// [`add_into`] without SIMD.
fn plain_add_into(dst: &mut [f32], src: &[f32]) {
    dst.iter_mut().zip(src).for_each(|(d, s)| *d += s);
}

/// `out = X · Wᵀ` for `X` (n × k) and `W` (m × k), all row-major.
///
/// With AVX2 and FMA, four input rows meet two weight rows at a time, so
/// each weight row is read once per four tokens; otherwise plain dots.
pub fn matmul_transposed(x: &[f32], w: &[f32], n: usize, k: usize, m: usize, out: &mut [f32]) {
    let (x, w, out) = (&x[..n * k], &w[..m * k], &mut out[..n * m]);
    #[cfg(target_arch = "x86_64")]
    {
        if k % 8 == 0
            && std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the processor has AVX2 and FMA (checked above), and
            // the slices were cut to exactly n·k, m·k and n·m values.
            unsafe { simd::matmul(x, w, n, k, m, out) };
            return;
        }
    }
    for (xr, or) in x.chunks_exact(k).zip(out.chunks_exact_mut(m)) {
        for (o, wj) in or.iter_mut().zip(w.chunks_exact(k)) {
            *o = dot(xr, wj);
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod simd {
    use std::arch::x86_64::*;

    /// [`super::dot`] with the eight running sums in one register: a
    /// multiply then an add per lane (no fused multiply-add, which would
    /// round once instead of twice), then the lanes summed in order.
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn dot(a: &[f32], b: &[f32]) -> f32 {
        let n = a.len().min(b.len());
        let whole = n - n % 8;
        let mut acc = _mm256_setzero_ps();
        let mut c = 0;
        while c < whole {
            // SAFETY: c + 8 <= whole <= the length of both slices.
            let (x, y) = unsafe {
                (
                    _mm256_loadu_ps(a.as_ptr().add(c)),
                    _mm256_loadu_ps(b.as_ptr().add(c)),
                )
            };
            acc = _mm256_add_ps(acc, _mm256_mul_ps(x, y));
            c += 8;
        }
        let mut lanes = [0f32; 8];
        // SAFETY: `lanes` holds eight values.
        unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), acc) };
        lanes.iter().sum::<f32>() + super::tail_dot(&a[whole..n], &b[whole..n])
    }

    /// [`super::add_into`], eight values at a time.
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn add_into(dst: &mut [f32], src: &[f32]) {
        let n = dst.len().min(src.len());
        let whole = n - n % 8;
        let mut c = 0;
        while c < whole {
            // SAFETY: c + 8 <= whole <= the length of both slices.
            unsafe {
                let sum = _mm256_add_ps(
                    _mm256_loadu_ps(dst.as_ptr().add(c)),
                    _mm256_loadu_ps(src.as_ptr().add(c)),
                );
                _mm256_storeu_ps(dst.as_mut_ptr().add(c), sum);
            }
            c += 8;
        }
        for (d, s) in dst[whole..n].iter_mut().zip(&src[whole..n]) {
            *d += s;
        }
    }

    /// Sum of the eight lanes.
    #[target_feature(enable = "avx2,fma")]
    fn hsum(v: __m256) -> f32 {
        let pair = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
        let quad = _mm_add_ps(pair, _mm_movehl_ps(pair, pair));
        let single = _mm_add_ss(quad, _mm_shuffle_ps(quad, quad, 1));
        _mm_cvtss_f32(single)
    }

    /// `out = X · Wᵀ`; `x`, `w`, `out` hold exactly n·k, m·k, n·m values
    /// and `k` is a multiple of 8.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn matmul(
        x: &[f32],
        w: &[f32],
        n: usize,
        k: usize,
        m: usize,
        out: &mut [f32],
    ) {
        let xp = x.as_ptr();
        let wp = w.as_ptr();
        let mut t = 0;
        while t < n {
            let rows = (n - t).min(4);
            let mut j = 0;
            while j < m {
                let cols = (m - j).min(2);
                let mut acc = [[_mm256_setzero_ps(); 2]; 4];
                let mut c = 0;
                while c < k {
                    let wv = [
                        _mm256_loadu_ps(wp.add(j * k + c)),
                        _mm256_loadu_ps(wp.add((j + cols - 1) * k + c)),
                    ];
                    for (r, acc_r) in acc.iter_mut().enumerate().take(rows) {
                        let xv = _mm256_loadu_ps(xp.add((t + r) * k + c));
                        acc_r[0] = _mm256_fmadd_ps(xv, wv[0], acc_r[0]);
                        acc_r[1] = _mm256_fmadd_ps(xv, wv[1], acc_r[1]);
                    }
                    c += 8;
                }
                for (r, acc_r) in acc.iter().enumerate().take(rows) {
                    for (q, &sum) in acc_r.iter().enumerate().take(cols) {
                        out[(t + r) * m + j + q] = hsum(sum);
                    }
                }
                j += 2;
            }
            t += 4;
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Values of many magnitudes and signs, so that a different order of
    /// the additions (or a fused multiply-add) would change the last bits.
    fn values(n: usize, seed: u32) -> Vec<f32> {
        let mut x = seed.wrapping_mul(2_654_435_761) | 1;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                let unit = (x >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
                unit * 10f32.powi((x % 7) as i32 - 3)
            })
            .collect()
    }

    #[test]
    fn dot_and_add_give_the_bits_of_the_plain_loops_at_every_length() {
        for n in [0, 1, 7, 8, 9, 63, 64, 96, 100, 288] {
            let (a, b) = (values(n, 1 + n as u32), values(n, 1000 + n as u32));
            assert_eq!(
                dot(&a, &b).to_bits(),
                plain_dot(&a, &b).to_bits(),
                "n = {n}"
            );
            let (mut fast, mut plain) = (a.clone(), a.clone());
            add_into(&mut fast, &b);
            plain_add_into(&mut plain, &b);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&fast), bits(&plain), "n = {n}");
        }
    }
}
