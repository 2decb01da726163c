// A hit point's attributes, its material with textures applied, its shading normal and alpha
// coverage: twin of src/surface.rs (same names; the rules are written down there).
// Needs bindings.glsl, rng.glsl and texture.glsl.
#ifndef SURFACE_GLSL
#define SURFACE_GLSL
#include "scene_arrays.glsl"
// Whether texture reference t is there (not NO_TEXTURE), in a scene whose features hold any
// texture (FEATURE_TEXTURES): kernels made for a scene without textures compile without
// their lookups.
#define HAS_TEXTURE(t) (SCENE_HAS(FEATURE_TEXTURES) && (t) != NO_TEXTURE)
#include "transform.glsl"

struct SurfacePoint {
    vec3 p;
    vec3 ng;          // unit geometric normal of the front face
    vec3 ns;          // unit interpolated vertex normal (ng on flat triangles)
    vec4 tangent;
    vec2 uv0;
    vec2 uv1;
    vec4 color;
    vec2 uv_area;     // |duv1 x duv2| per set (level of detail)
    float world_area; // |e1 x e2| in world space
    uint flags;
};

float surface_uv_area(vec2 t0, vec2 t1, vec2 t2) {
    vec2 a = t1 - t0;
    vec2 b = t2 - t0;
    return abs(a.x * b.y - a.y * b.x);
}

SurfacePoint surface_point(GpuTriangle tri, uvec4 tv, float u, float v) {
    SurfacePoint sp;
    sp.p = tri.p0 + u * tri.e1 + v * tri.e2;
    vec3 c = cross(tri.e1, tri.e2);
    sp.ng = normalize(c);
    if ((tv.w & TRIANGLE_PLAIN) != 0u) {
        sp.ns = sp.ng;
        sp.tangent = vec4(0.0, 0.0, 0.0, 1.0);
        sp.uv0 = vec2(0.0);
        sp.uv1 = vec2(0.0);
        sp.color = vec4(1.0);
        sp.uv_area = vec2(0.0);
        sp.world_area = length(c);
        sp.flags = tv.w;
        return sp;
    }
    GpuVertex a = vertex_at(tv.x);
    GpuVertex b = vertex_at(tv.y);
    GpuVertex d = vertex_at(tv.z);
    float w = 1.0 - u - v;
    vec4 uv = w * a.uv + u * b.uv + v * d.uv;
    sp.ns = sp.ng;
    if ((tv.w & TRIANGLE_FLAT) == 0u) {
        vec3 n = w * a.normal + u * b.normal + v * d.normal;
        float len = length(n);
        if (len > 0.0 && !isinf(len)) sp.ns = n / len;
    }
    sp.tangent = w * a.tangent + u * b.tangent + v * d.tangent;
    sp.uv0 = uv.xy;
    sp.uv1 = uv.zw;
    sp.color = w * a.color + u * b.color + v * d.color;
    sp.uv_area = vec2(surface_uv_area(a.uv.xy, b.uv.xy, d.uv.xy),
                      surface_uv_area(a.uv.zw, b.uv.zw, d.uv.zw));
    sp.world_area = length(c);
    sp.flags = tv.w;
    return sp;
}

// The surface point of an instanced triangle moved to world space (surface_to_world).
void surface_to_world(inout SurfacePoint sp, GpuTriangle tri, GpuInstance inst) {
    if ((inst.flags & INSTANCE_IDENTITY) != 0u) return;
    sp.p = transform_point(inst.object_to_world, sp.p);
    bool flat_normal = all(equal(sp.ns, sp.ng));
    sp.ng = normalize(transform_normal(inst.world_to_object, sp.ng));
    sp.ns = flat_normal ? sp.ng : normalize(transform_normal(inst.world_to_object, sp.ns));
    vec3 t = transform_vector(inst.object_to_world, sp.tangent.xyz);
    float sign_w = (inst.flags & INSTANCE_MIRRORED) != 0u ? -1.0 : 1.0;
    sp.tangent = vec4(t, sp.tangent.w * sign_w);
    sp.world_area = length(cross(transform_vector(inst.object_to_world, tri.e1),
                                 transform_vector(inst.object_to_world, tri.e2)));
}

