//! What every lobe shares: the transport mode a path carries, a BSDF sample, the lobes'
//! indices, and the threshold below which refraction is a delta.

use super::fresnel::ThinFilm;
use crate::layout::{GpuMaterial, MATERIAL_UNLIT};
use glam::Vec3;

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

pub(super) fn average(v: Vec3) -> f32 {
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
pub(super) fn no_specular_layer(
    metallic: f32,
    f0: Vec3,
    f90: f32,
    film: &ThinFilm,
    etap: f32,
) -> bool {
    metallic == 0.0 && f90 == 0.0 && f0.max_element() == 0.0 && film.factor <= 0.0 && etap >= 1.0
}
