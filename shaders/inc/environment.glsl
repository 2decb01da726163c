// Environment lighting: the equirectangular map's bilinear lookup, its 2-D piecewise-constant
// sampling (marginal and conditional CDFs inverted) and the density of a direction. Twin of
// src/lights/environment.rs (conventions and sources there); reads env_texels (RGBE), env_marginal and env_conditional.
#ifndef ENVIRONMENT_GLSL
#define ENVIRONMENT_GLSL
#include "convert.glsl"

#define ENV_PI 3.14159265358979323846

// The RGB an RGBE texel stands for: mantissas * 2^(e - 136); exponent byte 0 is black.
vec3 rgbe_decode(uint t) {
    uint e = t >> 24;
    if (e == 0u) return vec3(0.0);
    float scale = uintBitsToFloat((e + 127u - 136u) << 23);
    return vec3(float(t & 0xffu), float((t >> 8) & 0xffu), float((t >> 16) & 0xffu)) * scale;
}

// The map's frame: d turned by -(--env-rotate) about +Y.
vec3 env_to_map(vec3 d) {
    float c = frame.env_rotation.x;
    float s = frame.env_rotation.y;
    return vec3(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
}

vec3 env_from_map(vec3 d) {
    float c = frame.env_rotation.x;
    float s = frame.env_rotation.y;
    return vec3(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
}

// (u, v) in [0, 1]^2 of unit direction d, and sin(theta).
vec2 env_direction_uv(vec3 d, out float sin_theta) {
    vec3 m = env_to_map(d);
    float y = clamp(m.y, -1.0, 1.0);
    float theta = acos(y);
    float phi = atan(m.x, -m.z);
    sin_theta = sqrt(max(1.0 - y * y, 0.0));
    return vec2(phi * float(0.5 / ENV_PI) + 0.5, theta * float(1.0 / ENV_PI));
}

// Radiance arriving from unit direction d: bilinear between texel centres, wrapping in u and
// clamped in v, times the frame's scale.
vec3 env_radiance(vec3 d) {
    int w = int(frame.env_width);
    int h = int(frame.env_height);
    if (w == 0) return vec3(0.0);
    float sin_theta;
    vec2 uv = env_direction_uv(d, sin_theta);
    float x = uv.x * float(w) - 0.5;
    float y = uv.y * float(h) - 0.5;
    float x0 = floor(x);
    float y0 = floor(y);
    float tx = x - x0;
    float ty = y - y0;
    // x0 lies in [-1, w - 1]: one step wraps it.
    ivec2 c0 = trunc_to_int(vec2(x0, y0));
    int i0 = c0.x;
    if (i0 < 0) i0 += w;
    int i1 = i0 + 1 == w ? 0 : i0 + 1;  // (i0 + 1) mod w, i0 in [0, w)
    int j0 = clamp(c0.y, 0, h - 1);
    int j1 = clamp(c0.y + 1, 0, h - 1);
    vec3 top = mix(rgbe_decode(env_texels[j0 * w + i0]), rgbe_decode(env_texels[j0 * w + i1]), tx);
    vec3 bottom = mix(rgbe_decode(env_texels[j1 * w + i0]), rgbe_decode(env_texels[j1 * w + i1]), tx);
    return mix(top, bottom, ty) * frame.env_scale;
}

// The CDF at the end of row j's conditional bin i, or of marginal bin j (src/lights/environment.rs:
// entry k is the CDF at the end of bin k; the start of bin 0 is 0).
float env_conditional_end(uint j, uint i) { return env_conditional[j * frame.env_width + i]; }
float env_conditional_start(uint j, uint i) { return i == 0u ? 0.0 : env_conditional[j * frame.env_width + i - 1u]; }
float env_marginal_start(uint j) { return j == 0u ? 0.0 : env_marginal[j - 1u]; }

// Bin of u in [0, 1) in the marginal CDF: the first row whose end exceeds u (cdf_search).
uint env_marginal_search(float u) {
    uint lo = 0u;
    uint hi = frame.env_height - 1u;
    if (lo < hi) do {
        uint mid = (lo + hi) / 2u;
        if (env_marginal[mid] > u) hi = mid; else lo = mid + 1u;
    } while (lo < hi);
    return lo;
}

// Bin of u in [0, 1) in row j's conditional CDF (cdf_search).
uint env_conditional_search(uint j, float u) {
    uint lo = 0u;
    uint hi = frame.env_width - 1u;
    if (lo < hi) do {
        uint mid = (lo + hi) / 2u;
        if (env_conditional_end(j, mid) > u) hi = mid; else lo = mid + 1u;
    } while (lo < hi);
    return lo;
}

// Density in solid angle with which env_sample produces unit direction d.
float env_pdf(vec3 d) {
    uint w = frame.env_width;
    uint h = frame.env_height;
    if (!SCENE_HAS(FEATURE_ENVIRONMENT) || w == 0u) return 0.0;
    float sin_theta;
    vec2 uv = env_direction_uv(d, sin_theta);
    if (!(sin_theta > 0.0)) return 0.0;
    uvec2 ji = uvec2(trunc_to_int(vec2(uv.y * float(h), uv.x * float(w))));
    uint j = min(ji.x, h - 1u);
    uint i = min(ji.y, w - 1u);
    float pdf_v = (env_marginal[j] - env_marginal_start(j)) * float(h);
    float pdf_u = (env_conditional_end(j, i) - env_conditional_start(j, i)) * float(w);
    return pdf_v * pdf_u / (2.0 * float(ENV_PI) * float(ENV_PI) * sin_theta);
}

// A direction from the map's distribution for u in [0, 1)^2 (the lecture's P^-1 in two
// dimensions) and its density in solid angle; false at a pole or without a map.
bool env_sample(vec2 u, out vec3 wi, out float pdf) {
    uint w = frame.env_width;
    uint h = frame.env_height;
    wi = vec3(0.0, 1.0, 0.0);
    pdf = 0.0;
    if (!SCENE_HAS(FEATURE_ENVIRONMENT) || w == 0u) return false;
    uint j = env_marginal_search(u.y);
    float v0 = env_marginal_start(j);
    float v1 = env_marginal[j];
    float y = (float(j) + clamp((u.y - v0) / (v1 - v0), 0.0, 1.0)) / float(h);
    uint i = env_conditional_search(j, u.x);
    float c0 = env_conditional_start(j, i);
    float c1 = env_conditional_end(j, i);
    float x = (float(i) + clamp((u.x - c0) / (c1 - c0), 0.0, 1.0)) / float(w);
    float theta = float(ENV_PI) * y;
    float phi = 2.0 * float(ENV_PI) * (x - 0.5);
    float sin_theta = sin(theta);
    if (!(sin_theta > 0.0)) return false;
    vec3 m = vec3(sin_theta * sin(phi), cos(theta), -sin_theta * cos(phi));
    pdf = (v1 - v0) * float(h) * (c1 - c0) * float(w) / (2.0 * float(ENV_PI) * float(ENV_PI) * sin_theta);
    wi = env_from_map(m);
    return true;
}

#endif
