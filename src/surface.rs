//! What a hit point looks like: interpolated vertex attributes, the material with its textures
//! applied, the shading normal (normal maps) and alpha coverage. Twin of
//! `shaders/inc/surface.glsl`, same names.
//!
//! - Attributes are interpolated with the hit's barycentrics (u weights p1, v weights p2).
//! - Textures modulate the factors as glTF says: base colour × texture (sRGB) × COLOR_0,
//!   metallic × B and roughness × G of the metallic-roughness texture, emission × emissive
//!   texture (sRGB), transmission × R, KHR_materials_specular's specular × A of its
//!   specularTexture and specularColor × RGB of its specularColorTexture (sRGB). An unlit
//!   material (KHR_materials_unlit) emits base colour × texture × COLOR_0: the loader puts the
//!   base colour's factor and texture in the emission slots, and `surface_emission` multiplies
//!   in the vertex colour. KHR_materials_clearcoat: clearcoat × R, clearcoatRoughness × G of
//!   their textures, and the coat's own normal (`GpuMaterial::clearcoat_normal`);
//!   KHR_materials_sheen: sheenColor × RGB (sRGB), sheenRoughness × A;
//!   KHR_materials_anisotropy: strength × B, the direction from RG and the rotation in the
//!   tangent frame (`surface_anisotropy`); KHR_materials_iridescence: iridescence × R, the
//!   film's thickness mix(minimum, maximum, G) (the maximum without a texture);
//!   KHR_materials_diffuse_transmission: its factor × A, its colour × RGB (sRGB). Occlusion maps are ignored: a path tracer computes the
//!   occlusion they approximate.
//! - Normal maps are tangent-space (glTF: B = w·cross(N, T)), their XY scaled by `scale`.
//! - The level of detail is the ray cone's (`texture.rs`): `surface_lod_base`.
//! - Alpha: MASK keeps the surface where alpha ≥ alphaCutoff; BLEND keeps it with probability
//!   alpha (stochastic transparency, Enderton et al. 2010), decided by a hash of the ray and
//!   the triangle so that every traversal of one ray sees the same surfaces. The expected
//!   image is the alpha-blended one, and both closest-hit and shadow rays obey it.

use crate::layout::{
    GpuInstance, GpuMaterial, GpuTriangle, GpuVertex, INSTANCE_IDENTITY, INSTANCE_MIRRORED,
    MATERIAL_ALPHA_BLEND, MATERIAL_ALPHA_MASK, MATERIAL_TEXTURED, MATERIAL_UNLIT, NO_TEXTURE,
    TRIANGLE_FLAT, TRIANGLE_PLAIN, TRIANGLE_TEST_ALPHA, TRIANGLE_TEST_CULL,
};
use crate::sampling::{pcg4d, uint_to_unit_float};
use crate::texture::{sample_texture_ref, TextureData};
use crate::tlas::{transform_normal, transform_point, transform_vector};
use glam::{UVec4, Vec2, Vec3, Vec4};

/// The attributes of one hit point.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Unit geometric normal of the front face.
    pub ng: Vec3,
    /// Unit interpolated vertex normal (`ng` on flat triangles), not flipped to any side.
    pub ns: Vec3,
    /// Interpolated TANGENT (xyz not normalised; w the bitangent sign).
    pub tangent: Vec4,
    pub uv: [Vec2; 2],
    pub color: Vec4,
    /// |Δuv₁ × Δuv₂| of the triangle for each texture coordinate set, and |e1 × e2| in world
    /// space: the areas of the level of detail (`surface_lod_base`).
    pub uv_area: [f32; 2],
    pub world_area: f32,
    /// `TRIANGLE_*` bits.
    pub flags: u32,
}

