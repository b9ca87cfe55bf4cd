//! Integer hashes of the GI-1.0 caches (`math/hash.hlsl`).
//!
//! The caches key their cells with *chained* scalar hashes: `h(a + h(b + h(c)))`, innermost word
//! last, so a descriptor of any length costs one hash per word and no 64-bit maths.

/// PCG multiplier, shared with the random stream.
pub(crate) const PCG_MULTIPLIER: u32 = 747_796_405;
/// PCG increment of the stateless hash.
pub(crate) const PCG_INCREMENT: u32 = 2_891_336_453;

const XXHASH_PRIME2: u32 = 2_246_822_519;
const XXHASH_PRIME3: u32 = 3_266_489_917;
const XXHASH_PRIME4: u32 = 668_265_263;
const XXHASH_PRIME5: u32 = 374_761_393;

/// PCG's RXS-M-XS output permutation of a 32-bit LCG state.
#[inline]
pub(crate) fn pcg_output(state: u32) -> u32 {
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// PCG hash (RXS-M-XS 32, Jarzynski & Olano 2020): one LCG step of `v`, then the output permutation.
#[inline]
pub fn pcg(v: u32) -> u32 {
    pcg_output(v.wrapping_mul(PCG_MULTIPLIER).wrapping_add(PCG_INCREMENT))
}

/// xxHash32's single-word finaliser as GI-1.0 uses it (seed folded into `PRIME5`); the checksum hash.
#[inline]
pub fn xxhash32(v: u32) -> u32 {
    let mut r = v.wrapping_add(XXHASH_PRIME5);
    r = XXHASH_PRIME4.wrapping_mul(r.rotate_left(17));
    r = XXHASH_PRIME2.wrapping_mul(r ^ (r >> 15));
    r = XXHASH_PRIME3.wrapping_mul(r ^ (r >> 13));
    r ^ (r >> 16)
}

/// Chained PCG: `pcg(w[0] + pcg(w[1] + … pcg(w[N-1])))`, the bucket hash of the caches.
/// An empty array hashes to 0.
#[inline]
pub fn pcg_chain<const N: usize>(words: [u32; N]) -> u32 {
    let mut h = 0u32;
    let mut i = N;
    // Innermost word first; starting from 0 makes `pcg(w + 0)` the innermost term.
    while i > 0 {
        i -= 1;
        h = pcg(words[i].wrapping_add(h));
    }
    h
}

/// Chained xxHash with the nesting of [`pcg_chain`], the checksum hash of the caches.
#[inline]
pub fn xxhash32_chain<const N: usize>(words: [u32; N]) -> u32 {
    let mut h = 0u32;
    let mut i = N;
    while i > 0 {
        i -= 1;
        h = xxhash32(words[i].wrapping_add(h));
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    // Expected values from an independent transcription of the §3.1 formulas (Python, mod 2^32).
    #[test]
    fn pcg_known_answers() {
        assert_eq!(pcg(0), 129_708_002);
        assert_eq!(pcg(1), 2_831_084_092);
        assert_eq!(pcg(2), 2_055_130_248);
        assert_eq!(pcg(12345), 4_099_845_390);
        assert_eq!(pcg(0xdead_beef), 1_730_779_506);
        assert_eq!(pcg(u32::MAX), 3_861_530_882);
    }

    #[test]
    fn xxhash_known_answers() {
        assert_eq!(xxhash32(0), 878_055_299);
        assert_eq!(xxhash32(1), 2_491_795_611);
        assert_eq!(xxhash32(2), 2_725_137_873);
        assert_eq!(xxhash32(12345), 1_108_257_898);
        assert_eq!(xxhash32(0xdead_beef), 2_885_598_944);
        assert_eq!(xxhash32(u32::MAX), 975_606_439);
    }

    #[test]
    fn chains_nest_innermost_last() {
        assert_eq!(pcg_chain([1, 2, 3]), 3_847_790_828);
        assert_eq!(
            pcg_chain([1, 2, 3]),
            pcg(1u32.wrapping_add(pcg(2u32.wrapping_add(pcg(3)))))
        );
        assert_eq!(xxhash32_chain([1, 2, 3]), 2_183_478_673);
        assert_eq!(
            xxhash32_chain([7, 8]),
            xxhash32(7u32.wrapping_add(xxhash32(8)))
        );
        assert_eq!(pcg_chain([5]), pcg(5));
        assert_eq!(pcg_chain([]), 0);
        // Order matters: the chain is not symmetric.
        assert_ne!(pcg_chain([1, 2]), pcg_chain([2, 1]));
    }

    #[test]
    fn pcg_is_a_permutation_on_a_sample() {
        // The LCG step and the RXS-M-XS output are both bijections, so no collisions may appear.
        let mut seen: Vec<u32> = (0..1u32 << 16).map(pcg).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 1 << 16);
    }
}
