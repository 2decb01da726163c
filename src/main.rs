//! `wavetrace`: render glTF scenes on a Vulkan device or the CPU, list devices, benchmark.

mod cli;
mod shard_cmd;
mod verify_cmd;

use anyhow::{bail, Context as _, Result};
use clap::Parser;
use cli::{
    BenchArgs, Cli, Command, CompareArgs, DeviceKind, EstimatorsArgs, RenderArgs, RenderOptions,
};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::mem::size_of;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use wavetrace::environment::EnvironmentMap;
use wavetrace::gpu::{GpuOptions, GpuRenderer};
use wavetrace::layout::{BvhNode, GpuTriangle, LightEntry};
use wavetrace::render::{PreparedScene, RenderOutput, RenderSettings, RenderStats};
use wavetrace::scene::{Budget, LoadOptions, Scene};

/// Largest image the film may hold (pixels), far above any real render.
const MAX_PIXELS: u64 = 1 << 26;
/// Largest side of an image in pixels.
const MAX_SIDE: u32 = 16384;
/// Width of an image when neither --width nor --height is given.
const DEFAULT_WIDTH: u32 = 512;

/// The image size from --width and --height, filling a missing one from the camera's aspect ratio
/// (width / height: a perspective camera's aspectRatio, an orthographic one's xmag / ymag) where
/// the file gives one, else making the image square.
fn image_size(width: Option<u32>, height: Option<u32>, aspect: Option<f32>) -> (u32, u32) {
    let aspect = aspect.filter(|a| a.is_finite() && *a > 0.0).unwrap_or(1.0) as f64;
    let scaled = |v: u32, by: f64| ((v as f64 * by).round().clamp(1.0, u32::MAX as f64)) as u32;
    match (width, height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, scaled(w, 1.0 / aspect)),
        (None, Some(h)) => (scaled(h, aspect), h),
        (None, None) => (DEFAULT_WIDTH, scaled(DEFAULT_WIDTH, 1.0 / aspect)),
    }
}

