//! What a render is, as the command line gives it: the options `render`, `verify` and `bench`
//! share (size, samples, integrator settings, device, loading limits), `render`'s own arguments,
//! and the parsers of their values. Scripts depend on these names; keep them.

use anyhow::Result;
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use wavetrace::mis::Heuristic;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DeviceKind {
    /// The wavefront path tracer on a Vulkan device.
    Gpu,
    /// The reference path tracer on all CPU cores.
    Cpu,
    /// A real GPU when Vulkan has one, else the CPU reference (on the whole faster than a CPU
    /// Vulkan driver such as lavapipe: on most of the committed scenes `wavetrace bench`
    /// measures, the default Cornell box included); says which.
    Auto,
}

/// How the random numbers of a pixel's samples relate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SamplerArg {
    /// Latin hypercube (N rooks) over the pixel's samples for every 2-D pair.
    Stratified,
    /// Every number independent.
    Independent,
    /// Owen-scrambled, shuffled Sobol (0,2)-sequence over the pixel's samples for every 2-D pair.
    Sobol,
}

impl SamplerArg {
    pub fn code(self) -> u32 {
        match self {
            SamplerArg::Stratified => wavetrace::layout::SAMPLER_STRATIFIED,
            SamplerArg::Independent => wavetrace::layout::SAMPLER_INDEPENDENT,
            SamplerArg::Sobol => wavetrace::layout::SAMPLER_SOBOL,
        }
    }
}

/// How next event estimation picks the emitter to sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LightSamplerArg {
    /// A light BVH over the emitters, descended by each node's importance to the shading point
    /// (Conty Estevez & Kulla 2018); directional lights by power.
    Bvh,
    /// In proportion to emitted power alone, wherever the shading point is.
    Power,
}

impl LightSamplerArg {
    pub fn code(self) -> u32 {
        match self {
            LightSamplerArg::Bvh => wavetrace::layout::LIGHT_SAMPLER_BVH,
            LightSamplerArg::Power => wavetrace::layout::LIGHT_SAMPLER_POWER,
        }
    }
}

/// `--gpu-index`: one device, a list, or every usable one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GpuIndex {
    One(usize),
    List(Vec<usize>),
    All,
}

impl GpuIndex {
    /// The device of a one-device command (`verify`, renders in passes): a list names none.
    pub fn one(&self) -> Option<usize> {
        match self {
            GpuIndex::One(i) => Some(*i),
            _ => None,
        }
    }
}

fn parse_gpu_index(text: &str) -> Result<GpuIndex, String> {
    if text == "all" {
        return Ok(GpuIndex::All);
    }
    let list = text
        .split(',')
        .map(|t| t.trim().parse::<usize>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| format!("'{text}' is not a device index, a list like 0,1 or all"))?;
    Ok(match list.as_slice() {
        [one] => GpuIndex::One(*one),
        _ => GpuIndex::List(list),
    })
}

/// Which estimator renders (`--integrator`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorArg {
    /// Paths from the camera, next event estimation and MIS at every vertex.
    Path,
    /// Paths from the emitters, every vertex joined to the camera (light tracing).
    Light,
    /// Bidirectional path tracing: a camera and a light subpath per sample, joined in every
    /// way, each (s, t) strategy weighted by --mis over all strategies.
    Bdpt,
}

impl IntegratorArg {
    pub fn integrator(self) -> wavetrace::render::Integrator {
        match self {
            IntegratorArg::Path => wavetrace::render::Integrator::Path,
            IntegratorArg::Light => wavetrace::render::Integrator::Light,
            IntegratorArg::Bdpt => wavetrace::render::Integrator::Bdpt,
        }
    }
}

fn parse_paths(s: &str) -> Result<std::sync::Arc<wavetrace::paths::PathExpr>, String> {
    wavetrace::paths::PathExpr::parse(s).map(std::sync::Arc::new)
}

/// An AOV layer written beside the image (`--aov`): the library's, with its help.
pub use wavetrace::render::Aov as AovArg;

/// `--texture-lod`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TextureLodArg {
    Cones,
    Finest,
}

/// One `--aov`: AOV layers, or an extra layer of paths matching an expression.
#[derive(Clone, Debug)]
pub enum AovSpec {
    Properties(Vec<AovArg>),
    Paths {
        name: String,
        expr: std::sync::Arc<wavetrace::paths::PathExpr>,
    },
}

/// Channel and layer names of the image's own, which a path layer may not take.
const RESERVED_LAYER_NAMES: &[&str] = &[
    "R", "G", "B", "A", "variance", "count", "sum", "sum_sq", "albedo", "normal", "depth",
    "position", "uv", "material", "instance", "emission", "alpha", "noisy",
];

