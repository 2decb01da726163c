// Every struct the GPU reads or writes: the twins of src/layout.rs (checked by tests/twins/shaders.rs).
// std430 in storage buffers, std140 for FrameParams; a vec3 is always followed by a 4-byte scalar.
#ifndef LAYOUT_GLSL
#define LAYOUT_GLSL

#define WORKGROUP_SIZE 64

// Random-number dimension blocks (src/layout.rs, mod dim).
#define CAMERA_BLOCK 0u  // pixel jitter (x, y), point on the lens (z, w)
#define BLOCKS_PER_BOUNCE 2u
uint bounce_block(uint depth) { return 1u + depth * BLOCKS_PER_BOUNCE; }
// Light subpaths (--integrator light): blocks of their own above every camera bounce's.
#define LIGHT_BLOCK_BASE (1u << 24)
uint light_block(uint vertex) { return LIGHT_BLOCK_BASE + 2u * vertex; }
#define WAVELENGTH_BLOCK (LIGHT_BLOCK_BASE - 1u)  // the sample's wavelength (spectrum.glsl)

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
#define MATERIAL_ALPHA_MASK 2u
#define MATERIAL_ALPHA_BLEND 4u
#define MATERIAL_TEXTURED 8u
#define MATERIAL_UNLIT 16u
#define MATERIAL_EXTENDED 32u  // material image only (src/layout.rs)
#define MATERIAL_ENERGY_COMPENSATION 64u  // bsdf/energy (src/layout.rs)
#define NO_TEXTURE 0xffffffffu

// A glTF metallic-roughness material (bsdf.glsl reads it) and its emitted radiance, with the
// texture references that modulate its factors at each surface point (surface.glsl).
// Total: 256 bytes.
struct GpuMaterial {
    vec3 base_color;     // 12 bytes: linear RGB, baseColorFactor
    uint flags;          // 4 bytes
    vec3 emission;       // 12 bytes: radiance
    float metallic;      // 4 bytes
    float roughness;     // 4 bytes: GGX alpha = roughness^2
    float ior;           // 4 bytes: KHR_materials_ior
    float transmission;  // 4 bytes: KHR_materials_transmission
    float specular;      // 4 bytes: KHR_materials_specular's specularFactor
    float alpha;         // 4 bytes: baseColorFactor's alpha
    float alpha_cutoff;  // 4 bytes
    float normal_scale;  // 4 bytes
    uint base_color_texture;          // 4 bytes: GpuTextureRef index or NO_TEXTURE
    uint metallic_roughness_texture;  // 4 bytes
    uint emissive_texture;            // 4 bytes
    uint normal_texture;              // 4 bytes
    uint transmission_texture;        // 4 bytes
    vec3 specular_color;              // 12 bytes: KHR_materials_specular's specularColorFactor
    uint specular_texture;            // 4 bytes: A x specular
    uint specular_color_texture;      // 4 bytes: sRGB; RGB x specular_color
    float clearcoat;                  // 4 bytes: KHR_materials_clearcoat's clearcoatFactor
    float clearcoat_roughness;        // 4 bytes: alpha = roughness^2
    uint clearcoat_texture;           // 4 bytes: R x clearcoat
    uint clearcoat_roughness_texture; // 4 bytes: G x clearcoat_roughness
    uint clearcoat_normal_texture;    // 4 bytes
    float clearcoat_normal_scale;     // 4 bytes
    float sheen_roughness;            // 4 bytes: KHR_materials_sheen's sheenRoughnessFactor
    vec3 clearcoat_normal;            // 12 bytes: the coat's world normal at a hit (0: the shading normal)
    uint sheen_color_texture;         // 4 bytes: sRGB; RGB x sheen_color
    vec3 sheen_color;                 // 12 bytes: sheenColorFactor (0: no sheen)
    uint sheen_roughness_texture;     // 4 bytes: A x sheen_roughness
    vec3 anisotropy_direction;        // 12 bytes: KHR_materials_anisotropy's world direction at a hit (0: none)
    float anisotropy;                 // 4 bytes: anisotropyStrength (x texture B at a hit)
    float anisotropy_rotation;        // 4 bytes: anisotropyRotation, radians
    uint anisotropy_texture;          // 4 bytes: RG direction, B x anisotropy
    float iridescence;                // 4 bytes: KHR_materials_iridescence's iridescenceFactor
    float iridescence_ior;            // 4 bytes
    float iridescence_thickness_min;  // 4 bytes: nm
    float iridescence_thickness;      // 4 bytes: nm, the maximum (at a hit: mix(min, max, texture G))
    uint iridescence_texture;         // 4 bytes: R x iridescence
    uint iridescence_thickness_texture; // 4 bytes: G
    vec3 attenuation;                 // 12 bytes: KHR_materials_volume's sigma = -ln(colour)/distance behind back faces (0: none)
    float thickness;                  // 4 bytes: thicknessFactor
    vec3 diffuse_transmission_color;  // 12 bytes: KHR_materials_diffuse_transmission's colour factor
    float diffuse_transmission;       // 4 bytes: diffuseTransmissionFactor (0: none)
    uint diffuse_transmission_texture;       // 4 bytes: A x diffuse_transmission
    uint diffuse_transmission_color_texture; // 4 bytes: sRGB; RGB x the colour
    float dispersion;                 // 4 bytes: KHR_materials_dispersion, 20 / Abbe number
    uint pad1;                        // 4 bytes
};

