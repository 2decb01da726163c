//! `wavetrace verify`: each scene rendered on the GPU and with the CPU reference (independent
//! seeds, the same settings), or once against a stored reference, then the per-tile Welch test;
//! a line per scene, a summary, and the reports of `wavetrace::verify` on request.

use super::options::{
    parse_alpha, parse_fraction, parse_unit_interval, DeviceKind, IntegratorArg, RenderOptions,
};
use super::prepare::{prepare, resolve_device};
use anyhow::{bail, Context as _, Result};
use clap::Args;
use std::time::Instant;
use wavetrace::flip::{flip, DisplayImage};
use wavetrace::gpu::{GpuOptions, GpuRenderer};
use wavetrace::render::RenderSettings;
use wavetrace::stats::compare_films;
use wavetrace::stats::PowerModel;
use wavetrace::verify::{
    json_report, junit_xml, write_report, DetectPlan, Judgement, RunInfo, SceneVerdict,
};

#[derive(Args, Debug, Clone)]
pub struct VerifyArgs {
    /// Scene files (.gltf or .glb), verified one after the other.
    #[arg(required = true)]
    pub scenes: Vec<std::path::PathBuf>,
    /// Test one render against this stored reference (.exr written by wavetrace) instead of
    /// rendering both sides; with several scenes, one reference per scene in the same order.
    #[arg(long, value_name = "REF.exr")]
    pub against: Vec<std::path::PathBuf>,
    /// With --against: which integrator renders.
    #[arg(long, value_enum, default_value_t = DeviceKind::Gpu)]
    pub device: DeviceKind,
    /// Tile size in pixels: one Welch test per tile and channel.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub tile: u32,
    /// Family-wise significance level of each scene's test, Šidák-corrected over tiles × channels.
    #[arg(long, default_value_t = 0.01, value_parser = parse_alpha)]
    pub alpha: f64,
    /// Write the images, z-score heat maps and index.html into this folder.
    #[arg(long, value_name = "DIR")]
    pub report: Option<std::path::PathBuf>,
    /// Write a JUnit XML file (one test case per scene).
    #[arg(long, value_name = "FILE.xml")]
    pub junit: Option<std::path::PathBuf>,
    /// Write every figure as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<std::path::PathBuf>,
    /// Choose each scene's sample count so that the test detects a relative bias of the GPU
    /// image of this size (e.g. 0.5% or 0.005) with probability --power, from pilot renders at
    /// --spp, and report that power. Renders with the independent sampler (the power model
    /// needs the film's variance to be the pixel mean's).
    #[arg(long, value_name = "BIAS", value_parser = parse_fraction)]
    pub detect: Option<f64>,
    /// With --detect: the probability of rejecting when the bias is there.
    #[arg(long, default_value_t = 0.9, value_parser = parse_alpha)]
    pub power: f64,
    /// With --detect: at most this many samples per pixel on each side.
    #[arg(long, default_value_t = 65536, value_parser = clap::value_parser!(u32).range(1..=16_777_216))]
    pub detect_max_spp: u32,
    /// With --against a reference that carries no variance (a .png or .jpg, or an .exr without
    /// wavetrace's variance and count layers, e.g. from another renderer): judge by NVIDIA's
    /// FLIP perceptual error instead, passing where its mean is at most E.
    #[arg(long, value_name = "E", value_parser = parse_unit_interval)]
    pub max_flip: Option<f64>,
    /// With --against: judge even where the reference's recorded settings differ from the
    /// render's in what decides the image (max depth, size, camera, lighting, …); without it
    /// such a scene fails, every difference named.
    #[arg(long)]
    pub allow_settings_mismatch: bool,
    #[command(flatten)]
    pub opts: RenderOptions,
}

/// The recorded settings that decide a render's expectation: a reference must match the render
/// in these. The others (samples, seed, sampler, MIS, roulette, light sampler, device, version,
/// instancing, layers) change only the noise, so a reference may differ in them.
const DECIDING_SETTINGS: &[&str] = &[
    "scene_hash",
    "width",
    "height",
    "camera",
    "camera_placed",
    "aperture",
    "focus_distance",
    "paths",
    "max_depth",
    "environment",
    "sky",
    "texture_lod",
    "energy_compensation",
    "moment",
];