#ifdef BINDINGS_GLSL
// (The wavefront kernels' only: they bind the placements and the hit records.)
// The placement hit `hit` lies on: extend stores it only where the kernels walk a top level;
// without one the scene is its one identity placement, 0.
uint hit_instance(HitRecord hit) { return SCENE_HAS(FEATURE_TOP_LEVEL) ? hit.instance : 0u; }

// The world-space surface of `hit` and its triangle `tri` (src/render/prepared.rs,
// PreparedScene::hit_surface): surface_point, then surface_to_world where there is a top level
// (without one the bottom level is in world space, and its placement is not read).
SurfacePoint hit_surface(HitRecord hit, out GpuTriangle tri) {
    tri = triangle_at(hit.triangle);
    SurfacePoint sp = surface_point(tri, triangle_vertices_at(hit.triangle), hit.u, hit.v);
    if (SCENE_HAS(FEATURE_TOP_LEVEL)) surface_to_world(sp, tri, instance_at(hit.instance));
    return sp;
}
#endif

// log2(W / |cos|) + the uv density, per set (Akenine-Moller et al. 2021, eq. 34).
// How many mip levels finer than its pixel's footprint sample `sample` reads: half the bit
// length of the sample index (surface::sample_footprint_levels).
float sample_footprint_levels(uint sample_index) {
    return sample_index == 0u ? 0.0 : 0.5 * (float(findMSB(sample_index)) + 1.0);
}

vec2 surface_lod_base(SurfacePoint sp, float cone_width, float cos_view) {
    float footprint = log2(max(cone_width / max(abs(cos_view), 1e-6), 1e-30));
    vec2 density = 0.5 * log2(max(sp.uv_area, vec2(1e-30)) / max(sp.world_area, 1e-30));
    return vec2(footprint) + density;
}

#define LOD_MAGNIFY vec2(-1e30)

// The textures a material can name, as the slots of surface_textures, in the order it applies
// them: the coat's factor before the coat's normal map, which only a coat reads.
#define TEXTURE_SLOT_EMISSIVE 0u
#define TEXTURE_SLOT_CLEARCOAT 1u
#define TEXTURE_SLOT_BASE_COLOR 2u
#define TEXTURE_SLOT_METALLIC_ROUGHNESS 3u
#define TEXTURE_SLOT_TRANSMISSION 4u
#define TEXTURE_SLOT_SPECULAR 5u
#define TEXTURE_SLOT_SPECULAR_COLOR 6u
#define TEXTURE_SLOT_CLEARCOAT_ROUGHNESS 7u
#define TEXTURE_SLOT_SHEEN_COLOR 8u
#define TEXTURE_SLOT_SHEEN_ROUGHNESS 9u
#define TEXTURE_SLOT_IRIDESCENCE 10u
#define TEXTURE_SLOT_IRIDESCENCE_THICKNESS 11u
#define TEXTURE_SLOT_DIFFUSE_TRANSMISSION 12u
#define TEXTURE_SLOT_DIFFUSE_TRANSMISSION_COLOR 13u
#define TEXTURE_SLOT_CLEARCOAT_NORMAL 14u
#define TEXTURE_SLOT_ANISOTROPY 15u
#define TEXTURE_SLOT_NORMAL 16u
// The slots an emitter's material reads (surface_emitter), and every slot but the normal map's.
#define TEXTURE_SLOTS_EMITTER ((1u << TEXTURE_SLOT_EMISSIVE) | (1u << TEXTURE_SLOT_CLEARCOAT))
#define TEXTURE_SLOTS_MATERIAL ((1u << TEXTURE_SLOT_NORMAL) - 1u)
#define TEXTURE_SLOTS_ALL ((1u << (TEXTURE_SLOT_NORMAL + 1u)) - 1u)

