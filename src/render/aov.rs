//! AOV layers (`render --aov`, the Python package's `aov=`): properties of the surface each
//! camera ray hits first, each rendered as a pass of its own — over the image's own samples
//! where a denoiser wants them antialiased like the image (albedo, normal, emission, alpha), or
//! as one ray through each pixel's centre where a value must not be averaged (depth, position,
//! uv, IDs). The kernels' `FrameParams::aov` selects the property (`layout::AOV_*`).

use super::backend::Backend;
use super::prepared::PreparedScene;
use super::settings::RenderSettings;
use crate::film::Film;
use crate::image_io::LayerKind;
use crate::layout::*;

/// One AOV layer (the command line's `--aov` values, whose help these comments are).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Aov {
    /// Base colour (factor × texture × vertex colour, linear RGB), black where the camera ray
    /// leaves the scene; averaged over the image's samples (a denoiser's albedo).
    #[value(alias = "base-color")]
    Albedo,
    /// World-space shading normal with its normal map, raw in [−1, 1]; averaged over the
    /// image's samples (a denoiser's normal).
    Normal,
    /// Distance from the eye along the camera ray through the pixel's centre, scene units
    /// (0 where it escapes).
    Depth,
    /// World-space position of the hit through the pixel's centre (0 where it escapes).
    Position,
    /// TEXCOORD_0 (u, v) through the pixel's centre.
    Uv,
    /// The material through the pixel's centre: its index in the file + 1 (0 where nothing is
    /// hit; the default material numbered after the file's last).
    Material,
    /// The placement through the pixel's centre (0 where nothing is hit): 1 for the meshes
    /// baked into world space, k + 2 for the k-th node that places a mesh several nodes share.
    Instance,
    /// Emitted radiance (emissive factor × texture × strength), averaged.
    Emission,
    /// Coverage: the fraction of the pixel's samples whose camera ray hits a surface.
    Alpha,
}

impl Aov {
    pub const ALL: [Aov; 9] = [
        Aov::Albedo,
        Aov::Normal,
        Aov::Depth,
        Aov::Position,
        Aov::Uv,
        Aov::Material,
        Aov::Instance,
        Aov::Emission,
        Aov::Alpha,
    ];

    /// The layer's name (its EXR channels' prefix).
    pub fn name(self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::Position => "position",
            Aov::Uv => "uv",
            Aov::Material => "material",
            Aov::Instance => "instance",
            Aov::Emission => "emission",
            Aov::Alpha => "alpha",
        }
    }

    /// The layer of `name` (`base-color` is albedo's other name).
    pub fn from_name(name: &str) -> Option<Aov> {
        match name {
            "base-color" | "base_color" => Some(Aov::Albedo),
            _ => Aov::ALL.into_iter().find(|a| a.name() == name),
        }
    }

    /// `FrameParams::aov` of its pass.
    pub fn code(self) -> u32 {
        match self {
            Aov::Albedo => AOV_BASE_COLOR,
            Aov::Normal => AOV_NORMAL,
            Aov::Depth => AOV_DEPTH,
            Aov::Position => AOV_POSITION,
            Aov::Uv => AOV_UV,
            Aov::Material => AOV_MATERIAL,
            Aov::Instance => AOV_INSTANCE,
            Aov::Emission => AOV_EMISSION,
            Aov::Alpha => AOV_ALPHA,
        }
    }

    /// How an image file holds it.
    pub fn kind(self) -> LayerKind {
        match self {
            Aov::Albedo | Aov::Emission => LayerKind::Color,
            Aov::Normal => LayerKind::Direction,
            Aov::Depth => LayerKind::Depth,
            Aov::Position => LayerKind::Point,
            Aov::Uv => LayerKind::Uv,
            Aov::Material | Aov::Instance => LayerKind::Id,
            Aov::Alpha => LayerKind::Alpha,
        }
    }

    /// Whether the layer is one camera ray through each pixel's centre (exact, not averaged)
    /// rather than the mean over the image's own samples.
    pub fn through_centre(self) -> bool {
        matches!(
            self,
            Aov::Depth | Aov::Position | Aov::Uv | Aov::Material | Aov::Instance
        )
    }
}

/// The pass of `aov` for an image of `settings` rendered with samples 0..`samples`: the same
/// samples with the same random numbers (so the layer lines up with the image's
/// antialiasing), or one ray through each pixel's centre.
pub fn render_aov(
    backend: &dyn Backend,
    prepared: &PreparedScene,
    settings: &RenderSettings,
    aov: Aov,
    samples: u32,
) -> anyhow::Result<Film> {
    let never = std::sync::atomic::AtomicBool::new(false);
    let hidden = indicatif::ProgressBar::hidden();
    let mut s = RenderSettings {
        aov: aov.code(),
        paths: None,
        ..settings.clone()
    };
    let range = if aov.through_centre() {
        s.debug_flags |= FLAG_PIXEL_CENTRE;
        0..1
    } else {
        0..samples
    };
    let (out, _) = backend.render_range(prepared, &s, range, &hidden, &never)?;
    if let Some(fault) = out.stats.fault {
        anyhow::bail!("layer {}: {fault}", aov.name());
    }
    Ok(out.film)
}
