//! `wavetrace bench --kernels`: each scene's GPU kernels made without rendering, with the
//! driver's registers, spills and scratch per kernel.

use super::bench_args::{read_rows_json, scene_name, statistics_changes, statistics_json};
use super::report::deferred_slots;
use anyhow::{Context as _, Result};
use std::path::{Path, PathBuf};
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{LoadOptions, Scene};

/// `bench --kernels`: each scene's kernels made on the GPU for `settings`, without rendering,
/// and the driver's statistics of each.
pub(crate) fn bench_kernels(
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
        if let Err(why) = wavetrace::render::check(&prepared, settings) {
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
