// Owen-scrambled, shuffled Sobol points for the 2-D pairs of a path, after Burley, "Practical
// Hash-based Owen Scrambling", JCGT 9(4), 2020: twin of src/sobol/mod.rs (see there for the
// properties). Needs pcg4d and uint_to_unit_float of rng.glsl, which includes this file.
#ifndef SOBOL_GLSL
#define SOBOL_GLSL

// Tag mixed into the keys ("SOBL").
#define SOBOL_TAG 0x534f424cu

// The superset-XOR transform of x's bits (src/sobol/mod.rs says why): sobol2's dimension 1 before
// its mirroring.
uint superset_xor(uint x) {
    x ^= (x >> 1u) & 0x55555555u;
    x ^= (x >> 2u) & 0x33333333u;
    x ^= (x >> 4u) & 0x0f0f0f0fu;
    x ^= (x >> 8u) & 0x00ff00ffu;
    x ^= (x >> 16u) & 0x0000ffffu;
    return x;
}

// The first two Sobol dimensions at index, as 32-bit binary fractions: van der Corput, and the
// direction numbers of x + 1, v_0 = 2^31, v_(k+1) = v_k ^ (v_k >> 1) (Joe & Kuo 2008), summed
// in closed form.
uvec2 sobol2(uint index) {
    return uvec2(bitfieldReverse(index), bitfieldReverse(superset_xor(index)));
}

// Laine-Karras hash with Burley's constants (Burley 2020, Listing 2): bit j of the result
// depends on bits 0..j of x alone.
uint laine_karras_permutation(uint x, uint seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// Nested uniform (Owen) scrambling of a 32-bit binary fraction (Burley 2020, Listing 3).
uint nested_uniform_scramble(uint x, uint seed) {
    return bitfieldReverse(laine_karras_permutation(bitfieldReverse(x), seed));
}

// Keys of one pair of one pixel: x = index shuffle, y and z = scrambles of the coordinates.
uvec4 sobol_keys(uint seed, uint pixel, uint dimension) {
    return pcg4d(uvec4(pixel, dimension, seed, SOBOL_TAG));
}

// Point index of the shuffled, scrambled Sobol (0,2)-sequence keyed by keys (Burley 2020, §4):
// the scrambles of sobol2's coordinates with sobol2's mirror and the scramble's own cancelled
// (src/sobol/mod.rs).
uvec2 shuffled_scrambled_sobol2(uint index, uvec4 keys) {
    uint shuffled = nested_uniform_scramble(index, keys.x);
    return uvec2(bitfieldReverse(laine_karras_permutation(shuffled, keys.y)),
                 bitfieldReverse(laine_karras_permutation(superset_xor(shuffled), keys.z)));
}

// The Sobol sampler's pair of dimension `dimension` of sample sample_index of pixel, in [0, 1)^2.
vec2 sobol_pair(uint seed, uint pixel, uint sample_index, uint dimension) {
    uvec2 p = shuffled_scrambled_sobol2(sample_index, sobol_keys(seed, pixel, dimension));
    return vec2(uint_to_unit_float(p.x), uint_to_unit_float(p.y));
}

#endif
