//! `wavetrace render`: one scene to EXR or PNG, on the CPU reference or a Vulkan device (or
//! several), in one go, in passes (`--target-error`, `--time-limit`) or as a shard, with path
//! layers (`--aov NAME=EXPR`) beside the image.

use super::options::{AovArg, DeviceKind, GpuIndex, RenderArgs};
use super::prepare::{check_output, default_scene, prepare, resolve_device};
use super::report::{print_stats, Progress};
use super::shards::{finish, plan, record, stop_flag, INTERRUPTED_EXIT};
use anyhow::{bail, Context, Result};
use indicatif::ProgressBar;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use wavetrace::cpu::CpuBackend;
use wavetrace::gpu::{GpuBackend, GpuOptions, GpuRenderer};
use wavetrace::image_io::{Layer, LayerKind};
use wavetrace::render::progressive::{Progressive, ProgressiveReport};
use wavetrace::render::{Backend, PreparedScene, RenderOutput, RenderSettings, RenderStats};

pub(crate) fn render(args: &RenderArgs) -> Result<()> {
    // `-o -`: the image goes to standard output, everything printed to standard error.
    let to_stdout;
    let with_temporary;
    let args = if args.output.as_deref() == Some(Path::new("-")) {
        let Some(format) = args.out.format else {
            bail!("-o - writes the image to standard output: say its format with --format png|jpeg|exr|hdr");
        };
        if args.sample_range.is_some() || args.shard.is_some() || args.resume.is_some() {
            bail!("-o - writes a whole image: it does not combine with --sample-range, --shard or --resume");
        }
        let temporary = std::env::temp_dir().join(format!(
            "wavetrace-stdout-{}.{}",
            std::process::id(),
            format.extension()
        ));
        to_stdout = Some((stdout_to_stderr()?, temporary.clone()));
        let mut a = args.clone();
        a.output = Some(temporary);
        with_temporary = a;
        &with_temporary
    } else {
        if args.out.format.is_some() {
            bail!("--format names the format of -o - (standard output); a file's extension names its own");
        }
        to_stdout = None;
        args
    };
    let path = args.scene.clone().map_or_else(default_scene, Ok)?;
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
    let mut record = record(
        &args.opts,
        &path,
        &prepared,
        &settings,
        device,
        &args.opts.moment(),
    )?;
    let progressive = progressive_options(args, &settings)?;
    if settings.integrator != wavetrace::render::Integrator::Path && progressive.is_some() {
        bail!("--target-error and --time-limit render in passes with --integrator path only");
    }
    if args.bdpt_strategies.is_some() {
        if settings.integrator == wavetrace::render::Integrator::Path {
            bail!("--bdpt-strategies needs --integrator bdpt (or light)");
        }
        if args.sample_range.is_some() || args.shard.is_some() || args.resume.is_some() {
            bail!("--bdpt-strategies renders every sample: it does not combine with --sample-range, --shard or --resume");
        }
    }
    let path_layers = args.opts.path_layers()?;
    let write_options = args.out.write_options()?;
    let aovs = aov_passes(args);
    if !aovs.is_empty() {
        let what = "--aov PROPERTY, --transparent and --denoise";
        if settings.integrator != wavetrace::render::Integrator::Path {
            bail!("{what} need --integrator path");
        }
        if progressive.is_some() {
            bail!("{what} render beside a whole image: they do not combine with --target-error or --time-limit");
        }
        if args.sample_range.is_some() || args.shard.is_some() || args.resume.is_some() {
            bail!("{what} render beside a whole image: they do not combine with --sample-range, --shard or --resume");
        }
        if args.bdpt_strategies.is_some() {
            bail!("{what} do not combine with --bdpt-strategies");
        }
        if multi_gpu(&args.opts.gpu_index).is_some() {
            bail!("{what} render on one device: give --gpu-index N");
        }
    }
    let mut settings = settings;
    if args.out.transparent {
        settings.debug_flags |= wavetrace::layout::FLAG_TRANSPARENT_BACKGROUND;
    }
    let denoiser = match args.out.denoise {
        true => Some(wavetrace::denoise::Denoiser::load()?),
        false => None,
    };
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
        if multi_gpu(&args.opts.gpu_index).is_some() {
            refuse("several --gpu-index devices")?;
        }
    }
    let plan = plan(args, &record, progressive.is_some(), default_output)?;
    let output = plan.output.clone();
    // Samples to render now (a test may stop them early, as a signal would).
    let todo = match args.stop_after {
        Some(n) => plan.todo.start..plan.todo.end.min(plan.todo.start.saturating_add(n)),
        None => plan.todo.as_range(),
    };
    let stop = stop_flag(progressive.is_some());
    let mut end = todo.end;
    check_output(&output)?;
    check_layer_output(&aovs, &output)?;
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
    let backend = backend(args, device, progressive.is_some())?;
    println!(
        "rendering {width}×{height} {how}, max depth {}, on {}",
        args.opts.max_depth,
        backend.describe()
    );
    // The kernels made and run once on a few pixels first: a driver that compiles at a
    // kernel's first dispatch (lavapipe) does it here, reported apart from the render's time.
    if device == DeviceKind::Gpu && args.bdpt_strategies.is_none() {
        let warming = std::time::Instant::now();
        let never = AtomicBool::new(false);
        let hidden = ProgressBar::hidden();
        backend.render_range(&prepared, &settings.warm_up(), 0..1, &hidden, &never)?;
        println!(
            "kernels ready in {:.3} s (made and dispatched once: with a cold driver cache, the shader compiler's time)",
            warming.elapsed().as_secs_f64()
        );
    }
    let progress_guard = Progress::new(
        settings.pixel_count() * todo.len() as u64,
        args.progress_mode(),
    );
    let progress = &progress_guard.bar;
    let out = match (&progressive, &args.bdpt_strategies) {
        // The strategy images are the CPU twin's (the device is the CPU here).
        (None, Some(dir)) => {
            let (out, strategies) =
                wavetrace::cpu::render_strategies(&prepared, &settings, progress);
            wavetrace::cpu::bidir::write_strategies(&strategies, dir, args.out.exposure)?;
            println!(
                "wrote {} strategy images and strategies.png to {}",
                2 * strategies.films.len(),
                dir.display()
            );
            Ok(out)
        }
        (None, None) => backend
            .render_range(&prepared, &settings, todo.clone(), progress, stop)
            .map(|(out, e)| {
                end = e;
                out
            }),
        (Some(p), _) => backend
            .render_progressive(&prepared, &settings, p, progress)
            .map(|(out, r)| {
                report = Some(r);
                out
            }),
    };
    drop(progress_guard);
    let RenderOutput { film, stats } = out?;
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
        let (film, r) = finish(plan, film, end, record);
        record = r;
        (film, end < target.end)
    };
    // (After a fault the device is gone: the layers are left out of the partial image.)
    let (mut film, mut layers) = (film, Vec::new());
    let mut attributes = record.attributes();
    if fault.is_none() {
        layers = render_path_layers(&*backend, &prepared, &settings, &path_layers, end)?;
        let (denoised, more) = aov_layers_and_denoise(
            args,
            &*backend,
            &prepared,
            &settings,
            film,
            end,
            denoiser.as_ref(),
            &mut attributes,
        )?;
        film = denoised;
        layers.extend(more);
    }
    wavetrace::image_io::write_output(&film, &layers, &output, &write_options, &attributes)?;
    match &to_stdout {
        Some((stdout, temporary)) => {
            let copied = std::fs::read(temporary).and_then(|bytes| {
                use std::io::Write;
                let mut out = stdout;
                out.write_all(&bytes)?;
                out.flush()
            });
            let _ = std::fs::remove_file(temporary);
            copied.context("writing the image to standard output")?;
            eprintln!("wrote the image to standard output");
        }
        None => println!("wrote {}", output.display()),
    }
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
        std::process::exit(INTERRUPTED_EXIT);
    }
    Ok(())
}

