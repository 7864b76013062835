//! spaCy's string ids: MurmurHash64A of the UTF-8 bytes with seed 1, except
//! for the reserved symbol names, and thinc's 128-bit hash of a 64-bit key.

use std::collections::HashMap;
use std::sync::OnceLock;

use super::symbols::SYMBOL_NAMES;

/// MurmurHash64A (Austin Appleby), as the `murmurhash` package's `hash64`.
pub fn murmurhash64a(key: &[u8], seed: u64) -> u64 {
    const M: u64 = 0xc6a4_a793_5bd1_e995;
    const R: u32 = 47;
    let mut h = seed ^ (key.len() as u64).wrapping_mul(M);
    let mut chunks = key.chunks_exact(8);
    for chunk in &mut chunks {
        let mut k = u64::from_le_bytes([
            chunk[0], chunk[1], chunk[2], chunk[3], chunk[4], chunk[5], chunk[6], chunk[7],
        ]);
        k = k.wrapping_mul(M);
        k ^= k >> R;
        k = k.wrapping_mul(M);
        h ^= k;
        h = h.wrapping_mul(M);
    }
    let tail = chunks.remainder();
    if !tail.is_empty() {
        for (i, &byte) in tail.iter().enumerate() {
            h ^= u64::from(byte) << (8 * i);
        }
        h = h.wrapping_mul(M);
    }
    h ^= h >> R;
    h = h.wrapping_mul(M);
    h ^= h >> R;
    h
}

/// The hash spaCy gives a string (`hash_string`), ignoring symbols.
pub fn hash_string(text: &str) -> u64 {
    murmurhash64a(text.as_bytes(), 1)
}

fn symbol_ids() -> &'static HashMap<&'static str, u64> {
    static IDS: OnceLock<HashMap<&'static str, u64>> = OnceLock::new();
    IDS.get_or_init(|| {
        SYMBOL_NAMES
            .iter()
            .enumerate()
            .map(|(i, name)| (*name, i as u64))
            .collect()
    })
}

/// The id spaCy's `StringStore.add` returns: the symbol id for a reserved
/// name, else the string's hash.
pub fn string_id(text: &str) -> u64 {
    match symbol_ids().get(text) {
        Some(&id) => id,
        None => hash_string(text),
    }
}

/// thinc's `MurmurHash3_x86_128_uint64`: four 32-bit keys from one 64-bit id.
pub fn thinc_hash(val: u64, seed: u32) -> [u32; 4] {
    const C1: u64 = 0x87c3_7b91_1142_53d5;
    const C2: u64 = 0x4cf5_ad43_2745_937f;
    let mut h1 = val.wrapping_mul(C1);
    h1 = h1.rotate_left(31);
    h1 = h1.wrapping_mul(C2);
    h1 ^= u64::from(seed);
    h1 ^= 8;
    let mut h2 = u64::from(seed) ^ 8;
    h1 = h1.wrapping_add(h2);
    h2 = h2.wrapping_add(h1);
    h1 = fmix64(h1);
    h2 = fmix64(h2);
    h1 = h1.wrapping_add(h2);
    h2 = h2.wrapping_add(h1);
    [h1 as u32, (h1 >> 32) as u32, h2 as u32, (h2 >> 32) as u32]
}

fn fmix64(mut k: u64) -> u64 {
    k ^= k >> 33;
    k = k.wrapping_mul(0xff51_afd7_ed55_8ccd);
    k ^= k >> 33;
    k = k.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    k ^= k >> 33;
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symbols_take_their_ids() {
        assert_eq!(string_id(""), 0);
        assert_eq!(string_id("IS_ALPHA"), 1);
        assert_eq!(string_id("_"), 456);
        assert_ne!(string_id("walk"), hash_string("walkx"));
    }

    #[test]
    fn hashes_match_spacy() {
        assert_eq!(string_id("walk"), 1674876016505392235);
        assert_eq!(string_id("a"), 11901859001352538922);
        assert_eq!(string_id("the bathtub"), 13902257110329229134);
        assert_eq!(string_id("ééé"), 10584630606492146223);
        assert_eq!(string_id("'s"), 16428057658620181782);
    }

    #[test]
    fn thinc_hash_matches_numpy_ops() {
        assert_eq!(
            thinc_hash(1674876016505392235, 8),
            [1711858160, 691883233, 420303592, 3185308498]
        );
        assert_eq!(
            thinc_hash(5, 8),
            [1797445366, 4269458499, 548684401, 4256704101]
        );
    }
}