/// The hit point (u, v) of triangle `tri` whose vertex indices and flags are `tv`.
pub fn surface_point(
    tri: &GpuTriangle,
    tv: UVec4,
    vertices: &[GpuVertex],
    u: f32,
    v: f32,
) -> SurfacePoint {
    let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
    let p = Vec3::from(tri.p0) + u * e1 + v * e2;
    let cross = e1.cross(e2);
    let ng = cross.normalize();
    if tv.w & TRIANGLE_PLAIN != 0 {
        return SurfacePoint {
            p,
            ng,
            ns: ng,
            tangent: Vec4::new(0.0, 0.0, 0.0, 1.0),
            uv: [Vec2::ZERO; 2],
            color: Vec4::ONE,
            uv_area: [0.0; 2],
            world_area: cross.length(),
            flags: tv.w,
        };
    }
    let [a, b, c] = [tv.x, tv.y, tv.z].map(|i| vertices[i as usize]);
    let w = 1.0 - u - v;
    let mix4 = |x: [f32; 4], y: [f32; 4], z: [f32; 4]| {
        w * Vec4::from(x) + u * Vec4::from(y) + v * Vec4::from(z)
    };
    let uv = mix4(a.uv, b.uv, c.uv);
    let ns = if tv.w & TRIANGLE_FLAT != 0 {
        ng
    } else {
        let n = w * Vec3::from(a.normal) + u * Vec3::from(b.normal) + v * Vec3::from(c.normal);
        let length = n.length();
        if length > 0.0 && length.is_finite() {
            n / length
        } else {
            ng
        }
    };
    // Areas for the level of detail: |Δuv₁ × Δuv₂| against |e1 × e2|.
    let uv_area = |s: usize| {
        let (t0, t1, t2) = (
            Vec2::from_slice(&a.uv[2 * s..]),
            Vec2::from_slice(&b.uv[2 * s..]),
            Vec2::from_slice(&c.uv[2 * s..]),
        );
        (t1 - t0).perp_dot(t2 - t0).abs()
    };
    SurfacePoint {
        p,
        ng,
        ns,
        tangent: mix4(a.tangent, b.tangent, c.tangent),
        uv: [uv.truncate().truncate().into(), Vec2::new(uv.z, uv.w)],
        color: mix4(a.color, b.color, c.color),
        uv_area: [uv_area(0), uv_area(1)],
        world_area: cross.length(),
        flags: tv.w,
    }
}

/// A surface point of an instanced (object-space) triangle `tri` moved to world space by its
/// instance: position by the transform, normals by its inverse transpose, the tangent by its
/// linear part with the bitangent sign flipped by a mirroring transform, and the uv density
/// against the world-space area. The identity instance changes nothing.
pub fn surface_to_world(sp: &mut SurfacePoint, tri: &GpuTriangle, inst: &GpuInstance) {
    if inst.flags & INSTANCE_IDENTITY != 0 {
        return;
    }
    let (m, w) = (&inst.object_to_world, &inst.world_to_object);
    sp.p = transform_point(m, sp.p);
    let flat = sp.ns == sp.ng;
    sp.ng = transform_normal(w, sp.ng).normalize();
    sp.ns = if flat {
        sp.ng
    } else {
        transform_normal(w, sp.ns).normalize()
    };
    let t = transform_vector(m, sp.tangent.truncate());
    let sign = if inst.flags & INSTANCE_MIRRORED != 0 {
        -1.0
    } else {
        1.0
    };
    sp.tangent = t.extend(sp.tangent.w * sign);
    let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
    sp.world_area = transform_vector(m, e1)
        .cross(transform_vector(m, e2))
        .length();
}