/// Runs every scene; true if all agree.
pub fn verify(args: &VerifyArgs) -> Result<bool> {
    if !args.against.is_empty() && args.against.len() != args.scenes.len() {
        bail!(
            "--against names {} references for {} scenes: give one per scene, in the same order",
            args.against.len(),
            args.scenes.len()
        );
    }
    if args.opts.integrator != IntegratorArg::Path || args.opts.paths.is_some() {
        bail!(
            "verify compares the path tracer (--integrator path, all paths): its per-tile test \
             takes a tile's pixels as independent, which light tracing's splats are not \
             (tests/integrators/bidir.rs compares the light and bidirectional integrators over independent batches)"
        );
    }
    if args.detect.is_some() && !args.against.is_empty() {
        bail!("--detect chooses the sample count of the GPU and CPU renders; it does not apply with --against");
    }
    if args.max_flip.is_none() {
        if let Some(image) = args
            .against
            .iter()
            .find(|r| !r.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")))
        {
            bail!(
                "{}: the reference carries no variance (not an EXR written by wavetrace), so the statistical \
                 test cannot judge it; give --max-flip E to judge by NVIDIA's FLIP perceptual error",
                image.display()
            );
        }
    }
    if args.against.is_empty() && args.device == DeviceKind::Cpu {
        bail!("--device cpu: without --against, verify renders each scene on the GPU and with the CPU reference; --device chooses the side that renders against a stored reference (--against REF.exr)");
    }
    let side = if args.against.is_empty() {
        DeviceKind::Gpu
    } else {
        resolve_device(args.device, args.opts.gpu_index.as_ref().map(|_| 0))
    };
    let needs_gpu = args.against.is_empty() || side == DeviceKind::Gpu;
    let gpu = if needs_gpu {
        Some(GpuRenderer::new(&GpuOptions {
            device_index: match &args.opts.gpu_index {
                None => None,
                Some(g) => Some(g.one().ok_or_else(|| {
                    anyhow::anyhow!("verify renders on one device: give --gpu-index N")
                })?),
            },
            validation: args.opts.validate,
            timing: false,
            count_fetches: false,
        })?)
    } else {
        None
    };
    let gpu_label = |seed: u32| match &gpu {
        Some(g) => format!("GPU ({}), seed {seed}", g.device().name),
        None => format!("GPU, seed {seed}"),
    };
    let mut verdicts = Vec::new();
    for (i, path) in args.scenes.iter().enumerate() {
        // A scene that cannot be judged is a failed test case; the others still run and the
        // reports are written.
        let mut settings = Vec::new();
        match verify_scene(args, i, path, side, gpu.as_ref(), &gpu_label, &mut settings) {
            Ok(verdict) => verdicts.push(verdict),
            Err(e) => {
                let message = format!("{e:#}");
                eprintln!("error: {}: {message}", path.display());
                verdicts.push(SceneVerdict::error(
                    path.display().to_string(),
                    message,
                    settings,
                ));
            }
        }
    }
    let agreeing = verdicts.iter().filter(|v| v.passed()).count();
    println!(
        "{agreeing} of {} scenes agree{}",
        verdicts.len(),
        if agreeing == verdicts.len() {
            ""
        } else {
            "; the failing tiles are listed above"
        }
    );
    if let Some(dir) = &args.report {
        write_report(dir, &verdicts)?;
        println!("report: {}", dir.join("index.html").display());
    }
    if let Some(file) = &args.junit {
        write_creating_folders(file, &junit_xml(&verdicts))?;
    }
    if let Some(file) = &args.json {
        write_creating_folders(
            file,
            &serde_json::to_string_pretty(&json_report(
                &verdicts,
                &RunInfo {
                    version: super::version::LONG.to_owned(),
                    device: match &gpu {
                        Some(g) => g.device().name.clone(),
                        None => "CPU".to_owned(),
                    },
                },
            ))?,
        )?;
    }
    Ok(agreeing == verdicts.len())
}

/// One scene rendered and judged; `recorded` receives the settings of the rendered side as soon
/// as they are known (for the reports of a scene that fails after that).
#[allow(clippy::too_many_arguments)]
fn verify_scene(
    args: &VerifyArgs,
    i: usize,
    path: &std::path::Path,
    side: DeviceKind,
    gpu: Option<&GpuRenderer>,
    gpu_label: &dyn Fn(u32) -> String,
    recorded: &mut Vec<(String, String)>,
) -> Result<SceneVerdict> {
    let device = side;
    let (_scene, prepared, settings) = prepare(path, &args.opts, device)?;
    let moment = args.opts.moment();
    let record = super::shards::record(&args.opts, path, &prepared, &settings, device, &moment)?;
    *recorded = record.settings.clone();
    if let Some(reference) = args.against.get(i) {
        check_reference_settings(reference, &record, args.allow_settings_mismatch)?;
    }
    let start = Instant::now();
    let render_gpu = |s: &RenderSettings| -> Result<wavetrace::film::Film> {
        let g = gpu
            .as_ref()
            .expect("a GPU renderer exists when a side renders on it");
        Ok(g.render(&prepared, s, args.opts.wavefront)?.film)
    };
    let render_cpu = |s: &RenderSettings| {
        // The debug flags bias the GPU side only: the reference stays the reference.
        let clean = RenderSettings {
            debug_flags: 0,
            ..s.clone()
        };
        wavetrace::cpu::render(&prepared, &clean).film
    };
    // --detect: pilot renders at --spp choose the sample count of the real ones.
    let mut detect = None;
    let mut settings = settings;
    if let Some(bias) = args.detect {
        // The power model needs the film's variance to be that of the pixel mean: independent
        // samples (stats::power).
        settings.sampler = wavetrace::layout::SAMPLER_INDEPENDENT;
        let pilot_cpu = RenderSettings {
            seed: settings.seed.wrapping_add(1),
            ..settings.clone()
        };
        let (pa, pb) = (render_gpu(&settings)?, render_cpu(&pilot_cpu));
        let model = PowerModel::new(&pa, &pb, settings.spp, args.tile, args.alpha);
        let (spp, power) = model.plan(
            bias,
            args.power,
            settings.spp,
            args.detect_max_spp.max(settings.spp),
        );
        println!(
            "{}: --detect {}%: {spp} spp per side gives power {power:.3} (asked {}; pilot {} spp)",
            path.display(),
            bias * 100.0,
            args.power,
            settings.spp
        );
        detect = Some(DetectPlan {
            bias,
            pilot_spp: settings.spp,
            spp,
            power,
            target: args.power,
        });
        // Fresh seeds: the final renders are independent of the pilots that chose their size.
        settings = RenderSettings {
            spp,
            seed: settings.seed.wrapping_add(2),
            ..settings
        };
    }
    let (label_a, a, label_b, b) = match args.against.get(i) {
        None => {
            // Independent seeds: the same seed would draw the same numbers on both sides.
            let cpu_settings = RenderSettings {
                seed: settings.seed.wrapping_add(1),
                ..settings.clone()
            };
            (
                gpu_label(settings.seed),
                render_gpu(&settings)?,
                format!("CPU reference, seed {}", cpu_settings.seed),
                Reference::Film(render_cpu(&cpu_settings)),
            )
        }
        Some(reference) => {
            let b = read_reference(reference, args.max_flip)?;
            let a = match side {
                DeviceKind::Gpu => render_gpu(&settings)?,
                // (resolve_device never answers Auto.)
                DeviceKind::Cpu | DeviceKind::Auto => render_cpu(&settings),
            };
            let label = match side {
                DeviceKind::Gpu => gpu_label(settings.seed),
                DeviceKind::Cpu | DeviceKind::Auto => format!("CPU, seed {}", settings.seed),
            };
            (label, a, format!("reference {}", reference.display()), b)
        }
    };
    let b_film = match &b {
        Reference::Film(f) | Reference::Display(_, f) => f,
    };
    for (label, film) in [(&label_a, &a), (&label_b, b_film)] {
        if film.dropped > 0 {
            eprintln!(
                "note: {}: {label} dropped {} NaN/Inf samples",
                path.display(),
                film.dropped
            );
        }
    }
    let judgement = match b {
        Reference::Film(b) => {
            let comparison = compare_films(&a, &b, args.tile, args.alpha)
                .with_context(|| format!("comparing the two renders of {}", path.display()))?;
            println!("{}: {comparison}", path.display());
            (b, Judgement::Welch(comparison))
        }
        Reference::Display(display, b) => {
            let result = flip(&display, &DisplayImage::from_film(&a))
                .with_context(|| format!("comparing the render of {}", path.display()))?;
            let max = args.max_flip.expect("read_reference asks for --max-flip");
            println!(
                "{}: {}: mean FLIP error {:.6} (at most {max}), median {:.6}, 99th percentile {:.6}, max {:.6}",
                path.display(),
                if result.mean <= max { "PASS" } else { "FAIL" },
                result.mean,
                result.median,
                result.p99,
                result.max
            );
            (b, Judgement::Flip { result, max })
        }
    };
    Ok(SceneVerdict {
        scene: path.display().to_string(),
        label_a,
        label_b,
        a,
        b: judgement.0,
        judgement: judgement.1,
        seconds: start.elapsed().as_secs_f64(),
        detect,
        settings: record.settings,
    })
}

/// Refuses a stored reference whose recorded settings differ from the render's in what decides
/// the image ([`DECIDING_SETTINGS`]), naming every difference, unless `allow` says to judge
/// anyway (then each is a note). A reference without a record (another renderer's image) is
/// not checked.
fn check_reference_settings(
    reference: &std::path::Path,
    render: &wavetrace::shard::Record,
    allow: bool,
) -> Result<()> {
    let is_exr = reference
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if !is_exr {
        return Ok(());
    }
    let (_, attributes) = wavetrace::image_io::read_film_exact(reference)?;
    let Some(stored) = wavetrace::shard::Record::from_attributes(reference, &attributes)? else {
        return Ok(());
    };
    let differences: Vec<String> = DECIDING_SETTINGS
        .iter()
        .filter_map(|&key| {
            let (theirs, ours) = (stored.get(key), render.get(key));
            (theirs != ours).then(|| {
                format!(
                    "{key}: the reference {}, the render {}",
                    theirs.unwrap_or("(not recorded)"),
                    ours.unwrap_or("(not recorded)")
                )
            })
        })
        .collect();
    if differences.is_empty() {
        return Ok(());
    }
    if allow {
        for d in &differences {
            eprintln!(
                "note: {}: {d} (--allow-settings-mismatch)",
                reference.display()
            );
        }
        return Ok(());
    }
    bail!(
        "the reference {} was rendered with other settings than this render, so their images \
         differ whatever the renderer: {}; render the reference again with the same settings, or \
         give --allow-settings-mismatch to judge anyway",
        reference.display(),
        differences.join("; ")
    )
}

/// A stored reference: a wavetrace EXR with variance (judged by the Welch test), or an image
/// without variance as displayed (judged by FLIP), with its film for the report.
enum Reference {
    Film(wavetrace::film::Film),
    Display(DisplayImage, wavetrace::film::Film),
}

/// Reads `--against` file `path`: an EXR with wavetrace's variance and count layers is a film;
/// anything else needs `--max-flip` and is compared as displayed.
fn read_reference(path: &std::path::Path, max_flip: Option<f64>) -> Result<Reference> {
    let is_exr = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if is_exr {
        let data = wavetrace::image_io::read_exr(path)?;
        if data.variance.is_some() && data.count.is_some() {
            return Ok(Reference::Film(wavetrace::image_io::read_film(path)?));
        }
    }
    if max_flip.is_none() {
        bail!(
            "{}: the reference carries no variance (not an EXR written by wavetrace), so the statistical \
             test cannot judge it; give --max-flip E to judge by NVIDIA's FLIP perceptual error",
            path.display()
        );
    }
    let display = DisplayImage::load(path)?;
    let film = display.to_film();
    Ok(Reference::Display(display, film))
}

/// Writes `text` to `file`, creating its folder if needed.
fn write_creating_folders(file: &std::path::Path, text: &str) -> Result<()> {
    if let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(file, text).with_context(|| format!("writing {}", file.display()))
}
