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

// The world-space surface of `hit` and its triangle `tri` (src/render.rs,
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
vec2 surface_lod_base(SurfacePoint sp, float cone_width, float cos_view) {
    float footprint = log2(max(cone_width / max(abs(cos_view), 1e-6), 1e-30));
    vec2 density = 0.5 * log2(max(sp.uv_area, vec2(1e-30)) / max(sp.world_area, 1e-30));
    return vec2(footprint) + density;
}

#define LOD_MAGNIFY vec2(-1e30)

// The emitted radiance factor at the point: emissive factor × texture, × the vertex colour for
// an unlit material (src/surface.rs).
vec3 surface_emission(GpuMaterial m, SurfacePoint sp, vec2 lod) {
    vec3 e = m.emission;
    if ((m.flags & MATERIAL_UNLIT) != 0u) e *= sp.color.xyz;
    if (!HAS_TEXTURE(m.emissive_texture)) return e;
    return e * sample_texture_ref(m.emissive_texture, sp.uv0, sp.uv1, lod).xyz;
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
    o.emission = surface_emission(m, sp, lod);
    if (HAS_TEXTURE(m.clearcoat_texture)) {
        o.clearcoat *= sample_texture_ref(m.clearcoat_texture, sp.uv0, sp.uv1, lod).x;
    }
    return o;
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

// KHR_materials_anisotropy at the point (surface.rs, surface_anisotropy): the strength and the
// world direction of alpha_t, T d.x + B d.y with d the texture's RG in [-1, 1]^2 (else (1, 0))
// rotated by anisotropyRotation; strength 0 where the tangent frame is degenerate.
float surface_anisotropy(GpuMaterial m, SurfacePoint sp, vec2 lod, out vec3 direction) {
    vec3 t, b;
    direction = vec3(0.0);
    if (!surface_tangent_frame(sp, t, b)) return 0.0;
    vec2 d = vec2(1.0, 0.0);
    float strength = m.anisotropy;
    if (HAS_TEXTURE(m.anisotropy_texture)) {
        vec4 texel = sample_texture_ref(m.anisotropy_texture, sp.uv0, sp.uv1, lod);
        d = 2.0 * texel.xy - vec2(1.0);
        strength *= texel.z;
    }
    float s = sin(m.anisotropy_rotation);
    float c = cos(m.anisotropy_rotation);
    d = vec2(c * d.x - s * d.y, s * d.x + c * d.y);
    direction = t * d.x + b * d.y;
    return strength;
}

// The interpolated normal perturbed by tangent-space normal map `tex` (or NO_TEXTURE), XY scaled
// by `scale` (surface_mapped_normal): the base's and the clearcoat's maps.
vec3 surface_mapped_normal(uint tex, float scale, SurfacePoint sp, vec2 lod) {
    if (!HAS_TEXTURE(tex)) return sp.ns;
    vec3 n = sp.ns;
    vec3 t, b;
    if (!surface_tangent_frame(sp, t, b)) return n;
    vec4 texel = sample_texture_ref(tex, sp.uv0, sp.uv1, lod);
    float x = (2.0 * texel.x - 1.0) * scale;
    float y = (2.0 * texel.y - 1.0) * scale;
    float z = 2.0 * texel.z - 1.0;
    vec3 mapped = t * x + b * y + n * z;
    float len = length(mapped);
    return (len > 1e-12 && !isinf(len)) ? mapped / len : n;
}

// The shading normal with the normal map applied (unit, not flipped).
vec3 surface_normal(GpuMaterial m, SurfacePoint sp, vec2 lod) {
    return surface_mapped_normal(m.normal_texture, m.normal_scale, sp, lod);
}

// Material m at the surface point: factors times textures times vertex colour.

GpuMaterial surface_material(GpuMaterial m, SurfacePoint sp, vec2 lod) {
    // The emission and the coat's factor, as emitters read them.
    GpuMaterial o = surface_emitter(m, sp, lod);
    vec4 base = vec4(m.base_color, m.alpha) * sp.color;
    if (HAS_TEXTURE(m.base_color_texture)) base *= sample_texture_ref(m.base_color_texture, sp.uv0, sp.uv1, lod);
    o.base_color = base.xyz;
    o.alpha = base.w;
    if (HAS_TEXTURE(m.metallic_roughness_texture)) {
        vec4 mr = sample_texture_ref(m.metallic_roughness_texture, sp.uv0, sp.uv1, lod);
        o.metallic *= mr.z;
        o.roughness *= mr.y;
    }
    if (HAS_TEXTURE(m.transmission_texture)) {
        o.transmission *= sample_texture_ref(m.transmission_texture, sp.uv0, sp.uv1, lod).x;
    }
    if (HAS_TEXTURE(m.specular_texture)) {
        o.specular *= sample_texture_ref(m.specular_texture, sp.uv0, sp.uv1, lod).w;
    }
    if (HAS_TEXTURE(m.specular_color_texture)) {
        o.specular_color = m.specular_color * sample_texture_ref(m.specular_color_texture, sp.uv0, sp.uv1, lod).xyz;
    }
    if (HAS_TEXTURE(m.clearcoat_roughness_texture)) {
        o.clearcoat_roughness *= sample_texture_ref(m.clearcoat_roughness_texture, sp.uv0, sp.uv1, lod).y;
    }
    if (HAS_TEXTURE(m.sheen_color_texture)) {
        o.sheen_color = m.sheen_color * sample_texture_ref(m.sheen_color_texture, sp.uv0, sp.uv1, lod).xyz;
    }
    if (HAS_TEXTURE(m.sheen_roughness_texture)) {
        o.sheen_roughness *= sample_texture_ref(m.sheen_roughness_texture, sp.uv0, sp.uv1, lod).w;
    }
    // The coat's normal: its own map, else the interpolated normal (0: the base's shading normal).
    if (o.clearcoat > 0.0 && (HAS_TEXTURE(m.clearcoat_normal_texture) || HAS_TEXTURE(m.normal_texture))) {
        o.clearcoat_normal = surface_mapped_normal(m.clearcoat_normal_texture, m.clearcoat_normal_scale, sp, lod);
    }
    if (HAS_TEXTURE(m.iridescence_texture)) {
        o.iridescence *= sample_texture_ref(m.iridescence_texture, sp.uv0, sp.uv1, lod).x;
    }
    if (HAS_TEXTURE(m.iridescence_thickness_texture)) {
        float g = sample_texture_ref(m.iridescence_thickness_texture, sp.uv0, sp.uv1, lod).y;
        o.iridescence_thickness = mix(m.iridescence_thickness_min, m.iridescence_thickness, g);
    }
    if (HAS_TEXTURE(m.diffuse_transmission_texture)) {
        o.diffuse_transmission *= sample_texture_ref(m.diffuse_transmission_texture, sp.uv0, sp.uv1, lod).w;
    }
    if (HAS_TEXTURE(m.diffuse_transmission_color_texture)) {
        o.diffuse_transmission_color = m.diffuse_transmission_color * sample_texture_ref(m.diffuse_transmission_color_texture, sp.uv0, sp.uv1, lod).xyz;
    }
    if (m.anisotropy > 0.0) o.anisotropy = surface_anisotropy(m, sp, lod, o.anisotropy_direction);
    return o;
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
// only where emitter_reads_surface says the emitter reads them (src/render.rs, emitter_at).
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