// The texture reference in slot `slot` of material m.
uint material_texture(GpuMaterial m, uint slot) {
    switch (slot) {
    case TEXTURE_SLOT_EMISSIVE: return m.emissive_texture;
    case TEXTURE_SLOT_CLEARCOAT: return m.clearcoat_texture;
    case TEXTURE_SLOT_BASE_COLOR: return m.base_color_texture;
    case TEXTURE_SLOT_METALLIC_ROUGHNESS: return m.metallic_roughness_texture;
    case TEXTURE_SLOT_TRANSMISSION: return m.transmission_texture;
    case TEXTURE_SLOT_SPECULAR: return m.specular_texture;
    case TEXTURE_SLOT_SPECULAR_COLOR: return m.specular_color_texture;
    case TEXTURE_SLOT_CLEARCOAT_ROUGHNESS: return m.clearcoat_roughness_texture;
    case TEXTURE_SLOT_SHEEN_COLOR: return m.sheen_color_texture;
    case TEXTURE_SLOT_SHEEN_ROUGHNESS: return m.sheen_roughness_texture;
    case TEXTURE_SLOT_IRIDESCENCE: return m.iridescence_texture;
    case TEXTURE_SLOT_IRIDESCENCE_THICKNESS: return m.iridescence_thickness_texture;
    case TEXTURE_SLOT_DIFFUSE_TRANSMISSION: return m.diffuse_transmission_texture;
    case TEXTURE_SLOT_DIFFUSE_TRANSMISSION_COLOR: return m.diffuse_transmission_color_texture;
    case TEXTURE_SLOT_CLEARCOAT_NORMAL: return m.clearcoat_normal_texture;
    case TEXTURE_SLOT_ANISOTROPY: return m.anisotropy_texture;
    default: return m.normal_texture;
    }
}

// The slots of `slots` in which material m has a texture (bit s for slot s); none in kernels
// made without textures. The anisotropy's texture is read only where there is anisotropy. (A
// loop of constant bounds, unrolled: material_texture's cases fold away.)
uint material_texture_slots(GpuMaterial m, uint slots) {
    if (!SCENE_HAS(FEATURE_TEXTURES)) return 0u;
    uint present = 0u;
    [[unroll]] for (uint s = 0u; s <= TEXTURE_SLOT_NORMAL; s++) {
        if (material_texture(m, s) != NO_TEXTURE) present |= 1u << s;
    }
    if (!(m.anisotropy > 0.0)) present &= ~(1u << TEXTURE_SLOT_ANISOTROPY);
    return present & slots;
}

// The unit tangent and bitangent of the point's tangent frame: TANGENT made orthogonal to the
// interpolated normal, B = w cross(N, T); false where the tangent is degenerate.
bool surface_tangent_frame(SurfacePoint sp, out vec3 t, out vec3 b) {
    vec3 n = sp.ns;
    t = sp.tangent.xyz - n * dot(n, sp.tangent.xyz);
    b = vec3(0.0);
    float t_len = length(t);
    if (!(t_len > 1e-12) || isinf(t_len)) return false;
    t /= t_len;
    b = cross(n, t) * (sp.tangent.w < 0.0 ? -1.0 : 1.0);
    return true;
}

// The interpolated normal perturbed by a tangent-space normal map's texel, XY scaled by `scale`
// (surface_mapped_normal): the base's and the clearcoat's maps.
vec3 surface_mapped_normal(vec4 texel, float scale, SurfacePoint sp) {
    vec3 n = sp.ns;
    vec3 t, b;
    if (!surface_tangent_frame(sp, t, b)) return n;
    float x = (2.0 * texel.x - 1.0) * scale;
    float y = (2.0 * texel.y - 1.0) * scale;
    float z = 2.0 * texel.z - 1.0;
    vec3 mapped = t * x + b * y + n * z;
    float len = length(mapped);
    return (len > 1e-12 && !isinf(len)) ? mapped / len : n;
}

