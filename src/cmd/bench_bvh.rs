//! `wavetrace bench --bvh`: BVH build time, SAH cost and traversal cost per ray, and the GPU's
//! own walks on the same random rays against the CPU reference's.

use super::bench_args::host_cpu;
use anyhow::{Context as _, Result};
use glam::Vec3;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use wavetrace::gpu::GpuRenderer;
use wavetrace::render::PreparedScene;
use wavetrace::scene::{LoadOptions, Scene};

/// Boxes tested per ray and rays per second of `RAYS` closest-hit rays `ray(i)` through `tree`.
pub(crate) fn walk_cost(
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
pub(crate) const RAYS: u32 = 1 << 20;

/// A build's parts in ms: the primitive references, the tree, its assembly (`BvhStats`).
pub(crate) fn build_parts_ms(stats: &wavetrace::bvh::BvhStats) -> [f64; 3] {
    [stats.refs_time, stats.tree_time, stats.assemble_time].map(|t| t.as_secs_f64() * 1e3)
}

/// `bench --bvh`: build time, tree statistics and closest-hit traversal cost per scene.
pub(crate) fn bench_bvh(
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
pub(crate) struct WalkComparison {
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
pub(crate) fn bench_gpu_walk(
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