/// How many mip levels finer than its pixel's footprint sample `sample` of a pixel reads: ½·k
/// with k the bit length of `sample` (0 for the first sample, 1 for the second, 2 for the
/// third and fourth, …). The first 2ᵏ samples of a pixel stratify it into 2ᵏ cells (the
/// samplers' (0, 2)-sequence property), so from sample 2ᵏ⁻¹ on each stands for a cell of side
/// 2^(−k/2) of the pixel, and its ray cone is that cell's: the box pixel filter then averages
/// the cells, and the texture is filtered once over the pixel rather than in the mip level and
/// again in the pixel filter (which stayed blurrier than the supersampled picture at any sample
/// count, issue 57). A function of the sample index alone, so passes, shards and resumed
/// renders read the same levels as one render of all their samples.
pub fn sample_footprint_levels(sample: u32) -> f32 {
    0.5 * (u32::BITS - sample.leading_zeros()) as f32
}

/// The texture-independent part of the level of detail for each coordinate set:
/// log2(W / |cos θ|) + ½·log2(uv area / world area), W the cone's width at the hit and θ the
/// angle between the ray and the geometric normal (Akenine-Möller et al. 2021, eq. 34).
pub fn surface_lod_base(sp: &SurfacePoint, cone_width: f32, cos_view: f32) -> [f32; 2] {
    let footprint = (cone_width / cos_view.abs().max(1e-6)).max(1e-30).log2();
    let density = |s: usize| 0.5 * (sp.uv_area[s].max(1e-30) / sp.world_area.max(1e-30)).log2();
    [footprint + density(0), footprint + density(1)]
}

/// A level of detail that always magnifies (alpha tests read level 0).
pub const LOD_MAGNIFY: [f32; 2] = [-1e30, -1e30];

/// The emitted radiance factor at the point: emissive factor × texture, × the vertex colour
/// for an unlit material (its emission is its base colour term).
pub fn surface_emission(
    data: &TextureData,
    m: &GpuMaterial,
    sp: &SurfacePoint,
    lod: [f32; 2],
) -> Vec3 {
    let mut e = Vec3::from(m.emission);
    if m.flags & MATERIAL_UNLIT != 0 {
        e *= sp.color.truncate();
    }
    if m.emissive_texture == NO_TEXTURE {
        return e;
    }
    e * sample_texture_ref(data, m.emissive_texture, sp.uv, lod).truncate()
}

/// Whether [`surface_emitter`] reads the surface point: an emissive or clearcoat texture, or an
/// unlit material's vertex colour. Where it does not, the emitter is the material's own factors
/// (`surface_emitter` returns them unchanged), and the point's attributes need not be
/// interpolated.
pub fn emitter_reads_surface(m: &GpuMaterial) -> bool {
    m.emissive_texture != NO_TEXTURE
        || m.clearcoat_texture != NO_TEXTURE
        || m.flags & MATERIAL_UNLIT != 0
}

/// An emitter's material at a point as [`crate::cpu::emitted_radiance`] reads it: the
/// emission ([`surface_emission`]) and KHR_materials_clearcoat's clearcoat × R of its texture
/// (the coat darkens the emission below it), the rest as the factors give it.
pub fn surface_emitter(
    data: &TextureData,
    m: &GpuMaterial,
    sp: &SurfacePoint,
    lod: [f32; 2],
) -> GpuMaterial {
    let mut out = *m;
    out.emission = surface_emission(data, m, sp, lod).to_array();
    if m.clearcoat_texture != NO_TEXTURE {
        out.clearcoat *= sample_texture_ref(data, m.clearcoat_texture, sp.uv, lod).x;
    }
    out
}

/// Whether [`surface_material`] returns `m` itself at `sp`: no texture (`MATERIAL_TEXTURED`), no
/// anisotropy (its direction follows the surface's tangent) and a white vertex colour, so every
/// factor is multiplied by nothing or by an exact 1. The CPU reference then reads the material
/// in place instead of copying it per vertex.
pub fn material_is_constant(m: &GpuMaterial, sp: &SurfacePoint) -> bool {
    m.flags & MATERIAL_TEXTURED == 0 && !(m.anisotropy > 0.0) && sp.color == Vec4::ONE
}