fn main() -> ExitCode {
    // A closed pipe (`wavetrace compare a b | head`) ends the process quietly, as for any Unix
    // tool, instead of making println! panic.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(&args),
        Command::Devices => devices(),
        Command::Bench(args) => bench(&args),
        Command::Estimators(args) => return exit_like_diff(estimators(&args)),
        Command::Verify(args) => return exit_like_diff(verify_cmd::verify(&args)),
        Command::Compare(args) => return exit_like_diff(compare(&args)),
        Command::Merge(args) => shard_cmd::merge(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Exit status of the commands that answer a yes/no question, like diff(1): 0 yes, 1 no,
/// 2 error.
fn exit_like_diff(answer: Result<bool>) -> ExitCode {
    match answer {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// The committed scenes folder, from the working directory or from the source tree.
fn scenes_dir() -> PathBuf {
    let local = PathBuf::from("scenes");
    if local.is_dir() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
    }
}

/// Memory per triangle of the GPU uploads: staging and device copies of the BVH nodes,
/// triangles and light table (on a CPU Vulkan device both live in host memory).
const GPU_BYTES_PER_TRIANGLE: u64 =
    2 * (2 * size_of::<BvhNode>() + size_of::<GpuTriangle>() + size_of::<LightEntry>()) as u64;
/// Film memory per pixel: mean and variance accumulators and the sample count, on the host and
/// (for GPU renders) on the device.
const FILM_BYTES_PER_PIXEL: u64 = 32;

/// Reserves the film and, on the GPU, the scene's uploads.
fn reserve_render_memory(
    budget: &Budget,
    triangles: usize,
    pixels: u64,
    device: DeviceKind,
) -> Result<()> {
    let copies = if device == DeviceKind::Gpu { 2 } else { 1 };
    budget.reserve(
        &format!("the film of {pixels} pixels"),
        pixels * FILM_BYTES_PER_PIXEL * copies,
    )?;
    if device == DeviceKind::Gpu {
        budget.reserve(
            &format!("the GPU uploads of {triangles} triangles"),
            triangles as u64 * GPU_BYTES_PER_TRIANGLE,
        )?;
    }
    Ok(())
}

/// A kernel's scene-image fetches per ray it handles: shadow rays for the connect kernels,
/// extension rays for the others (`RenderStats::kernel_fetches`).
fn fetches_per_ray(stats: &RenderStats, kernel: &str) -> Option<(f64, &'static str)> {
    let (_, n) = stats.kernel_fetches.iter().find(|(k, _)| k == kernel)?;
    let (rays, what) = match kernel.starts_with("connect") {
        true => (stats.shadow_rays, "shadow"),
        false => (stats.extension_rays, "extension"),
    };
    Some((*n as f64 / rays.max(1) as f64, what))
}

/// The deferred arrays kernels made for `features` keep per lane: the bottom levels', and the
/// top level's where there is one ("16", "16, top level 2").
fn deferred_slots(features: u32) -> String {
    use wavetrace::layout::{qbvh_stack_size, tlas_stack_size, FEATURE_TOP_LEVEL};
    match features & FEATURE_TOP_LEVEL != 0 {
        true => format!(
            "{}, top level {}",
            qbvh_stack_size(features),
            tlas_stack_size(features)
        ),
        false => qbvh_stack_size(features).to_string(),
    }
}

fn print_stats(stats: &RenderStats, per_kernel: bool) {
    println!(
        "done in {:.3} s: {:.3} M samples/s, {:.3} M rays/s ({} extension + {} shadow rays); {} NaN/Inf samples dropped",
        stats.seconds,
        stats.samples_per_second() * 1e-6,
        stats.rays_per_second() * 1e-6,
        stats.extension_rays,
        stats.shadow_rays,
        stats.dropped
    );
    if let Some(memory) = stats.device_memory.as_ref().filter(|_| per_kernel) {
        println!("{memory}");
    }
    if let Some(features) = stats.kernel_features.filter(|_| per_kernel) {
        let names = wavetrace::layout::feature_names(features);
        println!(
            "kernels made for: {}; deferred slots per lane: {}{}",
            match names.len() {
                0 => "no optional feature (the plain path)".to_string(),
                _ => names.join(", "),
            },
            deferred_slots(features),
            stats.kernels_made.map_or(String::new(), kernels_made_words)
        );
    }
    if per_kernel && !stats.kernel_seconds.is_empty() {
        let total: f64 = stats.kernel_seconds.iter().map(|(_, s)| s).sum();
        for (name, s) in &stats.kernel_seconds {
            println!(
                "  {name:<17} {:>10.3} ms  {:>5.1} %{}",
                s * 1e3,
                100.0 * s / total.max(1e-12),
                fetches_per_ray(stats, name).map_or(String::new(), |(f, rays)| format!(
                    "  {f:>6.1} scene fetches per {rays} ray"
                ))
            );
            if let Some((_, statistics)) = stats.kernel_statistics.iter().find(|(k, _)| k == name) {
                println!(
                    "  {:<17} driver: {}",
                    "",
                    wavetrace::render::statistics_line(statistics)
                );
            }
        }
        if let Some(host) = host_phases(stats) {
            println!("  outside the kernels: {host}");
        }
    }
}

/// How many pipelines the render made before its first sample and how long that took
/// (`RenderStats::kernels_made`), in words.
fn kernels_made_words((made, seconds): (usize, f64)) -> String {
    match made {
        0 => "; its pipelines made for an earlier render".to_string(),
        1 => format!("; 1 pipeline made before the render, in {seconds:.3} s"),
        n => format!("; {n} pipelines made before the render, in {seconds:.3} s"),
    }
}

/// The GPU render's wall time outside its kernels (`RenderStats::host_seconds`), in words.
fn host_phases(stats: &RenderStats) -> Option<String> {
    if stats.host_seconds.is_empty() {
        return None;
    }
    let phases: Vec<String> = stats
        .host_seconds
        .iter()
        .map(|(name, s)| match name.as_str() {
            "between batches" => format!(
                "{name} {:.1} ms ({} submission{})",
                s * 1e3,
                stats.submissions,
                if stats.submissions == 1 { "" } else { "s" }
            ),
            _ => format!("{name} {:.1} ms", s * 1e3),
        })
        .collect();
    Some(phases.join(", "))
}

/// A progress bar over the render's samples on stderr (hidden when stderr is not a terminal);
/// renders in passes restart it each pass, with the pass in its message.
fn progress_bar(samples: u64) -> ProgressBar {
    let bar = ProgressBar::new(samples);
    if let Ok(style) = ProgressStyle::with_template(
        "{bar:40} {percent:>3}%  {elapsed_precise} elapsed, {eta} left  {msg}",
    ) {
        bar.set_style(style);
    }
    bar
}

/// Loads `path` under the options' limits and reserves what rendering it on `device` will take;
/// returns the scene and the settings the options ask for, and prints the scene's notes.
fn prepare(
    path: &Path,
    opts: &RenderOptions,
    device: DeviceKind,
) -> Result<(Scene, PreparedScene, RenderSettings)> {
    let options = LoadOptions {
        allow_paths: opts.allow_paths.clone(),
        budget: Budget::new(
            opts.max_memory
                .unwrap_or_else(wavetrace::scene::default_memory_budget),
        ),
        instancing: !opts.no_instancing,
    };
    let mut scene = Scene::load_with(path, &options)?;
    if let Some(which) = &opts.camera {
        scene.select_camera(which)?;
    }
    let prepared = PreparedScene::new(&scene);
    let (width, height) = image_size(opts.width, opts.height, scene.camera.aspect_ratio());
    if width > MAX_SIDE || height > MAX_SIDE || width as u64 * height as u64 > MAX_PIXELS {
        bail!(
            "{width}×{height} is too large (at most {MAX_SIDE} pixels a side and {MAX_PIXELS} in all); \
             render a smaller image"
        );
    }
    reserve_render_memory(
        &options.budget,
        prepared.triangles.len(),
        width as u64 * height as u64,
        device,
    )?;
    let env_map = match &opts.env {
        Some(file) => {
            let left = options.budget.limit().saturating_sub(options.budget.used());
            let map = EnvironmentMap::load(file, left)?;
            options.budget.reserve(
                &format!("the environment map {}", file.display()),
                (map.texels.len() + map.conditional.len() + map.marginal.len()) as u64
                    * 4
                    * if device == DeviceKind::Gpu { 2 } else { 1 },
            )?;
            Some(std::sync::Arc::new(map))
        }
        None => None,
    };
    let settings = RenderSettings {
        width,
        height,
        spp: opts.spp,
        max_depth: opts.max_depth,
        seed: opts.seed,
        environment: opts.environment,
        env_map,
        env_scale: opts.env_scale,
        env_rotate: opts.env_rotate,
        mis: opts.mis.heuristic(opts.mis_beta),
        sampler: opts.sampler.code(),
        light_sampler: opts.light_sampler.code(),
        rr_mode: opts.rr.code(),
        rr_start_depth: opts.rr_depth,
        debug_flags: opts.debug_flags,
        aov: opts.aov_property()?.code(),
        aperture: opts.aperture,
        focus_distance: opts.focus_distance,
        integrator: opts.integrator.integrator(),
        paths: opts.paths.clone(),
        finest_textures: opts.texture_lod == crate::cli::TextureLodArg::Finest,
    };
    prepared
        .thin_lens(&settings)
        .with_context(|| format!("{}", path.display()))?;
    wavetrace::cpu::bidir::check(&prepared, &settings)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    for note in &scene.notes {
        eprintln!("note: {}: {note}", path.display());
    }
    if prepared.lights.is_empty()
        && settings.environment_map().is_none()
        && settings.aov == wavetrace::layout::AOV_RADIANCE
    {
        eprintln!(
            "note: {}: nothing emits light (no emissive surfaces, punctual lights or environment): the image will be black",
            path.display()
        );
    }
    Ok((scene, prepared, settings))
}

/// `--device auto`: a GPU (discrete, integrated or virtual) when the Vulkan loader reports a
/// usable one or `--gpu-index` names a device, else the CPU reference, which `wavetrace bench`
/// measures faster than a CPU Vulkan driver (lavapipe) on most of the committed scenes (the
/// default Cornell box by about 1.3×; lavapipe leads on two or three of the nine by up to
/// 1.16×, README "Performance"). Says which.
pub(crate) fn resolve_device(kind: DeviceKind, gpu_index: Option<usize>) -> DeviceKind {
    if kind != DeviceKind::Auto {
        return kind;
    }
    if gpu_index.is_some() {
        eprintln!("device auto: gpu (--gpu-index names one)");
        return DeviceKind::Gpu;
    }
    match wavetrace::gpu::list_devices() {
        Ok(devices) => match devices.iter().find(|d| d.renders() && d.kind != "cpu") {
            Some(d) => {
                eprintln!("device auto: gpu ({})", d.name);
                DeviceKind::Gpu
            }
            None => {
                let cpu_drivers: Vec<&str> = devices
                    .iter()
                    .filter(|d| d.renders())
                    .map(|d| d.name.as_str())
                    .collect();
                eprintln!(
                    "device auto: cpu (no GPU{}; the CPU reference is the faster there)",
                    if cpu_drivers.is_empty() {
                        String::new()
                    } else {
                        format!(", only the CPU Vulkan driver {}", cpu_drivers.join(", "))
                    }
                );
                DeviceKind::Cpu
            }
        },
        Err(_) => {
            eprintln!("device auto: cpu (no Vulkan driver)");
            DeviceKind::Cpu
        }
    }
}

fn render(args: &RenderArgs) -> Result<()> {
    let path = args
        .scene
        .clone()
        .unwrap_or_else(|| scenes_dir().join("cornell-box.gltf"));
    // The strategy images are written by the CPU twin.
    let cpu_only = args.bdpt_strategies.is_some();
    if cpu_only && args.device == DeviceKind::Gpu {
        bail!("--bdpt-strategies writes the CPU integrator's strategy images: add --device cpu");
    }
    let device = if cpu_only && args.device == DeviceKind::Auto {
        eprintln!(
            "device auto: cpu (--bdpt-strategies writes the CPU integrator's strategy images)"
        );
        DeviceKind::Cpu
    } else {
        resolve_device(args.device, args.opts.gpu_index.as_ref().map(|_| 0))
    };
    let (_scene, prepared, settings) = prepare(&path, &args.opts, device)?;
    let (width, height) = (settings.width, settings.height);
    let default_output = PathBuf::from(format!(
        "{}.png",
        path.file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("render")
    ));
    let mut record = shard_cmd::record(args, &path, &prepared, &settings, device)?;
    let progressive = progressive_options(args, &settings)?;
    if settings.integrator != wavetrace::cpu::Integrator::Path && progressive.is_some() {
        bail!("--target-error and --time-limit render in passes with --integrator path only");
    }
    if args.bdpt_strategies.is_some() {
        if settings.integrator == wavetrace::cpu::Integrator::Path {
            bail!("--bdpt-strategies needs --integrator bdpt (or light)");
        }
        if args.sample_range.is_some() || args.shard.is_some() || args.resume.is_some() {
            bail!("--bdpt-strategies renders every sample: it does not combine with --sample-range, --shard or --resume");
        }
    }
    let path_layers = args.opts.path_layers()?;
    if !path_layers.is_empty() {
        let refuse = |what: &str| -> Result<()> {
            bail!("--aov NAME=EXPR renders its layers beside a whole image: it does not combine with {what}")
        };
        if progressive.is_some() {
            refuse("--target-error or --time-limit")?;
        }
        if args.sample_range.is_some() || args.shard.is_some() || args.resume.is_some() {
            refuse("--sample-range, --shard or --resume")?;
        }
        if args.bdpt_strategies.is_some() {
            refuse("--bdpt-strategies")?;
        }
        if settings.aov != wavetrace::layout::AOV_RADIANCE {
            refuse("a property --aov (path layers hold radiance)")?;
        }
        if multi_gpu(&args.opts.gpu_index).is_some() {
            refuse("several --gpu-index devices")?;
        }
    }
    let plan = shard_cmd::plan(args, &record, progressive.is_some(), default_output)?;
    let output = plan.output.clone();
    // Samples to render now (a test may stop them early, as a signal would).
    let todo = match args.stop_after {
        Some(n) => plan.todo.start..plan.todo.end.min(plan.todo.start.saturating_add(n)),
        None => plan.todo.as_range(),
    };
    let stop = shard_cmd::stop_flag(progressive.is_some());
    let mut end = todo.end;
    match output.extension().and_then(|e| e.to_str()) {
        Some("exr") | Some("png") => {}
        _ => bail!("{}: the output must end in .exr or .png", output.display()),
    }
    let b = &prepared.bvh.stats;
    println!(
        "{}: {} triangles stored, {} placements, {} emitting{}, {} materials{}, {} textures ({:.1} MiB with mip levels); BVH {} nodes, depth {}, SAH cost {:.2}, built in {:.2} ms{}",
        path.display(),
        prepared.triangles.len(),
        prepared.instances.len(),
        prepared.lights.len(),
        // `--light-sampler bvh` where the tree cannot tell the emitters apart (render.rs).
        if settings.light_sampler == wavetrace::layout::LIGHT_SAMPLER_BVH
            && prepared.light_power_alike
        {
            " (sampled by power: their light BVH cannot tell them apart)"
        } else {
            ""
        },
        prepared.materials.len(),
        if prepared.plain_diffuse() {
            " (all plain diffuse)"
        } else {
            ""
        },
        prepared.textures.len(),
        (prepared.texels.len() * 4) as f64 / (1 << 20) as f64,
        b.nodes,
        b.max_depth,
        b.sah_cost,
        b.build_time.as_secs_f64() * 1e3,
        if prepared.light_nodes.is_empty() {
            String::new()
        } else {
            format!(
                "; light BVH {} nodes, built in {:.2} ms",
                prepared.light_nodes.len(),
                prepared.light_bvh_time.as_secs_f64() * 1e3
            )
        }
    );
    let how = match &progressive {
        None if plan.target.len() == settings.spp && plan.partial.is_none() => {
            format!("at {} spp", args.opts.spp)
        }
        None => format!(
            "samples {}..{} of {} spp{}",
            plan.todo.start,
            plan.todo.end,
            args.opts.spp,
            match &plan.partial {
                Some(p) => format!(
                    " (continuing {}, which holds {}..{})",
                    p.path.display(),
                    plan.target.start,
                    plan.todo.start
                ),
                None => String::new(),
            }
        ),
        Some(p) => format!(
            "in passes of {} spp (at most {}){}{}{}",
            args.opts.spp,
            p.max_passes(settings.spp) * settings.spp,
            p.target_error
                .map(|e| format!(", target relative error {e}"))
                .unwrap_or_default(),
            if p.adaptive { " per pixel" } else { "" },
            p.time_limit
                .map(|t| format!(", time limit {t} s"))
                .unwrap_or_default()
        ),
    };
    let mut report = None;
    let RenderOutput { film, stats } = match device {
        DeviceKind::Gpu if progressive.is_none() && multi_gpu(&args.opts.gpu_index).is_some() => {
            let devices = multi_gpu(&args.opts.gpu_index).unwrap()?;
            let progress = progress_bar(settings.pixel_count() * todo.len() as u64);
            let out = render_on_devices(
                args,
                &prepared,
                &settings,
                &devices,
                todo.clone(),
                &how,
                &progress,
            );
            progress.finish_and_clear();
            out?
        }
        DeviceKind::Gpu => {
            let mut gpu = GpuRenderer::new(&GpuOptions {
                device_index: match &args.opts.gpu_index {
                    None => None,
                    Some(g) => Some(g.one().ok_or_else(|| {
                        anyhow::anyhow!("renders in passes run on one device: give --gpu-index N")
                    })?),
                },
                validation: args.opts.validate,
                timing: true,
                count_fetches: args.stats,
            })?;
            gpu.set_band_pixel_limit(args.band_pixels);
            println!(
                "rendering {width}×{height} {how}, max depth {}, on {} (Vulkan {}, {})",
                args.opts.max_depth,
                gpu.device().name,
                gpu.device().api_version,
                gpu.device().driver
            );
            let progress = progress_bar(settings.pixel_count() * todo.len() as u64);
            let out = match &progressive {
                None => gpu
                    .render_range_with_progress(
                        &prepared,
                        &settings,
                        args.opts.wavefront,
                        todo.clone(),
                        &progress,
                        stop,
                    )
                    .map(|(out, e)| {
                        end = e;
                        out
                    }),
                Some(p) => gpu
                    .render_progressive(&prepared, &settings, args.opts.wavefront, p, &progress)
                    .map(|(out, r)| {
                        report = Some(r);
                        out
                    }),
            };
            progress.finish_and_clear();
            out?
        }
        // (resolve_device never answers Auto.)
        DeviceKind::Cpu | DeviceKind::Auto => {
            println!(
                "rendering {width}×{height} {how}, max depth {}, on the CPU ({} threads)",
                args.opts.max_depth,
                rayon::current_num_threads()
            );
            let progress = progress_bar(settings.pixel_count() * todo.len() as u64);
            let out = match &progressive {
                None if args.bdpt_strategies.is_some() => {
                    let dir = args.bdpt_strategies.as_ref().unwrap();
                    let (out, strategies) =
                        wavetrace::cpu::render_strategies(&prepared, &settings, &progress);
                    wavetrace::cpu::bidir::write_strategies(&strategies, dir, args.exposure)?;
                    println!(
                        "wrote {} strategy images and strategies.png to {}",
                        2 * strategies.films.len(),
                        dir.display()
                    );
                    out
                }
                None => {
                    let (out, e) = wavetrace::cpu::render_range(
                        &prepared,
                        &settings,
                        todo.clone(),
                        &progress,
                        stop,
                    );
                    end = e;
                    out
                }
                Some(p) => {
                    let (out, r) =
                        wavetrace::cpu::render_progressive(&prepared, &settings, p, &progress);
                    report = Some(r);
                    out
                }
            };
            progress.finish_and_clear();
            out
        }
    };
    print_stats(&stats, args.stats);
    if let Some(r) = &report {
        println!("{r}");
    }
    let fault = stats.fault.clone();
    let (film, interrupted) = if progressive.is_some() {
        // Renders in passes hold different samples per pixel: no range to merge or resume.
        record.samples = None;
        record.target = None;
        record.dropped = film.dropped;
        (film, false)
    } else {
        let target = plan.target;
        let (film, r) = shard_cmd::finish(plan, film, end, record);
        record = r;
        (film, end < target.end)
    };
    // (After a fault the device is gone: the layers are left out of the partial image.)
    let layers = match fault {
        None => render_path_layers(args, &prepared, &settings, device, &path_layers, end)?,
        Some(_) => Vec::new(),
    };
    wavetrace::image_io::write_image_layers(
        &film,
        &layers,
        &output,
        args.exposure,
        &record.attributes(),
    )?;
    println!("wrote {}", output.display());
    if let Some(fault) = fault {
        let held = record
            .samples
            .map_or_else(|| "no samples".to_owned(), |r| format!("samples {r}"));
        bail!(
            "{fault}: {} holds the {held} finished before it{}",
            output.display(),
            resume_hint(&output, "")
        );
    }
    if interrupted {
        let held = record.samples.expect("fixed-range renders have a range");
        eprintln!(
            "stopped early: {} holds samples {held} of the {} asked for{}",
            output.display(),
            record.target.expect("fixed-range renders have a target"),
            resume_hint(
                &output,
                " (write .exr to be able to continue it with --resume)"
            )
        );
        std::process::exit(shard_cmd::INTERRUPTED_EXIT);
    }
    Ok(())
}

/// How to continue a partial render written to `output`: `--resume` for an EXR, else
/// `otherwise`.
fn resume_hint(output: &Path, otherwise: &str) -> String {
    if output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
    {
        format!(
            "; continue with the same command and --resume {}",
            output.display()
        )
    } else {
        otherwise.to_owned()
    }
}

/// The `--aov NAME=EXPR` layers: the image's samples 0..`samples` again with `--paths EXPR` in
/// place of the image's, on the same device with the same random numbers, so each layer holds
/// exactly the image's paths that match its expression.
fn render_path_layers(
    args: &RenderArgs,
    prepared: &PreparedScene,
    settings: &RenderSettings,
    device: DeviceKind,
    layers: &[(String, std::sync::Arc<wavetrace::paths::PathExpr>)],
    samples: u32,
) -> Result<Vec<(String, wavetrace::film::Film)>> {
    if layers.is_empty() {
        return Ok(Vec::new());
    }
    let gpu = match device {
        DeviceKind::Gpu => Some(GpuRenderer::new(&GpuOptions {
            device_index: args.opts.gpu_index.as_ref().and_then(|g| g.one()),
            validation: args.opts.validate,
            timing: false,
            count_fetches: false,
        })?),
        _ => None,
    };
    let never = std::sync::atomic::AtomicBool::new(false);
    let hidden = ProgressBar::hidden();
    layers
        .iter()
        .map(|(name, expr)| {
            let s = RenderSettings {
                paths: Some(expr.clone()),
                ..settings.clone()
            };
            let film = match &gpu {
                Some(g) => g
                    .render_range_with_progress(
                        prepared,
                        &s,
                        args.opts.wavefront,
                        0..samples,
                        &hidden,
                        &never,
                    )
                    .and_then(|(out, _)| match out.stats.fault {
                        Some(fault) => bail!("layer {name}: {fault}"),
                        None => Ok(out.film),
                    })?,
                None => {
                    wavetrace::cpu::render_range(prepared, &s, 0..samples, &hidden, &never)
                        .0
                        .film
                }
            };
            println!("layer {name}: the paths {}", expr.source);
            Ok((name.clone(), film))
        })
        .collect()
}

/// The devices of `--gpu-index LIST|all`, or None for one device.
fn multi_gpu(index: &Option<crate::cli::GpuIndex>) -> Option<Result<Vec<usize>>> {
    match index {
        Some(crate::cli::GpuIndex::List(list)) => Some(Ok(list.clone())),
        Some(crate::cli::GpuIndex::All) => {
            Some(wavetrace::gpu::list_devices().and_then(|devices| {
                // Devices that render every scene; those that render only scenes of one
                // binding per array (SwiftShader, 45 times slower than lavapipe) where there
                // is no other.
                let pick = |full: bool| -> Vec<usize> {
                    devices
                        .iter()
                        .filter(|d| d.renders() && (!full || d.splits_scene_arrays()))
                        .map(|d| d.index)
                        .collect()
                };
                let mut usable = pick(true);
                if usable.is_empty() {
                    usable = pick(false);
                }
                if usable.is_empty() {
                    bail!(
                        "--gpu-index all: no usable Vulkan device ({})",
                        wavetrace::gpu::INSTALL_HINT
                    );
                }
                Ok(usable)
            }))
        }
        _ => None,
    }
}

/// Renders samples `todo` split into one contiguous range per device of `devices`, side by side
/// (a thread and a Vulkan device each), and merges the films: what one render of all samples
/// gives, to float rounding of the sums (`Film::merge`). Reports each device's share and speed.
fn render_on_devices(
    args: &RenderArgs,
    prepared: &wavetrace::render::PreparedScene,
    settings: &RenderSettings,
    devices: &[usize],
    todo: std::ops::Range<u32>,
    how: &str,
    progress: &indicatif::ProgressBar,
) -> Result<RenderOutput> {
    let n = devices.len() as u32;
    let len = todo.end - todo.start;
    println!(
        "rendering {}×{} {how}, max depth {}, on {} Vulkan devices {:?}",
        settings.width, settings.height, args.opts.max_depth, n, devices
    );
    let never = std::sync::atomic::AtomicBool::new(false);
    let start = std::time::Instant::now();
    let results: Vec<Result<(String, std::ops::Range<u32>, RenderOutput)>> =
        std::thread::scope(|scope| {
            let handles: Vec<_> = devices
                .iter()
                .enumerate()
                .map(|(k, &device)| {
                    let k = k as u32;
                    let range = todo.start + (k as u64 * len as u64 / n as u64) as u32
                        ..todo.start + ((k as u64 + 1) * len as u64 / n as u64) as u32;
                    let never = &never;
                    scope.spawn(move || -> Result<_> {
                        let gpu = GpuRenderer::new(&GpuOptions {
                            device_index: Some(device),
                            validation: args.opts.validate,
                            timing: false,
                            count_fetches: false,
                        })?;
                        let name = format!("{device}: {}", gpu.device().name);
                        let (out, _) = gpu.render_range_with_progress(
                            prepared,
                            settings,
                            args.opts.wavefront,
                            range.clone(),
                            progress,
                            never,
                        )?;
                        if let Some(fault) = &out.stats.fault {
                            bail!("{name}: {fault}");
                        }
                        Ok((name, range, out))
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| {
                    h.join()
                        .unwrap_or_else(|_| Err(anyhow::anyhow!("a device's thread panicked")))
                })
                .collect()
        });
    let mut film = wavetrace::film::Film::new(settings.width, settings.height);
    let mut stats = RenderStats::default();
    for result in results {
        let (name, range, out) = result?;
        progress.suspend(|| {
            println!(
                "  device {name}: samples {}..{}, {:.3} s, {:.3} M samples/s",
                range.start,
                range.end,
                out.stats.seconds,
                out.stats.samples_per_second() * 1e-6
            )
        });
        film.merge(&out.film);
        stats.samples += out.stats.samples;
        stats.extension_rays += out.stats.extension_rays;
        stats.shadow_rays += out.stats.shadow_rays;
        stats.dropped += out.stats.dropped;
    }
    film.dropped = stats.dropped;
    stats.seconds = start.elapsed().as_secs_f64();
    Ok(RenderOutput { film, stats })
}

/// The pass options of `render` (`--target-error`, `--adaptive`, `--max-spp`,
/// `--time-limit`), checked against the settings; None for a render of exactly --spp samples.
fn progressive_options(
    args: &RenderArgs,
    settings: &RenderSettings,
) -> Result<Option<wavetrace::progressive::Progressive>> {
    if args.target_error.is_none() && args.time_limit.is_none() {
        if args.max_spp.is_some() {
            bail!("--max-spp caps renders in passes: give --target-error or --time-limit too");
        }
        return Ok(None);
    }
    let p = wavetrace::progressive::Progressive {
        target_error: args.target_error,
        adaptive: args.adaptive,
        max_spp: args
            .max_spp
            .unwrap_or(wavetrace::progressive::DEFAULT_MAX_SPP.max(settings.spp)),
        time_limit: args.time_limit,
    };
    p.check(settings)?;
    Ok(Some(p))
}

fn devices() -> Result<()> {
    let list = wavetrace::gpu::list_devices()?;
    if list.is_empty() {
        bail!(
            "no Vulkan device was found: {}",
            wavetrace::gpu::INSTALL_HINT
        );
    }
    for d in list {
        println!(
            "{}: {} ({}, Vulkan {}, {}){}",
            d.index,
            d.name,
            d.kind,
            d.api_version,
            d.driver,
            if !d.usable {
                format!(
                    " — not usable: needs {}",
                    wavetrace::gpu::context::REQUIREMENTS
                )
            } else if let Some(shortfall) = d.storage_shortfall() {
                format!(" — cannot render: {shortfall} (it runs the twin tests' kernels)")
            } else if !d.splits_scene_arrays() {
                format!(
                    " — renders scenes whose arrays each fit one storage binding (it binds {} \
                     storage buffers per kernel, not {})",
                    d.max_storage_buffers,
                    wavetrace::gpu::pipelines::STORAGE_BUFFERS
                )
            } else {
                String::new()
            }
        );
    }
    Ok(())
}

/// The host's processor as `bench` records it beside its figures: /proc/cpuinfo's first
/// "model name" on Linux, else the architecture. Speed figures belong to a machine (a change of
/// virtual machine from one processor to another moved this project's Cornell box figures by
/// more than most changes do), so a `--baseline` from another processor is said to be one.
fn host_cpu() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines()
                .find_map(|l| l.strip_prefix("model name")?.split_once(':'))
                .map(|(_, name)| name.trim().to_owned())
        })
        .filter(|name| !name.is_empty())
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned())
}

/// What differs between the machine of a `bench --json` document and this run's, as a notice
/// (`None` where the processor, its threads and the GPU, where this run opened one, are the
/// same): ratios against it then compare machines as well as builds.
fn baseline_machine_notice(
    doc: &serde_json::Value,
    cpu: &str,
    threads: usize,
    gpu: Option<&str>,
) -> Option<String> {
    let their_cpu = doc["cpu"].as_str();
    let their_threads = doc["cpu_threads"].as_u64();
    let their_gpu = doc["gpu"].as_str();
    let mut differs = Vec::new();
    match their_cpu {
        None => differs.push("it does not name its processor".to_owned()),
        Some(c) if c != cpu => differs.push(format!("its processor was {c}, this one is {cpu}")),
        Some(_) => {}
    }
    if let Some(t) = their_threads.filter(|&t| t != threads as u64) {
        differs.push(format!("it ran {t} CPU threads, this run {threads}"));
    }
    if let (Some(theirs), Some(ours)) = (their_gpu, gpu) {
        if theirs != ours {
            differs.push(format!("its GPU was {theirs}, this one is {ours}"));
        }
    }
    (!differs.is_empty()).then(|| {
        format!(
            "note: the baseline's machine may not be this one ({}): its ratios compare the machines as well as the builds",
            differs.join("; ")
        )
    })
}

/// An option's value as the command line spells it.
fn value_name(v: &impl clap::ValueEnum) -> String {
    v.to_possible_value()
        .map_or(String::new(), |p| p.get_name().to_owned())
}

fn bench(args: &BenchArgs) -> Result<()> {
    let scenes = if args.scenes.is_empty() {
        let dir = scenes_dir();
        let mut found: Vec<PathBuf> = std::fs::read_dir(&dir)
            .with_context(|| format!("reading {}", dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "gltf" || e == "glb"))
            .collect();
        found.sort();
        found
    } else {
        args.scenes.clone()
    };
    if args.bvh {
        // The GPU's walk beside the CPU's, unless --cpu-only (no Vulkan device is opened).
        let gpu = (!args.cpu_only).then(|| {
            GpuRenderer::new(&GpuOptions {
                device_index: args.gpu_index,
                validation: false,
                timing: true,
                count_fetches: false,
            })
        });
        return bench_bvh(&scenes, args.builds as usize, args.json.as_deref(), gpu);
    }
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        spp: args.spp,
        max_depth: args.max_depth,
        environment: args.environment,
        env_map: match &args.env {
            Some(file) => Some(std::sync::Arc::new(EnvironmentMap::load(
                file,
                wavetrace::scene::default_memory_budget(),
            )?)),
            None => None,
        },
        integrator: args.integrator.integrator(),
        sampler: args.sampler.code(),
        light_sampler: args.light_sampler.code(),
        ..RenderSettings::default()
    };
    if args.kernels {
        return bench_kernels(
            &scenes,
            &settings,
            args.gpu_index,
            args.json.as_deref(),
            args.baseline.as_deref(),
        );
    }
    // How the rows sample, as `--sampler` and `--light-sampler` name it: part of a row's key
    // against a baseline (rows written before these options existed used the defaults).
    let (sampler, light_sampler) = (value_name(&args.sampler), value_name(&args.light_sampler));
    let gpu = if args.cpu_only {
        Err(anyhow::anyhow!("not opened (--cpu-only)"))
    } else {
        GpuRenderer::new(&GpuOptions {
            device_index: args.gpu_index,
            validation: false,
            timing: true,
            // One atomic addition per invocation and kernel: within the run-to-run spread on
            // lavapipe.
            count_fetches: !args.no_fetch_counts,
        })
    };
    let gpu_name = match &gpu {
        Ok(g) => format!("{} ({})", g.device().name, g.device().driver),
        Err(e) => format!("unavailable: {e:#}"),
    };
    let cpu = host_cpu();
    println!(
        "wavetrace bench ({:?} integrator, {sampler} sampler, {light_sampler} light sampler): {}×{} at {} spp, max depth {}; gpu = {gpu_name}; cpu = {cpu}, {} threads",
        settings.integrator,
        args.width,
        args.height,
        args.spp,
        args.max_depth,
        rayon::current_num_threads()
    );
    // Rows of an earlier `bench --json` sampled as these are, by (scene, device): samples/s.
    let baseline: std::collections::HashMap<(String, String), f64> = match &args.baseline {
        Some(file) => {
            let (v, rows) = read_rows_json(file, "bench --json")?;
            if let Some(notice) = baseline_machine_notice(
                &v,
                &cpu,
                rayon::current_num_threads(),
                gpu.is_ok().then_some(gpu_name.as_str()),
            ) {
                println!("{notice}");
            }
            rows.iter()
                .filter(|r| {
                    r["sampler"].as_str().unwrap_or("sobol") == sampler
                        && r["light_sampler"].as_str().unwrap_or("bvh") == light_sampler
                })
                .filter_map(|r| {
                    Some((
                        (
                            r["scene"].as_str()?.to_owned(),
                            r["device"].as_str()?.to_owned(),
                        ),
                        r["samples_per_second"].as_f64()?,
                    ))
                })
                .collect()
        }
        None => Default::default(),
    };
    println!(
        "{:<20} {:<6} {:>9} {:>14} {:>12} {:>9}{}",
        "scene",
        "device",
        "time s",
        "M samples/s",
        "M rays/s",
        "dropped",
        if args.baseline.is_some() {
            "  × baseline"
        } else {
            ""
        }
    );
    let mut json_rows = Vec::new();
    for path in &scenes {
        // Loading (glTF, buffers, images and their mip chains) and preparing (BVH, emitter
        // table, light BVH) timed apart: for a real file they can take longer than its render.
        let start = std::time::Instant::now();
        let scene = Scene::load_with(path, &LoadOptions::default())?;
        let load_ms = start.elapsed().as_secs_f64() * 1e3;
        let start = std::time::Instant::now();
        let prepared = PreparedScene::new(&scene);
        let prepare_ms = start.elapsed().as_secs_f64() * 1e3;
        drop(scene);
        let name = scene_name(path);
        // (device, stats, the untimed warm-up's ms before it where one ran)
        let mut rows: Vec<(&str, RenderStats, Option<f64>)> = Vec::new();
        if let Err(why) = wavetrace::cpu::bidir::check(&prepared, &settings) {
            println!("{name:<20} skipped: {why}");
            continue;
        }
        // Each scene's kernels are specialised for its features, and lavapipe compiles a
        // kernel's code at its first dispatch (seconds on a cold Mesa shader cache: BDPT on
        // cornell-materials 10 s), so an untimed render of a few pixels with the same
        // settings dispatches them first and the timed render reuses its pipelines. Reported
        // apart, as the start-up a first render of the scene pays.
        if let Ok(g) = &gpu {
            let start = std::time::Instant::now();
            let warm_up_ms = match args.no_warm_up {
                true => None,
                false => {
                    g.render(&prepared, &settings.warm_up(), args.wavefront)?;
                    Some(start.elapsed().as_secs_f64() * 1e3)
                }
            };
            let stats = g.render(&prepared, &settings, args.wavefront)?.stats;
            rows.push(("gpu", stats, warm_up_ms));
        }
        if !args.gpu_only {
            rows.push((
                "cpu",
                wavetrace::cpu::render(&prepared, &settings).stats,
                None,
            ));
        }
        for (device, s, warm_up_ms) in rows {
            let ratio = baseline
                .get(&(name.clone(), device.to_owned()))
                .filter(|_| settings.integrator == wavetrace::cpu::Integrator::Path)
                .map_or(String::new(), |b| {
                    format!("  {:>10.3}", s.samples_per_second() / b)
                });
            println!(
                "{name:<20} {device:<6} {:>9.3} {:>14.3} {:>12.3} {:>9}{ratio}",
                s.seconds,
                s.samples_per_second() * 1e-6,
                s.rays_per_second() * 1e-6,
                s.dropped
            );
            json_rows.push(serde_json::json!({
                "scene": name,
                "device": device,
                "integrator": format!("{:?}", settings.integrator).to_lowercase(),
                "sampler": sampler,
                "light_sampler": light_sampler,
                "device_name": if device == "gpu" { gpu_name.clone() } else { format!("CPU reference, {} threads", rayon::current_num_threads()) },
                "seconds": s.seconds,
                "samples_per_second": s.samples_per_second(),
                "rays_per_second": s.rays_per_second(),
                "extension_rays": s.extension_rays,
                "shadow_rays": s.shadow_rays,
                "dropped": s.dropped,
                "kernel_ms": s.kernel_seconds.iter().map(|(k, t)| (k.clone(), serde_json::json!(t * 1e3))).collect::<serde_json::Map<_, _>>(),
                "host_ms": s.host_seconds.iter().map(|(k, t)| (k.clone(), serde_json::json!(t * 1e3))).collect::<serde_json::Map<_, _>>(),
                "submissions": s.submissions,
                "scene_reads": s.device_memory.as_ref().map(|m| m.scene_reads),
                "kernel_statistics": statistics_json(&s.kernel_statistics),
                "kernel_fetches_per_ray": s.kernel_seconds.iter().filter_map(|(k, _)| Some((k.clone(), serde_json::json!(fetches_per_ray(&s, k)?.0)))).collect::<serde_json::Map<_, _>>(),
                "bvh_build_ms": prepared.bvh.stats.build_time.as_secs_f64() * 1e3,
                "light_bvh_build_ms": prepared.light_bvh_time.as_secs_f64() * 1e3,
                "load_ms": load_ms,
                "prepare_ms": prepare_ms,
                "triangles": prepared.triangles.len(),
                "warm_up_ms": warm_up_ms,
            }));
            if !s.kernel_seconds.is_empty() {
                let kernels: Vec<String> = s
                    .kernel_seconds
                    .iter()
                    .map(|(k, t)| match fetches_per_ray(&s, k) {
                        Some((f, _)) => format!("{k} {:.1} ms ({f:.1} fetches/ray)", t * 1e3),
                        None => format!("{k} {:.1} ms", t * 1e3),
                    })
                    .collect();
                println!("{:<20} {:<6} per kernel: {}", "", "", kernels.join(", "));
                for (k, statistics) in &s.kernel_statistics {
                    println!(
                        "{:<20} {:<6} {k}, driver: {}",
                        "",
                        "",
                        wavetrace::render::statistics_line(statistics)
                    );
                }
                if let Some(host) = host_phases(&s) {
                    println!("{:<20} {:<6} outside the kernels: {host}", "", "");
                }
            }
            if let Some(ms) = warm_up_ms {
                println!(
                    "{:<20} {:<6} warm-up before timing (pipelines made, first dispatches): {ms:.0} ms",
                    "", ""
                );
            }
        }
        println!(
            "{:<20} {:<6} loaded in {load_ms:.1} ms, prepared in {prepare_ms:.1} ms (BVH {:.1} ms, light BVH {:.1} ms)",
            "",
            "",
            prepared.bvh.stats.build_time.as_secs_f64() * 1e3,
            prepared.light_bvh_time.as_secs_f64() * 1e3
        );
    }
    if let Some(file) = &args.json {
        let doc = serde_json::json!({
            "width": args.width,
            "height": args.height,
            "spp": args.spp,
            "max_depth": args.max_depth,
            "gpu": gpu_name,
            "cpu": cpu,
            "cpu_threads": rayon::current_num_threads(),
            "rows": json_rows,
        });
        std::fs::write(file, serde_json::to_string_pretty(&doc)?)
            .with_context(|| format!("writing {}", file.display()))?;
        println!("wrote {}", file.display());
    }
    Ok(())
}

/// `bench --kernels`: each scene's kernels made on the GPU for `settings`, without rendering,
/// and the driver's statistics of each.
fn bench_kernels(
    scenes: &[PathBuf],
    settings: &RenderSettings,
    gpu_index: Option<usize>,
    json: Option<&Path>,
    baseline: Option<&Path>,
) -> Result<()> {
    let integrator = format!("{:?}", settings.integrator).to_lowercase();
    // An earlier `bench --kernels --json`'s statistics by (scene, kernel), of this integrator.
    let baseline: std::collections::HashMap<(String, String), serde_json::Value> = match baseline {
        Some(file) => {
            let (_, rows) = read_rows_json(file, "bench --kernels --json")?;
            rows.iter()
                .filter(|r| r["integrator"].as_str() == Some(integrator.as_str()))
                .filter_map(|r| Some((r["scene"].as_str()?, r["kernel_statistics"].as_object()?)))
                .flat_map(|(scene, kernels)| {
                    kernels
                        .iter()
                        .map(move |(k, s)| ((scene.to_owned(), k.clone()), s.clone()))
                })
                .collect()
        }
        None => Default::default(),
    };
    let compiler = wavetrace::gpu::KernelCompiler::new(gpu_index)?;
    let device = compiler.device();
    let gpu_name = format!("{} ({})", device.name, device.driver);
    println!(
        "wavetrace bench --kernels ({:?} integrator): each scene's kernels made on {gpu_name}, without rendering",
        settings.integrator
    );
    if !compiler.reports_statistics() {
        println!(
            "notice: this device reports no statistics of its kernels (it lacks VK_KHR_pipeline_executable_properties); the kernels were made"
        );
    }
    let mut rows = Vec::new();
    for path in scenes {
        let scene = Scene::load_with(path, &LoadOptions::default())?;
        let prepared = PreparedScene::new(&scene);
        drop(scene);
        let name = scene_name(path);
        if let Err(why) = wavetrace::cpu::bidir::check(&prepared, settings) {
            println!("{name}: skipped: {why}");
            continue;
        }
        let compiled = compiler
            .compile(&prepared, settings)
            .with_context(|| format!("{}: making its kernels", path.display()))?;
        let features = wavetrace::layout::feature_names(compiled.features);
        println!(
            "{name}: kernels made for {}; deferred slots per lane: {}",
            match features.len() {
                0 => "no optional feature (the plain path)".to_string(),
                _ => features.join(", "),
            },
            deferred_slots(compiled.features)
        );
        for (kernel, statistics) in &compiled.kernels {
            println!(
                "  {kernel:<17} {}",
                match statistics.is_empty() {
                    true => "(no statistics)".to_string(),
                    false => wavetrace::render::statistics_line(statistics),
                }
            );
            if let Some(before) = baseline.get(&(name.clone(), kernel.clone())) {
                println!(
                    "  {:<17} against the baseline: {}",
                    "",
                    statistics_changes(before, statistics)
                );
            }
        }
        rows.push(serde_json::json!({
            "scene": name,
            "integrator": integrator,
            "features": features,
            "deferred_slots": wavetrace::layout::qbvh_stack_size(compiled.features),
            "top_level_deferred_slots": (compiled.features & wavetrace::layout::FEATURE_TOP_LEVEL != 0)
                .then(|| wavetrace::layout::tlas_stack_size(compiled.features)),
            "kernel_statistics": statistics_json(&compiled.kernels),
        }));
    }
    if let Some(file) = json {
        let doc = serde_json::json!({ "gpu": gpu_name, "rows": rows });
        std::fs::write(file, serde_json::to_string_pretty(&doc)?)
            .with_context(|| format!("writing {}", file.display()))?;
        println!("wrote {}", file.display());
    }
    Ok(())
}

/// A JSON document with "rows" (as `written_by` writes it) and those rows.
fn read_rows_json(
    file: &Path,
    written_by: &str,
) -> Result<(serde_json::Value, Vec<serde_json::Value>)> {
    let text =
        std::fs::read_to_string(file).with_context(|| format!("reading {}", file.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", file.display()))?;
    let rows = v["rows"]
        .as_array()
        .with_context(|| {
            format!(
                "{}: no \"rows\" (write it with {written_by})",
                file.display()
            )
        })?
        .clone();
    Ok((v, rows))
}

/// A scene's name in `bench`'s rows: its file name without the extension.
fn scene_name(path: &Path) -> String {
    path.file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("?")
        .to_owned()
}

/// Kernels' statistics as JSON: kernel → statistic name → value (`bench --json`'s
/// `kernel_statistics`).
fn statistics_json(
    kernels: &[(String, Vec<wavetrace::render::KernelStatistic>)],
) -> serde_json::Map<String, serde_json::Value> {
    kernels
        .iter()
        .map(|(k, list)| {
            let values = list.iter().map(|s| (s.name.clone(), s.value.to_json()));
            (k.clone(), serde_json::Value::Object(values.collect()))
        })
        .collect()
}

/// A kernel's statistics that differ from a baseline's (`before`: name → value, as
/// `bench --kernels --json` writes them), "name before → now" (hashes left out), or "the same".
fn statistics_changes(
    before: &serde_json::Value,
    now: &[wavetrace::render::KernelStatistic],
) -> String {
    let changed: Vec<String> = now
        .iter()
        .filter(|s| !s.is_hash())
        .filter_map(|s| {
            let old = before.get(&s.name)?;
            let new = s.value.to_json();
            (*old != new).then(|| format!("{} {old} → {new}", s.name))
        })
        .collect();
    match changed.is_empty() {
        true => "the same".to_string(),
        false => changed.join(", "),
    }
}

/// Boxes tested per ray and rays per second of `RAYS` closest-hit rays `ray(i)` through `tree`.
fn walk_cost(
    tree: &(impl wavetrace::bvh::Hierarchy + Sync),
    triangles: &[wavetrace::layout::GpuTriangle],
    ray: &(impl Fn(u32) -> wavetrace::bvh::Ray + Sync),
) -> (f64, f64) {
    let started = std::time::Instant::now();
    let boxes = (0..RAYS)
        .into_par_iter()
        .map(|i| {
            let accept = |_, _, _| true;
            let ray = ray(i);
            let (_, boxes, _) = wavetrace::bvh::closest_triangle(
                tree,
                0,
                triangles,
                &ray,
                0.0,
                f32::INFINITY,
                accept,
            );
            boxes as u64
        })
        .sum::<u64>();
    let seconds = started.elapsed().as_secs_f64();
    (boxes as f64 / RAYS as f64, RAYS as f64 / seconds)
}

/// Rays `bench --bvh` traces through each tree.
const RAYS: u32 = 1 << 20;

/// A build's parts in ms: the primitive references, the tree, its assembly (`BvhStats`).
fn build_parts_ms(stats: &wavetrace::bvh::BvhStats) -> [f64; 3] {
    [stats.refs_time, stats.tree_time, stats.assemble_time].map(|t| t.as_secs_f64() * 1e3)
}

/// `bench --bvh`: build time, tree statistics and closest-hit traversal cost per scene.
fn bench_bvh(
    scenes: &[PathBuf],
    builds: usize,
    json: Option<&Path>,
    gpu: Option<Result<GpuRenderer>>,
) -> Result<()> {
    use wavetrace::bvh::{gpu_triangles, Bvh, Ray, WideBvh};
    let cpu = host_cpu();
    let gpu_name = match &gpu {
        None => "not opened (--cpu-only)".to_string(),
        Some(Ok(g)) => format!("{} ({})", g.device().name, g.device().driver),
        Some(Err(e)) => format!("unavailable: {e:#}"),
    };
    let gpu = gpu.and_then(|g| g.ok());
    println!(
        "wavetrace bench --bvh: {builds} builds (median and best), {RAYS} random closest-hit rays through the binary tree (the GPU's fallback), its 4-wide collapse (the CPU's) and that collapse with boxes quantised to a byte per plane (the GPU's); cpu = {cpu}, {} threads; gpu = {gpu_name}",
        rayon::current_num_threads()
    );
    println!(
        "{:<32} {:>10} {:>9} {:>8} {:>9} {:>10} {:>9} {:>6} {:>9} {:>10} {:>10} {:>10} {:>10} {:>11} {:>12} {:>11} {:>12}",
        "scene",
        "triangles",
        "build ms",
        "best ms",
        "first ms",
        "ms per M",
        "nodes",
        "depth",
        "SAH cost",
        "boxes/ray",
        "tris/ray",
        "M rays/s",
        "wide ms",
        "wide boxes",
        "wide M rays/s",
        "quant boxes",
        "quant M rays/s"
    );
    let mut rows = Vec::new();
    for path in scenes {
        let scene = Scene::load_with(path, &LoadOptions::default())?;
        let positions: Vec<[Vec3; 3]> = scene.triangles.iter().map(|t| t.p).collect();
        // The first build writes memory the process has not used yet (as a render's one build
        // does: page faults); the later ones mostly reuse what the allocator kept. Each build's
        // (ms, parts), fastest first.
        let mut bvh = Bvh::build(&positions);
        let first_ms = bvh.stats.build_time.as_secs_f64() * 1e3;
        let first_parts = build_parts_ms(&bvh.stats);
        let mut later = Vec::new();
        for _ in 0..builds {
            bvh = Bvh::build(&positions);
            later.push((
                bvh.stats.build_time.as_secs_f64() * 1e3,
                build_parts_ms(&bvh.stats),
            ));
        }
        later.sort_by(|a, b| a.0.total_cmp(&b.0));
        let times: Vec<f64> = later.iter().map(|&(ms, _)| ms).collect();
        let (build_ms, median_parts) = later[builds / 2];
        let triangles = gpu_triangles(&positions, &[], &bvh.order);
        // Rays from uniform points of the root's box in uniform directions (seeded, so every
        // build of the same tree is measured on the same rays).
        let root = bvh.nodes[0];
        let (lo, hi) = (Vec3::from(root.bounds_min), Vec3::from(root.bounds_max));
        let ray = |i: u32| {
            let u = wavetrace::sampling::rng_uniform4(11, i, 0, 0);
            let o = wavetrace::sampling::rng_uniform4(11, i, 0, 1);
            Ray {
                origin: lo + (hi - lo) * o.truncate(),
                dir: wavetrace::sampling::sample_uniform_cone(glam::Vec2::new(u.x, u.y), -1.0),
            }
        };
        let started = std::time::Instant::now();
        let (boxes, tested) = (0..RAYS)
            .into_par_iter()
            .map(|i| {
                let (b, t) = bvh.closest_hit_cost(&triangles, &ray(i), 0.0, f32::INFINITY);
                (b as u64, t as u64)
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        let rays_per_second = RAYS as f64 / started.elapsed().as_secs_f64();
        let started = std::time::Instant::now();
        let wide = WideBvh::collapse(&bvh.nodes, &[0]);
        let collapse_ms = started.elapsed().as_secs_f64() * 1e3;
        let (wide_boxes, wide_rays_per_second) = walk_cost(&wide, &triangles, &ray);
        let quant = wide.quantized();
        let (quant_boxes, quant_rays_per_second) = walk_cost(&quant, &triangles, &ray);
        let name = path
            .file_name()
            .and_then(|s| s.to_str())
            .unwrap_or("?")
            .to_owned();
        let s = &bvh.stats;
        let (boxes, tested) = (boxes as f64 / RAYS as f64, tested as f64 / RAYS as f64);
        let per_million = build_ms * 1e6 / positions.len().max(1) as f64;
        println!(
            "{name:<32} {:>10} {build_ms:>9.1} {:>8.1} {first_ms:>9.1} {per_million:>10.1} {:>9} {:>6} {:>9.2} {boxes:>10.1} {tested:>10.1} {:>10.2} {collapse_ms:>10.1} {wide_boxes:>11.1} {:>12.2} {quant_boxes:>11.1} {:>12.2}",
            positions.len(),
            times[0],
            s.nodes,
            s.max_depth,
            s.sah_cost,
            rays_per_second * 1e-6,
            wide_rays_per_second * 1e-6,
            quant_rays_per_second * 1e-6
        );
        let [refs_ms, tree_ms, assemble_ms] = median_parts;
        println!(
            "{:<32} median build: references {refs_ms:.1} ms, tree {tree_ms:.1} ms, assembly {assemble_ms:.1} ms; first build: {:.1}, {:.1}, {:.1} ms",
            "", first_parts[0], first_parts[1], first_parts[2]
        );
        rows.push(serde_json::json!({
            "scene": name,
            "triangles": positions.len(),
            "build_ms": build_ms,
            "build_ms_all": times,
            "build_ms_first": first_ms,
            "build_ms_per_million": per_million,
            "build_parts_ms": { "references": refs_ms, "tree": tree_ms, "assembly": assemble_ms },
            "build_parts_ms_first": {
                "references": first_parts[0],
                "tree": first_parts[1],
                "assembly": first_parts[2],
            },
            "nodes": s.nodes,
            "leaves": s.leaves,
            "max_depth": s.max_depth,
            "sah_cost": s.sah_cost,
            "boxes_per_ray": boxes,
            "triangles_per_ray": tested,
            "rays_per_second": rays_per_second,
            "wide_collapse_ms": collapse_ms,
            "wide_nodes": wide.nodes.len(),
            "wide_boxes_per_ray": wide_boxes,
            "wide_rays_per_second": wide_rays_per_second,
            "quantized_boxes_per_ray": quant_boxes,
            "quantized_rays_per_second": quant_rays_per_second,
        }));
        if let Some(gpu) = &gpu {
            let rays: Vec<Ray> = (0..RAYS).map(ray).collect();
            let walks = bench_gpu_walk(gpu, &scene, &rays, (hi - lo).length())?;
            println!("{:<32} {}", "", walks.describe(gpu));
            if let Some(row) = rows.last_mut() {
                row["gpu"] = serde_json::json!(gpu_name);
                row["gpu_rays_per_second"] = serde_json::json!(walks.gpu_rays_per_second);
                row["gpu_timed_by"] = serde_json::json!(walks.timed_by);
                row["cpu_reference_rays_per_second"] = serde_json::json!(walks.cpu_rays_per_second);
                row["gpu_hits_same"] = serde_json::json!(walks.same);
                row["gpu_hits_other_t"] = serde_json::json!(walks.other_t);
                row["gpu_hits_other_triangle"] = serde_json::json!(walks.other_triangle);
                row["gpu_any_rays_per_second"] = serde_json::json!(walks.gpu_any_rays_per_second);
                row["cpu_reference_any_rays_per_second"] =
                    serde_json::json!(walks.cpu_any_rays_per_second);
                row["gpu_any_same"] = serde_json::json!(walks.any_same);
                row["gpu_any_other"] = serde_json::json!(walks.any_other);
                row["any_blocked"] = serde_json::json!(walks.any_blocked);
            }
        }
    }
    if let Some(file) = json {
        let doc = serde_json::json!({
            "cpu": cpu,
            "cpu_threads": rayon::current_num_threads(),
            "gpu": gpu_name,
            "rays": RAYS,
            "rows": rows,
        });
        std::fs::write(file, serde_json::to_string_pretty(&doc)?)
            .with_context(|| format!("writing {}", file.display()))?;
        println!("wrote {}", file.display());
    }
    Ok(())
}

/// The render's own walks on `bench --bvh`'s rays: the GPU's `extend` (closest hits) and
/// `connect` (any hit, each ray cut at a random length up to the box's diagonal) against the CPU
/// reference's `PreparedScene::intersect_closest` and `intersect_any`, their rates and how their
/// answers compare.
struct WalkComparison {
    /// "timestamps" (the kernels' own time) or "submissions" (wall time of the submissions).
    timed_by: &'static str,
    gpu_rays_per_second: f64,
    cpu_rays_per_second: f64,
    /// Rays whose hits are the same: both miss, or the same triangle at the same t, bit for bit.
    same: u64,
    /// The same triangle at another t (the largest relative difference in `largest_dt`).
    other_t: u64,
    largest_dt: f32,
    /// Another triangle, or a hit where the other walk misses.
    other_triangle: u64,
    gpu_any_rays_per_second: f64,
    cpu_any_rays_per_second: f64,
    /// Shadow rays both walks find blocked, or both find free; and those they disagree on.
    any_same: u64,
    any_other: u64,
    /// Shadow rays the CPU reference finds blocked.
    any_blocked: u64,
}

impl WalkComparison {
    fn describe(&self, gpu: &GpuRenderer) -> String {
        let rays = self.same + self.other_t + self.other_triangle;
        format!(
            "the render's walks ({} by its {}; CPU reference): closest hit {:.2} and {:.2} M rays/s, {} of {rays} hits the same, {} at another t (largest |Δt|/t {:.1e}), {} on another triangle; any hit {:.2} and {:.2} M rays/s, {} of {rays} answers the same ({} blocked)",
            gpu.device().name,
            self.timed_by,
            self.gpu_rays_per_second * 1e-6,
            self.cpu_rays_per_second * 1e-6,
            self.same,
            self.other_t,
            self.largest_dt,
            self.other_triangle,
            self.gpu_any_rays_per_second * 1e-6,
            self.cpu_any_rays_per_second * 1e-6,
            self.any_same,
            self.any_blocked,
        )
    }
}

/// Traces `rays` on the GPU (`GpuRenderer::trace_closest` and `trace_any`, best of three
/// rounds) and with the CPU reference, with the keys the GPU gives them (ray i: pixel i mod
/// 1024², sample i / 1024², depth 0). The shadow rays are the same rays cut at lengths drawn
/// up to `diagonal`.
fn bench_gpu_walk(
    gpu: &GpuRenderer,
    scene: &Scene,
    rays: &[wavetrace::bvh::Ray],
    diagonal: f32,
) -> Result<WalkComparison> {
    const SEED: u32 = 11;
    const PIXELS: u32 = 1024 * 1024;
    let key = |i: usize, shadow: bool| {
        let i = i as u32;
        wavetrace::surface::alpha_key(SEED, i % PIXELS, i / PIXELS, 0, shadow)
    };
    let prepared = PreparedScene::new(scene);
    let pairs: Vec<(Vec3, Vec3)> = rays.iter().map(|r| (r.origin, r.dir)).collect();
    let traced = gpu.trace_closest(&prepared, &pairs, SEED, 3)?;
    let started = std::time::Instant::now();
    let cpu_hits: Vec<Option<wavetrace::bvh::Hit>> = rays
        .par_iter()
        .enumerate()
        .map(|(i, r)| {
            prepared
                .intersect_closest(r, 0.0, f32::MAX, key(i, false))
                .map(|(hit, _)| hit)
        })
        .collect();
    let cpu_seconds = started.elapsed().as_secs_f64();
    let shadows: Vec<(Vec3, Vec3, f32)> = rays
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let u = wavetrace::sampling::rng_uniform4(SEED, i as u32, 0, 2).x;
            (r.origin, r.dir, diagonal * u)
        })
        .collect();
    let blocked = gpu.trace_any(&prepared, &shadows, SEED, 3)?;
    let started = std::time::Instant::now();
    let cpu_blocked: Vec<bool> = shadows
        .par_iter()
        .enumerate()
        .map(|(i, &(origin, dir, t_max))| {
            let ray = wavetrace::bvh::Ray { origin, dir };
            prepared.intersect_any(&ray, 0.0, t_max, key(i, true))
        })
        .collect();
    let cpu_any_seconds = started.elapsed().as_secs_f64();
    let rate = |seconds: f64| rays.len() as f64 / seconds.max(1e-12);
    let mut walks = WalkComparison {
        timed_by: if traced.timed {
            "timestamps"
        } else {
            "submissions"
        },
        gpu_rays_per_second: rate(traced.kernel_seconds),
        cpu_rays_per_second: rate(cpu_seconds),
        same: 0,
        other_t: 0,
        largest_dt: 0.0,
        other_triangle: 0,
        gpu_any_rays_per_second: rate(blocked.kernel_seconds),
        cpu_any_rays_per_second: rate(cpu_any_seconds),
        any_same: 0,
        any_other: 0,
        any_blocked: cpu_blocked.iter().filter(|&&b| b).count() as u64,
    };
    for (g, c) in traced.hits.iter().zip(&cpu_hits) {
        match (g.triangle == wavetrace::layout::NO_HIT, c) {
            (true, None) => walks.same += 1,
            (false, Some(c)) if c.triangle == g.triangle => {
                if c.t.to_bits() == g.t.to_bits() {
                    walks.same += 1;
                } else {
                    walks.other_t += 1;
                    let dt = (c.t - g.t).abs() / c.t.abs().max(f32::MIN_POSITIVE);
                    walks.largest_dt = walks.largest_dt.max(dt);
                }
            }
            _ => walks.other_triangle += 1,
        }
    }
    for (&g, &c) in blocked.blocked.iter().zip(&cpu_blocked) {
        match g == c {
            true => walks.any_same += 1,
            false => walks.any_other += 1,
        }
    }
    Ok(walks)
}

/// Prints the per-tile comparison of two saved renders; true if they agree.
fn compare(args: &CompareArgs) -> Result<bool> {
    if args.flip {
        use wavetrace::flip::{flip, flip_heat_map, DisplayImage};
        let test = DisplayImage::load(&args.a)?;
        let reference = DisplayImage::load(&args.b)?;
        let r = flip(&reference, &test)
            .with_context(|| format!("comparing {} with {}", args.a.display(), args.b.display()))?;
        println!(
            "FLIP of {} against {}: mean {:.6}, median {:.6}, 99th percentile {:.6}, max {:.6} ({}×{} px, 8-bit sRGB, 67 pixels per degree)",
            args.a.display(),
            args.b.display(),
            r.mean,
            r.median,
            r.p99,
            r.max,
            r.width,
            r.height
        );
        if let Some(path) = &args.flip_map {
            flip_heat_map(&r)
                .save(path)
                .with_context(|| format!("writing {}", path.display()))?;
            println!("FLIP error map: {}", path.display());
        }
        return Ok(args.max_flip.is_none_or(|e| r.mean <= e));
    }
    if args.max_flip.is_some() {
        bail!("--max-flip applies to --flip");
    }
    let a = wavetrace::image_io::read_film(&args.a)?;
    let b = wavetrace::image_io::read_film(&args.b)?;
    let cmp = wavetrace::stats::compare_films(&a, &b, args.tile, args.alpha)
        .with_context(|| format!("comparing {} with {}", args.a.display(), args.b.display()))?;
    println!("{} vs {}: {cmp}", args.a.display(), args.b.display());
    let error = wavetrace::stats::image_error(&a, &b, wavetrace::stats::RELATIVE_MSE_EPSILON)?;
    println!(
        "relative MSE = {:.6e} (mean of (A−B)²/(B² + {}), B the reference); MSE = {:.6e}",
        error.relative_mse, error.epsilon, error.mse
    );
    Ok(cmp.passed())
}

/// `wavetrace estimators`: prints the tables; true if every check passed.
fn estimators(args: &EstimatorsArgs) -> Result<bool> {
    let report = wavetrace::mc::run(wavetrace::mc::Settings {
        samples: args.samples as usize,
        trials: args.trials as usize,
        seed: args.seed,
        alpha: args.alpha,
    })?;
    print!("{report}");
    Ok(report.failures() == 0)
}

#[cfg(test)]
mod tests {
    use super::image_size;

    #[test]
    fn missing_sides_follow_the_camera_aspect() {
        assert_eq!(image_size(None, None, None), (512, 512));
        assert_eq!(image_size(None, None, Some(2.0)), (512, 256));
        assert_eq!(image_size(Some(300), None, Some(1.5)), (300, 200));
        assert_eq!(image_size(None, Some(100), Some(1.5)), (150, 100));
        assert_eq!(image_size(Some(64), Some(48), Some(1.0)), (64, 48));
        assert_eq!(image_size(Some(64), None, Some(f32::NAN)), (64, 64));
    }
}
