//! The glTF 2.0 metallic-roughness BSDF (specification, Appendix B) with KHR_materials_ior,
//! KHR_materials_transmission, KHR_materials_specular and KHR_materials_unlit: evaluation,
//! sampling and pdf. Twin of `shaders/inc/bsdf.glsl`, same names.
//!
//! Direction convention (here and in the GLSL twin, never swapped): `wo` points from the surface
//! towards where the light goes (the previous vertex, e.g. the camera), `wi` from the surface
//! towards where it comes from (the next vertex, e.g. a light); both are unit vectors pointing
//! away from the surface. `ng` is the geometric normal of the front face (counter-clockwise
//! winding), not flipped: the BSDF shades both faces, and for transmission the front face is the
//! outside (air, η = 1) and the back face the inside (η = ior). `bsdf_eval` returns f without the
//! cosine. `mode` says which quantity the path carries: radiance (paths from the camera) or
//! importance (paths from a light); the two differ only by the η² of refraction (Veach 1997,
//! §5.2): with radiance, f_t carries 1/η² where η = η_wi / η_wo.
//!
//! The model, with c = baseColor, F_d the dielectric Fresnel and F_m the metal one (both on v·h):
//!   f = (1 − metallic) · [(1 − max(F_d)) · ((1 − transmission) · c/π + transmission · c · btdf)
//!                         + F_d · D·V]
//!     + metallic · F_m · D·V
//! exactly `mix(dielectric_brdf, metal_brdf, metallic)` with `fresnel_mix` of Appendix B as
//! KHR_materials_specular redefines it: F_d is RGB, F0 = min(((ior − 1)/(ior + 1))² ·
//! specularColor, 1) · specular, F90 = specular, and the layers below the specular one are
//! scaled by 1 − max(F_d) (the extension's "Implementation" section; with the default
//! specularColor 1 the three channels are equal and this is the core model). The
//! transmission lobe is a rough dielectric (Walter et al. 2007, eq. 21) refracting by `ior`,
//! tinted by c as KHR_materials_transmission says. No energy compensation: at grazing angles
//! the spec's dielectric mix (1 − F)·diffuse + F·specular reflects a little more than it
//! receives where the GGX lobe is rough (see `tests::dielectric_mix_gains_energy_at_grazing`).
//!
//! Lobes are sampled one at a time, chosen with probabilities proportional to an estimate of each
//! lobe's albedo; `bsdf_pdf` is the mixture pdf of the non-delta lobes, which is what MIS needs.
//! With α < [`microfacet::ALPHA_DELTA`] the specular lobes are Dirac deltas: `bsdf_eval` and
//! `bsdf_pdf` leave them out (they are zero almost everywhere), and `bsdf_sample` returns them
//! flagged `delta` with the ratio f·|cos|/pdf as `weight`.
//!
//! KHR_materials_clearcoat layers a GGX reflection over all of that exactly as the extension's
//! `fresnel_coat` writes it:
//!   f_coated = (1 − clearcoat · F_c(|V·N_c|)) · f + clearcoat · F_c(|V·N_c|) · D_c·V_c
//! with F_c Schlick's Fresnel of ior 1.5 (F0 = 0.04) on the *view* direction V and the coat's
//! normal N_c (its own normal map, else the interpolated normal even where the base is
//! normal-mapped), D_c·V_c the GGX lobe of α = clearcoatRoughness² about N_c (a delta mirror
//! below [`microfacet::ALPHA_DELTA`]), whose cosine is |L·N_c|: as f is multiplied by the
//! cosine to the base's shading normal, the coat's term carries |L·N_c|/|L·N| (1 where the two
//! normals agree). F_c on V makes the coated BSDF non-reciprocal; V is `wo` for radiance and
//! `wi` for importance, so the importance BSDF is the radiance one transposed, as BDPT needs.
//! The spec's darkening of the emission under the coat, emission · (1 − clearcoat · F_c), is
//! `cpu::path::coat_emission_weight` (F_c there on the angle to the geometric normal).
//!
//! KHR_materials_sheen layers the Charlie microfiber lobe (`sheen`) over the base with the
//! extension's albedo scaling, below the coat:
//!   f_sheen = sheenColor · D_s·ν_s + f · min(1 − max(sheenColor)·E(|V·N|), 1 − max(sheenColor)·E(|L·N|))
//! (symmetric in V and L, so reciprocal), E tabulated by quadrature; the lobe is sampled
//! uniformly over the hemisphere.
//!
//! KHR_materials_anisotropy: the base's GGX lobes (metal and dielectric reflection,
//! transmission) take α_t = mix(α, 1, strength²) along the anisotropy direction and α_b = α
//! across it (the extension's "Implementation"; [`anisotropic_alpha`]), with the anisotropic D,
//! Smith Λ and height-correlated visibility and the anisotropic visible-normal sampling of
//! Heitz 2018 (`microfacet`). The frame's tangent is the direction
//! (`GpuMaterial::anisotropy_direction`, from the mesh's tangents) made orthogonal to the
//! shading normal; the other lobes are isotropic and do not see it.
//!
//! KHR_materials_iridescence replaces the dielectric and the metal Fresnel by their mix with a
//! thin film's (`iridescence`, Belcour & Barla 2017 as the extension writes it), on v·h like
//! the core model's Fresnel ([`fresnel_layers`]); the layers below the dielectric specular are
//! scaled by 1 − max(F) of the mixed F as KHR_materials_specular says.
//!
//! KHR_materials_diffuse_transmission splits the diffuse lobe as the extension's
//! `mix(diffuse_brdf, diffuse_btdf, diffuseTransmission)` does: (1 − dt)·c/π on `wo`'s side
//! and dt·dtColor/π on the far side (a thin surface: no refraction, no η), both under
//! 1 − max(F) of the specular layer, the far side's F taken on the half vector of `wo` and `wi`
//! mirrored to `wo`'s side (as the Khronos sample renderer does), which keeps f symmetric.
//!
//! KHR_materials_unlit: the surface shows its base colour term whatever the lighting. A path
//! tracer gives it that look by making the surface an emitter of exactly that radiance
//! (`surface::surface_emission`) whose BSDF is zero: seen directly it is its base colour, it
//! reflects and transmits nothing, and like every emitter it lights the scene (a rasteriser's
//! unlit surface lights nothing only because rasterisers have no indirect light).

pub mod iridescence;
pub mod microfacet;
pub mod sheen;
pub(crate) mod sheen_table;
#[cfg(test)]
mod tests;
pub mod volume;