fn parse_aov(s: &str) -> Result<AovSpec, String> {
    let Some((name, expr)) = s.split_once('=') else {
        return s
            .split(',')
            .map(|p| {
                AovArg::from_str(p.trim(), true).map_err(|_| {
                    format!(
                        "'{p}' is neither a property (albedo, normal, depth, position, uv, material, instance, emission, alpha) nor NAME=EXPR"
                    )
                })
            })
            .collect::<Result<Vec<_>, _>>()
            .map(AovSpec::Properties);
    };
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(format!(
            "'{name}': a layer name is letters, digits, '_' and '-' (as in caustics=LS+DE)"
        ));
    }
    if RESERVED_LAYER_NAMES.contains(&name) {
        return Err(format!(
            "'{name}' names a channel or layer of the image itself; choose another layer name"
        ));
    }
    let expr = parse_paths(expr)?;
    Ok(AovSpec::Paths {
        name: name.to_owned(),
        expr,
    })
}

impl RenderOptions {
    /// The moment `--animation` and `--time` ask for (the static pose without either).
    pub fn moment(&self) -> wavetrace::scene::Moment {
        if self.animation.is_none() && self.time.is_none() {
            return wavetrace::scene::Moment::rest();
        }
        self.moment_at(self.time.unwrap_or(0.0))
    }

    /// `--animation` (every animation without it) at `time`, for `--time` and sequences.
    pub fn moment_at(&self, time: f32) -> wavetrace::scene::Moment {
        use wavetrace::scene::{Animations, Moment};
        let animations = match self.animation.as_deref() {
            None | Some("all") => Animations::All,
            Some(a) => Animations::One(a.to_owned()),
        };
        Moment { animations, time }
    }

    /// The `--aov PROPERTY,…` layers, in the order first asked for, each once.
    pub fn aov_layers(&self) -> Vec<AovArg> {
        let mut out: Vec<AovArg> = Vec::new();
        for a in &self.aov {
            if let AovSpec::Properties(list) = a {
                for p in list {
                    if !out.contains(p) {
                        out.push(*p);
                    }
                }
            }
        }
        out
    }

    /// The `--aov NAME=EXPR` layers, in order; names are unique.
    pub fn path_layers(
        &self,
    ) -> anyhow::Result<Vec<(String, std::sync::Arc<wavetrace::paths::PathExpr>)>> {
        let mut out: Vec<(String, std::sync::Arc<wavetrace::paths::PathExpr>)> = Vec::new();
        for a in &self.aov {
            if let AovSpec::Paths { name, expr } = a {
                if out.iter().any(|(n, _)| n == name) {
                    anyhow::bail!("--aov {name}=…: two layers are named {name}");
                }
                out.push((name.clone(), expr.clone()));
            }
        }
        Ok(out)
    }
}

/// The seed's combined-sampling weightings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MisArg {
    /// w = p^β / Σ p^β.
    Power,
    /// w = p / Σ p.
    Balance,
    /// w = 1 for the strategy with the largest pdf.
    Maximum,
    /// w = 1/2 each.
    Average,
    /// Emitter sampling alone (BSDF sampling only where emitter sampling cannot reach, e.g.
    /// after a mirror).
    LightOnly,
    /// BSDF sampling alone: no shadow rays.
    BsdfOnly,
}

impl MisArg {
    pub fn heuristic(self, beta: f32) -> Heuristic {
        match self {
            MisArg::Power => Heuristic::Power(beta),
            MisArg::Balance => Heuristic::Balance,
            MisArg::Maximum => Heuristic::Maximum,
            MisArg::Average => Heuristic::Average,
            MisArg::LightOnly => Heuristic::LightOnly,
            MisArg::BsdfOnly => Heuristic::BsdfOnly,
        }
    }
}

/// How Russian roulette chooses survival probabilities.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RrArg {
    /// min(1, largest throughput component).
    Throughput,
    /// The surface's estimated scattering albedo (the lecture's subcritical set-up).
    Albedo,
    /// No roulette: paths end at --max-depth.
    Off,
}

impl RrArg {
    pub fn code(self) -> u32 {
        match self {
            RrArg::Throughput => wavetrace::layout::RR_THROUGHPUT,
            RrArg::Albedo => wavetrace::layout::RR_ALBEDO,
            RrArg::Off => wavetrace::layout::RR_OFF,
        }
    }
}

/// `render --view`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ViewArg {
    Standard,
    KhronosPbrNeutral,
    Agx,
    Filmic,
}

/// `render --look`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LookArg {
    None,
    Punchy,
    Golden,
}

/// `render --exr-precision`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExrPrecisionArg {
    Half,
    Float,
}