// Shading attributes of one vertex, world space. Total: 64 bytes.
struct GpuVertex {
    vec4 tangent;  // 16 bytes: xyz unit tangent, w bitangent sign
    vec3 normal;   // 12 bytes
    uint pad;      // 4 bytes
    vec4 uv;       // 16 bytes: TEXCOORD_0 (xy), TEXCOORD_1 (zw)
    vec4 color;    // 16 bytes: COLOR_0
};
#define TRIANGLE_FLAT 1u
#define TRIANGLE_PLAIN 4u
// GpuTriangle.material: the index in the low 30 bits, the any-hit tests in the top two.
#define TRIANGLE_MATERIAL_MASK 0x3fffffffu
#define TRIANGLE_TEST_ALPHA 0x80000000u
#define TRIANGLE_TEST_CULL 0x40000000u
// A scene's features the wavefront kernels can be compiled without (src/layout.rs, FEATURE_*;
// SCENE_FEATURES below): the top level's walk, a binary walk, the general BSDF, the
// alpha lookup of the any-hit test, texture lookups, the environment, punctual lights, dispersion,
// volume attenuation, path expressions, the stratified and Sobol samplers, the light BVH, the
// thin film.
#define FEATURE_TOP_LEVEL 1u
#define FEATURE_BINARY_WALK 2u
#define FEATURE_GENERAL_BSDF 4u
#define FEATURE_ALPHA 8u
#define FEATURE_TEXTURES 16u
#define FEATURE_ENVIRONMENT 32u
#define FEATURE_PUNCTUAL 64u
#define FEATURE_DISPERSION 128u
#define FEATURE_VOLUME 256u
#define FEATURE_PATHS 512u
#define FEATURE_STRATIFIED 1024u
#define FEATURE_SOBOL 2048u
#define FEATURE_LIGHT_BVH 4096u
#define FEATURE_IRIDESCENCE 8192u
// Whether `features` holds feature f. (The specialisation constant is passed in, not named: an
// expression of specialisation constants alone compiles to OpSpecConstantOp, which naga does
// not read; the driver folds it once inlined, scene_arrays.glsl.)
bool scene_feature_in(uint features, uint f) { return (features & f) != 0u; }
#ifdef KERNEL_INDEX
// A wavefront kernel: the render's features (src/render/prepared.rs, PreparedScene::gpu_features) as a
// specialisation constant, every feature by default; a pipeline made for a render that lacks
// one compiles without its code.
layout(constant_id = 6) const uint SCENE_FEATURES = 0xffffffffu;
#define SCENE_HAS(f) scene_feature_in(SCENE_FEATURES, f)
#else
// A test kernel: every feature's code is there.
#define SCENE_HAS(f) true
#endif
uint triangle_material(GpuTriangle t) { return t.material & TRIANGLE_MATERIAL_MASK; }

// A mip chain of RGBA8 texels and glTF's sampler settings (src/layout.rs). Total: 32 bytes.
struct GpuTexture {
    uint texel_offset;  // 4 bytes
    uint width;         // 4 bytes
    uint height;        // 4 bytes
    uint levels;        // 4 bytes
    uint wrap_s;        // 4 bytes
    uint wrap_t;        // 4 bytes
    uint filters;       // 4 bytes: mag in bits 0-3, min in bits 4-7
    uint srgb;          // 4 bytes
};
#define WRAP_REPEAT 0u
#define WRAP_CLAMP_TO_EDGE 1u
#define WRAP_MIRRORED_REPEAT 2u
#define FILTER_NEAREST 0u
#define FILTER_LINEAR 1u
#define MIN_NEAREST 0u
#define MIN_LINEAR 1u
#define MIN_NEAREST_MIPMAP_NEAREST 2u
#define MIN_LINEAR_MIPMAP_NEAREST 3u
#define MIN_NEAREST_MIPMAP_LINEAR 4u
#define MIN_LINEAR_MIPMAP_LINEAR 5u