use crate::layout::{GpuMaterial, MATERIAL_UNLIT};
use crate::sampling::{
    build_frame, cosine_hemisphere_pdf, sample_cosine_hemisphere, sample_uniform_cone,
    uniform_cone_pdf,
};
use glam::{Vec2, Vec3};
use iridescence::fresnel_iridescence;
use microfacet::*;
use sheen::{charlie_d, sheen_albedo, sheen_alpha, sheen_visibility};
use std::f32::consts::FRAC_1_PI;

/// Below this |η − 1| the transmission lobe is a delta whatever the roughness
/// (`BsdfFrame::transmission_is_delta`).
pub const ETA_DELTA: f32 = 1e-3;

/// Which quantity a path carries (`mode` of every BSDF function).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// Paths from the camera: f as the rendering equation for radiance uses it.
    Radiance,
    /// Paths from a light: the adjoint BSDF.
    Importance,
}

/// A sampled incident direction: `weight` = f·|cos θᵢ|/pdf, `pdf` the solid-angle mixture pdf of
/// the non-delta lobes (for a delta lobe: the probability of choosing it), `delta` whether it
/// came from a delta lobe.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub weight: Vec3,
    pub pdf: f32,
    pub delta: bool,
}

/// Lobe indices of [`BsdfFrame::lobe_pmf`].
pub const LOBE_DIFFUSE: usize = 0;
pub const LOBE_REFLECTION: usize = 1;
pub const LOBE_TRANSMISSION: usize = 2;
pub const LOBE_CLEARCOAT: usize = 3;
pub const LOBE_SHEEN: usize = 4;
pub const LOBE_DIFFUSE_TRANSMISSION: usize = 5;
/// How many lobes [`BsdfFrame::lobe_pmf`] chooses among.
pub const LOBE_COUNT: usize = 6;

/// A material seen from `wo`: the local frame with +Z on `wo`'s side, the relative index of
/// refraction and the lobe selection probabilities.
#[derive(Clone, Copy, Debug)]
pub struct BsdfFrame {
    t: Vec3,
    b: Vec3,
    n: Vec3,
    /// `wo` in the local frame (z > 0).
    wo: Vec3,
    base: Vec3,
    metallic: f32,
    transmission: f32,
    /// GGX α along `t` and `b` ([`anisotropic_alpha`]).
    alpha: Vec2,
    /// η on the far side / η on `wo`'s side (1 for opaque surfaces' geometry).
    etap: f32,
    /// The dielectric Fresnel's RGB F0 ([`specular_f0`]) and F90 (specular).
    f0: Vec3,
    f90: f32,
    /// KHR_materials_iridescence's thin film over the base ([`fresnel_layers`]).
    film: ThinFilm,
    /// KHR_materials_diffuse_transmission: its factor (0: none) and colour.
    dt: f32,
    dt_color: Vec3,
    /// Probabilities of choosing the diffuse, reflection, transmission, clearcoat and sheen
    /// lobes.
    pub lobe_pmf: [f32; LOBE_COUNT],
    /// Sum of the lobe albedo estimates (before normalising to `lobe_pmf`).
    pub albedo_estimate: f32,
    /// The geometric normal on `wo`'s side, in the local frame: a direction reflects or
    /// transmits by the side of the geometric surface it lies on.
    ng: Vec3,
    /// The same in world space.
    ng_world: Vec3,
    /// The clearcoat layer: its weight (0: none), α, world frame about N_c (on `wo`'s side) and
    /// `wo` in that frame.
    clearcoat: f32,
    cc_alpha: Vec2,
    cc_t: Vec3,
    cc_b: Vec3,
    cc_n: Vec3,
    cc_wo: Vec3,
    /// The sheen layer: its colour, max component (0: none), α and roughness (the albedo
    /// table's axis), and the scaling 1 − max(colour)·E(cos θo) of the layers below.
    sheen_color: Vec3,
    sheen_max: f32,
    sheen_alpha: f32,
    sheen_roughness: f32,
    sheen_scale_o: f32,
    /// A plain diffuse surface: no metal, specular layer, thin film, transmission, diffuse
    /// transmission, sheen or coat, so Lambert's lobe alone (`lobe_pmf` 1 for it and 0 for the
    /// others; all 0 where the base colour is black or the surface unlit).
    /// [`eval`](Self::eval), [`pdf`](Self::pdf) and [`sample`](Self::sample) then take the
    /// diffuse lobe's terms alone: the same floats as the general path, whose other terms are
    /// each an exact 0 added or an exact 1 multiplied (test
    /// `plain_diffuse_frames_equal_the_general_path`). A Lambertian scene (the Cornell box
    /// Mitsuba renders with its `diffuse` BSDF) spends much of a vertex in the BSDF otherwise.
    plain: bool,
}

/// The clearcoat's Fresnel weight F_c = F0 + (1 − F0)(1 − |cos|)⁵ with F0 = ((1.5 − 1)/(1.5 +
/// 1))² = 0.04 (KHR_materials_clearcoat, `fresnel_coat`).
pub fn fresnel_coat(cos: f32) -> f32 {
    let f0 = dielectric_f0(1.5);
    f0 + (1.0 - f0) * schlick_weight(cos.abs())
}

/// KHR_materials_iridescence's film: its factor (0: none), index and thickness (nm).
#[derive(Clone, Copy, Debug)]
pub struct ThinFilm {
    pub factor: f32,
    pub ior: f32,
    pub thickness: f32,
}

/// The dielectric (RGB: KHR_materials_specular's F0, F90, [`fresnel_dielectric_color`]) and the
/// metal ([`fresnel_conductor`]) Fresnel terms at cosine `cos` to the microfacet normal on
/// `wo`'s side, each mixed with the thin film's reflectance by its factor as
/// KHR_materials_iridescence writes it: F = mix(F_base, F_film, iridescenceFactor), the film over
/// a base of F0 = the dielectric's F0 or the base colour ([`fresnel_iridescence`], seen from air
/// at the outside cosine: the transmitted angle's when `etap` < 1; total internal reflection
/// stays 1). The film's reflectance is clamped to [0, 1] so that the layers below keep a
/// non-negative 1 − max(F).
pub fn fresnel_layers(
    cos: f32,
    f0: Vec3,
    f90: f32,
    etap: f32,
    base: Vec3,
    metallic: f32,
    film: &ThinFilm,
) -> (Vec3, Vec3) {
    let mut fd = fresnel_dielectric_color(cos, f0, f90, etap);
    let mut fm = fresnel_conductor(base, cos);
    if film.factor <= 0.0 {
        return (fd, fm);
    }
    let mut c = cos.abs().min(1.0);
    let mut tir = false;
    if etap < 1.0 {
        let sin2_t = (1.0 - c * c) / (etap * etap);
        tir = sin2_t >= 1.0;
        c = (1.0 - sin2_t).max(0.0).sqrt();
    }
    if !tir && metallic < 1.0 {
        let thin = fresnel_iridescence(1.0, film.ior, c, film.thickness, f0).min(Vec3::ONE);
        fd += (thin - fd) * film.factor;
    }
    if metallic > 0.0 {
        let thin = fresnel_iridescence(1.0, film.ior, cos.abs().min(1.0), film.thickness, base)
            .min(Vec3::ONE);
        fm += (thin - fm) * film.factor;
    }
    (fd, fm)
}