/// Material `m` at the surface point: factors times textures times vertex colour.
pub fn surface_material(
    data: &TextureData,
    m: &GpuMaterial,
    sp: &SurfacePoint,
    lod: [f32; 2],
) -> GpuMaterial {
    // The emission and the coat's factor, as emitters read them.
    let mut out = surface_emitter(data, m, sp, lod);
    let mut base = Vec4::from((Vec3::from(m.base_color), m.alpha)) * sp.color;
    if m.base_color_texture != NO_TEXTURE {
        base *= sample_texture_ref(data, m.base_color_texture, sp.uv, lod);
    }
    out.base_color = base.truncate().to_array();
    out.alpha = base.w;
    if m.metallic_roughness_texture != NO_TEXTURE {
        let mr = sample_texture_ref(data, m.metallic_roughness_texture, sp.uv, lod);
        out.metallic *= mr.z;
        out.roughness *= mr.y;
    }
    if m.transmission_texture != NO_TEXTURE {
        out.transmission *= sample_texture_ref(data, m.transmission_texture, sp.uv, lod).x;
    }
    if m.specular_texture != NO_TEXTURE {
        out.specular *= sample_texture_ref(data, m.specular_texture, sp.uv, lod).w;
    }
    if m.specular_color_texture != NO_TEXTURE {
        let c = sample_texture_ref(data, m.specular_color_texture, sp.uv, lod).truncate();
        out.specular_color = (Vec3::from(m.specular_color) * c).to_array();
    }
    if m.clearcoat_roughness_texture != NO_TEXTURE {
        out.clearcoat_roughness *=
            sample_texture_ref(data, m.clearcoat_roughness_texture, sp.uv, lod).y;
    }
    if m.sheen_color_texture != NO_TEXTURE {
        let c = sample_texture_ref(data, m.sheen_color_texture, sp.uv, lod).truncate();
        out.sheen_color = (Vec3::from(m.sheen_color) * c).to_array();
    }
    if m.sheen_roughness_texture != NO_TEXTURE {
        out.sheen_roughness *= sample_texture_ref(data, m.sheen_roughness_texture, sp.uv, lod).w;
    }
    // The coat's normal: its own map, else the interpolated normal even where the base is
    // normal-mapped (KHR_materials_clearcoat); zero leaves the base's shading normal.
    if out.clearcoat > 0.0
        && (m.clearcoat_normal_texture != NO_TEXTURE || m.normal_texture != NO_TEXTURE)
    {
        let scale = m.clearcoat_normal_scale;
        let nc = surface_mapped_normal(data, m.clearcoat_normal_texture, scale, sp, lod);
        out.clearcoat_normal = nc.to_array();
    }
    if m.iridescence_texture != NO_TEXTURE {
        out.iridescence *= sample_texture_ref(data, m.iridescence_texture, sp.uv, lod).x;
    }
    if m.iridescence_thickness_texture != NO_TEXTURE {
        let g = sample_texture_ref(data, m.iridescence_thickness_texture, sp.uv, lod).y;
        let (lo, hi) = (m.iridescence_thickness_min, m.iridescence_thickness);
        out.iridescence_thickness = lo + (hi - lo) * g;
    }
    if m.diffuse_transmission_texture != NO_TEXTURE {
        out.diffuse_transmission *=
            sample_texture_ref(data, m.diffuse_transmission_texture, sp.uv, lod).w;
    }
    if m.diffuse_transmission_color_texture != NO_TEXTURE {
        let c = sample_texture_ref(data, m.diffuse_transmission_color_texture, sp.uv, lod);
        out.diffuse_transmission_color =
            (Vec3::from(m.diffuse_transmission_color) * c.truncate()).to_array();
    }
    if m.anisotropy > 0.0 {
        let (strength, direction) = surface_anisotropy(data, m, sp, lod);
        out.anisotropy = strength;
        out.anisotropy_direction = direction.to_array();
    }
    out
}