/// `render --exr-compression`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExrCompressionArg {
    Zip,
    Piz,
    Dwaa,
    Rle,
    None,
}

/// `render --format` (with `-o -`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    Png,
    Jpeg,
    Exr,
    Hdr,
}

impl FormatArg {
    pub fn extension(self) -> &'static str {
        match self {
            FormatArg::Png => "png",
            FormatArg::Jpeg => "jpg",
            FormatArg::Exr => "exr",
            FormatArg::Hdr => "hdr",
        }
    }
}

fn parse_progress_interval(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!(
            "'{s}': the interval is a positive number of seconds"
        )),
    }
}

fn parse_bit_depth(s: &str) -> Result<u8, String> {
    match s {
        "8" => Ok(8),
        "16" => Ok(16),
        _ => Err(format!("'{s}': a PNG has 8 or 16 bits per channel")),
    }
}

/// How `render` writes its image (`docs/usage.md`, "Output").
#[derive(Args, Debug, Clone)]
pub struct OutputArgs {
    /// Exposure in stops, applied before the view transform (PNG, JPEG, HDR; never EXR).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub exposure: f32,
    /// How a PNG or JPEG shows the scene-linear image: khronos-pbr-neutral (the default: base
    /// colours as they are, highlights compressed towards white), agx (Blender 4's default
    /// view), filmic (Hable's curve), standard (clipped to [0, 1]). EXR and HDR stay linear.
    #[arg(long, value_enum, default_value_t = ViewArg::KhronosPbrNeutral)]
    pub view: ViewArg,
    /// A look of the view transform: punchy or golden (AgX's).
    #[arg(long, value_enum)]
    pub look: Option<LookArg>,
    /// Bits per PNG channel: 8 or 16.
    #[arg(long, value_name = "8|16", default_value_t = 8, value_parser = parse_bit_depth)]
    pub bit_depth: u8,
    /// JPEG quality, 1 to 100.
    #[arg(long, default_value_t = 90, value_parser = clap::value_parser!(u8).range(1..=100))]
    pub quality: u8,
    /// EXR sample type of the image and its colour, normal and uv layers: float (the default:
    /// the EXR also carries each pixel's statistics, which merge and compare read) or half.
    /// Statistics, depth and position stay float.
    #[arg(long, value_enum, default_value_t = ExrPrecisionArg::Float)]
    pub exr_precision: ExrPrecisionArg,
    /// EXR compression: zip (the default), piz, rle and none are lossless; dwaa is lossy and
    /// leaves out the statistics that merge and compare read.
    #[arg(long, value_enum, default_value_t = ExrCompressionArg::Zip)]
    pub exr_compression: ExrCompressionArg,
    /// Camera rays that escape see nothing: the background is alpha 0 in PNG and EXR (film
    /// transparent, as Blender calls it); the environment still lights the scene.
    #[arg(long)]
    pub transparent: bool,
    /// The format of `-o -` (standard output).
    #[arg(long, value_enum)]
    pub format: Option<FormatArg>,
    /// Denoise the image with Intel Open Image Denoise (albedo and normal as its guides); the
    /// noisy image stays in the EXR as layer `noisy`. Install the library with
    /// `bash tools/install_oidn.sh`.
    #[arg(long)]
    pub denoise: bool,
}

impl RenderArgs {
    /// How the render reports its progress.
    pub(crate) fn progress_mode(&self) -> super::report::ProgressMode {
        super::report::ProgressMode {
            quiet: self.quiet,
            interval: self.progress_interval,
        }
    }
}

impl OutputArgs {
    /// The view transform with its look.
    pub fn view(&self) -> Result<wavetrace::view::View> {
        use wavetrace::view::{Look, View};
        let look = match self.look {
            None | Some(LookArg::None) => Look::None,
            Some(LookArg::Punchy) => Look::Punchy,
            Some(LookArg::Golden) => Look::Golden,
        };
        Ok(match (self.view, look) {
            (ViewArg::Agx, look) => View::Agx(look),
            (view, Look::None) => match view {
                ViewArg::Standard => View::Standard,
                ViewArg::KhronosPbrNeutral => View::KhronosPbrNeutral,
                ViewArg::Filmic => View::Filmic,
                ViewArg::Agx => unreachable!(),
            },
            (view, _) => anyhow::bail!(
                "--look: the {} view has no looks; punchy and golden are AgX's (--view agx)",
                view.to_possible_value()
                    .map(|v| v.get_name().to_owned())
                    .unwrap_or_default()
            ),
        })
    }