// A material's use of a texture: texture coordinate set and KHR_texture_transform. Total: 32 bytes.
struct GpuTextureRef {
    vec4 transform;  // 16 bytes: rows (x, y) and (z, w) of the 2x2 part
    vec2 offset;     // 8 bytes
    uint texture;    // 4 bytes
    uint texcoord;   // 4 bytes
};

// Emitter table entry, CDF proportional to power. Total: 16 bytes.
struct LightEntry {
    float cdf;        // 4 bytes
    uint triangle;    // 4 bytes
    float pmf;        // 4 bytes
    uint pad;         // 4 bytes
};

// A KHR_lights_punctual light in world space (src/layout.rs). Total: 64 bytes.
struct GpuPunctualLight {
    vec3 position;      // 12 bytes
    uint kind;          // 4 bytes: LIGHT_*
    vec3 direction;     // 12 bytes: the direction it shines along
    float range;        // 4 bytes: 0 = none
    vec3 intensity;     // 12 bytes: W/sr (point, spot) or W/m^2 (directional)
    float spot_scale;   // 4 bytes
    float spot_offset;  // 4 bytes
    uint pad0;          // 4 bytes
    uint pad1;          // 4 bytes
    uint pad2;          // 4 bytes
};
#define LIGHT_POINT 0u
#define LIGHT_SPOT 1u
#define LIGHT_DIRECTIONAL 2u
#define LIGHT_ENTRY_PUNCTUAL 0x80000000u

// Constants of one render (std140 uniform). Total: 4288 bytes.
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
    vec3 env_scale;       // 12 bytes: RGB factor on the environment map (environment.glsl)
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
    float cone_width;       // 4 bytes: ray cone at the camera (texture level of detail)
    float cone_spread;      // 4 bytes: its spread angle
    uint aov;               // 4 bytes: AOV_*
    uint tlas_root;         // 4 bytes: BVH node of the top level's root (tlas.glsl)
    uint env_width;         // 4 bytes: environment map size; 0 = no environment
    uint env_height;        // 4 bytes
    vec2 env_rotation;      // 8 bytes: cos, sin of --env-rotate (about +Y)
    float env_pmf;          // 4 bytes: probability that NEE samples the environment
    uint light_sampler;     // 4 bytes: LIGHT_SAMPLER_*
    float light_bounded_cdf;  // 4 bytes: the table's CDF at its last bounded light
    uint active_pixel_count;  // 4 bytes: 0 = the band's pixels in order; n > 0 = the first n
                              //   entries of active_pixels (bindings.glsl, scene.glsl)
    uint integrator;        // 4 bytes: INTEGRATOR_*
    uint spectral;          // 4 bytes: 1 = the scene has a dispersive material (spectrum.glsl)
    uint count_fetches;     // 4 bytes: 1 = count scene-image fetches (scene_arrays.glsl)
    uint tlas_wide_root;    // 4 bytes: quantised 4-wide root of the top level (tlas.glsl), or NO_WIDE_ROOT
    vec4 sheen_albedo[256];   // 4096 bytes: KHR_materials_sheen's E table, four entries a vec4
    vec4 ggx_albedo[528];     // 8448 bytes: energy compensation's (A, B) table, two pairs a vec4, then its averages
};
#define INTEGRATOR_PATH 0u
#define INTEGRATOR_LIGHT 1u
#define INTEGRATOR_BDPT 2u
#define LIGHT_SAMPLER_POWER 0u
#define LIGHT_SAMPLER_BVH 1u
#define AOV_RADIANCE 0u
#define AOV_BASE_COLOR 1u
#define AOV_NORMAL 2u
#define AOV_UV 3u
#define AOV_EMISSION 4u
#define AOV_DEPTH 5u
#define AOV_POSITION 6u
#define AOV_MATERIAL 7u
#define AOV_INSTANCE 8u
#define AOV_ALPHA 9u
#define CAMERA_PERSPECTIVE 0u
#define CAMERA_ORTHOGRAPHIC 1u
#define SAMPLER_INDEPENDENT 0u
#define SAMPLER_STRATIFIED 1u
#define SAMPLER_SOBOL 2u
#define RR_THROUGHPUT 0u
#define RR_ALBEDO 1u
#define RR_OFF 2u
#define DEBUG_NO_NEE 1u
#define FLAG_TRANSPARENT_BACKGROUND 2u
#define FLAG_PIXEL_CENTRE 4u

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

