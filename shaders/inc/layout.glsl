// Every struct the GPU reads or writes: the twins of src/layout.rs (checked by tests/shaders.rs).
// std430 in storage buffers, std140 for FrameParams; a vec3 is always followed by a 4-byte scalar.
#ifndef LAYOUT_GLSL
#define LAYOUT_GLSL

#define WORKGROUP_SIZE 64

// Random-number dimension blocks (src/layout.rs, mod dim).
#define CAMERA_BLOCK 0u  // pixel jitter (x, y), point on the lens (z, w)
#define BLOCKS_PER_BOUNCE 2u
uint bounce_block(uint depth) { return 1u + depth * BLOCKS_PER_BOUNCE; }

// Flattened BVH node, depth-first; interior: left child = next node. Total: 32 bytes.
struct BvhNode {
    vec3 bounds_min;  // 12 bytes
    uint offset;      // 4 bytes: leaf: first triangle; interior: right child
    vec3 bounds_max;  // 12 bytes
    uint count;       // 4 bytes: leaf: triangle count (> 0); interior: 0
};
bool bvh_node_is_leaf(BvhNode n) { return n.count > 0u; }
uint bvh_node_right_child(BvhNode n) { return n.offset; }
uint bvh_node_first_triangle(BvhNode n) { return n.offset; }

// World-space triangle, p0 and edges; cross(e1, e2) points to the front face. Total: 48 bytes.
struct GpuTriangle {
    vec3 p0;          // 12 bytes
    uint material;    // 4 bytes
    vec3 e1;          // 12 bytes: p1 - p0
    float light_pmf;  // 4 bytes: probability of choosing it in emitter sampling
    vec3 e2;          // 12 bytes: p2 - p0
    float area;       // 4 bytes
};

#define MATERIAL_DOUBLE_SIDED 1u

// A glTF metallic-roughness material (bsdf.glsl reads it) and its emitted radiance.
// Total: 48 bytes.
struct GpuMaterial {
    vec3 base_color;     // 12 bytes: linear RGB, baseColorFactor
    uint flags;          // 4 bytes
    vec3 emission;       // 12 bytes: radiance
    float metallic;      // 4 bytes
    float roughness;     // 4 bytes: GGX alpha = roughness^2
    float ior;           // 4 bytes: KHR_materials_ior
    float transmission;  // 4 bytes: KHR_materials_transmission
    float specular;      // 4 bytes: KHR_materials_specular's specularFactor
};

// Emitter table entry, CDF proportional to power. Total: 16 bytes.
struct LightEntry {
    float cdf;        // 4 bytes
    uint triangle;    // 4 bytes
    float pmf;        // 4 bytes
    uint pad;         // 4 bytes
};

// Constants of one render (std140 uniform). Total: 144 bytes.
struct FrameParams {
    vec3 cam_position;    // 12 bytes
    float tan_half_fov_y; // 4 bytes: perspective: tan(yfov / 2); orthographic: 0
    vec3 cam_right;       // 12 bytes
    float aspect;         // 4 bytes
    vec3 cam_up;          // 12 bytes
    uint width;           // 4 bytes
    vec3 cam_forward;     // 12 bytes
    uint height;          // 4 bytes
    uint seed;            // 4 bytes
    uint max_depth;       // 4 bytes
    uint light_count;     // 4 bytes
    uint rr_start_depth;  // 4 bytes
    vec3 environment;     // 12 bytes
    uint debug_flags;     // 4 bytes
    uint band_first_pixel;  // 4 bytes: the film holds pixels [band_first_pixel,
    uint band_pixel_count;  // 4 bytes:   band_first_pixel + band_pixel_count)
    uint mis_heuristic;     // 4 bytes: MIS_* of mis.glsl
    float mis_beta;         // 4 bytes: beta of the power heuristic
    uint spp;               // 4 bytes: samples per pixel of the whole render
    uint sampler_mode;      // 4 bytes: SAMPLER_*
    uint rr_mode;           // 4 bytes: RR_*
    uint cam_projection;    // 4 bytes: CAMERA_*
    float cam_znear;        // 4 bytes: primary rays start on the near plane
    float lens_radius;      // 4 bytes: thin lens; 0 = pinhole
    float focus_distance;   // 4 bytes: thin lens: distance of the plane in focus
    float cam_ymag;         // 4 bytes: orthographic: half-height of the view; else 0
};
#define CAMERA_PERSPECTIVE 0u
#define CAMERA_ORTHOGRAPHIC 1u
#define SAMPLER_INDEPENDENT 0u
#define SAMPLER_STRATIFIED 1u
#define SAMPLER_SOBOL 2u
#define RR_THROUGHPUT 0u
#define RR_ALBEDO 1u
#define RR_OFF 2u
#define DEBUG_NO_NEE 1u

// Per-dispatch push constants; see src/layout.rs for the batch indexing. Total: 32 bytes.
struct DispatchParams {
    uint first_sample;   // 4 bytes
    uint first_pixel;    // 4 bytes
    uint batch_size;     // 4 bytes
    uint depth;          // 4 bytes
    uint counter;        // 4 bytes: dispatch_args: queue counter to read
    uint args_slot;      // 4 bytes: dispatch_args: argument slot to write
    uint total_counter;  // 4 bytes: dispatch_args: total to add the count to, or 0xffffffff
    uint clear_mask;     // 4 bytes: dispatch_args: bit k set = zero counters[k]
};

// What carries between bounces for one path. Total: 48 bytes.
struct PathState {
    vec3 throughput;      // 12 bytes
    float prev_bsdf_pdf;  // 4 bytes
    vec3 radiance;        // 12 bytes
    uint prev_specular;   // 4 bytes
    uvec4 pad;            // 16 bytes
};

// Extension-queue ray. Total: 32 bytes.
struct QueuedRay {
    vec3 origin;  // 12 bytes
    uint path;    // 4 bytes
    vec3 dir;     // 12 bytes
    uint pad;     // 4 bytes
};

// Closest hit; triangle == NO_HIT on a miss. Total: 16 bytes.
struct HitRecord {
    float t;        // 4 bytes
    uint triangle;  // 4 bytes
    float u;        // 4 bytes
    float v;        // 4 bytes
};
#define NO_HIT 0xffffffffu

// Shadow ray and the contribution it carries. Total: 48 bytes.
struct ShadowRay {
    vec3 origin;        // 12 bytes
    uint path;          // 4 bytes
    vec3 dir;           // 12 bytes
    float t_max;        // 4 bytes
    vec3 contribution;  // 12 bytes
    uint pad;           // 4 bytes
};

// Per-pixel sum, sum of squares and count. Total: 32 bytes.
struct FilmPixel {
    vec3 sum;     // 12 bytes
    uint count;   // 4 bytes
    vec3 sum_sq;  // 12 bytes
    uint pad;     // 4 bytes
};

// Counter buffer indices (src/layout.rs, mod counter).
#define COUNTER_RAYS_0 0u
#define COUNTER_RAYS_1 1u
#define COUNTER_SHADOW 2u
#define COUNTER_TOTAL_EXTENSION_RAYS 3u
#define COUNTER_TOTAL_SHADOW_RAYS 4u
#define COUNTER_DROPPED_SAMPLES 5u
// Indirect-argument slots (src/layout.rs, mod args).
#define ARGS_RAYS 0u
#define ARGS_SHADOW 1u

#endif
