#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Light tracing and BDPT, stage 4: any-hit test of every join queued by shade_light,
// generate_light or connect_bdpt; an unoccluded one splats its contribution onto its pixel
// (the shadow ray's `pad`) with order-independent integer atomics. params.depth = the
// strategy's code 64 s + t, which keys the alpha test (ALPHA_CONNECT + 64 s + t).
#include "layout.glsl"
#include "bindings.glsl"
#define BVH_ANY_HIT
#include "rng.glsl"
#include "sampling.glsl"
#include "bsdf.glsl"
#include "scene.glsl"
#include "texture.glsl"
#include "surface.glsl"
#include "bvh.glsl"
#include "tlas.glsl"
#include "light_tracing.glsl"
#include "spectrum.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void kernel_main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counters[COUNTER_SHADOW]) return;
    ShadowRay shadow = shadow_rays[i];
    uint pixel, sample_index;
    path_pixel_sample(shadow.path, pixel, sample_index);
    uvec4 key = alpha_key(frame.seed, pixel, sample_index, ALPHA_CONNECT + params.depth, true);
    // A join to the camera (t = 1) runs from the light vertex: towards the eye.
    if (params.depth % 64u == 1u) key = towards_eye(key);
    if (!scene_intersect_any(shadow.origin, shadow.dir, 0.0, shadow.t_max, key)) {
        // KHR_materials_dispersion: a spectral sample's weight r(λ)/p(λ) (Bidir::sample).
        vec3 c = shadow.contribution;
        if (frame.spectral != 0u) c *= wavelength_weight(sample_wavelength_of(frame.seed, pixel, sample_index));
        splat_add(sample_index - params.first_sample, shadow.pad, c);
    }
}

void main() {
    kernel_main();
    count_scene_fetches();
}
