// The one descriptor set every wavefront kernel shares (src/gpu/bindings.rs, `Binding`).
#ifndef BINDINGS_GLSL
#define BINDINGS_GLSL

layout(std140, set = 0, binding = 0) uniform Frame { FrameParams frame; };
layout(std430, set = 0, binding = 1) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(std430, set = 0, binding = 2) readonly buffer Triangles { GpuTriangle triangles[]; };
layout(std430, set = 0, binding = 3) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, set = 0, binding = 4) readonly buffer Lights { LightEntry lights[]; };
layout(std430, set = 0, binding = 5) buffer Paths { PathState paths[]; };
// Two queues of batch_size rays each, ping-ponged by depth & 1.
layout(std430, set = 0, binding = 6) buffer Rays { QueuedRay rays[]; };
// The hit records' instances (the rest of a record is hit_image's texel; hit_store, hit_load).
layout(std430, set = 0, binding = 7) buffer HitInstances { uint hit_instances[]; };
layout(std430, set = 0, binding = 8) buffer Shadows { ShadowRay shadow_rays[]; };
layout(std430, set = 0, binding = 9) buffer Film { FilmPixel film[]; };
layout(std430, set = 0, binding = 10) buffer Counters { uint counters[]; };
layout(std430, set = 0, binding = 11) buffer Args { uvec4 dispatch_args[]; };
// Shading data (surface.glsl, texture.glsl): per-triangle vertex indices (xyz) and TRIANGLE_*
// flags (w) in BVH order, vertices, textures, texture references and RGBA8 texels.
layout(std430, set = 0, binding = 12) readonly buffer TriangleVertices { uvec4 triangle_vertices[]; };
layout(std430, set = 0, binding = 13) readonly buffer Vertices { GpuVertex vertices[]; };
layout(std430, set = 0, binding = 14) readonly buffer Textures { GpuTexture textures[]; };
layout(std430, set = 0, binding = 15) readonly buffer TextureRefs { GpuTextureRef texture_refs[]; };
layout(std430, set = 0, binding = 16) readonly buffer Texels { uint texels[]; };
// The top level's leaves: placements of the bottom-level BVHs (tlas.glsl), in top-level order.
layout(std430, set = 0, binding = 17) readonly buffer Instances { GpuInstance instances[]; };
// KHR_lights_punctual lights; emitter-table entries with LIGHT_ENTRY_PUNCTUAL point here.
layout(std430, set = 0, binding = 18) readonly buffer Punctual { GpuPunctualLight punctual_lights[]; };
// The environment map (environment.glsl): RGBE texels, each row's conditional CDF, the marginal.
layout(std430, set = 0, binding = 19) readonly buffer EnvTexels { uint env_texels[]; };
layout(std430, set = 0, binding = 20) readonly buffer EnvConditional { float env_conditional[]; };
layout(std430, set = 0, binding = 21) readonly buffer EnvMarginal { float env_marginal[]; };
// The light BVH over the table's bounded emitters (light_bvh.glsl) and, per triangle, its
// trail from the root (NO_LIGHT_TRAIL for triangles that do not emit).
#define LIGHT_BVH_NODE_ONLY
#include "light_bvh.glsl"
#undef LIGHT_BVH_NODE_ONLY
layout(std430, set = 0, binding = 22) readonly buffer LightNodes { GpuLightNode light_nodes[]; };
layout(std430, set = 0, binding = 23) readonly buffer LightTrails { uint light_trails[]; };
// Renders that stop at a target error, --adaptive: the band-local indices of the pixels still
// sampled in this pass (frame.active_pixel_count of them; scene.glsl, path_pixel_sample).
layout(std430, set = 0, binding = 24) readonly buffer ActivePixels { uint active_pixels[]; };
// Light tracing's splat image: per pixel and channel, a 64-bit fixed-point sum (2^-24 units)
// as two words, low then high (light_tracing.glsl, splat_add), added with integer atomics so
// the sum does not depend on the order of the additions.
layout(std430, set = 0, binding = 25) buffer Splats { uint splats[]; };
// --paths: the path-expression automata (paths.glsl); word 0 = 0 without an expression.
layout(std430, set = 0, binding = 26) readonly buffer PathDfa { uint path_dfa[]; };
// --integrator bdpt: both subpaths of every path of the batch (bdpt.glsl).
layout(std430, set = 0, binding = 27) buffer BdptVertices { BdptVertex bdpt_vertices[]; };
// Further bindings of the five large scene arrays, for scenes larger than one binding holds
// (scene_arrays.glsl): chunks 1 to 3 of each, chunk 0 being the binding above. Not declared in
// the kernels built with SCENE_ONE_BINDING (build.rs: KERNELS_ONE_BINDING), for devices that
// bind fewer storage buffers than all of these (SwiftShader: 30), rendering scenes whose arrays
// each fit one binding.
#ifndef SCENE_ONE_BINDING
layout(std430, set = 0, binding = 28) readonly buffer BvhNodes1 { BvhNode bvh_nodes1[]; };
layout(std430, set = 0, binding = 29) readonly buffer BvhNodes2 { BvhNode bvh_nodes2[]; };
layout(std430, set = 0, binding = 30) readonly buffer BvhNodes3 { BvhNode bvh_nodes3[]; };
layout(std430, set = 0, binding = 31) readonly buffer Triangles1 { GpuTriangle triangles1[]; };
layout(std430, set = 0, binding = 32) readonly buffer Triangles2 { GpuTriangle triangles2[]; };
layout(std430, set = 0, binding = 33) readonly buffer Triangles3 { GpuTriangle triangles3[]; };
layout(std430, set = 0, binding = 34) readonly buffer TriangleVertices1 { uvec4 triangle_vertices1[]; };
layout(std430, set = 0, binding = 35) readonly buffer TriangleVertices2 { uvec4 triangle_vertices2[]; };
layout(std430, set = 0, binding = 36) readonly buffer TriangleVertices3 { uvec4 triangle_vertices3[]; };
layout(std430, set = 0, binding = 37) readonly buffer Vertices1 { GpuVertex vertices1[]; };
layout(std430, set = 0, binding = 38) readonly buffer Vertices2 { GpuVertex vertices2[]; };
layout(std430, set = 0, binding = 39) readonly buffer Vertices3 { GpuVertex vertices3[]; };
layout(std430, set = 0, binding = 40) readonly buffer Texels1 { uint texels1[]; };
layout(std430, set = 0, binding = 41) readonly buffer Texels2 { uint texels2[]; };
layout(std430, set = 0, binding = 42) readonly buffer Texels3 { uint texels3[]; };
#endif
// The read-only scene arrays as RGBA32UI images (records of 16-byte texels, row after row; the
// textures' texels R32UI), read instead of the buffers above where the specialization constant
// SCENE_IMAGES is not 0 (scene_arrays.glsl; src/gpu/bindings.rs, SceneImage): as storage images
// with imageLoad where it is 1, as sampled images with texelFetch (bindings 54 to 64, the same
// images) where it is 2. On llvmpipe a sampled image's texel is read through a function that
// works out each lane's mip level, its size, row pitch and offset (about 200 instructions for 8
// lanes) and a storage image's through one that only bounds-checks and loads (about 50;
// docs/perf-log/2026-12-02-lavapipe-scene-reads.md); on a GPU both go through its texture units.
layout(set = 0, binding = 43, rgba32ui) uniform readonly uimage2D bvh_node_image;
layout(set = 0, binding = 44, rgba32ui) uniform readonly uimage2D triangle_image;
layout(set = 0, binding = 45, rgba32ui) uniform readonly uimage2D triangle_vertex_image;
layout(set = 0, binding = 46, rgba32ui) uniform readonly uimage2D vertex_image;
layout(set = 0, binding = 47, rgba32ui) uniform readonly uimage2D material_image;
layout(set = 0, binding = 48, rgba32ui) uniform readonly uimage2D light_node_image;
layout(set = 0, binding = 49, r32ui) uniform readonly uimage2D texel_image;
layout(set = 0, binding = 50, rgba32ui) uniform readonly uimage2D instance_image;
layout(set = 0, binding = 51, rgba32ui) uniform readonly uimage2D texture_image;
layout(set = 0, binding = 52, rgba32ui) uniform readonly uimage2D texture_ref_image;
layout(set = 0, binding = 53, rgba32ui) uniform readonly uimage2D light_image;
#extension GL_EXT_samplerless_texture_functions : require
layout(set = 0, binding = 54) uniform utexture2D bvh_node_image_sampled;
layout(set = 0, binding = 55) uniform utexture2D triangle_image_sampled;
layout(set = 0, binding = 56) uniform utexture2D triangle_vertex_image_sampled;
layout(set = 0, binding = 57) uniform utexture2D vertex_image_sampled;
layout(set = 0, binding = 58) uniform utexture2D material_image_sampled;
layout(set = 0, binding = 59) uniform utexture2D light_node_image_sampled;
layout(set = 0, binding = 60) uniform utexture2D texel_image_sampled;
layout(set = 0, binding = 61) uniform utexture2D instance_image_sampled;
layout(set = 0, binding = 62) uniform utexture2D texture_image_sampled;
layout(set = 0, binding = 63) uniform utexture2D texture_ref_image_sampled;
layout(set = 0, binding = 64) uniform utexture2D light_image_sampled;
// The hit records' first 16 bytes (t, triangle, u, v), one texel a record at scene_texel_at(i):
// extend stores them, the shade kernels load them (hit_store, hit_load); a texel is one call of
// llvmpipe's image function for 8 lanes where four words of a storage buffer are a bounds-checked
// load per lane and word. The instance, read only with a top level, stays in hit_instances[].
layout(set = 0, binding = 65, rgba32ui) uniform uimage2D hit_image;
#define SCENE_SPLIT_BINDINGS
#include "scene_arrays.glsl"
layout(push_constant) uniform Push { DispatchParams params; };