    /// How the image is encoded.
    pub fn write_options(&self) -> Result<wavetrace::image_io::WriteOptions> {
        use exr::compression::Compression;
        Ok(wavetrace::image_io::WriteOptions {
            exposure: self.exposure,
            view: self.view()?,
            png_bits: self.bit_depth,
            jpeg_quality: self.quality,
            exr_precision: match self.exr_precision {
                ExrPrecisionArg::Half => wavetrace::image_io::ExrPrecision::Half,
                ExrPrecisionArg::Float => wavetrace::image_io::ExrPrecision::Float,
            },
            exr_compression: match self.exr_compression {
                ExrCompressionArg::Zip => Compression::ZIP16,
                ExrCompressionArg::Piz => Compression::PIZ,
                ExrCompressionArg::Dwaa => Compression::DWAA(None),
                ExrCompressionArg::Rle => Compression::RLE,
                ExrCompressionArg::None => Compression::Uncompressed,
            },
        })
    }
}

#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene file; default: scenes/cornell-box.gltf.
    pub scene: Option<PathBuf>,
    /// Which integrator renders: a real GPU if there is one, else the CPU (auto), or say which.
    #[arg(long, value_enum, default_value_t = DeviceKind::Auto)]
    pub device: DeviceKind,
    /// Output image: .exr (linear, with variance) or .png (tonemapped sRGB); default: SCENE.png.
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub out: OutputArgs,
    /// Where standard error is not a terminal (a CI log, a batch job's file), a progress line
    /// every SECONDS instead of one per 10 % of the samples.
    #[arg(long, value_name = "SECONDS", value_parser = parse_progress_interval)]
    pub progress_interval: Option<f64>,
    /// No progress bar or progress lines.
    #[arg(long, short = 'q')]
    pub quiet: bool,
    /// Print per-kernel GPU time.
    #[arg(long)]
    pub stats: bool,
    /// Render in passes of --spp samples per pixel until every pixel's relative standard error
    /// is below E: the standard error of its mean luminance over max(mean luminance, 0.1 × the
    /// image's mean luminance after the first pass). Deterministic: the same seed stops after
    /// the same passes with the same image.
    #[arg(long, value_name = "E", value_parser = parse_target_error, allow_negative_numbers = true)]
    pub target_error: Option<f64>,
    /// With --target-error: each pixel stops on its own once below E, so converged pixels get
    /// no more samples.
    #[arg(long, requires = "target_error")]
    pub adaptive: bool,
    /// With --target-error or --time-limit: at most N samples per pixel, in whole passes of
    /// --spp (default 65536, or --spp if larger).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=wavetrace::render::progressive::MAX_SPP_LIMIT as i64))]
    pub max_spp: Option<u32>,
    /// Render in passes of --spp samples per pixel and stop after the pass during which
    /// SECONDS of rendering have passed (with or without --target-error). Not deterministic:
    /// how many passes fit depends on the machine and its load.
    #[arg(long, value_name = "SECONDS", value_parser = parse_time_limit, allow_negative_numbers = true)]
    pub time_limit: Option<f64>,
    /// With --integrator bdpt or light: write every (s, t) strategy's weighted and unweighted
    /// image to DIR (s light vertices, t camera vertices), and the grid of them,
    /// DIR/strategies.png.
    #[arg(long, value_name = "DIR")]
    pub bdpt_strategies: Option<PathBuf>,
    /// Render only samples START..END (END excluded) of the --spp samples, with the random
    /// numbers the whole render would draw for them: a shard for `wavetrace merge` (.exr only).
    #[arg(long, value_name = "START..END", value_parser = parse_sample_range, conflicts_with = "shard")]
    pub sample_range: Option<wavetrace::shard::SampleRange>,
    /// Render shard I of N (counting from 0): samples ⌊I·spp/N⌋..⌊(I+1)·spp/N⌋, e.g.
    /// `--shard $SLURM_ARRAY_TASK_ID/8` (.exr only).
    #[arg(long, value_name = "I/N", value_parser = wavetrace::shard::parse_shard)]
    pub shard: Option<(u32, u32)>,
    /// Render frames A to B (both included) of the animation at --fps, one image each, frame F
    /// at F / fps seconds: the `#`s of -o become the frame number (out_####.png →
    /// out_0012.png; without `#`s, _#### is added before the extension). The file is read and
    /// the device's kernels built once; each frame poses the scene and rebuilds its BVH. With
    /// --shard I/N, shard I renders its share of the frames (every frame whole).
    #[arg(long, value_name = "A..B", value_parser = parse_frames, conflicts_with_all = ["sample_range", "resume", "target_error", "time_limit", "time", "bdpt_strategies"])]
    pub frames: Option<(u32, u32)>,
    /// With --frames: leave out the frames whose image already exists (a requeued or retried
    /// task continues where it stopped; frames are written whole or not at all).
    #[arg(long, requires = "frames")]
    pub skip_existing: bool,
    /// With --frames: frames per second.
    #[arg(long, value_name = "F", default_value_t = 24.0, requires = "frames", value_parser = parse_fps)]
    pub fps: f64,
    /// Continue the render that wrote PARTIAL.exr (stopped by a signal): give the same scene
    /// and options; renders the samples it lacks and writes the whole (to -o, default
    /// PARTIAL.exr itself).
    #[arg(long, value_name = "PARTIAL.exr")]
    pub resume: Option<PathBuf>,
    /// Test-only: stop as a signal would once N samples per pixel are rendered.
    #[arg(long, value_name = "N", hide = true)]
    pub stop_after: Option<u32>,
    /// Test-only: the GPU film holds at most N pixels at a time (whole rows), as in an image
    /// larger than one storage binding.
    #[arg(long, value_name = "N", hide = true)]
    pub band_pixels: Option<u64>,
    #[command(flatten)]
    pub opts: RenderOptions,
}