// What carries between bounces for one path. Total: 80 bytes.
struct PathState {
    vec3 throughput;      // 12 bytes
    float prev_bsdf_pdf;  // 4 bytes
    vec3 radiance;        // 12 bytes
    uint prev_specular;   // 4 bytes
    vec3 prev_position;   // 12 bytes: the previous vertex (light BVH pmf for MIS)
    float cone_width;     // 4 bytes: ray cone width at the ray's origin
    vec3 prev_normal;     // 12 bytes: its geometric normal
    uint pad0;            // 4 bytes
    vec3 medium;          // 12 bytes: attenuation coefficient of the medium the ray enters at its origin
    float wavelength;     // 4 bytes: nm, since the path's first dispersive vertex; 0 before
};

// Extension-queue ray. Total: 32 bytes.
struct QueuedRay {
    vec3 origin;  // 12 bytes
    uint path;    // 4 bytes
    vec3 dir;     // 12 bytes
    uint pad;     // 4 bytes
};

// Closest hit; triangle == NO_HIT on a miss. Total: 32 bytes.
struct HitRecord {
    float t;        // 4 bytes
    uint triangle;  // 4 bytes
    float u;        // 4 bytes
    float v;        // 4 bytes
    uint instance;  // 4 bytes: GpuInstance whose bottom level holds the triangle
    uint pad0;      // 4 bytes
    uint pad1;      // 4 bytes
    uint pad2;      // 4 bytes
};

// One placement of a bottom-level BVH (tlas.glsl). Total: 112 bytes.
struct GpuInstance {
    vec4 object_to_world[3];  // 48 bytes: rows of the 3x4 affine transform
    vec4 world_to_object[3];  // 48 bytes: rows of its inverse
    uint blas_root;           // 4 bytes
    uint flags;               // 4 bytes: INSTANCE_*
    uint wide_root;           // 4 bytes: node of the quantised 4-wide root (qbvh.glsl), or NO_WIDE_ROOT
    uint placement;           // 4 bytes: 0 the baked geometry, k + 1 the scene's instance k
};
#define INSTANCE_IDENTITY 1u
#define INSTANCE_MIRRORED 2u
#define NO_HIT 0xffffffffu
#define NO_WIDE_ROOT 0xffffffffu

// A quantised 4-wide BVH node (src/bvh/quantized.rs, QuantNode), read from two consecutive
// BvhNode records of the node array (scene_arrays.glsl, quant_node_at). Total: 64 bytes.
struct QuantNode {
    vec3 origin;           // 12 bytes: the planes' origin per axis
    uint exponents_valid;  // 4 bytes: bytes 0-2 the scale's biased exponent per axis, byte 3 the slots in use
    uvec4 child;           // 16 bytes: per slot a node index, or a leaf's first triangle | QBVH_LEAF
    uint q[6];             // 24 bytes: minima on x, y, z, then maxima; slot s in byte s of each
    uint count;            // 4 bytes: a leaf slot's triangle count in byte s
    uint pad;              // 4 bytes
};

// Shadow ray and the contribution it carries. Total: 48 bytes.
struct ShadowRay {
    vec3 origin;        // 12 bytes
    uint path;          // 4 bytes
    vec3 dir;           // 12 bytes
    float t_max;        // 4 bytes
    vec3 contribution;  // 12 bytes
    uint pad;           // 4 bytes
};

// Alpha-test keys of light subpaths' bounces (ALPHA_LIGHT_WALK + bounce) and of connections
// (src/layout.rs).
#define ALPHA_LIGHT_WALK (1u << 20)
#define ALPHA_CONNECT (1u << 21)

// One vertex of a BDPT subpath (src/cpu/bidir/bdpt.rs, Vertex; bdpt.glsl). Total: 96 bytes.
struct BdptVertex {
    vec3 p;          // 12 bytes
    uint kind;       // 4 bytes: BDPT_VERTEX_*, | BDPT_VERTEX_DELTA
    vec3 ng;         // 12 bytes
    float pdf_fwd;   // 4 bytes
    vec3 ns;         // 12 bytes
    float pdf_rev;   // 4 bytes
    vec3 wo;         // 12 bytes
    uint index;      // 4 bytes: triangle or punctual light
    vec3 beta;       // 12 bytes
    uint instance;   // 4 bytes: NO_HIT at an emitter's own point
    vec2 bary;       // 8 bytes
    uint pad0;       // 4 bytes
    uint pad1;       // 4 bytes
};
#define BDPT_VERTEX_CAMERA 0u
#define BDPT_VERTEX_AREA_LIGHT 1u
#define BDPT_VERTEX_POINT_LIGHT 2u
#define BDPT_VERTEX_SURFACE 3u
#define BDPT_VERTEX_DELTA 16u

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
#define COUNTER_FETCHES 8u
// Indirect-argument slots (src/layout.rs, mod args).
#define ARGS_RAYS 0u
#define ARGS_SHADOW 1u

#endif