/// The shading normal: the interpolated normal, perturbed by the normal map if there is one and
/// the tangent frame is not degenerate. Unit length, not flipped to any side.
pub fn surface_normal(
    data: &TextureData,
    m: &GpuMaterial,
    sp: &SurfacePoint,
    lod: [f32; 2],
) -> Vec3 {
    surface_mapped_normal(data, m.normal_texture, m.normal_scale, sp, lod)
}

/// The interpolated normal perturbed by tangent-space normal map `texture` (or `NO_TEXTURE`)
/// with XY scaled by `scale`: [`surface_normal`]'s rule, for the base's and the clearcoat's maps.
pub fn surface_mapped_normal(
    data: &TextureData,
    texture: u32,
    scale: f32,
    sp: &SurfacePoint,
    lod: [f32; 2],
) -> Vec3 {
    if texture == NO_TEXTURE {
        return sp.ns;
    }
    let n = sp.ns;
    let Some((t, b)) = surface_tangent_frame(sp) else {
        return n;
    };
    let texel = sample_texture_ref(data, texture, sp.uv, lod);
    let x = (2.0 * texel.x - 1.0) * scale;
    let y = (2.0 * texel.y - 1.0) * scale;
    let z = 2.0 * texel.z - 1.0;
    let mapped = t * x + b * y + n * z;
    let length = mapped.length();
    if length > 1e-12 && length.is_finite() {
        mapped / length
    } else {
        n
    }
}

/// The unit tangent and bitangent of the point's tangent frame: TANGENT made orthogonal to the
/// interpolated normal (Gram–Schmidt), B = w·cross(N, T) (glTF); None where the tangent is
/// degenerate (no TANGENT and no MikkTSpace tangents).
pub fn surface_tangent_frame(sp: &SurfacePoint) -> Option<(Vec3, Vec3)> {
    let n = sp.ns;
    let t = sp.tangent.truncate();
    let t = t - n * n.dot(t);
    let t_length = t.length();
    if !(t_length > 1e-12 && t_length.is_finite()) {
        return None;
    }
    let t = t / t_length;
    Some((t, n.cross(t) * if sp.tangent.w < 0.0 { -1.0 } else { 1.0 }))
}

/// KHR_materials_anisotropy at the point: the strength (anisotropyStrength × the texture's B)
/// and the world-space direction of α_t, T·d.x + B·d.y with d the texture's RG mapped to
/// [−1, 1]² (else (1, 0)) rotated by anisotropyRotation counter-clockwise (the extension's
/// "Implementation"); strength 0 where the tangent frame is degenerate.
pub fn surface_anisotropy(
    data: &TextureData,
    m: &GpuMaterial,
    sp: &SurfacePoint,
    lod: [f32; 2],
) -> (f32, Vec3) {
    let Some((t, b)) = surface_tangent_frame(sp) else {
        return (0.0, Vec3::ZERO);
    };
    let (mut d, mut strength) = (Vec2::X, m.anisotropy);
    if m.anisotropy_texture != NO_TEXTURE {
        let texel = sample_texture_ref(data, m.anisotropy_texture, sp.uv, lod);
        d = Vec2::new(2.0 * texel.x - 1.0, 2.0 * texel.y - 1.0);
        strength *= texel.z;
    }
    let (sin, cos) = m.anisotropy_rotation.sin_cos();
    let d = Vec2::new(cos * d.x - sin * d.y, sin * d.x + cos * d.y);
    (strength, t * d.x + b * d.y)
}

/// The uniform number that decides a BLEND surface's presence for one ray (`key`) and one
/// triangle.
pub fn alpha_random(key: UVec4, triangle: u32) -> f32 {
    let h = pcg4d(UVec4::new(
        key.x,
        key.y,
        key.z,
        key.w ^ triangle.wrapping_mul(0x9e37_79b9),
    ));
    uint_to_unit_float(h.x)
}