/// "A..B", both included, A ≤ B.
fn parse_frames(text: &str) -> Result<(u32, u32), String> {
    let (a, b) = text
        .trim()
        .split_once("..")
        .ok_or_else(|| format!("'{text}': expected FIRST..LAST, e.g. 1..48"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|e| format!("'{text}': '{v}': {e}"))
    };
    let (a, b) = (parse(a)?, parse(b)?);
    if b < a {
        return Err(format!("'{text}': the last frame comes before the first"));
    }
    if b - a >= 1_000_000 {
        return Err(format!("'{text}': at most a million frames at a time"));
    }
    Ok((a, b))
}

/// Frames per second: finite and above 0.
fn parse_fps(text: &str) -> Result<f64, String> {
    let f: f64 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if f.is_finite() && f > 0.0 && f <= 1e6 {
        Ok(f)
    } else {
        Err("frames per second must be a finite number above 0".into())
    }
}

/// "START..END".
fn parse_sample_range(text: &str) -> Result<wavetrace::shard::SampleRange, String> {
    text.parse()
}

/// A relative error: finite and above 0.
fn parse_target_error(text: &str) -> Result<f64, String> {
    let e: f64 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if e.is_finite() && e > 0.0 {
        Ok(e)
    } else {
        Err("the relative error must be a finite number above 0, e.g. 0.05".into())
    }
}

/// A time limit: finite seconds above 0.
fn parse_time_limit(text: &str) -> Result<f64, String> {
    let t: f64 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if t.is_finite() && t > 0.0 {
        Ok(t)
    } else {
        Err("the limit must be a finite number of seconds above 0".into())
    }
}

