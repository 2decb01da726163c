//! KHR_lights_punctual on both integrators: a point light (with `range`), a spot light (with
//! its smooth cone falloff) and a directional light over a Lambertian plane seen from above by
//! an orthographic camera, direct lighting only. Each pixel's expectation is the spec's formula
//! integrated over the pixel (L = ρ/π · E_⊥ · cos θ, E_⊥ = I/d² · window · falloff, or E for a
//! directional light); the CPU render must match it within z standard errors of its pixel mean,
//! z two-sided at family-wise α = 0.01 Šidák-corrected over pixels × channels (plus 1e-6
//! absolute and 1e-5 relative for f32 rounding); the GPU must agree with the CPU per tile.
//! LightsPunctualLamp renders alike.

use crate::common;

use crate::common::{assert_agree_at, render_cpu, render_gpu};
use glam::{Vec2, Vec3};
use wavetrace::layout::*;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{Camera, Material, Projection, Scene, Triangle};
use wavetrace::stats::{normal_quantile_upper, sidak};

const ALBEDO: f32 = 0.6;
const HALF: f32 = 2.0;

fn plane_scene(lights: Vec<GpuPunctualLight>) -> PreparedScene {
    // The plane z = 0 over [-4, 4]², front face +Z, Lambertian in glTF's terms.
    let s = 4.0;
    let (a, b, c, d) = (
        Vec3::new(-s, -s, 0.0),
        Vec3::new(s, -s, 0.0),
        Vec3::new(s, s, 0.0),
        Vec3::new(-s, s, 0.0),
    );
    let material = Material {
        name: "plane".into(),
        base_color: Vec3::splat(ALBEDO),
        metallic: 0.0,
        roughness: 1.0,
        specular: 0.0,
        ..Material::default_white()
    };
    PreparedScene::new(&Scene {
        source: "test".into(),
        triangles: vec![Triangle::flat([a, b, c], 0), Triangle::flat([a, c, d], 0)],
        materials: vec![material],
        vertices: Vec::new(),
        textures: Default::default(),
        meshes: Vec::new(),
        instances: Vec::new(),
        punctual: lights,
        // Looking down −Z at the square [-HALF, HALF]².
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            forward: Vec3::NEG_Z,
            right: Vec3::X,
            up: Vec3::Y,
            projection: Projection::Orthographic {
                xmag: HALF,
                ymag: HALF,
            },
            znear: 0.0,
        },
        cameras: Vec::new(),
        dropped_degenerate: 0,
        skipped_primitives: 0,
        notes: Vec::new(),
    })
}

fn light(kind: u32, position: Vec3, direction: Vec3, intensity: f32) -> GpuPunctualLight {
    GpuPunctualLight {
        position: position.to_array(),
        kind,
        direction: direction.normalize().to_array(),
        intensity: [intensity, 0.5 * intensity, 0.25 * intensity],
        ..Default::default()
    }
}

fn spot(mut l: GpuPunctualLight, inner: f32, outer: f32) -> GpuPunctualLight {
    // KHR_lights_punctual, "Inner and Outer Cone Angles".
    l.spot_scale = 1.0 / (inner.cos() - outer.cos()).max(0.001);
    l.spot_offset = -outer.cos() * l.spot_scale;
    l
}

/// The radiance the plane sends up at (x, y) from `l`, by the specification's formulas.
fn expected(l: &GpuPunctualLight, x: f32, y: f32) -> Vec3 {
    let p = Vec3::new(x, y, 0.0);
    let i = Vec3::from(l.intensity);
    let brdf = ALBEDO / std::f32::consts::PI;
    if l.kind == LIGHT_DIRECTIONAL {
        let cos = (-Vec3::from(l.direction)).z.max(0.0);
        return i * brdf * cos;
    }
    let to = Vec3::from(l.position) - p;
    let d = to.length();
    let wi = to / d;
    let mut e = i / (d * d) * wi.z.max(0.0);
    if l.range > 0.0 {
        e *= (1.0 - (d / l.range).powi(4)).clamp(0.0, 1.0);
    }
    if l.kind == LIGHT_SPOT {
        let a = (Vec3::from(l.direction).dot(-wi) * l.spot_scale + l.spot_offset).clamp(0.0, 1.0);
        e *= a * a;
    }
    e * brdf
}

