#version 460
#extension GL_GOOGLE_include_directive : require
// Light tracing, stage 4: any-hit test of every join to the camera; an unoccluded one splats
// its contribution onto its pixel (the shadow ray's `pad`) with order-independent integer
// atomics. params.depth = the light vertex's index, s - 1.
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

layout(local_size_x = WORKGROUP_SIZE) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counters[COUNTER_SHADOW]) return;
    ShadowRay shadow = shadow_rays[i];
    uint pixel, sample_index;
    path_pixel_sample(shadow.path, pixel, sample_index);
    uint s = params.depth + 1u;
    uvec4 key = alpha_key(frame.seed, pixel, sample_index, ALPHA_CONNECT + s * 64u + 1u, true);
    if (!scene_intersect_any(shadow.origin, shadow.dir, 0.0, shadow.t_max, key)) {
        splat_add(shadow.pad, shadow.contribution);
    }
}
