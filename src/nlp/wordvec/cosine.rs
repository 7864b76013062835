//! The cosine of two f32 vectors with NumPy's exact arithmetic on x86-64
//! (OpenBLAS Haswell kernels), as the reference computes
//! `np.dot(x, y) / float(norm(x) * norm(y))` on rows of a Fortran-ordered
//! matrix.

/// Cosine of `x` and `y` bit-for-bit as the reference: the dot product of the
/// strided rows, over the product of the f32 norms (each the square root of
/// the contiguous dot product), divided in f32; 0 when a norm is 0.
pub fn numpy_cosine(x: &[f32], y: &[f32]) -> f32 {
    let norms = contiguous_dot(x, x).sqrt() * contiguous_dot(y, y).sqrt();
    if norms == 0.0 {
        return 0.0;
    }
    strided_dot(x, y) / norms
}

/// OpenBLAS `sdot` on non-unit strides: pairs summed in f32, accumulated in
/// f64, rounded to f32 at the end.
fn strided_dot(x: &[f32], y: &[f32]) -> f32 {
    let mut dot = 0.0f64;
    let mut pairs_x = x.chunks_exact(2);
    let mut pairs_y = y.chunks_exact(2);
    for (a, b) in pairs_x.by_ref().zip(pairs_y.by_ref()) {
        dot += f64::from(b[0] * a[0] + b[1] * a[1]);
    }
    for (a, b) in pairs_x.remainder().iter().zip(pairs_y.remainder()) {
        dot += f64::from(b * a);
    }
    dot as f32
}

/// OpenBLAS `sdot` on contiguous vectors: blocks of 32 in four 8-lane FMA
/// accumulators reduced as the Haswell kernel does, the rest accumulated in
/// f64, then the two added and rounded to f32.
fn contiguous_dot(x: &[f32], y: &[f32]) -> f32 {
    let blocked = x.len().min(y.len()) & !31;
    let mut acc = [[0.0f32; 8]; 4];
    for base in (0..blocked).step_by(32) {
        for (k, lanes) in acc.iter_mut().enumerate() {
            for (l, lane) in lanes.iter_mut().enumerate() {
                let i = base + 8 * k + l;
                *lane = x[i].mul_add(y[i], *lane);
            }
        }
    }
    let halves = acc.map(|a| [a[0] + a[4], a[1] + a[5], a[2] + a[6], a[3] + a[7]]);
    let lanes: [f32; 4] =
        std::array::from_fn(|l| (halves[0][l] + halves[1][l]) + (halves[2][l] + halves[3][l]));
    let blocked_sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    let mut dot = 0.0f64;
    for (a, b) in x[blocked..].iter().zip(&y[blocked..]) {
        dot += f64::from(b * a);
    }
    (dot + f64::from(blocked_sum)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_vectors_have_cosine_one_and_zero_vectors_zero() {
        let x: Vec<f32> = (0..50).map(|i| i as f32 * 0.25 - 3.0).collect();
        let y: Vec<f32> = x.iter().map(|v| v * 2.0).collect();
        assert!((numpy_cosine(&x, &y) - 1.0).abs() < 1e-6);
        assert_eq!(numpy_cosine(&x, &[0.0; 50]), 0.0);
    }
}
