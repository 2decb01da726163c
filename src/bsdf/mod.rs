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
//! transmission lobe is thin-walled by default, as the specification says: without
//! KHR_materials_volume (or with thicknessFactor 0) it is the reflection lobe mirrored through
//! the surface, straight through when smooth, with no η (`BsdfFrame::eval_thin_transmission`);
//! with a volume it is a rough dielectric (Walter et al. 2007, eq. 21) refracting by `ior` into
//! the medium the mesh bounds; tinted by c either way as KHR_materials_transmission says. No energy compensation: at grazing angles
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

mod clearcoat;
pub mod energy;
pub(crate) mod energy_table;
mod fresnel;
mod gltf;
pub mod iridescence;
mod lambert;
mod lobes;
pub mod microfacet;
mod shading;
pub mod sheen;
pub(crate) mod sheen_table;
#[cfg(test)]
mod tests;
mod vertex;
pub mod volume;

pub use fresnel::{fresnel_coat, fresnel_layers, ThinFilm};
pub use gltf::{bsdf_albedo_estimate, bsdf_eval, bsdf_pdf, bsdf_sample, BsdfFrame};
pub use lambert::LambertFrame;
pub use lobes::{
    material_is_plain, BsdfSample, TransportMode, ETA_DELTA, LOBE_CLEARCOAT, LOBE_COUNT,
    LOBE_DIFFUSE, LOBE_DIFFUSE_TRANSMISSION, LOBE_REFLECTION, LOBE_SHEEN, LOBE_TRANSMISSION,
};
pub use shading::{
    anisotropic_alpha, anisotropic_frame, bend_shading_normal, SHADING_NORMAL_MIN_COS,
};
pub use vertex::{ShadingFrame, VertexBsdf};