/// How far above the geometric surface the shading normal must reflect `wo`
/// ([`bend_shading_normal`]): the cosine of the reflected direction with the geometric normal.
pub const SHADING_NORMAL_MIN_COS: f32 = 0.01;

/// A shading normal `ns` (on `ng`'s side) bent so that the mirror reflection of `wo` about it
/// lies at least [`SHADING_NORMAL_MIN_COS`] above the geometric surface (Keller et al. 2017,
/// "The Iray Light Transport Simulation and Rendering System", §A.3): without it, a normal map
/// or interpolated normal that faces away from `wo` turns the surface black. `ng` and `wo` must
/// be unit and on the same side (ng·wo > 0); returns a unit vector with ns·wo > 0.
pub fn bend_shading_normal(ns: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    let r = 2.0 * wo.dot(ns) * ns - wo;
    let height = r.dot(ng);
    if height >= SHADING_NORMAL_MIN_COS {
        return ns;
    }
    // Lift the reflection to the minimum height, keeping its azimuth, and take the half vector.
    let tangential = r - height * ng;
    let length = tangential.length();
    if !(length > 1e-12) {
        return ng;
    }
    let lifted = tangential
        * ((1.0 - SHADING_NORMAL_MIN_COS * SHADING_NORMAL_MIN_COS).sqrt() / length)
        + SHADING_NORMAL_MIN_COS * ng;
    (wo + lifted).normalize()
}

/// KHR_materials_anisotropy's roughnesses (α_t, α_b) = (mix(α, 1, strength²), α) (the
/// extension's "Implementation"); (α, α) without anisotropy. The lobe is a delta where α_t <
/// [`ALPHA_DELTA`]; otherwise α_b is at least [`ALPHA_DELTA`] (a lobe rough along the tangent
/// and smooth across it is a line of directions, no density: it is kept finitely narrow).
pub fn anisotropic_alpha(alpha: f32, strength: f32) -> Vec2 {
    if strength <= 0.0 {
        return Vec2::splat(alpha);
    }
    let at = alpha + (1.0 - alpha) * strength * strength;
    Vec2::new(
        at,
        if at < ALPHA_DELTA {
            alpha
        } else {
            alpha.max(ALPHA_DELTA)
        },
    )
}

/// The tangent frame (t, b) about unit `n`: where `strength` > 0, t is `direction` made
/// orthogonal to n (KHR_materials_anisotropy's α_t axis) and b = n × t; else, and where the
/// direction is degenerate, [`build_frame`]'s.
pub fn anisotropic_frame(n: Vec3, strength: f32, direction: Vec3) -> (Vec3, Vec3) {
    if strength > 0.0 {
        let t = direction - n * n.dot(direction);
        let length = t.length();
        if length > 1e-12 && length.is_finite() {
            let t = t / length;
            return (t, n.cross(t));
        }
    }
    build_frame(n)
}