/// How to continue a partial render written to `output`: `--resume` for an EXR, else
/// `otherwise`.
pub(crate) fn resume_hint(output: &Path, otherwise: &str) -> String {
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
pub(crate) fn render_path_layers(
    backend: &dyn Backend,
    prepared: &PreparedScene,
    settings: &RenderSettings,
    layers: &[(String, std::sync::Arc<wavetrace::paths::PathExpr>)],
    samples: u32,
) -> Result<Vec<Layer>> {
    let never = AtomicBool::new(false);
    let hidden = ProgressBar::hidden();
    layers
        .iter()
        .map(|(name, expr)| {
            let s = RenderSettings {
                paths: Some(expr.clone()),
                ..settings.clone()
            };
            let (out, _) = backend.render_range(prepared, &s, 0..samples, &hidden, &never)?;
            if let Some(fault) = out.stats.fault {
                bail!("layer {name}: {fault}");
            }
            println!("layer {name}: the paths {}", expr.source);
            Ok(Layer {
                name: name.clone(),
                kind: LayerKind::Paths,
                film: out.film,
            })
        })
        .collect()
}

/// The AOV passes a render needs: those `--aov` asks for, alpha for `--transparent`, albedo
/// and normal for `--denoise`.
pub(crate) fn aov_passes(args: &RenderArgs) -> Vec<AovArg> {
    let mut aovs = args.opts.aov_layers();
    let mut need = |a: AovArg| {
        if !aovs.contains(&a) {
            aovs.push(a);
        }
    };
    if args.out.transparent {
        need(AovArg::Alpha);
    }
    if args.out.denoise {
        need(AovArg::Albedo);
        need(AovArg::Normal);
    }
    aovs
}

/// Refuses, before anything renders, AOV layers that `output`'s format cannot hold.
pub(crate) fn check_layer_output(aovs: &[AovArg], output: &Path) -> Result<()> {
    let display = matches!(
        wavetrace::image_io::extension(output).as_deref(),
        Some("png" | "jpg" | "jpeg" | "hdr")
    );
    if let Some(a) = aovs.iter().find(|a| {
        use wavetrace::image_io::LayerKind::*;
        display && matches!(a.kind(), Point | Depth | Id)
    }) {
        bail!(
            "cannot write layer {} beside {}: write an .exr to keep it",
            a.name(),
            output.display()
        );
    }
    Ok(())
}

/// The AOV layers `args` ask for (`aov_passes`) of the image's samples 0..`samples`, and with
/// `denoiser` the image denoised, its noisy self kept as layer `noisy` and the record noting
/// it; the albedo and normal guides stay only where `--aov` asks for them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn aov_layers_and_denoise(
    args: &RenderArgs,
    backend: &dyn Backend,
    prepared: &PreparedScene,
    settings: &RenderSettings,
    film: wavetrace::film::Film,
    samples: u32,
    denoiser: Option<&wavetrace::denoise::Denoiser>,
    attributes: &mut Vec<(String, String)>,
) -> Result<(wavetrace::film::Film, Vec<Layer>)> {
    let mut layers = render_aov_layers(backend, prepared, settings, &aov_passes(args), samples)?;
    let Some(denoiser) = denoiser else {
        return Ok((film, layers));
    };
    let (denoised, note) = denoise(denoiser, &film, &layers)?;
    println!("{note}");
    attributes.push(("wavetrace.denoised".to_owned(), note));
    let asked = args.opts.aov_layers();
    layers.retain(|l| {
        !matches!(l.name.as_str(), "albedo" | "normal") || asked.iter().any(|a| a.name() == l.name)
    });
    layers.push(Layer {
        name: "noisy".to_owned(),
        kind: LayerKind::Paths,
        film,
    });
    Ok((denoised, layers))
}