// KHR_materials_anisotropy at the point (surface.rs, surface_anisotropy): the strength and the
// world direction of alpha_t, T d.x + B d.y with d the texture's RG in [-1, 1]^2 (else (1, 0))
// rotated by anisotropyRotation; strength 0 where the tangent frame is degenerate. `texel` is
// the anisotropy texture's where `textured`.
float surface_anisotropy(GpuMaterial m, SurfacePoint sp, bool textured, vec4 texel, out vec3 direction) {
    vec3 t, b;
    direction = vec3(0.0);
    if (!surface_tangent_frame(sp, t, b)) return 0.0;
    vec2 d = vec2(1.0, 0.0);
    float strength = m.anisotropy;
    if (textured) {
        d = 2.0 * texel.xy - vec2(1.0);
        strength *= texel.z;
    }
    float s = sin(m.anisotropy_rotation);
    float c = cos(m.anisotropy_rotation);
    d = vec2(c * d.x - s * d.y, s * d.x + c * d.y);
    direction = t * d.x + b * d.y;
    return strength;
}

// Reads the textures of m in the slots `present` names (material_texture_slots) at the point and
// applies each to o (its base colour and alpha to `base`; the coat's normal map only under a
// coat), keeping the anisotropy's and the normal map's texels for the caller. One rolled loop
// over the slots, so that a kernel holds one copy of the texture lookup where a lookup per slot
// (as src/surface.rs writes them) made llvmpipe compile seventeen: compiling `shade` for a
// textured scene took lavapipe 17 s (DamagedHelmet) to 58 s (a scene whose texels span several
// bindings), which every render of such a scene paid until Mesa's shader cache held it.
void surface_textures(GpuMaterial m, SurfacePoint sp, vec2 lod, uint present, inout GpuMaterial o,
                      inout vec4 base, out vec4 anisotropy, out vec4 normal) {
    anisotropy = vec4(0.0);
    normal = vec4(0.0);
    if (present != 0u) do {
        uint s = uint(findLSB(present));
        present &= present - 1u;
        if (s != TEXTURE_SLOT_CLEARCOAT_NORMAL || o.clearcoat > 0.0) {
            vec4 v = sample_texture_ref(material_texture(m, s), sp.uv0, sp.uv1, lod);
            if (s == TEXTURE_SLOT_EMISSIVE) o.emission = o.emission * v.xyz;
            else if (s == TEXTURE_SLOT_CLEARCOAT) o.clearcoat *= v.x;
            else if (s == TEXTURE_SLOT_BASE_COLOR) base *= v;
            else if (s == TEXTURE_SLOT_METALLIC_ROUGHNESS) {
                o.metallic *= v.z;
                o.roughness *= v.y;
            }
            else if (s == TEXTURE_SLOT_TRANSMISSION) o.transmission *= v.x;
            else if (s == TEXTURE_SLOT_SPECULAR) o.specular *= v.w;
            else if (s == TEXTURE_SLOT_SPECULAR_COLOR) o.specular_color = m.specular_color * v.xyz;
            else if (s == TEXTURE_SLOT_CLEARCOAT_ROUGHNESS) o.clearcoat_roughness *= v.y;
            else if (s == TEXTURE_SLOT_SHEEN_COLOR) o.sheen_color = m.sheen_color * v.xyz;
            else if (s == TEXTURE_SLOT_SHEEN_ROUGHNESS) o.sheen_roughness *= v.w;
            else if (s == TEXTURE_SLOT_IRIDESCENCE) o.iridescence *= v.x;
            else if (s == TEXTURE_SLOT_IRIDESCENCE_THICKNESS) {
                o.iridescence_thickness = mix(m.iridescence_thickness_min, m.iridescence_thickness, v.y);
            }
            else if (s == TEXTURE_SLOT_DIFFUSE_TRANSMISSION) o.diffuse_transmission *= v.w;
            else if (s == TEXTURE_SLOT_DIFFUSE_TRANSMISSION_COLOR) {
                o.diffuse_transmission_color = m.diffuse_transmission_color * v.xyz;
            }
            else if (s == TEXTURE_SLOT_CLEARCOAT_NORMAL) {
                o.clearcoat_normal = surface_mapped_normal(v, m.clearcoat_normal_scale, sp);
            }
            else if (s == TEXTURE_SLOT_ANISOTROPY) anisotropy = v;
            else normal = v;
        }
    } while (present != 0u);
}