/// What a render is: its size, samples, integrator settings, device and loading limits (shared
/// by `render` and `verify`).
#[derive(Args, Debug, Clone)]
pub struct RenderOptions {
    /// Samples per pixel.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_048_576))]
    pub spp: u32,
    /// Scattering events per path: 0 shows emitters only, 1 is direct lighting.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub max_depth: u32,
    /// Image width in pixels (default: 512, or from the height and the camera's aspect ratio).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: Option<u32>,
    /// Image height in pixels (default: from the width and the camera's aspect ratio, if any).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: Option<u32>,
    /// Random seed: the same seed gives the same image on the same device.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Which of the file's cameras renders: N is the glTF camera `cameras[N]`, anything else a
    /// camera's or node's name (default: the first camera met in the scene's node tree).
    #[arg(long, value_name = "N|NAME")]
    pub camera: Option<String>,
    /// Pose the file by one of its animations: N is `animations[N]`, anything else its name,
    /// `all` plays every animation at once. An unknown one is an error that lists them.
    #[arg(long, value_name = "N|NAME|all")]
    pub animation: Option<String>,
    /// The moment of the animation to render, in seconds (default 0 with --animation; without
    /// --animation, every animation plays). Before its first keyframe an animation holds its
    /// first value, after its last its last. Without --time or --animation: the file's static
    /// pose.
    #[arg(long, value_name = "SECONDS", value_parser = parse_finite, allow_negative_numbers = true)]
    pub time: Option<f32>,
    /// Place a perspective camera by hand at X,Y,Z looking at --look-at (instead of the file's
    /// camera or the default framing).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_negative_numbers = true,
          requires = "look_at", conflicts_with_all = ["camera", "orbit"])]
    pub from: Option<glam::Vec3>,
    /// The point the --from camera looks at.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_negative_numbers = true,
          requires = "from")]
    pub look_at: Option<glam::Vec3>,
    /// The direction towards the top of the image for --from (default +Y).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_negative_numbers = true,
          requires = "from")]
    pub up: Option<glam::Vec3>,
    /// Place a perspective camera on a sphere about the scene's centre: AZ degrees about +Y from
    /// the default view (+Z side; 90 is +X), EL degrees up, DIST from the centre (default: the
    /// distance at which the bounding sphere fits the view).
    #[arg(long, value_name = "AZ,EL[,DIST]", value_parser = parse_orbit, allow_negative_numbers = true,
          conflicts_with = "camera")]
    pub orbit: Option<(f32, f32, Option<f32>)>,
    /// Vertical field of view in degrees of a perspective camera: the one --from or --orbit
    /// places (default 40), or the file's or the default one.
    #[arg(long, value_name = "DEG", value_parser = parse_fov)]
    pub fov: Option<f32>,
    /// Thin-lens depth of field: the lens diameter in scene units (perspective cameras; default 0,
    /// a pinhole).
    #[arg(long, default_value_t = 0.0, value_parser = parse_aperture, value_name = "D", allow_negative_numbers = true)]
    pub aperture: f32,
    /// Distance along the view of the plane in focus (default: the centre of the scene's
    /// bounding box).
    #[arg(long, value_parser = parse_focus_distance, value_name = "F", allow_negative_numbers = true)]
    pub focus_distance: Option<f32>,
    /// Vulkan device index, as `wavetrace devices` lists them; for `render`, also a list
    /// (`0,1,3`) or `all`: the samples are split into one contiguous range per device, rendered
    /// side by side and merged.
    #[arg(long, value_parser = parse_gpu_index, value_name = "N|N,M,…|all")]
    pub gpu_index: Option<GpuIndex>,
    /// Paths in flight per GPU batch (default: 2^20 on GPUs, 2^17 on CPU Vulkan devices).
    #[arg(long)]
    pub wavefront: Option<u32>,
    /// The estimator: paths from the camera (path), from the emitters joined to the camera
    /// (light), or both joined in every way (bdpt), on the CPU or the GPU alike.
    #[arg(long, value_enum, default_value_t = IntegratorArg::Path)]
    pub integrator: IntegratorArg,
    /// Keep only the paths whose vertices match EXPR, a regular expression over L (emitter),
    /// D (non-delta scattering), S (delta scattering) and E (eye), written emitter-first:
    /// 'LDE' direct diffuse light, 'LS+DE' caustics on diffuse surfaces, 'L(D|S)*E' everything.
    #[arg(long, value_name = "EXPR", value_parser = parse_paths)]
    pub paths: Option<std::sync::Arc<wavetrace::paths::PathExpr>>,
    /// How emitter sampling and BSDF sampling are weighted (multiple importance sampling);
    /// with --integrator bdpt, how all (s, t) strategies are.
    #[arg(long, value_enum, default_value_t = MisArg::Power)]
    pub mis: MisArg,
    /// β of the power heuristic (2 is Veach's recommendation; 1 is the balance heuristic).
    #[arg(long, default_value_t = 2.0, value_parser = parse_beta)]
    pub mis_beta: f32,
    /// Russian roulette: survival by path throughput, by surface albedo, or none.
    #[arg(long, value_enum, default_value_t = RrArg::Throughput)]
    pub rr: RrArg,
    /// Scattering events before Russian roulette starts.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub rr_depth: u32,
    /// How each pixel's samples place their random pairs (pixel position, point on a light,
    /// BSDF direction): N-rooks stratified, independent, or Owen-scrambled Sobol.
    #[arg(long, value_enum, default_value_t = SamplerArg::Sobol)]
    pub sampler: SamplerArg,
    /// How next event estimation picks the emitter to sample: through the light BVH, by each
    /// emitter's importance to the shading point, or by emitted power alone.
    #[arg(long, value_enum, default_value_t = LightSamplerArg::Bvh)]
    pub light_sampler: LightSamplerArg,
    /// AOV layers beside the image, comma-separated and repeatable: properties of the surface
    /// each camera ray hits first — albedo, normal (world space, raw), emission and alpha
    /// averaged over the image's samples; depth, position, uv, material and instance through
    /// each pixel's centre, exact — as EXR layers (albedo.R, normal.X, depth.Z, uv.U,
    /// material.id, …; beside a PNG, colours and normals as files OUTPUT.NAME.png). Or
    /// NAME=EXPR: an extra EXR layer NAME (channels NAME.R, …, NAME.variance.R, …; a PNG output
    /// gets OUTPUT.NAME.png beside it) holding the radiance of only the paths that match
    /// the path expression EXPR (see --paths), from the same paths as the image.
    #[arg(long, value_name = "PROPERTY|NAME=EXPR", value_parser = parse_aov)]
    pub aov: Vec<AovSpec>,
    /// Texture level of detail: the mip level each camera path's ray cone selects, a footprint
    /// per sample (cones, the default), or the finest level everywhere (finest), as light tracing and BDPT read
    /// textures: use it to compare those integrators with the path tracer on textured scenes,
    /// where coarse mip levels of a texture atlas bleed across its islands.
    #[arg(long, value_enum, default_value_t = TextureLodArg::Cones)]
    pub texture_lod: TextureLodArg,
    /// Energy compensation of the GGX lobes (multiple scattering, and the albedo coupling of
    /// the layers below the specular one), as Cycles, Filament and three.js do: on, the
    /// default, or off for glTF's single-scattering model exactly (what the reference scenes
    /// and the specification's formulas are checked with).
    #[arg(long, value_enum, default_value_t = OnOff::On)]
    pub energy_compensation: OnOff,
    /// Radiance of rays that leave the scene: one value (grey) or R,G,B (0: black).
    #[arg(long, value_parser = parse_radiance)]
    pub environment: Option<glam::Vec3>,
    /// What lights the scene from every direction: an equirectangular map FILE (Radiance .hdr or
    /// OpenEXR; +Y up, the image's top row straight up, its centre looking along −Z), `studio`
    /// (the built-in neutral studio) or `none` (black). Without it (and without
    /// --environment), a scene with no light of its own is lit by the studio.
    #[arg(long, value_name = "FILE|studio|none", conflicts_with = "environment", value_parser = parse_env)]
    pub env: Option<EnvArg>,
    /// Light the scene with a physical daylight sky and sun (Preetham et al. 1999; the sun a
    /// directional light): see --sun-elevation, --sun-azimuth, --turbidity. Replaces the
    /// environment; the file's own lights stay.
    #[arg(long, conflicts_with_all = ["env", "environment", "env_rotate", "env_scale"])]
    pub sky: bool,
    /// With --sky: the sun's height above the horizon, 0 to 90 degrees.
    #[arg(long, value_name = "DEG", default_value_t = 45.0, requires = "sky", value_parser = parse_finite)]
    pub sun_elevation: f32,
    /// With --sky: the sun's direction about +Y, from +Z (where a default camera stands) towards
    /// +X (its right), in degrees.
    #[arg(long, value_name = "DEG", default_value_t = 30.0, requires = "sky", allow_negative_numbers = true, value_parser = parse_finite)]
    pub sun_azimuth: f32,
    /// With --sky: atmospheric turbidity, 2 (very clear) to 10 (hazy).
    #[arg(long, value_name = "T", default_value_t = 3.0, requires = "sky", value_parser = parse_finite)]
    pub turbidity: f32,
    /// Turn the environment map by DEG degrees about +Y (counter-clockwise seen from above).
    #[arg(long, value_name = "DEG", default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse_finite)]
    pub env_rotate: f32,
    /// Multiply the environment map's radiance by K.
    #[arg(long, value_name = "K", default_value_t = 1.0, value_parser = parse_scale)]
    pub env_scale: f32,
    /// Run with the Vulkan validation layer (when installed); its errors fail the render.
    #[arg(long)]
    pub validate: bool,
    /// A folder besides the scene's own that buffer and image URIs may read from (repeatable).
    /// Without it, wavetrace reads only files inside the scene file's folder.
    #[arg(long = "allow-path", value_name = "DIR")]
    pub allow_paths: Vec<PathBuf>,
    /// Memory the scene may take: file, buffers, triangles, BVH, film and GPU uploads, e.g.
    /// 512M or 4G (default: half the machine's physical memory).
    #[arg(long, value_parser = wavetrace::scene::parse_size, value_name = "SIZE")]
    pub max_memory: Option<u64>,
    /// Bake every placement of a shared mesh into world space instead of storing the mesh once
    /// and instancing it (memory grows with placements × triangles; for comparisons).
    #[arg(long)]
    pub no_instancing: bool,
    /// Test-only `layout::DEBUG_*` bits for the GPU side (e.g. 1 drops next event estimation).
    #[arg(long, default_value_t = 0, hide = true)]
    pub debug_flags: u32,
}

