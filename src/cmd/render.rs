//! `wavetrace render`: one scene to EXR or PNG, on the CPU reference or a Vulkan device (or
//! several), in one go, in passes (`--target-error`, `--time-limit`) or as a shard, with path
//! layers (`--aov NAME=EXPR`) beside the image.

use super::options::{DeviceKind, GpuIndex, RenderArgs};
use super::prepare::{prepare, resolve_device, scenes_dir};
use super::report::{print_stats, progress_bar};
use super::shards::{finish, plan, record, stop_flag, INTERRUPTED_EXIT};
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use std::path::{Path, PathBuf};
use wavetrace::gpu::{GpuOptions, GpuRenderer};
use wavetrace::render::{PreparedScene, RenderOutput, RenderSettings, RenderStats};

pub(crate) fn render(args: &RenderArgs) -> Result<()> {
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
    let mut record = record(args, &path, &prepared, &settings, device)?;
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
    let plan = plan(args, &record, progressive.is_some(), default_output)?;
    let output = plan.output.clone();
    // Samples to render now (a test may stop them early, as a signal would).
    let todo = match args.stop_after {
        Some(n) => plan.todo.start..plan.todo.end.min(plan.todo.start.saturating_add(n)),
        None => plan.todo.as_range(),
    };
    let stop = stop_flag(progressive.is_some());
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
        let (film, r) = finish(plan, film, end, record);
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

/// Renders samples `todo` split into one contiguous range per device of `devices`, side by side
/// (a thread and a Vulkan device each), and merges the films: what one render of all samples
/// gives, to float rounding of the sums (`Film::merge`). Reports each device's share and speed.
pub(crate) fn render_on_devices(
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
pub(crate) fn progressive_options(
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