fn average(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

/// Whether every frame of material `m` is [plain](BsdfFrame) whatever its textures: unlit, or
/// no metal, specular layer, thin film, transmission, diffuse transmission, sheen or coat by
/// their factors (the textures multiply them, so 0 stays 0). `layout::FEATURE_GENERAL_BSDF`.
pub fn material_is_plain(m: &GpuMaterial) -> bool {
    m.flags & MATERIAL_UNLIT != 0
        || (m.metallic == 0.0
            && m.specular == 0.0
            && m.iridescence == 0.0
            && m.transmission == 0.0
            && m.diffuse_transmission == 0.0
            && m.sheen_color == [0.0; 3]
            && m.clearcoat == 0.0)
}

/// No specular layer ([`BsdfFrame::specular_free`]): no metal, F0 = F90 = 0, no thin film and
/// no total internal reflection, so the dielectric Fresnel term is 0 at every angle.
fn no_specular_layer(metallic: f32, f0: Vec3, f90: f32, film: &ThinFilm, etap: f32) -> bool {
    metallic == 0.0 && f90 == 0.0 && f0.max_element() == 0.0 && film.factor <= 0.0 && etap >= 1.0
}

/// The shading frame of a surface seen from `wo`, the first steps of every frame
/// ([`BsdfFrame::new_shading`], [`LambertFrame::new`]).
struct Shading {
    /// ng · wo.
    cos_g: f32,
    /// Whether `wo` lies on the front face's side.
    front: bool,
    /// The geometric normal on `wo`'s side.
    ng_wo: Vec3,
    /// The shading normal on `wo`'s side, bent ([`bend_shading_normal`]), and the tangents.
    n: Vec3,
    t: Vec3,
    b: Vec3,
    /// `ng_wo` in the local frame (+Z where the shading normal is the geometric one).
    ng_local: Vec3,
    unlit: bool,
    /// KHR_materials_anisotropy's strength (0 for an unlit surface).
    anisotropy: f32,
}

impl Shading {
    /// None where `wo` lies in the surface's plane (no light leaves along it).
    #[inline(always)]
    fn new(m: &GpuMaterial, ng: Vec3, ns: Vec3, wo: Vec3) -> Option<Shading> {
        let cos_g = ng.dot(wo);
        if cos_g == 0.0 || !cos_g.is_finite() {
            return None;
        }
        let front = cos_g > 0.0;
        let ng_wo = if front { ng } else { -ng };
        let n = if ns == ng {
            ng_wo
        } else {
            bend_shading_normal(if front { ns } else { -ns }, ng_wo, wo)
        };
        // The tangent: KHR_materials_anisotropy's direction of α_t where the material has one,
        // else any (the other lobes are isotropic about n).
        let unlit = m.flags & MATERIAL_UNLIT != 0;
        let anisotropy = if unlit { 0.0 } else { m.anisotropy };
        let (t, b) = anisotropic_frame(n, anisotropy, Vec3::from(m.anisotropy_direction));
        let ng_local = if ns == ng {
            Vec3::Z
        } else {
            Vec3::new(ng_wo.dot(t), ng_wo.dot(b), ng_wo.dot(n))
        };
        Some(Shading {
            cos_g,
            front,
            ng_wo,
            n,
            t,
            b,
            ng_local,
            unlit,
            anisotropy,
        })
    }
}

/// A plain diffuse material ([`material_is_plain`]) seen from `wo`: Lambert's lobe alone, the
/// fields a [`plain`](BsdfFrame) [`BsdfFrame`] reads (72 bytes of its 280), whose plain path is
/// this frame's. Its eval, pdf and sample give the general path's floats (test
/// `lambert_frames_equal_the_general_path`).
/// The CPU reference shades every vertex of a plain material with it: building the general
/// frame — the layers' arithmetic and the stores of its fields — was most of a plain vertex's
/// BSDF work.
#[derive(Clone, Copy, Debug)]
pub struct LambertFrame {
    t: Vec3,
    b: Vec3,
    n: Vec3,
    /// The geometric normal on `wo`'s side, in the local frame.
    ng: Vec3,
    base: Vec3,
    /// The diffuse lobe's probability: 1, or 0 where the surface scatters nothing.
    pmf: f32,
    /// The diffuse lobe's albedo estimate, average(base colour) ([`BsdfFrame::albedo_estimate`]).
    pub albedo_estimate: f32,
}

impl LambertFrame {
    /// The frame of a plain material `m` at shading normal `ns` ([`BsdfFrame::new_shading`]
    /// for such a material, which it must be). None where `wo` lies in the surface's plane.
    pub fn new(m: &GpuMaterial, ng: Vec3, ns: Vec3, wo: Vec3) -> Option<LambertFrame> {
        debug_assert!(material_is_plain(m));
        let s = Shading::new(m, ng, ns, wo)?;
        let base = if s.unlit {
            Vec3::ZERO
        } else {
            Vec3::from(m.base_color)
        };
        // new_shading's lobe estimates of a plain material: the diffuse lobe's
        // 1 · (1 − 0) · average(base), every other lobe's an exact 0; normalised by their sum
        // (1 where the surface scatters; NaN where the sum is infinite, as there).
        let diffuse = average(base);
        let total = diffuse;
        Some(LambertFrame {
            t: s.t,
            b: s.b,
            n: s.n,
            ng: s.ng_local,
            base,
            pmf: if total > 0.0 { diffuse / total } else { 0.0 },
            albedo_estimate: total,
        })
    }

    /// Whether local `wi` lies on the same side of the geometric and the shading surface.
    fn consistent(&self, wi: Vec3) -> bool {
        (wi.dot(self.ng) > 0.0) == (wi.z > 0.0)
    }

    fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Lambert's f at world-space `wi` (the same in both transport modes).
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        let wi = self.to_local(wi);
        if self.consistent(wi) && wi.z > 0.0 {
            FRAC_1_PI * self.base
        } else {
            Vec3::ZERO
        }
    }

    /// The cosine-weighted pdf at world-space `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let wi = self.to_local(wi);
        if self.consistent(wi) && wi.z > 0.0 {
            self.pmf * cosine_hemisphere_pdf(wi.z)
        } else {
            0.0
        }
    }

    /// |cos| between world-space `wi` and the shading normal.
    pub fn cos_theta(&self, wi: Vec3) -> f32 {
        wi.dot(self.n).abs()
    }

    /// A cosine-weighted direction for `u.xy` if the surface scatters anything (`u.z`, the
    /// general frame's lobe choice, is not read); a direction on the surface is no sample.
    pub fn sample(&self, u: Vec3) -> Option<BsdfSample> {
        if !(self.pmf > 0.0) {
            return None;
        }
        let local = sample_cosine_hemisphere(Vec2::new(u.x, u.y));
        if !(local.z > 0.0) {
            return None;
        }
        let wi = self.t * local.x + self.b * local.y + self.n * local.z;
        let pdf = self.pdf(wi);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval(wi) * (self.cos_theta(wi) / pdf),
            pdf,
            delta: false,
        })
    }
}

/// What a path vertex asks of its BSDF (the CPU reference's `shade`), from a general
/// [`BsdfFrame`] or a [`LambertFrame`].
pub trait VertexBsdf {
    fn eval(&self, wi: Vec3, mode: TransportMode) -> Vec3;
    fn pdf(&self, wi: Vec3) -> f32;
    fn sample(&self, u: Vec3, mode: TransportMode) -> Option<BsdfSample>;
    fn cos_theta(&self, wi: Vec3) -> f32;
    fn albedo_estimate(&self) -> f32;
}

impl VertexBsdf for BsdfFrame {
    fn eval(&self, wi: Vec3, mode: TransportMode) -> Vec3 {
        BsdfFrame::eval(self, wi, mode)
    }
    fn pdf(&self, wi: Vec3) -> f32 {
        BsdfFrame::pdf(self, wi)
    }
    fn sample(&self, u: Vec3, mode: TransportMode) -> Option<BsdfSample> {
        BsdfFrame::sample(self, u, mode)
    }
    fn cos_theta(&self, wi: Vec3) -> f32 {
        BsdfFrame::cos_theta(self, wi)
    }
    fn albedo_estimate(&self) -> f32 {
        self.albedo_estimate
    }
}

/// A vertex's frame for callers that build several per vertex (light tracing, BDPT): a plain
/// material's [`LambertFrame`], bit for bit the general frame's values
/// (`lambert_frames_equal_the_general_path`) at a quarter of its size and less of its setup,
/// else the general [`BsdfFrame`].
pub enum ShadingFrame {
    Lambert(LambertFrame),
    General(BsdfFrame),
}

impl ShadingFrame {
    /// [`BsdfFrame::new_shading`], as the plain frame where `m` is [plain](material_is_plain).
    #[inline]
    pub fn new_shading(m: &GpuMaterial, ng: Vec3, ns: Vec3, wo: Vec3) -> Option<ShadingFrame> {
        if material_is_plain(m) {
            LambertFrame::new(m, ng, ns, wo).map(ShadingFrame::Lambert)
        } else {
            BsdfFrame::new_shading(m, ng, ns, wo).map(ShadingFrame::General)
        }
    }
}