#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// A slot of the queue whose length is counters[counter], for each lane that calls this
// together (with the same counter): one atomicAdd per subgroup for all its pushing lanes, made
// by the first of them, each lane then taking its rank among them (warp-aggregated atomics, as
// the queues of Laine et al. 2013, "Megakernels Considered Harmful", §4.2, are pushed). A lane
// per atomic would send every lane of a GPU's wide dispatch to one address; which ray lands in
// which slot was never fixed (the lanes' atomics come in any order) and nothing depends on it:
// each ray names its path. (The rank is an exclusive sum and the first lane the one of rank 0,
// where subgroupElect and subgroupBallotBitCount would do: naga, which validates every kernel,
// reads scans and broadcasts but not those two.)
uint queue_push_slot(uint counter) {
    uint rank = subgroupExclusiveAdd(1u);
    uint pushing = subgroupAdd(1u);
    uint first = 0u;
    if (rank == 0u) first = atomicAdd(counters[counter], pushing);
    return subgroupBroadcastFirst(first) + rank;
}

// Hit record i as extend stores it: t, triangle, u and v in the hit image's texel, the instance
// in hit_instances[] where there is a top level (without one it is 0 and never read).
void hit_store(uint i, HitRecord hit) {
    imageStore(hit_image, scene_texel_at(i),
               uvec4(floatBitsToUint(hit.t), hit.triangle, floatBitsToUint(hit.u), floatBitsToUint(hit.v)));
    if (SCENE_HAS(FEATURE_TOP_LEVEL)) hit_instances[i] = hit.instance;
}

