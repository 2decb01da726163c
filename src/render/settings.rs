//! What to render and how: [`RenderSettings`] (size, samples, depth, seed, lighting, MIS,
//! samplers, Russian roulette, AOV, lens, path expression) and which estimator renders
//! ([`Integrator`]).

use crate::layout::LIGHT_SAMPLER_BVH;
use crate::layout::{RR_THROUGHPUT, SAMPLER_SOBOL};
use crate::lights::environment::EnvironmentMap;
use crate::mis::Heuristic;
use glam::Vec3;
use std::sync::Arc;

/// What to render and how.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Scattering events per path: 0 = emitters seen directly, 1 = direct lighting, ...
    pub max_depth: u32,
    pub seed: u32,
    /// Russian roulette applies to paths with at least this many scattering events.
    pub rr_start_depth: u32,
    /// `layout::RR_*`: how survival probabilities are chosen (throughput by default).
    pub rr_mode: u32,
    /// Radiance of rays that leave the scene, the same in every direction (`--environment`);
    /// ignored when `env_map` is set.
    pub environment: Vec3,
    /// An equirectangular environment map (`--env`), times `env_scale`, turned `env_rotate`
    /// degrees about +Y.
    pub env_map: Option<Arc<EnvironmentMap>>,
    pub env_scale: f32,
    pub env_rotate: f32,
    /// How emitter and BSDF sampling are combined (the power heuristic, β = 2, by default).
    pub mis: Heuristic,
    /// `layout::SAMPLER_*`: Owen-scrambled Sobol by default.
    pub sampler: u32,
    /// `layout::LIGHT_SAMPLER_*`: how next event estimation picks an emitter (`--light-sampler`).
    pub light_sampler: u32,
    /// `layout::DEBUG_*` bits; 0 except in tests.
    pub debug_flags: u32,
    /// `layout::AOV_*`: radiance, or a property of the first hit (`--aov`).
    pub aov: u32,
    /// Thin-lens diameter in scene units (`--aperture`); 0 is a pinhole. Perspective cameras
    /// only: check with [`PreparedScene::thin_lens`].
    pub aperture: f32,
    /// Distance of the plane in focus (`--focus-distance`); `None` focuses on the centre of
    /// the scene's bounding box.
    pub focus_distance: Option<f32>,
    /// The estimator (`--integrator`): the path tracer by default.
    pub integrator: Integrator,
    /// Only paths matching this expression count (`--paths`).
    pub paths: Option<Arc<crate::paths::PathExpr>>,
    /// Textures at their finest level everywhere (`--texture-lod finest`), as light and BDPT
    /// vertices read them, instead of the level the camera ray's cone selects.
    pub finest_textures: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 512,
            height: 512,
            spp: 64,
            max_depth: 8,
            seed: 0,
            rr_start_depth: 3,
            rr_mode: RR_THROUGHPUT,
            environment: Vec3::ZERO,
            env_map: None,
            env_scale: 1.0,
            env_rotate: 0.0,
            mis: Heuristic::Power(2.0),
            sampler: SAMPLER_SOBOL,
            light_sampler: LIGHT_SAMPLER_BVH,
            debug_flags: 0,
            aov: crate::layout::AOV_RADIANCE,
            aperture: 0.0,
            focus_distance: None,
            integrator: Integrator::Path,
            paths: None,
            finest_textures: false,
        }
    }
}

impl RenderSettings {
    /// The same render at 16² pixels (or fewer) and 1 sample: it dispatches every kernel the
    /// full render does, specialised alike (`PreparedScene::gpu_features` reads neither size
    /// nor samples), so `bench` runs it untimed first and lavapipe's compiles at a kernel's
    /// first dispatch stay out of the timed render.
    pub fn warm_up(&self) -> RenderSettings {
        RenderSettings {
            width: self.width.min(16),
            height: self.height.min(16),
            spp: 1,
            ..self.clone()
        }
    }

    pub fn pixel_count(&self) -> u64 {
        self.width as u64 * self.height as u64
    }
    pub fn total_samples(&self) -> u64 {
        self.pixel_count() * self.spp as u64
    }

    /// The environment lighting the render and its RGB scale: the `--env` map times
    /// `--env-scale`, or the constant map times `--environment`; None when it is black.
    pub fn environment_map(&self) -> Option<(Arc<EnvironmentMap>, Vec3)> {
        match &self.env_map {
            Some(map) if self.env_scale > 0.0 => {
                Some((Arc::clone(map), Vec3::splat(self.env_scale)))
            }
            Some(_) => None,
            None if self.environment.max_element() > 0.0 => {
                Some((EnvironmentMap::constant(), self.environment))
            }
            None => None,
        }
    }
}

/// Which estimator renders (`--integrator`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Paths from the camera with next event estimation and MIS (`cpu::path`, the wavefront).
    #[default]
    Path,
    /// Paths from the emitters, every vertex joined to the camera.
    Light,
    /// Both subpaths, every (s, t) connection, MIS over all strategies.
    Bdpt,
}

impl Integrator {
    /// The name `--integrator` takes.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Path => "path",
            Integrator::Light => "light",
            Integrator::Bdpt => "bdpt",
        }
    }
}