/// A finite number.
fn parse_finite(text: &str) -> Result<f32, String> {
    let v: f32 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err("must be finite".into())
    }
}

/// A point or direction: three finite numbers X,Y,Z.
fn parse_point(text: &str) -> Result<glam::Vec3, String> {
    let values: Vec<f32> = text
        .split(',')
        .map(parse_finite)
        .collect::<Result<_, _>>()?;
    match values.as_slice() {
        [x, y, z] => Ok(glam::Vec3::new(*x, *y, *z)),
        _ => Err("expected three numbers X,Y,Z".into()),
    }
}

/// `--orbit AZ,EL[,DIST]`: finite angles in degrees (elevation within ±90), a positive
/// distance.
fn parse_orbit(text: &str) -> Result<(f32, f32, Option<f32>), String> {
    let values: Vec<f32> = text
        .split(',')
        .map(parse_finite)
        .collect::<Result<_, _>>()?;
    let (az, el, dist) = match values.as_slice() {
        [az, el] => (*az, *el, None),
        [az, el, d] => (*az, *el, Some(*d)),
        _ => return Err("expected AZ,EL or AZ,EL,DIST (degrees, degrees, scene units)".into()),
    };
    if el.abs() > 90.0 {
        return Err(format!("elevation {el} must lie within -90 and 90 degrees"));
    }
    if dist.is_some_and(|d| d <= 0.0) {
        return Err("the distance must be positive".into());
    }
    Ok((az, el, dist))
}

