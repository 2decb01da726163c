#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Stage 2: closest hit for every queued extension ray.
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
    uint queue = params.depth & 1u;
    if (i >= counters[queue]) return;
    QueuedRay ray = rays[queue * params.batch_size + i];
    uint pixel, sample_index;
    path_pixel_sample(ray.path, pixel, sample_index);
    uvec4 key = alpha_key(frame.seed, pixel, sample_index, params.depth, false);
    HitRecord hit;
    scene_intersect_closest(ray.origin, ray.dir, 0.0, 3.402823466e38, key, hit);
    hit_store(i, hit);
}

void main() {
    kernel_main();
    count_scene_fetches();
}