impl VertexBsdf for ShadingFrame {
    #[inline]
    fn eval(&self, wi: Vec3, mode: TransportMode) -> Vec3 {
        match self {
            ShadingFrame::Lambert(f) => f.eval(wi),
            ShadingFrame::General(f) => f.eval(wi, mode),
        }
    }
    #[inline]
    fn pdf(&self, wi: Vec3) -> f32 {
        match self {
            ShadingFrame::Lambert(f) => f.pdf(wi),
            ShadingFrame::General(f) => f.pdf(wi),
        }
    }
    #[inline]
    fn sample(&self, u: Vec3, mode: TransportMode) -> Option<BsdfSample> {
        match self {
            ShadingFrame::Lambert(f) => f.sample(u),
            ShadingFrame::General(f) => f.sample(u, mode),
        }
    }
    #[inline]
    fn cos_theta(&self, wi: Vec3) -> f32 {
        match self {
            ShadingFrame::Lambert(f) => f.cos_theta(wi),
            ShadingFrame::General(f) => f.cos_theta(wi),
        }
    }
    #[inline]
    fn albedo_estimate(&self) -> f32 {
        match self {
            ShadingFrame::Lambert(f) => f.albedo_estimate,
            ShadingFrame::General(f) => f.albedo_estimate,
        }
    }
}

impl VertexBsdf for LambertFrame {
    fn eval(&self, wi: Vec3, _mode: TransportMode) -> Vec3 {
        LambertFrame::eval(self, wi)
    }
    fn pdf(&self, wi: Vec3) -> f32 {
        LambertFrame::pdf(self, wi)
    }
    fn sample(&self, u: Vec3, _mode: TransportMode) -> Option<BsdfSample> {
        LambertFrame::sample(self, u)
    }
    fn cos_theta(&self, wi: Vec3) -> f32 {
        LambertFrame::cos_theta(self, wi)
    }
    fn albedo_estimate(&self) -> f32 {
        self.albedo_estimate
    }
}

impl BsdfFrame {
    /// The frame of the geometric normal (no shading normal). None where `wo` lies in the
    /// surface's plane (no light leaves along it).
    pub fn new(m: &GpuMaterial, ng: Vec3, wo: Vec3) -> Option<BsdfFrame> {
        BsdfFrame::new_shading(m, ng, ng, wo)
    }

    /// The frame of shading normal `ns` (unit, either side), flipped with the geometric normal
    /// `ng` to `wo`'s side and bent by [`bend_shading_normal`]. The BSDF is evaluated in it,
    /// but whether a direction reflects or transmits is decided by the geometric surface, and
    /// where the two disagree the BSDF is zero, so no light leaks through a surface whose
    /// shading normal tilts over its horizon (Veach 1997, §5.3; pbrt-v3 §9.1).
    pub fn new_shading(m: &GpuMaterial, ng: Vec3, ns: Vec3, wo: Vec3) -> Option<BsdfFrame> {
        let Shading {
            cos_g,
            front,
            ng_wo,
            n,
            t,
            b,
            ng_local,
            unlit,
            anisotropy,
        } = Shading::new(m, ng, ns, wo)?;
        let wo_local = Vec3::new(
            wo.dot(t),
            wo.dot(b),
            if ns == ng { cos_g.abs() } else { wo.dot(n) },
        );
        // An unlit surface scatters nothing: every lobe's weight is 0.
        let transmission = if m.metallic < 1.0 && !unlit {
            m.transmission
        } else {
            0.0
        };
        let ior = m.ior.max(1.0);
        let etap = if transmission > 0.0 && !front {
            1.0 / ior
        } else {
            ior
        };
        let (base, metallic, specular) = if unlit {
            (Vec3::ZERO, 0.0, 0.0)
        } else {
            (Vec3::from(m.base_color), m.metallic, m.specular)
        };
        let f0 = specular_f0(m.ior, Vec3::from(m.specular_color), specular);
        let f90 = specular;
        let film = ThinFilm {
            factor: if unlit { 0.0 } else { m.iridescence },
            ior: m.iridescence_ior,
            thickness: m.iridescence_thickness,
        };
        // Lobe albedo estimates at the macro normal (Fresnel at cos θo). Without a specular
        // layer fe = 0 (see `specular_free`) and fm has the factor metallic = 0: both terms 0.
        let specular_free = no_specular_layer(metallic, f0, f90, &film, etap);
        let (fe, fm) = if specular_free {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            fresnel_layers(wo_local.z, f0, f90, etap, base, metallic, &film)
        };
        let fm = average(fm);
        let dielectric = 1.0 - metallic;
        let dt = if unlit { 0.0 } else { m.diffuse_transmission };
        let dt_color = Vec3::from(m.diffuse_transmission_color);
        let diffuse = dielectric * (1.0 - transmission) * (1.0 - fe.max_element());
        let mut w = [
            diffuse * (1.0 - dt) * average(base),
            dielectric * average(fe) + metallic * fm,
            dielectric * transmission * (1.0 - fe.max_element()) * average(base),
            0.0,
            0.0,
            diffuse * dt * average(dt_color),
        ];
        // The sheen: its albedo E(cos θo) taken from the layers below (albedo scaling).
        let sheen_color = if unlit {
            Vec3::ZERO
        } else {
            Vec3::from(m.sheen_color)
        };
        let sheen_max = sheen_color.max_element();
        let mut sheen_scale_o = 1.0;
        if sheen_max > 0.0 {
            let e = sheen_albedo(wo_local.z, m.sheen_roughness);
            sheen_scale_o = (1.0 - sheen_max * e).max(0.0);
            for k in [0, 1, 2, LOBE_DIFFUSE_TRANSMISSION] {
                w[k] *= sheen_scale_o;
            }
            w[LOBE_SHEEN] = average(sheen_color) * e;
        }
        // The coat: its frame about N_c (the base's normal unless the hit gave its own), and
        // its weight clearcoat · F_c(wo·N_c) taken from the base lobes' estimates.
        let clearcoat = if unlit { 0.0 } else { m.clearcoat };
        let (mut cc_t, mut cc_b, mut cc_n, mut cc_wo) = (t, b, n, wo_local);
        if clearcoat > 0.0 {
            let nc = Vec3::from(m.clearcoat_normal);
            if nc != Vec3::ZERO {
                cc_n = bend_shading_normal(if front { nc } else { -nc }, ng_wo, wo);
                (cc_t, cc_b) = build_frame(cc_n);
                cc_wo = Vec3::new(wo.dot(cc_t), wo.dot(cc_b), wo.dot(cc_n));
            }
            let wc = clearcoat * fresnel_coat(cc_wo.z);
            for k in [0, 1, 2, LOBE_DIFFUSE_TRANSMISSION] {
                w[k] *= 1.0 - wc;
            }
            w[LOBE_SHEEN] *= 1.0 - wc;
            w[LOBE_CLEARCOAT] = wc;
        }
        let total = w.iter().sum::<f32>();
        let lobe_pmf = if total > 0.0 {
            w.map(|x| x / total)
        } else {
            [0.0; LOBE_COUNT]
        };
        let plain = specular_free
            && transmission == 0.0
            && dt == 0.0
            && sheen_max <= 0.0
            && clearcoat <= 0.0;
        Some(BsdfFrame {
            t,
            b,
            n,
            wo: wo_local,
            base,
            metallic,
            transmission,
            alpha: anisotropic_alpha(m.roughness * m.roughness, anisotropy),
            etap,
            f0,
            f90,
            film,
            dt,
            dt_color,
            lobe_pmf,
            albedo_estimate: total,
            ng: ng_local,
            ng_world: ng_wo,
            clearcoat,
            cc_alpha: Vec2::splat(m.clearcoat_roughness * m.clearcoat_roughness),
            cc_t,
            cc_b,
            cc_n,
            cc_wo,
            sheen_color,
            sheen_max,
            sheen_alpha: sheen_alpha(m.sheen_roughness),
            sheen_roughness: m.sheen_roughness,
            sheen_scale_o,
            plain,
        })
    }

