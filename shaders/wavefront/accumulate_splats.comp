#version 460
#extension GL_GOOGLE_include_directive : require
// Light tracing, stage 5, once per sample index: each pixel's splat sum over the pass's light
// subpaths (one per pixel of the image) is that pixel's sample; it goes into the film and the
// sums are cleared for the next pass. One thread per pixel.
#include "layout.glsl"
#include "bindings.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void main() {
    uint t = gl_GlobalInvocationID.x;
    if (t >= frame.band_pixel_count) return;
    vec3 l;
    for (uint ch = 0u; ch < 3u; ch++) {
        uint word = 6u * t + 2u * ch;
        l[ch] = float(splats[word + 1u]) * 256.0 + float(splats[word]) * (1.0 / 16777216.0);
        splats[word] = 0u;
        splats[word + 1u] = 0u;
    }
    if (any(isnan(l)) || any(isinf(l))) {
        atomicAdd(counters[COUNTER_DROPPED_SAMPLES], 1u);
        return;
    }
    FilmPixel acc = film[t];
    acc.sum += l;
    acc.sum_sq += l * l;
    acc.count += 1u;
    film[t] = acc;
}
