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
    uvec4 h = pcg4d(uvec4(pixel, sample_index, block, seed));
    return vec4(uint_to_unit_float(h.x), uint_to_unit_float(h.y), uint_to_unit_float(h.z),
                uint_to_unit_float(h.w));
}

#endif