    /// A [`plain`](Self::plain) frame as the [`LambertFrame`] it is: its eval, pdf and sample
    /// are [`eval_local`](Self::eval_local)'s, [`pdf_local`](Self::pdf_local)'s and the diffuse
    /// lobe's sample with their zero terms left out.
    fn lambert(&self) -> LambertFrame {
        LambertFrame {
            t: self.t,
            b: self.b,
            n: self.n,
            ng: self.ng,
            base: self.base,
            pmf: self.lobe_pmf[LOBE_DIFFUSE],
            albedo_estimate: self.albedo_estimate,
        }
    }

    /// Whether local `wi` lies on the same side of the geometric and the shading surface.
    fn consistent(&self, wi: Vec3) -> bool {
        (wi.dot(self.ng) > 0.0) == (wi.z > 0.0)
    }

    /// |cos| between world-space `wi` and the shading normal: the cosine of the rendering
    /// equation.
    pub fn cos_theta(&self, wi: Vec3) -> f32 {
        wi.dot(self.n).abs()
    }

    fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }

    /// No specular layer: a dielectric with KHR_materials_specular's factor 0 (F0 = F90 = 0),
    /// no metal, no thin film and no total internal reflection (η ≥ 1) has fd = 0 at every
    /// angle, so its reflection term is 0 and its diffuse lobe keeps all of 1 − max(fd);
    /// [`eval_local`](Self::eval_local) skips the Fresnel and the reflection term (the same value
    /// bit for bit: x + 0 = x).
    fn specular_free(&self) -> bool {
        no_specular_layer(self.metallic, self.f0, self.f90, &self.film, self.etap)
    }

    fn is_delta(&self) -> bool {
        self.alpha.x < ALPHA_DELTA
    }

    /// Whether the transmission lobe is a delta: where the reflection is, and where the two
    /// sides' indices match, |η − 1| < [`ETA_DELTA`]: the generalised half vector of wo and a
    /// direction wi is ∝ wo + η·wi (Walter et al. 2007, eq. 16), so every microfacet refracts
    /// within about |η − 1|·α of straight through, whatever the roughness (an ior of 1 passes
    /// a sharp image, as KHR_materials_transmission's TransmissionRoughnessTest shows).
    fn transmission_is_delta(&self) -> bool {
        self.is_delta() || (self.etap - 1.0).abs() < ETA_DELTA
    }

    /// The generalised half vector of a refraction (Walter et al. 2007, eq. 16), on `wo`'s side;
    /// None if wo and wi do not lie on the sides of it that refraction requires.
    fn refraction_half_vector(&self, wi: Vec3) -> Option<Vec3> {
        let mut m = (self.wo + self.etap * wi).normalize();
        if m.z < 0.0 {
            m = -m;
        }
        (m.is_finite() && self.wo.dot(m) > 0.0 && wi.dot(m) < 0.0).then_some(m)
    }

    /// The dielectric and metal Fresnel terms at cosine `cos` ([`fresnel_layers`]).
    fn fresnel(&self, cos: f32) -> (Vec3, Vec3) {
        fresnel_layers(
            cos,
            self.f0,
            self.f90,
            self.etap,
            self.base,
            self.metallic,
            &self.film,
        )
    }

    /// f of the non-delta lobes for local `wi`.
    fn eval_local(&self, wi: Vec3, mode: TransportMode) -> Vec3 {
        let wo = self.wo;
        if !self.consistent(wi) {
            return Vec3::ZERO;
        }
        let dielectric = 1.0 - self.metallic;
        if wi.z > 0.0 {
            let h = (wo + wi).normalize();
            // Without a specular layer fd = 0: no Fresnel to evaluate and no reflection term.
            let specular = !self.specular_free();
            let (fd, fm) = if specular {
                self.fresnel(wo.dot(h))
            } else {
                (Vec3::ZERO, Vec3::ZERO)
            };
            let mut f = dielectric
                * (1.0 - self.transmission)
                * (1.0 - self.dt)
                * (1.0 - fd.max_element())
                * FRAC_1_PI
                * self.base;
            if specular && !self.is_delta() {
                let spec = ggx_d(h, self.alpha) * ggx_visibility(wo, wi, self.alpha);
                f += (dielectric * fd + self.metallic * fm) * spec;
            }
            if self.sheen_max > 0.0 {
                f = f * self.sheen_scale(wi.z)
                    + self.sheen_color
                        * (charlie_d(h.z, self.sheen_alpha)
                            * sheen_visibility(wo.z, wi.z, self.sheen_alpha));
            }
            f
        } else if wi.z < 0.0 {
            let diffuse = self.eval_diffuse_transmission(wi);
            if self.transmission <= 0.0 || self.transmission_is_delta() {
                return diffuse;
            }
            let Some(m) = self.refraction_half_vector(wi) else {
                return diffuse;
            };
            let (om, im) = (wo.dot(m), wi.dot(m));
            let fd = self.fresnel(om).0.max_element();
            let denom = self.etap * im + om;
            // Walter et al. 2007, eq. 21, for radiance (the 1/η² of refraction included).
            let g2 = 4.0 * wo.z * wi.z.abs() * ggx_visibility(wo, wi, self.alpha);
            let mut ft =
                ggx_d(m, self.alpha) * g2 * (im * om).abs() / (wo.z * wi.z.abs() * denom * denom);
            if mode == TransportMode::Importance {
                ft *= self.etap * self.etap;
            }
            diffuse
                + dielectric
                    * self.transmission
                    * (1.0 - fd)
                    * ft
                    * self.sheen_scale(wi.z)
                    * self.base
        } else {
            Vec3::ZERO
        }
    }

    /// KHR_materials_diffuse_transmission's Lambertian lobe on the far side at local `wi`
    /// (wi.z < 0): (1 − metallic)(1 − transmission)·dt·(1 − max F)·dtColor/π, F on the half
    /// vector of `wo` and `wi` mirrored to `wo`'s side (symmetric in the two, as the thin
    /// surface is), under the sheen's scaling.
    fn eval_diffuse_transmission(&self, wi: Vec3) -> Vec3 {
        if self.dt <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (self.wo + Vec3::new(wi.x, wi.y, -wi.z)).normalize();
        let fd = self.fresnel(self.wo.dot(h)).0.max_element();
        (1.0 - self.metallic)
            * (1.0 - self.transmission)
            * self.dt
            * (1.0 - fd)
            * FRAC_1_PI
            * self.sheen_scale(wi.z)
            * self.dt_color
    }

    /// Solid-angle pdf of the non-delta lobes' mixture at local `wi`.
    fn pdf_local(&self, wi: Vec3) -> f32 {
        let wo = self.wo;
        if !self.consistent(wi) {
            return 0.0;
        }
        let [p_diffuse, p_reflection, p_transmission, _, p_sheen, p_dt] = self.lobe_pmf;
        if wi.z > 0.0 {
            let mut pdf = p_diffuse * cosine_hemisphere_pdf(wi.z);
            if !self.is_delta() && p_reflection > 0.0 {
                let h = (wo + wi).normalize();
                // dω_h/dω_i = 1 / (4 |wo·h|) (Walter et al. 2007, eq. 14).
                pdf += p_reflection * ggx_vndf_pdf(wo, h, self.alpha) / (4.0 * wo.dot(h));
            }
            if p_sheen > 0.0 {
                pdf += p_sheen * uniform_cone_pdf(0.0);
            }
            pdf
        } else if wi.z < 0.0 {
            let diffuse = p_dt * cosine_hemisphere_pdf(-wi.z);
            if self.transmission_is_delta() || p_transmission <= 0.0 {
                return diffuse;
            }
            let Some(m) = self.refraction_half_vector(wi) else {
                return diffuse;
            };
            let denom = self.etap * wi.dot(m) + wo.dot(m);
            // dω_m/dω_i = η² |wi·m| / (wo·m + η wi·m)² (Walter et al. 2007, eq. 17).
            diffuse
                + p_transmission
                    * ggx_vndf_pdf(wo, m, self.alpha)
                    * self.etap
                    * self.etap
                    * wi.dot(m).abs()
                    / (denom * denom)
        } else {
            0.0
        }
    }

    /// f·|cos| of the delta lobe `lobe` at its one direction, and that direction.
    fn delta_lobe(&self, lobe: usize, mode: TransportMode) -> Option<(Vec3, Vec3)> {
        let wo = self.wo;
        let dielectric = 1.0 - self.metallic;
        let (fd, fm) = self.fresnel(wo.z);
        if lobe == LOBE_REFLECTION {
            let value = dielectric * fd + self.metallic * fm;
            Some((
                Vec3::new(-wo.x, -wo.y, wo.z),
                value * self.sheen_scale(wo.z),
            ))
        } else {
            let wi = refract_through(wo, Vec3::Z, self.etap)?;
            let mut value = dielectric
                * self.transmission
                * (1.0 - fd.max_element())
                * self.sheen_scale(wi.z)
                * self.base;
            if mode == TransportMode::Radiance {
                value /= self.etap * self.etap;
            }
            Some((wi, value))
        }
    }

    /// The sheen's albedo scaling of the layers below for a direction of cosine `cos_i`:
    /// min(1 − max(sheenColor)·E(cos θo), 1 − max(sheenColor)·E(cos θi)), at least 0; 1 without
    /// sheen.
    fn sheen_scale(&self, cos_i: f32) -> f32 {
        if self.sheen_max <= 0.0 {
            return 1.0;
        }
        let e = sheen_albedo(cos_i, self.sheen_roughness);
        self.sheen_scale_o.min((1.0 - self.sheen_max * e).max(0.0))
    }

    fn cc_is_delta(&self) -> bool {
        self.cc_alpha.x < ALPHA_DELTA
    }

    fn to_cc_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.cc_t), v.dot(self.cc_b), v.dot(self.cc_n))
    }

    /// The coat's weight clearcoat · F_c(|V·N_c|) for world-space `wi`: V is `wo` for radiance,
    /// `wi` for importance (the transposed BSDF).
    fn cc_weight(&self, wi: Vec3, mode: TransportMode) -> f32 {
        let v = match mode {
            TransportMode::Radiance => self.cc_wo.z,
            TransportMode::Importance => wi.dot(self.cc_n),
        };
        self.clearcoat * fresnel_coat(v)
    }

    /// The coat's GGX lobe D·V at world-space `wi` (0 for a delta coat or `wi` below the coat or
    /// the geometric surface), times |cos| to N_c over |cos| to the shading normal of the
    /// direction the integrator multiplies by (`wi` for radiance; `wo` for importance, the
    /// transpose).
    fn eval_clearcoat(&self, wi: Vec3, mode: TransportMode) -> f32 {
        let wc = self.to_cc_local(wi);
        if self.cc_is_delta() || wc.z <= 0.0 || wi.dot(self.ng_world) <= 0.0 {
            return 0.0;
        }
        let h = (self.cc_wo + wc).normalize();
        let spec = ggx_d(h, self.cc_alpha) * ggx_visibility(self.cc_wo, wc, self.cc_alpha);
        if self.cc_n == self.n {
            return spec;
        }
        let ratio = match mode {
            TransportMode::Radiance => wc.z / wi.dot(self.n).abs(),
            TransportMode::Importance => self.cc_wo.z / self.wo.z,
        };
        if ratio.is_finite() {
            spec * ratio
        } else {
            0.0
        }
    }

    /// Solid-angle pdf of the coat's visible-normal sampling at world-space `wi`.
    fn pdf_clearcoat(&self, wi: Vec3) -> f32 {
        let wc = self.to_cc_local(wi);
        if self.cc_is_delta() || wc.z <= 0.0 || wi.dot(self.ng_world) <= 0.0 {
            return 0.0;
        }
        let h = (self.cc_wo + wc).normalize();
        ggx_vndf_pdf(self.cc_wo, h, self.cc_alpha) / (4.0 * self.cc_wo.dot(h))
    }

    /// f(wo, wi) of the non-delta lobes for world-space `wi` ([`bsdf_eval`] with this frame).
    pub fn eval(&self, wi: Vec3, mode: TransportMode) -> Vec3 {
        if self.plain {
            return self.lambert().eval(wi);
        }
        let base = self.eval_local(self.to_local(wi), mode);
        if self.clearcoat <= 0.0 {
            return base;
        }
        let wc = self.cc_weight(wi, mode);
        (1.0 - wc) * base + Vec3::splat(wc * self.eval_clearcoat(wi, mode))
    }

    /// The mixture pdf at world-space `wi` ([`bsdf_pdf`] with this frame).
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if self.plain {
            return self.lambert().pdf(wi);
        }
        let base = self.pdf_local(self.to_local(wi));
        if self.clearcoat <= 0.0 || self.lobe_pmf[LOBE_CLEARCOAT] <= 0.0 {
            return base;
        }
        base + self.lobe_pmf[LOBE_CLEARCOAT] * self.pdf_clearcoat(wi)
    }

    /// Samples one lobe with `u.z`, then a direction in it with `u.xy` ([`bsdf_sample`]).
    pub fn sample(&self, u: Vec3, mode: TransportMode) -> Option<BsdfSample> {
        if self.plain {
            return self.lambert().sample(u);
        }
        // The first lobe whose cumulative probability exceeds u.z (rounding past the last
        // sum: the last lobe that can be chosen).
        let (mut lobe, mut cumulative) = (LOBE_COUNT, 0.0);
        for (i, &p) in self.lobe_pmf.iter().enumerate() {
            if p > 0.0 {
                lobe = i;
                cumulative += p;
                if u.z < cumulative {
                    break;
                }
            }
        }
        if lobe == LOBE_COUNT {
            return None;
        }
        let lobe_p = self.lobe_pmf[lobe];
        let uv = Vec2::new(u.x, u.y);
        let world = if lobe == LOBE_CLEARCOAT {
            let wc = if self.cc_is_delta() {
                Vec3::new(-self.cc_wo.x, -self.cc_wo.y, self.cc_wo.z)
            } else {
                reflect_about(self.cc_wo, sample_ggx_vndf(self.cc_wo, self.cc_alpha, uv))
            };
            let wi = self.cc_t * wc.x + self.cc_b * wc.y + self.cc_n * wc.z;
            if wc.z <= 0.0 || wi.dot(self.ng_world) <= 0.0 {
                return None;
            }
            if self.cc_is_delta() {
                // The mirror about N_c: f·|cos| = clearcoat · F_c, the same V·N_c either way.
                return Some(BsdfSample {
                    wi,
                    weight: Vec3::splat(self.cc_weight(wi, mode) / lobe_p),
                    pdf: lobe_p,
                    delta: true,
                });
            }
            wi
        } else {
            let delta = match lobe {
                LOBE_REFLECTION => self.is_delta(),
                LOBE_TRANSMISSION => self.transmission_is_delta(),
                _ => false,
            };
            if delta {
                let (wi, value) = self.delta_lobe(lobe, mode)?;
                if !self.consistent(wi) {
                    return None;
                }
                let world = self.to_world(wi);
                let scale = if self.clearcoat > 0.0 {
                    1.0 - self.cc_weight(world, mode)
                } else {
                    1.0
                };
                return Some(BsdfSample {
                    wi: world,
                    weight: value * (scale / lobe_p),
                    pdf: lobe_p,
                    delta: true,
                });
            }
            let wi = match lobe {
                LOBE_DIFFUSE => sample_cosine_hemisphere(uv),
                LOBE_DIFFUSE_TRANSMISSION => {
                    sample_cosine_hemisphere(uv) * Vec3::new(1.0, 1.0, -1.0)
                }
                // Charlie has no closed-form sampler: uniform directions, as Conty Estevez &
                // Kulla 2017 suggest (the lobe peaks towards grazing, where cosine sampling is
                // sparse).
                LOBE_SHEEN => sample_uniform_cone(uv, 0.0),
                LOBE_REFLECTION => reflect_about(self.wo, sample_ggx_vndf(self.wo, self.alpha, uv)),
                _ => refract_through(self.wo, sample_ggx_vndf(self.wo, self.alpha, uv), self.etap)?,
            };
            // Each lobe keeps to its side: a reflection below or a refraction above the surface
            // is no sample (the mixture pdf counts each lobe only on its own side).
            let reflects = lobe != LOBE_TRANSMISSION && lobe != LOBE_DIFFUSE_TRANSMISSION;
            if (wi.z > 0.0) != reflects || wi.z == 0.0 {
                return None;
            }
            self.to_world(wi)
        };
        self.weighed(world, mode)
    }

    /// A non-delta sample at world-space `wi`: the mixture's pdf and f·|cos|/pdf there.
    fn weighed(&self, wi: Vec3, mode: TransportMode) -> Option<BsdfSample> {
        let pdf = self.pdf(wi);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval(wi, mode) * (self.cos_theta(wi) / pdf),
            pdf,
            delta: false,
        })
    }
}

