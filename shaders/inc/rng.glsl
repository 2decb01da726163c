// Keyed random numbers: a pure function of (seed, pixel, sample, dimension block), never of a
// queue slot or thread. Twin of the RNG half of src/sampling.rs.
#ifndef RNG_GLSL
#define RNG_GLSL

// PCG-based 4-D hash (Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 2020, §3).
uvec4 pcg4d(uvec4 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

// The top 24 bits of x as a float in [0, 1).
float uint_to_unit_float(uint x) {
    return float(x >> 8u) * (1.0 / 16777216.0);
}

vec4 rng_uniform4(uint seed, uint pixel, uint sample_index, uint block) {
    // Two rounds of pcg4d (src/sampling.rs says why).
    uvec4 h = pcg4d(pcg4d(uvec4(pixel, sample_index, block, seed)));
    return vec4(uint_to_unit_float(h.x), uint_to_unit_float(h.y), uint_to_unit_float(h.z),
                uint_to_unit_float(h.w));
}

// Pseudo-random permutation of [0, n) keyed by key (Kensler, "Correlated Multi-Jittered
// Sampling", 2013, section 3): twin of sampling::permute.
uint permute(uint i, uint n, uint key) {
    uint w = n - 1u;
    w |= w >> 1u;
    w |= w >> 2u;
    w |= w >> 4u;
    w |= w >> 8u;
    w |= w >> 16u;
    for (;;) {
        i ^= key;
        i *= 0x9e3779b1u;
        i ^= (i & w) >> 3u;
        i ^= key >> 11u;
        i *= 0x85ebca6bu | 1u;
        i ^= (i & w) >> 7u;
        i *= 1u | (key >> 25u);
        i *= 0xc2b2ae35u | 1u;
        i ^= (i & w) >> 2u;
        i &= w;
        i ^= i >> 5u;
        if (i < n) break;
    }
    return (i + key) % n;
}

#define ONE_MINUS_EPSILON 0.99999994

// Stratified (N-rooks) version of a pair of uniforms: twin of sampling::stratify2.
vec2 stratify2(uint seed, uint pixel, uint sample_index, uint spp, uint dimension, vec2 jitter) {
    // Samples past the strata keep the independent pair (src/sampling.rs).
    if (sample_index >= spp) return jitter;
    uvec4 keys = pcg4d(uvec4(pixel, dimension, seed, 0x53545241u));
    float sx = float(permute(sample_index, spp, keys.x));
    float sy = float(permute(sample_index, spp, keys.y));
    float inv = 1.0 / float(spp);
    return min((vec2(sx, sy) + jitter) * inv, vec2(ONE_MINUS_EPSILON));
}

// The Sobol sampler, built on pcg4d and uint_to_unit_float above.
#include "sobol.glsl"

#endif
