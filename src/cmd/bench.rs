//! `wavetrace bench`: samples/s and rays/s of the GPU and the CPU reference on each scene, per
//! kernel time, against a baseline (`--baseline`) or as JSON (`--json`).

use super::bench_args::{
    baseline_machine_notice, host_cpu, read_rows_json, scene_name, statistics_json, value_name,
    BenchArgs,
};
use super::bench_bvh::bench_bvh;
use super::bench_kernels::bench_kernels;
use super::prepare::scenes_dir;
use super::report::{fetches_per_ray, host_phases};
use anyhow::{Context as _, Result};
use std::path::PathBuf;
use wavetrace::gpu::{GpuOptions, GpuRenderer};
use wavetrace::lights::environment::EnvironmentMap;
use wavetrace::render::{PreparedScene, RenderSettings, RenderStats};
use wavetrace::scene::{LoadOptions, Scene};

pub(crate) fn bench(args: &BenchArgs) -> Result<()> {
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
        if let Err(why) = wavetrace::render::check(&prepared, &settings) {
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
                .filter(|_| settings.integrator == wavetrace::render::Integrator::Path)
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
