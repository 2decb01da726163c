// Float-to-int conversions in vector arithmetic, for values known to lie within 2^22 of zero.
// llvmpipe makes GLSL's int(float) a saturating conversion, which LLVM 15 on AVX2 carries out
// lane by lane: a scalar conversion, two compares and two conditional moves for each of 8 lanes
// (tools/jit_profile.py: on the Cornell box 27 conversions per sample in shade, about 190
// instructions, where offset_ray_origin scales the normal). An integer-valued float t with
// |t| < 2^22 added to 1.5 * 2^23 lands in [2^23, 2^24), where the ulp is 1, so the sum is exact
// and its bits are those of 1.5 * 2^23 plus t. NaN gives 0, as lavapipe's int(NaN) and Rust's
// `as i32` do (the CPU twins' conversions): within the range the same ints bit for bit.
#ifndef CONVERT_GLSL
#define CONVERT_GLSL

// v truncated towards zero, for |v| < 2^22; NaN as 0.
int trunc_to_int(float v) {
    return floatBitsToInt(trunc(isnan(v) ? 0.0 : v) + 12582912.0) - 0x4B400000;
}
ivec2 trunc_to_int(vec2 v) {
    return floatBitsToInt(trunc(mix(v, vec2(0.0), isnan(v))) + 12582912.0) - 0x4B400000;
}
ivec3 trunc_to_int(vec3 v) {
    return floatBitsToInt(trunc(mix(v, vec3(0.0), isnan(v))) + 12582912.0) - 0x4B400000;
}

// v truncated to a uint, for 0 <= v < 2^22; NaN as 0 (Rust's `as u32`).
uint trunc_to_uint(float v) {
    return uint(trunc_to_int(v));
}

// (n / d, n % d) for 1 <= d < 2^30 and n / d < 2^22, exactly, without integer division, which
// llvmpipe carries out lane by lane (a `div` of 20-odd cycles for each of 8 lanes). The float
// quotient's relative error is at most 3 * 2^-24, so its truncation is within 1 of n / d, and
// the remainder it leaves, in [-d, 2d), says which way to step.
uvec2 div_mod(uint n, uint d) {
    uint q = trunc_to_uint(float(n) / float(d));
    int r = int(n - q * d);
    if (r < 0) {
        q -= 1u;
        r += int(d);
    } else if (r >= int(d)) {
        q += 1u;
        r -= int(d);
    }
    return uvec2(q, uint(r));
}

#endif