/// The AOV layers, one pass each (`wavetrace::render::aov`).
pub(crate) fn render_aov_layers(
    backend: &dyn Backend,
    prepared: &PreparedScene,
    settings: &RenderSettings,
    aovs: &[AovArg],
    samples: u32,
) -> Result<Vec<Layer>> {
    aovs.iter()
        .map(|&a| {
            let film = wavetrace::render::aov::render_aov(backend, prepared, settings, a, samples)?;
            Ok(Layer {
                name: a.name().to_owned(),
                kind: a.kind(),
                film,
            })
        })
        .collect()
}

/// The image denoised with its albedo and normal layers as guides (OIDN's "RT" filter, HDR,
/// auxiliary images as rendered, not prefiltered), as a film whose pixels hold the denoised
/// mean with no variance; and a line saying what ran and how long it took.
fn denoise(
    denoiser: &wavetrace::denoise::Denoiser,
    film: &wavetrace::film::Film,
    layers: &[Layer],
) -> Result<(wavetrace::film::Film, String)> {
    let plane = |f: &wavetrace::film::Film| -> Vec<[f32; 3]> {
        (0..f.len()).map(|p| f.mean(p).to_array()).collect()
    };
    let find = |name: &str| {
        layers
            .iter()
            .find(|l| l.name == name)
            .map(|l| plane(&l.film))
    };
    let (color, albedo, normal) = (plane(film), find("albedo"), find("normal"));
    let started = std::time::Instant::now();
    let denoised = denoiser.denoise(&wavetrace::denoise::DenoiseInput {
        width: film.width,
        height: film.height,
        color: &color,
        albedo: albedo.as_deref(),
        normal: normal.as_deref(),
        clean_aux: false,
    })?;
    let seconds = started.elapsed().as_secs_f64();
    let pixels = denoised
        .iter()
        .zip(&film.pixels)
        .map(|(d, p)| {
            let n = p.count.max(1) as f32;
            wavetrace::layout::FilmPixel {
                sum: d.map(|c| c * n),
                sum_sq: d.map(|c| c * c * n),
                count: p.count.max(1),
                ..Default::default()
            }
        })
        .collect();
    let out = wavetrace::film::Film::from_pixels(film.width, film.height, pixels, 0);
    let note = format!(
        "denoised with Open Image Denoise ({}) in {seconds:.3} s",
        denoiser.device_name()
    );
    Ok((out, note))
}