// Hit record i as hit_store left it.
HitRecord hit_load(uint i) {
    uvec4 h = imageLoad(hit_image, scene_texel_at(i));
    uint instance = SCENE_HAS(FEATURE_TOP_LEVEL) ? hit_instances[i] : 0u;
    return HitRecord(uintBitsToFloat(h.x), h.y, uintBitsToFloat(h.z), uintBitsToFloat(h.w), instance, 0u, 0u, 0u);
}

// The path tracer's state of path `path`, as generate and shade store it: what a later vertex
// of the path reads. The members only a feature reads (the previous vertex for the light BVH's
// pmf, the ray cone for textures, the path expression's state, the medium, the wavelength) are
// stored only where the kernels are made for it; without it no kernel reads them, and every
// word is a store per lane on lavapipe (docs/perf-log/2026-12-02-lavapipe-fetches-and-divergence.md).
void path_store(uint path, PathState state) {
    paths[path].throughput = state.throughput;
    paths[path].prev_bsdf_pdf = state.prev_bsdf_pdf;
    paths[path].radiance = state.radiance;
    paths[path].prev_specular = state.prev_specular;
    if (SCENE_HAS(FEATURE_LIGHT_BVH)) {
        paths[path].prev_position = state.prev_position;
        paths[path].prev_normal = state.prev_normal;
    }
    if (SCENE_HAS(FEATURE_TEXTURES)) paths[path].cone_width = state.cone_width;
    if (SCENE_HAS(FEATURE_PATHS)) paths[path].pad0 = state.pad0;
    if (SCENE_HAS(FEATURE_VOLUME)) paths[path].medium = state.medium;
    if (SCENE_HAS(FEATURE_DISPERSION)) paths[path].wavelength = state.wavelength;
}

#endif