/// A field of view in degrees, in (0, 180).
fn parse_fov(text: &str) -> Result<f32, String> {
    let v = parse_finite(text)?;
    if v > 0.0 && v < 180.0 {
        Ok(v)
    } else {
        Err(format!(
            "{v}: a field of view lies between 0 and 180 degrees"
        ))
    }
}

/// A finite, non-negative factor.
fn parse_scale(text: &str) -> Result<f32, String> {
    let v = parse_finite(text)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err("must be non-negative".into())
    }
}

/// "v" or "r,g,b": finite, non-negative radiance.
/// A switch given as on or off.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

/// `--env`: a map file, the built-in studio or none (a file named `studio` or `none` is reached
/// as `./studio`).
#[derive(Clone, Debug, PartialEq)]
pub enum EnvArg {
    File(PathBuf),
    Studio,
    None,
}

fn parse_env(text: &str) -> Result<EnvArg, String> {
    Ok(match text {
        "studio" => EnvArg::Studio,
        "none" => EnvArg::None,
        _ => EnvArg::File(PathBuf::from(text)),
    })
}

pub(crate) fn parse_radiance(text: &str) -> Result<glam::Vec3, String> {
    let values: Vec<f32> = text
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|e| format!("'{v}': {e}")))
        .collect::<Result<_, _>>()?;
    let rgb = match values.as_slice() {
        [v] => glam::Vec3::splat(*v),
        [r, g, b] => glam::Vec3::new(*r, *g, *b),
        _ => return Err("expected one value or three (R,G,B)".into()),
    };
    if !rgb.is_finite() || rgb.min_element() < 0.0 {
        return Err("radiance must be finite and non-negative".into());
    }
    Ok(rgb)
}

/// A lens diameter: finite and non-negative.
fn parse_aperture(text: &str) -> Result<f32, String> {
    let d: f32 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if d.is_finite() && d >= 0.0 {
        Ok(d)
    } else {
        Err("the lens diameter must be finite and non-negative".into())
    }
}

/// A focus distance: finite and positive.
fn parse_focus_distance(text: &str) -> Result<f32, String> {
    let f: f32 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if f.is_finite() && f > 0.0 {
        Ok(f)
    } else {
        Err("the distance must be positive and finite".into())
    }
}

/// β of the power heuristic: finite and positive.
fn parse_beta(text: &str) -> Result<f32, String> {
    let beta: f32 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if beta.is_finite() && beta > 0.0 && beta <= 64.0 {
        Ok(beta)
    } else {
        Err("β must lie in (0, 64]".into())
    }
}

/// A relative size: "0.5%" or "0.005", in (0, 1).
pub(crate) fn parse_fraction(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let (number, scale) = match t.strip_suffix('%') {
        Some(n) => (n, 0.01),
        None => (t, 1.0),
    };
    let v: f64 = number
        .trim()
        .parse()
        .map_err(|e| format!("'{text}': {e}"))?;
    let v = v * scale;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err("a relative bias must lie strictly between 0 and 1 (e.g. 0.5% or 0.005)".into())
    }
}

/// A value in [0, 1].
pub(crate) fn parse_unit_interval(text: &str) -> Result<f64, String> {
    let v: f64 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err("must lie in [0, 1]".into())
    }
}

/// A significance level in (0, 1).
pub(crate) fn parse_alpha(text: &str) -> Result<f64, String> {
    let alpha: f64 = text.trim().parse().map_err(|e| format!("'{text}': {e}"))?;
    if alpha > 0.0 && alpha < 1.0 {
        Ok(alpha)
    } else {
        Err("α must lie strictly between 0 and 1".into())
    }
}