/// The key of [`alpha_random`] for the ray of bounce `depth` of a path (`shadow`: its shadow
/// ray).
pub fn alpha_key(seed: u32, pixel: u32, sample: u32, depth: u32, shadow: bool) -> UVec4 {
    UVec4::new(
        pixel,
        sample,
        0x4000_0000 | (2 * depth + shadow as u32),
        seed,
    )
}

/// glTF's back-face culling (`doubleSided` false) is a rule of what the camera sees: a
/// single-sided triangle is absent only for primary camera rays that meet its back face (and
/// for the joins of light vertices to the camera, which are those rays traced from the other
/// end). Every other ray — bounces, shadow rays, light subpaths, BDPT's connections — meets
/// both faces, so transport is reciprocal and light and camera paths see one scene. The `z` of
/// a primary ray's alpha key: `alpha_key(…, 0, false)`.
pub const ALPHA_KEY_PRIMARY_Z: u32 = 0x4000_0000;

/// Alpha-key bit (in `z`, which `alpha_key` never sets this high): a join of a light vertex to
/// the camera, traced from the light vertex, so culled as the primary ray from the camera would
/// be: a single-sided triangle is absent where its front faces this ray.
pub const ALPHA_KEY_TOWARDS_EYE: u32 = 1 << 31;

/// `key` for a join to the camera traced from its far end ([`ALPHA_KEY_TOWARDS_EYE`]).
pub fn towards_eye(key: UVec4) -> UVec4 {
    UVec4::new(key.x, key.y, key.z | ALPHA_KEY_TOWARDS_EYE, key.w)
}

/// Whether a single-sided triangle with edges `e1`, `e2` (front-face normal e1 × e2) is absent
/// for a ray of direction `dir` with alpha key `key` (module rule above: primary rays and joins
/// to the camera only). The normal is formed only for those rays, which every other ray of a
/// path skips (Cornell box: 12 178 → 12 098 CPU instructions per sample).
pub fn culled(key: UVec4, dir: Vec3, e1: Vec3, e2: Vec3) -> bool {
    if key.z & ALPHA_KEY_TOWARDS_EYE != 0 {
        dir.dot(e1.cross(e2)) < 0.0
    } else {
        key.z == ALPHA_KEY_PRIMARY_Z && dir.dot(e1.cross(e2)) > 0.0
    }
}

/// Whether a surface of evaluated alpha `alpha` exists for the ray: MASK by the cutoff, BLEND
/// with probability alpha, OPAQUE always.
pub fn alpha_present(flags: u32, alpha: f32, cutoff: f32, u: f32) -> bool {
    if flags & MATERIAL_ALPHA_MASK != 0 {
        alpha >= cutoff
    } else if flags & MATERIAL_ALPHA_BLEND != 0 {
        u < alpha
    } else {
        true
    }
}

/// Whether triangle `index`'s surface exists at (u, v) for the ray with direction `dir` (in the
/// triangle's space) and alpha key `key`: the any-hit test of both traversals. A
/// TRIANGLE_TEST_CULL triangle does not exist where [`culled`] says; TRIANGLE_TEST_ALPHA
/// triangles exist by their alpha; all others always exist.
///
/// Inlined into both walks up to the alpha test, which stays out of line: every candidate hit of
/// an opaque scene takes this test, and as a call it cost about 60 instructions per candidate
/// (callgrind, Cornell box: its single-sided walls take the cull test).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn triangle_present(
    data: &TextureData,
    triangles: &[GpuTriangle],
    triangle_vertices: &[UVec4],
    vertices: &[GpuVertex],
    materials: &[GpuMaterial],
    index: u32,
    u: f32,
    v: f32,
    key: UVec4,
    dir: Vec3,
) -> bool {
    let tri = &triangles[index as usize];
    if tri.material & (TRIANGLE_TEST_ALPHA | TRIANGLE_TEST_CULL) == 0 {
        return true;
    }
    if tri.material & TRIANGLE_TEST_CULL != 0
        && culled(key, dir, Vec3::from(tri.e1), Vec3::from(tri.e2))
    {
        return false;
    }
    if tri.material & TRIANGLE_TEST_ALPHA == 0 {
        return true;
    }
    alpha_present_at(
        data,
        tri,
        triangle_vertices,
        vertices,
        materials,
        index,
        u,
        v,
        key,
    )
}

