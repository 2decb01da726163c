//! What a path vertex asks of its BSDF ([`VertexBsdf`]), from a general [`BsdfFrame`] or a
//! plain [`LambertFrame`], and the frame that picks one ([`ShadingFrame`]).

use super::gltf::BsdfFrame;
use super::lambert::LambertFrame;
use super::lobes::material_is_plain;
use super::lobes::{BsdfSample, TransportMode};
use crate::layout::GpuMaterial;
use glam::Vec3;

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
