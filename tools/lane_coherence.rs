//! How well the lanes of an 8-wide SIMD device (lavapipe) agree in the closest-hit walk, and how
//! much reordering the rays could change that: a model on the CPU, not a render.
//!
//!     cargo run --release --example lane_coherence [-- [--size N] [--bounces B] SCENE.gltf ...]
//!
//! Per scene (one placement: a scene with a top level is skipped), N² camera rays (jittered,
//! pinhole) and B diffuse bounces from their hits (cosine-distributed about the geometric normal,
//! `rng_uniform4` of pixel and bounce as the random numbers, origins offset as the integrators
//! offset them: a model of a path tracer's rays, not its estimator) are walked through the CPU's 4-wide tree (`PreparedScene::wide_bvh`, the collapse
//! the GPU's quantised nodes are made from), and each ray's boxes and triangles tested are counted.
//! The rays of a bounce are taken in groups of eight, and a group's efficiency is its mean over
//! its maximum: the share of a SIMD step's lanes doing work when a walk's trip count is its
//! longest lane's. Three orders: pixel order (as a subgroup pushes them to the wavefront's queues),
//! sorted by the octant of the direction, and sorted by octant within the cluster of triangles the
//! ray leaves (sixteen neighbours in the BVH's order). docs/perf-log/2026-12-02-lavapipe-fetches-and-divergence.md says what it found.

use anyhow::{bail, Context, Result};
use glam::{Vec2, Vec3};
use std::path::PathBuf;
use wavetrace::bvh::{closest_triangle, Ray};
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::sampling::{build_frame, offset_ray_origin, rng_uniform4, sample_cosine_hemisphere};
use wavetrace::scene::{camera_ray, Scene};

const LANES: usize = 8;

/// One walked ray: its sort keys and what its walk tested.
struct Walk {
    octant: u32,
    cluster: u32,
    boxes: u32,
    triangles: u32,
}

/// Efficiency of (boxes, triangles) with the walks taken in `order`, groups of LANES.
fn efficiency(walks: &[Walk], order: &[usize]) -> (f64, f64) {
    let (mut boxes, mut boxes_max, mut tris, mut tris_max) = (0u64, 0u64, 0u64, 0u64);
    for group in order.chunks(LANES) {
        let n = group.len() as u64;
        let b = group.iter().map(|&i| walks[i].boxes as u64);
        let t = group.iter().map(|&i| walks[i].triangles as u64);
        boxes += b.clone().sum::<u64>();
        boxes_max += b.max().unwrap_or(0) * n;
        tris += t.clone().sum::<u64>();
        tris_max += t.max().unwrap_or(0) * n;
    }
    (
        boxes as f64 / boxes_max.max(1) as f64,
        tris as f64 / tris_max.max(1) as f64,
    )
}

fn scene_report(path: &std::path::Path, size: u32, bounces: u32) -> Result<()> {
    let scene = Scene::load(path).with_context(|| format!("loading {}", path.display()))?;
    let prepared = PreparedScene::new(&scene);
    let roots = prepared.level_roots();
    if roots.len() != 2 {
        println!(
            "{}: {} placements, skipped (one only)",
            path.display(),
            roots.len() - 1
        );
        return Ok(());
    }
    let settings = RenderSettings {
        width: size,
        height: size,
        spp: 1,
        ..Default::default()
    };
    let frame = prepared.frame_params(&settings);
    let wide = prepared.wide_bvh();
    let mut rays: Vec<(u32, Ray, u32)> = (0..size * size)
        .map(|p| {
            let u = rng_uniform4(0, p, 0, 0);
            let jitter = Vec2::new(u.x, u.y);
            (p, camera_ray(&frame, p, jitter, Vec2::ZERO), u32::MAX)
        })
        .collect();
    println!(
        "{} ({size}², {bounces} bounces; efficiency of boxes, triangles)",
        path.display()
    );
    println!("  bounce      rays  boxes/ray  tris/ray  pixel order   by octant  by cluster+octant");
    for bounce in 0..=bounces {
        let mut walks = Vec::with_capacity(rays.len());
        let mut next = Vec::new();
        for &(pixel, ray, from) in &rays {
            let (hit, boxes, triangles) = closest_triangle(
                wide,
                roots[1],
                &prepared.triangles,
                &ray,
                0.0,
                f32::MAX,
                |_, _, _| true,
            );
            let d = ray.dir;
            walks.push(Walk {
                octant: (d.x < 0.0) as u32 | ((d.y < 0.0) as u32) << 1 | ((d.z < 0.0) as u32) << 2,
                cluster: from >> 4,
                boxes,
                triangles,
            });
            let Some(hit) = hit else { continue };
            let tri = &prepared.triangles[hit.triangle as usize];
            let mut n = Vec3::from(tri.e1)
                .cross(Vec3::from(tri.e2))
                .normalize_or_zero();
            if n.dot(d) > 0.0 {
                n = -n;
            }
            let u = rng_uniform4(0, pixel, 0, 1 + bounce);
            let local = sample_cosine_hemisphere(Vec2::new(u.x, u.y));
            let (t, b) = build_frame(n);
            let dir = (t * local.x + b * local.y + n * local.z).normalize();
            let origin = offset_ray_origin(ray.origin + hit.t * d, n);
            next.push((pixel, Ray { origin, dir }, hit.triangle));
        }
        if walks.is_empty() {
            break;
        }
        let pixel_order: Vec<usize> = (0..walks.len()).collect();
        let mut by_octant = pixel_order.clone();
        by_octant.sort_by_key(|&i| walks[i].octant);
        let mut by_cluster = pixel_order.clone();
        by_cluster.sort_by_key(|&i| (walks[i].cluster, walks[i].octant));
        let mean = |f: fn(&Walk) -> u32| {
            walks.iter().map(|w| f(w) as f64).sum::<f64>() / walks.len() as f64
        };
        let show = |(b, t): (f64, f64)| format!("{b:.2}, {t:.2}");
        println!(
            "  {bounce:>6} {:>9} {:>10.1} {:>9.2}  {:>11}  {:>10}  {:>17}",
            walks.len(),
            mean(|w| w.boxes),
            mean(|w| w.triangles),
            show(efficiency(&walks, &pixel_order)),
            show(efficiency(&walks, &by_octant)),
            show(efficiency(&walks, &by_cluster)),
        );
        rays = next;
    }
    Ok(())
}

fn main() -> Result<()> {
    let (mut size, mut bounces, mut scenes) = (256u32, 4u32, Vec::new());
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--size" => size = args.next().context("--size N")?.parse()?,
            "--bounces" => bounces = args.next().context("--bounces B")?.parse()?,
            s if s.starts_with("--") => bail!("unknown option {s}"),
            s => scenes.push(PathBuf::from(s)),
        }
    }
    if scenes.is_empty() {
        scenes.push(PathBuf::from("scenes/cornell-box.gltf"));
    }
    for scene in &scenes {
        scene_report(scene, size, bounces)?;
    }
    Ok(())
}