/// f(wo, wi) of the non-delta lobes (without the cosine).
pub fn bsdf_eval(m: &GpuMaterial, ng: Vec3, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
    match BsdfFrame::new(m, ng, wo) {
        Some(frame) => frame.eval(wi, mode),
        None => Vec3::ZERO,
    }
}

/// Pdf of [`bsdf_sample`] with respect to solid angle, over its non-delta lobes.
pub fn bsdf_pdf(m: &GpuMaterial, ng: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    match BsdfFrame::new(m, ng, wo) {
        Some(frame) => frame.pdf(wi),
        None => 0.0,
    }
}

/// Samples `wi` from three uniform numbers: `u.z` picks the lobe, `u.xy` the direction in it.
/// None if no direction results (a black material, total internal reflection of the sampled
/// microfacet, a direction below the surface).
pub fn bsdf_sample(
    m: &GpuMaterial,
    ng: Vec3,
    wo: Vec3,
    u: Vec3,
    mode: TransportMode,
) -> Option<BsdfSample> {
    BsdfFrame::new(m, ng, wo)?.sample(u, mode)
}

/// Sum of the estimated lobe albedos seen from `wo` (the lecture's subcritical survival
/// probability P = ∫K for `--rr albedo`); 0 where `wo` grazes the surface.
pub fn bsdf_albedo_estimate(m: &GpuMaterial, ng: Vec3, wo: Vec3) -> f32 {
    BsdfFrame::new(m, ng, wo).map_or(0.0, |f| f.albedo_estimate)
}
