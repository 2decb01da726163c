#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Stage 5: add each finished path's radiance to its pixel (sum, sum of squares, count). One thread
// per pixel of the batch, looping over the batch's samples of that pixel in sample order, so the
// film is the same on every run. Non-finite samples are dropped and counted.
#include "layout.glsl"
#include "bindings.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void kernel_main() {
    uint t = gl_GlobalInvocationID.x;
    // The batch goes round pixel_count pixels: the band's, or the active list's (scene.glsl,
    // path_pixel_sample).
    bool listed = frame.active_pixel_count != 0u;
    uint pixel_count = listed ? frame.active_pixel_count : frame.band_pixel_count;
    if (t >= min(params.batch_size, pixel_count)) return;
    uint slot0 = (params.first_pixel + t) % pixel_count;
    uint pixel = listed ? active_pixels[slot0] : slot0;  // within the band the film holds
    FilmPixel acc = film[pixel];
    uint dropped = 0u;
    for (uint slot = t; slot < params.batch_size; slot += pixel_count) {
        vec3 l = paths[slot].radiance;
        if (any(isnan(l)) || any(isinf(l))) {
            dropped += 1u;
        } else {
            acc.sum += l;
            acc.sum_sq += l * l;
            acc.count += 1u;
        }
    }
    film[pixel] = acc;
    if (dropped > 0u) atomicAdd(counters[COUNTER_DROPPED_SAMPLES], dropped);
}

void main() {
    kernel_main();
    count_scene_fetches();
}