// The emitted radiance factor before textures: emissive factor, x the vertex colour for an
// unlit material (src/surface.rs, surface_emission, whose emissive texture surface_textures
// applies).
vec3 surface_emission_factor(GpuMaterial m, SurfacePoint sp) {
    vec3 e = m.emission;
    if ((m.flags & MATERIAL_UNLIT) != 0u) e *= sp.color.xyz;
    return e;
}

// Whether surface_emitter reads the point: an emissive or clearcoat texture, or an unlit
// material's vertex colour; else the emitter is the material's own factors (src/surface.rs).
bool emitter_reads_surface(GpuMaterial m) {
    return HAS_TEXTURE(m.emissive_texture) || HAS_TEXTURE(m.clearcoat_texture)
        || (m.flags & MATERIAL_UNLIT) != 0u;
}

// An emitter's material at a point as emitted_radiance reads it: the emission and the coat's
// clearcoat x R of its texture (src/surface.rs, surface_emitter).
GpuMaterial surface_emitter(GpuMaterial m, SurfacePoint sp, vec2 lod) {
    GpuMaterial o = m;
    o.emission = surface_emission_factor(m, sp);
    vec4 base = vec4(0.0);
    vec4 anisotropy, normal;
    surface_textures(m, sp, lod, material_texture_slots(m, TEXTURE_SLOTS_EMITTER), o, base, anisotropy, normal);
    return o;
}

// Material m at the surface point (factors times textures times vertex colour) and, where `slots`
// holds the normal map's, its shading normal: the interpolated normal with the normal map applied
// (unit, not flipped; else the interpolated normal). src/surface.rs's surface_material and
// surface_normal, their textures read by one loop (surface_textures).
GpuMaterial surface_material_slots(GpuMaterial m, SurfacePoint sp, vec2 lod, uint slots, out vec3 ns) {
    GpuMaterial o = m;
    o.emission = surface_emission_factor(m, sp);
    vec4 base = vec4(m.base_color, m.alpha) * sp.color;
    vec4 anisotropy, normal;
    surface_textures(m, sp, lod, material_texture_slots(m, slots), o, base, anisotropy, normal);
    o.base_color = base.xyz;
    o.alpha = base.w;
    // The coat's normal: its own map (applied above), else the interpolated normal (0: the
    // base's shading normal).
    if (o.clearcoat > 0.0 && !HAS_TEXTURE(m.clearcoat_normal_texture) && HAS_TEXTURE(m.normal_texture)) {
        o.clearcoat_normal = sp.ns;
    }
    if (m.anisotropy > 0.0) {
        o.anisotropy = surface_anisotropy(m, sp, HAS_TEXTURE(m.anisotropy_texture), anisotropy, o.anisotropy_direction);
    }
    ns = HAS_TEXTURE(m.normal_texture) ? surface_mapped_normal(normal, m.normal_scale, sp) : sp.ns;
    return o;
}

GpuMaterial surface_material_normal(GpuMaterial m, SurfacePoint sp, vec2 lod, out vec3 ns) {
    return surface_material_slots(m, sp, lod, TEXTURE_SLOTS_ALL, ns);
}

// Material m at the surface point, without the normal map (src/surface.rs, surface_material).
GpuMaterial surface_material(GpuMaterial m, SurfacePoint sp, vec2 lod) {
    vec3 ns;
    return surface_material_slots(m, sp, lod, TEXTURE_SLOTS_MATERIAL, ns);
}

