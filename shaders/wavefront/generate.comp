#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Stage 1 of the wavefront loop: one camera ray and a fresh path state per path of the batch.
#include "layout.glsl"
#include "bindings.glsl"
#include "rng.glsl"
#include "scene.glsl"
#include "sampling.glsl"
#include "camera.glsl"
#include "paths.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void kernel_main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= params.batch_size) return;
    uint pixel, sample_index;
    path_pixel_sample(i, pixel, sample_index);
    vec4 u = rng_uniform4(frame.seed, pixel, sample_index, CAMERA_BLOCK);

    PathState state;
    state.throughput = vec3(1.0);
    state.prev_bsdf_pdf = 0.0;
    state.radiance = vec3(0.0);
    state.prev_specular = 1u;
    state.cone_width = frame.cone_width;
    state.prev_position = vec3(0.0);
    state.prev_normal = vec3(0.0);
    state.medium = vec3(0.0);
    state.wavelength = 0.0;
    // --paths: the eye-first automaton's state after E.
    state.pad0 = paths_enabled() ? dfa_step_reversed(0u, SYM_E) : 0u;
    path_store(i, state);

    QueuedRay ray;
    vec2 jitter = sample_pair(pixel, sample_index, 4u * CAMERA_BLOCK, u.xy);
    // The lens's pair only where a thin lens reads it (camera_ray); a pinhole ignores it.
    vec2 lens_u = frame.lens_radius > 0.0 ? sample_pair(pixel, sample_index, 4u * CAMERA_BLOCK + 2u, u.zw) : u.zw;
    // AOV layers that must not be averaged: the pixel's centre, the lens's centre.
    if ((frame.debug_flags & FLAG_PIXEL_CENTRE) != 0u) {
        jitter = vec2(0.5);
        lens_u = vec2(0.5);
    }
    camera_ray(frame, pixel, jitter, lens_u, ray.origin, ray.dir);
    ray.path = i;
    ray.pad = 0u;
    rays[i] = ray;  // queue 0; its counter is set to batch_size by the host
}

void main() {
    kernel_main();
    count_scene_fetches();
}