const SIZE: u32 = 32;

fn settings(seed: u32) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: 64,
        max_depth: 1,
        seed,
        ..RenderSettings::default()
    }
}

/// Every pixel's CPU mean against the formula integrated over the pixel (8 × 8 midpoints).
fn check_against_formula(lights: Vec<GpuPunctualLight>, what: &str) -> PreparedScene {
    let scene = plane_scene(lights.clone());
    // Each sample picks one light with its table probability: the pixel mean is normal enough
    // for the z test once every light is expected at least 50 times per pixel.
    let min_pmf = scene.lights.iter().map(|e| e.pmf).fold(1.0f32, f32::min);
    let spp = ((50.0 / min_pmf).ceil() as u32).next_power_of_two().max(64);
    let out = render_cpu(&scene, &RenderSettings { spp, ..settings(7) });
    assert_eq!(out.film.dropped, 0);
    let pixel = 2.0 * HALF / SIZE as f32;
    // Two-sided z at family-wise α = 0.01 over every pixel and channel (Šidák).
    let tests = (3 * SIZE * SIZE) as usize;
    let z_max = normal_quantile_upper(sidak(0.01, tests) / 2.0) as f32;
    let mut worst = (0.0f32, String::new());
    for py in 0..SIZE {
        for px in 0..SIZE {
            let mut want = Vec3::ZERO;
            for j in 0..8 {
                for i in 0..8 {
                    let q = Vec2::new(
                        px as f32 + (i as f32 + 0.5) / 8.0,
                        py as f32 + (j as f32 + 0.5) / 8.0,
                    );
                    let (x, y) = (-HALF + q.x * pixel, HALF - q.y * pixel);
                    want += lights.iter().map(|l| expected(l, x, y)).sum::<Vec3>() / 64.0;
                }
            }
            let index = (py * SIZE + px) as usize;
            let got = out.film.mean(index);
            let se = out.film.variance_of_mean(index).to_array().map(f32::sqrt);
            for c in 0..3 {
                let z = (got[c] - want[c]).abs() / (z_max * se[c] + 1e-6 + 1e-5 * want[c]);
                if z > worst.0 {
                    worst = (
                        z,
                        format!(
                            "pixel ({px}, {py}) channel {c}: {} vs {} ± {}",
                            got[c], want[c], se[c]
                        ),
                    );
                }
            }
        }
    }
    assert!(worst.0 <= 1.0, "{what}: {}", worst.1);
    scene
}

#[test]
fn point_light_with_range_matches_the_formula() {
    let mut l = light(LIGHT_POINT, Vec3::new(0.5, -0.3, 1.5), Vec3::NEG_Z, 4.0);
    l.range = 2.5;
    check_against_formula(vec![l], "point light with range");
}

#[test]
fn spot_light_matches_the_formula() {
    let l = spot(
        light(
            LIGHT_SPOT,
            Vec3::new(-0.4, 0.2, 2.0),
            Vec3::new(0.3, -0.2, -1.0),
            6.0,
        ),
        0.3,
        0.6,
    );
    check_against_formula(vec![l], "spot light");
}

#[test]
fn directional_light_matches_the_formula_and_gpu_agrees_with_all_three() {
    let d = light(
        LIGHT_DIRECTIONAL,
        Vec3::ZERO,
        Vec3::new(0.4, 0.3, -1.0),
        1.5,
    );
    check_against_formula(vec![d], "directional light");
    let mut p = light(LIGHT_POINT, Vec3::new(0.5, -0.3, 1.5), Vec3::NEG_Z, 4.0);
    p.range = 2.5;
    let s = spot(
        light(
            LIGHT_SPOT,
            Vec3::new(-0.4, 0.2, 2.0),
            Vec3::new(0.3, -0.2, -1.0),
            6.0,
        ),
        0.3,
        0.6,
    );
    // All three at once: the emitter table chooses among them by power.
    let scene = check_against_formula(vec![d, p, s], "three punctual lights");
    let cpu = render_cpu(&scene, &settings(2));
    if let Some(gpu) = render_gpu(&scene, &settings(1), None) {
        assert_eq!(gpu.film.dropped, 0);
        assert_agree_at(&gpu.film, &cpu.film, 0.01, "three punctual lights");
    }
}