/// Points standard output at standard error, so that what wavetrace prints does not mix with an
/// image written to standard output; returns the original standard output.
fn stdout_to_stderr() -> Result<std::fs::File> {
    use std::io::Write;
    use std::os::fd::FromRawFd;
    std::io::stdout().flush()?;
    // SAFETY: dup and dup2 on the process's own standard descriptors; the duplicate is owned
    // by the File returned.
    unsafe {
        let saved = libc::dup(1);
        if saved < 0 || libc::dup2(2, 1) < 0 {
            bail!(
                "cannot redirect standard output: {}",
                std::io::Error::last_os_error()
            );
        }
        Ok(std::fs::File::from_raw_fd(saved))
    }
}

/// The devices of `--gpu-index LIST|all`, or None for one device.
pub(crate) fn multi_gpu(index: &Option<GpuIndex>) -> Option<Result<Vec<usize>>> {
    match index {
        Some(GpuIndex::List(list)) => Some(Ok(list.clone())),
        Some(GpuIndex::All) => {
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

/// Vulkan devices side by side (`--gpu-index LIST|all`): samples split into one contiguous range
/// per device (a thread and a Vulkan device each), the films merged: what one render of all
/// samples gives, to float rounding of the sums (`Film::merge`). Reports each device's share and
/// speed. Renders every sample it is given (a signal ends it at once).
struct Devices {
    devices: Vec<usize>,
    validate: bool,
    wavefront: Option<u32>,
}

impl Backend for Devices {
    fn describe(&self) -> String {
        format!("{} Vulkan devices {:?}", self.devices.len(), self.devices)
    }

    fn render_range(
        &self,
        prepared: &PreparedScene,
        settings: &RenderSettings,
        todo: std::ops::Range<u32>,
        progress: &ProgressBar,
        _stop: &AtomicBool,
    ) -> Result<(RenderOutput, u32)> {
        let n = self.devices.len() as u32;
        let len = todo.end - todo.start;
        let never = std::sync::atomic::AtomicBool::new(false);
        let start = std::time::Instant::now();
        let results: Vec<Result<(String, std::ops::Range<u32>, RenderOutput)>> =
            std::thread::scope(|scope| {
                let handles: Vec<_> = self
                    .devices
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
                                validation: self.validate,
                                timing: false,
                                count_fetches: false,
                            })?;
                            let name = format!("{device}: {}", gpu.device().name);
                            let (out, _) = gpu.render_range_with_progress(
                                prepared,
                                settings,
                                self.wavefront,
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
        Ok((RenderOutput { film, stats }, todo.end))
    }

    fn render_progressive(
        &self,
        _scene: &PreparedScene,
        _settings: &RenderSettings,
        _options: &Progressive,
        _progress: &ProgressBar,
    ) -> Result<(RenderOutput, ProgressiveReport)> {
        bail!(PASSES_ON_ONE_DEVICE)
    }
}

/// Why renders in passes refuse several devices.
const PASSES_ON_ONE_DEVICE: &str = "renders in passes run on one device: give --gpu-index N";

/// What renders: the CPU reference, one Vulkan device (`--gpu-index N` or the default), or
/// several side by side (`--gpu-index LIST|all`, renders of a fixed sample count only).
pub(crate) fn backend(
    args: &RenderArgs,
    device: DeviceKind,
    in_passes: bool,
) -> Result<Box<dyn Backend>> {
    if device != DeviceKind::Gpu {
        // (resolve_device never answers Auto.)
        return Ok(Box::new(CpuBackend));
    }
    if !in_passes {
        if let Some(devices) = multi_gpu(&args.opts.gpu_index) {
            return Ok(Box::new(Devices {
                devices: devices?,
                validate: args.opts.validate,
                wavefront: args.opts.wavefront,
            }));
        }
    }
    let mut renderer = GpuRenderer::new(&GpuOptions {
        device_index: match &args.opts.gpu_index {
            None => None,
            Some(g) => Some(
                g.one()
                    .ok_or_else(|| anyhow::anyhow!(PASSES_ON_ONE_DEVICE))?,
            ),
        },
        validation: args.opts.validate,
        timing: true,
        count_fetches: args.stats,
    })?;
    renderer.set_band_pixel_limit(args.band_pixels);
    renderer.set_reuse_deeper_kernels(args.frames.is_some());
    Ok(Box::new(GpuBackend {
        renderer,
        wavefront: args.opts.wavefront,
    }))
}

/// The pass options of `render` (`--target-error`, `--adaptive`, `--max-spp`,
/// `--time-limit`), checked against the settings; None for a render of exactly --spp samples.
pub(crate) fn progressive_options(
    args: &RenderArgs,
    settings: &RenderSettings,
) -> Result<Option<wavetrace::render::progressive::Progressive>> {
    if args.target_error.is_none() && args.time_limit.is_none() {
        if args.max_spp.is_some() {
            bail!("--max-spp caps renders in passes: give --target-error or --time-limit too");
        }
        return Ok(None);
    }
    let p = wavetrace::render::progressive::Progressive {
        target_error: args.target_error,
        adaptive: args.adaptive,
        max_spp: args
            .max_spp
            .unwrap_or(wavetrace::render::progressive::DEFAULT_MAX_SPP.max(settings.spp)),
        time_limit: args.time_limit,
    };
    p.check(settings)?;
    Ok(Some(p))
}
