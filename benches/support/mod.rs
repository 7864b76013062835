//! What the benchmarks share: `cargo test` runs each of them once, without
//! `--bench`, to check that it still works; that check needs no
//! statistics, so the benchmarks cut their inputs to a few items there and
//! the test suite does not pay for a measurement.

/// Whether this run only checks that the benchmarks work (no `--bench`).
pub fn checking() -> bool {
    !std::env::args().any(|arg| arg == "--bench")
}

/// `many` when measuring, `few` when only checking.
pub fn count(many: usize, few: usize) -> usize {
    if checking() {
        few.min(many)
    } else {
        many
    }
}
