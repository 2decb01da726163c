#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Stage 4: any-hit test of every shadow ray; an unoccluded one adds its contribution to its path
// (each path has at most one shadow ray per bounce, so no atomics on radiance).
#include "layout.glsl"
#include "bindings.glsl"
#define BVH_ANY_HIT
#include "rng.glsl"
#include "sampling.glsl"
#include "scene.glsl"
#include "texture.glsl"
#include "surface.glsl"
#include "bvh.glsl"
#include "tlas.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void kernel_main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= counters[COUNTER_SHADOW]) return;
    ShadowRay shadow = shadow_rays[i];
    uint pixel, sample_index;
    path_pixel_sample(shadow.path, pixel, sample_index);
    uvec4 key = alpha_key(frame.seed, pixel, sample_index, params.depth, true);
    if (!scene_intersect_any(shadow.origin, shadow.dir, 0.0, shadow.t_max, key)) {
        paths[shadow.path].radiance += shadow.contribution;
    }
}

void main() {
    kernel_main();
    count_scene_fetches();
}