/// [`triangle_present`]'s alpha test of a TRIANGLE_TEST_ALPHA triangle.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn alpha_present_at(
    data: &TextureData,
    tri: &GpuTriangle,
    triangle_vertices: &[UVec4],
    vertices: &[GpuVertex],
    materials: &[GpuMaterial],
    index: u32,
    u: f32,
    v: f32,
    key: UVec4,
) -> bool {
    let tv = triangle_vertices[index as usize];
    let m = &materials[tri.material_index() as usize];
    let sp = surface_point(tri, tv, vertices, u, v);
    let mut alpha = m.alpha * sp.color.w;
    if m.base_color_texture != NO_TEXTURE {
        alpha *= sample_texture_ref(data, m.base_color_texture, sp.uv, LOD_MAGNIFY).w;
    }
    alpha_present(m.flags, alpha, m.alpha_cutoff, alpha_random(key, index))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng_uniform4;

    /// Where `material_is_constant` holds, `surface_material` returns the material's own bytes
    /// (random factors, unlit or not, coats, vertex colour white), so the CPU reference may read
    /// it in place; a vertex colour other than white, anisotropy or a texture makes it false.
    #[test]
    fn constant_materials_are_their_own_surface_material() {
        let data = TextureData {
            textures: &[],
            refs: &[],
            texels: &[],
        };
        let mut constant = 0;
        for i in 0..2000u32 {
            let r = rng_uniform4(17, i, 0, 0);
            let q = rng_uniform4(17, i, 1, 0);
            let m = GpuMaterial {
                base_color: [r.x, r.y, r.z],
                alpha: r.w,
                emission: [q.x * 4.0, q.y, -0.0],
                metallic: q.z,
                roughness: q.w,
                clearcoat: if i % 3 == 0 { r.x } else { 0.0 },
                anisotropy: if i % 5 == 0 { q.x } else { 0.0 },
                flags: if i % 4 == 1 { MATERIAL_UNLIT } else { 0 },
                ..Default::default()
            };
            let color = if i % 7 == 0 {
                Vec4::new(r.y, 1.0, 1.0, 1.0)
            } else {
                Vec4::ONE
            };
            let sp = SurfacePoint {
                p: Vec3::ZERO,
                ng: Vec3::Z,
                ns: Vec3::Z,
                tangent: Vec4::new(1.0, 0.0, 0.0, 1.0),
                uv: [Vec2::new(q.x, q.y); 2],
                color,
                uv_area: [1.0; 2],
                world_area: 1.0,
                flags: 0,
            };
            let is_constant = material_is_constant(&m, &sp);
            assert_eq!(
                is_constant,
                !(m.anisotropy > 0.0) && color == Vec4::ONE,
                "case {i}"
            );
            if is_constant {
                constant += 1;
                let out = surface_material(&data, &m, &sp, LOD_MAGNIFY);
                assert_eq!(
                    bytemuck::bytes_of(&out),
                    bytemuck::bytes_of(&m),
                    "case {i}: {m:?}"
                );
            }
        }
        assert!(constant > 1200, "{constant}");
        let textured = GpuMaterial {
            flags: MATERIAL_TEXTURED,
            ..Default::default()
        };
        let sp = surface_point(
            &GpuTriangle::default(),
            UVec4::new(0, 0, 0, TRIANGLE_PLAIN),
            &[],
            0.2,
            0.3,
        );
        assert!(!material_is_constant(&textured, &sp));
        assert!(material_is_constant(&GpuMaterial::default(), &sp));
    }
}
