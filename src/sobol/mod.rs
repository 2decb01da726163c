//! Owen-scrambled, shuffled Sobol points for the 2-D pairs of a path (pixel jitter, point on a
//! light, BSDF direction), after Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020.
//!
//! Each pair of each pixel is its own (0,2)-sequence: the first two Sobol dimensions, with the
//! sample index shuffled and both coordinates scrambled by hash-based nested uniform (Owen)
//! scrambling, keyed by a hash of (seed, pixel, dimension). So the first 2^k samples of a pixel
//! (and every aligned block of 2^k) put exactly one point in every elementary interval of area
//! 2^-k, every point stays uniform on [0, 1)², distinct pairs stay independent, and the numbers
//! remain a pure function of (seed, pixel, sample, dimension): shards and bands merge exactly.
//! The GLSL twin is `shaders/inc/sobol.glsl`, with the same names and the same arithmetic.

use crate::sampling::{pcg4d, uint_to_unit_float};
use glam::{UVec2, UVec4, Vec2};

/// Tag mixed into the keys so they differ from every other use of `pcg4d` ("SOBL").
const SOBOL_TAG: u32 = 0x534f_424c;

/// The first two dimensions of the Sobol sequence at `index`, as 32-bit binary fractions.
/// Dimension 0 is van der Corput (the index's bits mirrored about the binary point); dimension 1
/// XORs, for each set bit k of the index, the direction number v_k of the primitive polynomial
/// x + 1: v_0 = 2³¹, v_(k+1) = v_k ⊕ (v_k ≫ 1) (Sobol 1967; Joe & Kuo 2008, dimension 2), the
/// rows of Pascal's triangle mod 2. By Lucas' theorem bit 31 − j of v_k is set iff j ⊆ k
/// (bitwise), so the mirrored dimension 1 is the superset-XOR transform of the index's bits: five
/// shift-and-mask steps, one per bit of a bit position, instead of a loop over 32 bits.
pub fn sobol2(index: u32) -> UVec2 {
    UVec2::new(index.reverse_bits(), superset_xor(index).reverse_bits())
}

/// Bit j of the result is the XOR of the bits k ⊇ j of `x`: [`sobol2`]'s dimension 1 before
/// its mirroring.
pub fn superset_xor(x: u32) -> u32 {
    let mut x = x;
    x ^= (x >> 1) & 0x5555_5555;
    x ^= (x >> 2) & 0x3333_3333;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^= (x >> 16) & 0x0000_ffff;
    x
}

/// Laine and Karras's hash ("Stratified Sampling for Stochastic Transparency", EGSR 2011) with
/// Burley's constants (Burley 2020, Listing 2): adding the seed and XOR-ing with products by even
/// constants only carry upwards, so bit j of the result depends on bits 0..=j of `x` alone and
/// flips them as a bijection: on bit-reversed input, a nested uniform scramble.
pub fn laine_karras_permutation(x: u32, seed: u32) -> u32 {
    let mut x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Nested uniform (Owen) scrambling of a 32-bit binary fraction (Burley 2020, Listing 3): each
/// bit is flipped by a hash of the bits above it (the more significant digits), a bijection.
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// The keys of one 2-D pair of one pixel: x = index shuffle, y = scramble of the first
/// coordinate, z = scramble of the second (w unused).
pub fn sobol_keys(seed: u32, pixel: u32, dimension: u32) -> UVec4 {
    pcg4d(UVec4::new(pixel, dimension, seed, SOBOL_TAG))
}

/// Point `index` of the shuffled, scrambled Sobol (0,2)-sequence keyed by `keys` (Burley 2020,
/// §4 and Listing 4): the index is shuffled by nested uniform scrambling of its bits — bit j of
/// the shuffled index depends on bits 0..=j of the index, so every aligned block of 2^k indices
/// maps onto one representative of each residue mod 2^k, and the top k bits of both Sobol
/// coordinates depend only on those residues — then each coordinate is Owen-scrambled.
///
/// Written as `nested_uniform_scramble` of `sobol2(nested_uniform_scramble(index, keys.x))`'s
/// coordinates, but `sobol2` mirrors both coordinates and the scramble mirrors its input
/// first, so those two mirrors cancel: four bit reversals per pair instead of eight, the same
/// bits (test `shuffled_scrambled_sobol2_is_the_written_out_composition`).
pub fn shuffled_scrambled_sobol2(index: u32, keys: UVec4) -> UVec2 {
    let shuffled = nested_uniform_scramble(index, keys.x);
    UVec2::new(
        laine_karras_permutation(shuffled, keys.y).reverse_bits(),
        laine_karras_permutation(superset_xor(shuffled), keys.z).reverse_bits(),
    )
}

/// The Sobol sampler's pair of dimension `dimension` of sample `sample` of `pixel`, in [0, 1)²
/// (24-bit floats, as the keyed random numbers).
pub fn sobol_pair(seed: u32, pixel: u32, sample: u32, dimension: u32) -> Vec2 {
    let p = shuffled_scrambled_sobol2(sample, sobol_keys(seed, pixel, dimension));
    Vec2::new(uint_to_unit_float(p.x), uint_to_unit_float(p.y))
}

#[cfg(test)]
mod tests;