float alpha_random(uvec4 key, uint triangle) {
    uvec4 h = pcg4d(uvec4(key.x, key.y, key.z, key.w ^ (triangle * 0x9e3779b9u)));
    return uint_to_unit_float(h.x);
}

uvec4 alpha_key(uint seed, uint pixel, uint sample_index, uint depth, bool shadow) {
    return uvec4(pixel, sample_index, 0x40000000u | (2u * depth + (shadow ? 1u : 0u)), seed);
}

bool alpha_present(uint flags, float alpha, float cutoff, float u) {
    if ((flags & MATERIAL_ALPHA_MASK) != 0u) return alpha >= cutoff;
    if ((flags & MATERIAL_ALPHA_BLEND) != 0u) return u < alpha;
    return true;
}

// Back-face culling is what the camera sees: single-sided triangles are absent only for
// primary camera rays meeting their back face and for joins of light vertices to the camera
// traced from the light vertex (alpha-key bit ALPHA_KEY_TOWARDS_EYE); every other ray meets both
// faces (surface.rs, culled).
#define ALPHA_KEY_PRIMARY_Z 0x40000000u
#define ALPHA_KEY_TOWARDS_EYE 0x80000000u
uvec4 towards_eye(uvec4 key) { return uvec4(key.x, key.y, key.z | ALPHA_KEY_TOWARDS_EYE, key.w); }
// The normal e1 × e2 is formed only for the rays that cull.
bool culled(uvec4 key, vec3 dir, vec3 e1, vec3 e2) {
    if ((key.z & ALPHA_KEY_TOWARDS_EYE) != 0u) return dot(dir, cross(e1, e2)) < 0.0;
    return key.z == ALPHA_KEY_PRIMARY_Z && dot(dir, cross(e1, e2)) > 0.0;
}

// Emitting triangle `index`'s (record `tri`) material at barycentrics b, textures at level 0, as
// emitted_radiance reads it: surface_emitter at the point, whose attributes are interpolated
// only where emitter_reads_surface says the emitter reads them (src/render/prepared.rs, emitter_at).
GpuMaterial emitter_at(GpuTriangle tri, uint index, vec2 b) {
    GpuMaterial m = material_at(triangle_material(tri));
    if (!emitter_reads_surface(m)) return m;
    return surface_emitter(m, surface_point(tri, triangle_vertices_at(index), b.x, b.y), LOD_MAGNIFY);
}

// The any-hit test of both traversals: whether triangle `index` (its record `tri`, which the
// caller has read) exists at (u, v) for the ray of direction dir (triangle space): not where a
// TRIANGLE_TEST_CULL triangle is culled, alpha-tested ones by their alpha.
bool triangle_present(GpuTriangle tri, uint index, float u, float v, uvec4 key, vec3 dir) {
    if ((tri.material & (TRIANGLE_TEST_ALPHA | TRIANGLE_TEST_CULL)) == 0u) return true;
    if ((tri.material & TRIANGLE_TEST_CULL) != 0u && culled(key, dir, tri.e1, tri.e2)) return false;
    if (!SCENE_HAS(FEATURE_ALPHA) || (tri.material & TRIANGLE_TEST_ALPHA) == 0u) return true;
    uvec4 tv = triangle_vertices_at(index);
    GpuMaterial m = material_at(triangle_material(tri));
    SurfacePoint sp = surface_point(tri, tv, u, v);
    float alpha = m.alpha * sp.color.w;
    if (HAS_TEXTURE(m.base_color_texture)) alpha *= sample_texture_ref(m.base_color_texture, sp.uv0, sp.uv1, LOD_MAGNIFY).w;
    return alpha_present(m.flags, alpha, m.alpha_cutoff, alpha_random(key, index));
}

// triangle_present for a triangle whose record the caller has not read.
bool triangle_present(uint index, float u, float v, uvec4 key, vec3 dir) {
    return triangle_present(triangle_at(index), index, u, v, key, dir);
}

#endif