#[test]
fn lights_punctual_lamp_renders_alike() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/gltf-samples/valid/LightsPunctualLamp/LightsPunctualLamp.gltf");
    if !path.exists() {
        eprintln!("skipping: ../shared/gltf-samples not found");
        return;
    }
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    assert!(!scene.punctual.is_empty());
    assert!(
        scene
            .notes
            .iter()
            .all(|n| !n.contains("KHR_lights_punctual")),
        "{:?}",
        scene.notes
    );
    let prepared = PreparedScene::new(&scene);
    let s = |seed| RenderSettings {
        width: 40,
        height: 40,
        spp: 64,
        max_depth: 4,
        seed,
        ..RenderSettings::default()
    };
    common::gpu_agrees_with_cpu(&prepared, &s(1), &s(2), "LightsPunctualLamp");
}

/// An emissive texture that is black on its left half: the emitter table gives the triangles
/// that map to the black half almost no probability (the 10⁻³ floor of the texture's mean over
/// the image), those on the white half the rest, and the render stays the same on both sides.
#[test]
fn emitters_are_chosen_by_their_texture_over_them() {
    use std::sync::Arc;
    use wavetrace::scene::{MaterialTextures, TextureSet};
    // Two unit quads at x ∈ [-1, 0] (u ∈ [0, 0.5]) and x ∈ [0, 1] (u ∈ [0.5, 1]), facing +Z.
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for q in 0..2 {
        let x0 = q as f32 - 1.0;
        let base = vertices.len() as u32;
        for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            vertices.push(GpuVertex {
                normal: [0.0, 0.0, 1.0],
                uv: [0.5 * (q as f32 + dx), 1.0 - dy, 0.0, 0.0],
                color: [1.0; 4],
                ..Default::default()
            });
        }
        let p = |k: u32| {
            let (dx, dy) = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)][k as usize];
            Vec3::new(x0 + dx, dy, 0.0)
        };
        for [a, b, c] in [[0, 1, 2], [0, 2, 3]] {
            triangles.push(Triangle {
                p: [p(a), p(b), p(c)],
                material: 0,
                vertices: [base + a, base + b, base + c],
                flags: TRIANGLE_FLAT,
            });
        }
    }
    // A 2 × 1 texture, nearest: black left texel, white right texel.
    let textures = TextureSet {
        textures: vec![GpuTexture {
            width: 2,
            height: 1,
            levels: 2,
            wrap_s: WRAP_CLAMP_TO_EDGE,
            wrap_t: WRAP_CLAMP_TO_EDGE,
            filters: FILTER_NEAREST | (MIN_NEAREST << 4),
            ..Default::default()
        }],
        refs: vec![GpuTextureRef {
            transform: [1.0, 0.0, 0.0, 1.0],
            ..Default::default()
        }],
        texels: Arc::new(vec![0xff00_0000, 0xffff_ffff, 0xff80_8080]),
        means: vec![[0.5, 0.5, 0.5, 1.0]],
    };
    let material = Material {
        name: "half-black emitter".into(),
        base_color: Vec3::ZERO,
        emission: Vec3::splat(2.0),
        textures: MaterialTextures {
            emissive: Some(0),
            ..Default::default()
        },
        ..Material::default_white()
    };
    let mut scene = Scene::load(&common::scene_path("cornell-box.gltf")).unwrap();
    scene.triangles = triangles;
    scene.vertices = vertices;
    scene.materials = vec![material];
    scene.textures = textures;
    scene.punctual = Vec::new();
    let prepared = PreparedScene::new(&scene);
    let pmf_of = |x_sign: f32| -> f32 {
        prepared
            .lights
            .iter()
            .filter(|e| {
                let t = &prepared.triangles[e.triangle as usize];
                let centroid = Vec3::from(t.p0) + (Vec3::from(t.e1) + Vec3::from(t.e2)) / 3.0;
                centroid.x * x_sign > 0.0
            })
            .map(|e| e.pmf)
            .sum()
    };
    let (left, right) = (pmf_of(-1.0), pmf_of(1.0));
    assert!((left + right - 1.0).abs() < 1e-5);
    // Right: the texture's mean over it is 1, twice the image's 0.5; left: the 10⁻³ floor.
    assert!(
        (left / right - 1e-3 / 2.0).abs() < 1e-6,
        "left {left}, right {right}"
    );
}
