#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Light tracing and BDPT, the end of a batch's passes: each pixel's splat sum over a pass's
// light subpaths (one per pixel of the image) and camera paths is that pixel's sample; the
// samples of the batch's passes go into the film in pass order and the sums are cleared for
// the next batch. One thread per pixel.
#include "layout.glsl"
#include "bindings.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void kernel_main() {
    uint t = gl_GlobalInvocationID.x;
    uint pixels = frame.band_pixel_count;
    if (t >= pixels) return;
    // Whole passes, or one pass's last run of pixels (src/gpu/wavefront.rs, batches).
    uint passes = max(params.batch_size / pixels, 1u);
    FilmPixel acc = film[t];
    for (uint slot = 0u; slot < passes; slot++) {
        vec3 l;
        for (uint ch = 0u; ch < 3u; ch++) {
            uint word = 6u * (slot * pixels + t) + 2u * ch;
            l[ch] = float(splats[word + 1u]) * 256.0 + float(splats[word]) * (1.0 / 16777216.0);
            splats[word] = 0u;
            splats[word + 1u] = 0u;
        }
        if (any(isnan(l)) || any(isinf(l))) {
            atomicAdd(counters[COUNTER_DROPPED_SAMPLES], 1u);
            continue;
        }
        acc.sum += l;
        acc.sum_sq += l * l;
        acc.count += 1u;
    }
    film[t] = acc;
}

void main() {
    kernel_main();
    count_scene_fetches();
}
