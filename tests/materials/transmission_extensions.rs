//! KHR_materials_volume and KHR_materials_diffuse_transmission in scenes (one test binary, so
//! that lavapipe compiles the kernels once).
//!
//! Volume: Beer–Lambert attenuation inside transmissive meshes. An analytic slab (a smooth
//! glass box of thickness d and attenuation σ, seen at normal incidence under a uniform white
//! environment) reflects and transmits exactly what the series of its internal reflections
//! gives; the GPU agrees with the CPU per tile on it and on the Khronos AttenuationTest model
//! (skipped with a notice where ../shared/gltf-samples is absent); light tracing and BDPT
//! (CPU and GPU) agree with the path tracer on a lit absorbing block.
//!
//! Clearcoat over an emitter: "the emission is darkened by the Fresnel term" of the coat,
//! exactly Le·(1 − clearcoat·0.04) seen head-on, and every integrator darkens it alike where a
//! coated light grazes a floor (next event estimation, emitter hits, light subpaths).
//!
//! Thin walls: KHR_materials_transmission without a volume is an infinitely thin shell (glTF's
//! default). A smooth thin pane of base colour C in front of an emitter of radiance L shows
//! exactly (1 − F(θ))·C·L, head-on and at 60°, on CPU and GPU (where solid glass would show
//! a 1/η² of it and bend the view); light tracing and BDPT (the importance-mode BSDF) agree
//! with the path tracer through a rough thin pane.
//!
//! Diffuse transmission: scenes/leaf.gltf (tools/gen_scenes.py), a leaf lit from behind,
//! shows its transmission colour, and every integrator on CPU and GPU agrees with the CPU path
//! tracer per tile.

use crate::common;

use crate::common::{assert_agree_at, batch_tiles, compare_batch_tiles, render_cpu, render_gpu};
use base64::Engine;
use glam::Vec3;
use std::path::PathBuf;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::Scene;
use wavetrace::stats::{normal_quantile_upper, sidak};

const THICKNESS: f32 = 0.5;

/// A renderer of films for the batch comparisons (None: no GPU).
type Render<'a> = dyn Fn(&RenderSettings) -> Option<wavetrace::film::Film> + 'a;
const ATTENUATION_COLOR: [f32; 3] = [0.2, 0.5, 0.9];
const ATTENUATION_DISTANCE: f32 = 1.0;

/// Outward-facing triangles of the box of half extents `half` about `centre` (four vertices a
/// face, flat), appended to `positions` / `indices`.
fn add_box(positions: &mut Vec<f32>, indices: &mut Vec<u16>, half: [f32; 3], centre: [f32; 3]) {
    for k in 0..3 {
        for s in [1.0f32, -1.0] {
            let (u, v) = ((k + 1) % 3, (k + 2) % 3);
            // Corners counter-clockwise seen from outside (u × v = e_k; reversed for −e_k).
            let mut corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
            if s < 0.0 {
                corners.reverse();
            }
            let first = (positions.len() / 3) as u16;
            for (a, b) in corners {
                let mut p = centre;
                p[k] += s * half[k];
                p[u] += a * half[u];
                p[v] += b * half[v];
                positions.extend(p);
            }
            indices.extend([0, 1, 2, 0, 2, 3].map(|i| first + i));
        }
    }
}

/// A square of half extent `half` at height `z` facing +Z (`up`) or −Z.
fn add_square(positions: &mut Vec<f32>, indices: &mut Vec<u16>, half: f32, z: f32, up: bool) {
    let first = (positions.len() / 3) as u16;
    for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        positions.extend([a * half, b * half, z]);
    }
    let order = if up {
        [0, 1, 2, 0, 2, 3]
    } else {
        [0, 2, 1, 0, 3, 2]
    };
    indices.extend(order.map(|i| first + i));
}

/// A glTF of meshes (positions, u16 indices, material index each), `materials` and `camera`
/// (the JSON of cameras[0]) on a node translated to `eye`, written to the test's folder.
fn write_gltf(
    name: &str,
    meshes: &[(Vec<f32>, Vec<u16>, usize)],
    materials: &str,
    camera: &str,
    eye: [f32; 3],
) -> PathBuf {
    let mut bytes: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut json_meshes, mut nodes) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, (positions, indices, material)) in meshes.iter().enumerate() {
        let offset = bytes.len();
        bytes.extend(positions.iter().flat_map(|x| x.to_le_bytes()));
        views.push(format!(
            r#"{{"buffer": 0, "byteOffset": {offset}, "byteLength": {}}}"#,
            positions.len() * 4
        ));
        let axis = |a: usize, f: fn(f32, f32) -> f32| {
            positions
                .iter()
                .skip(a)
                .step_by(3)
                .copied()
                .reduce(f)
                .unwrap()
        };
        accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": 5126, "count": {}, "type": "VEC3", "min": [{}, {}, {}], "max": [{}, {}, {}]}}"#,
            2 * k,
            positions.len() / 3,
            axis(0, f32::min),
            axis(1, f32::min),
            axis(2, f32::min),
            axis(0, f32::max),
            axis(1, f32::max),
            axis(2, f32::max)
        ));
        let offset = bytes.len();
        bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
        while !bytes.len().is_multiple_of(4) {
            bytes.push(0);
        }
        views.push(format!(
            r#"{{"buffer": 0, "byteOffset": {offset}, "byteLength": {}}}"#,
            indices.len() * 2
        ));
        accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": 5123, "count": {}, "type": "SCALAR"}}"#,
            2 * k + 1,
            indices.len()
        ));
        json_meshes.push(format!(
            r#"{{"primitives": [{{"attributes": {{"POSITION": {}}}, "indices": {}, "material": {material}}}]}}"#,
            2 * k,
            2 * k + 1
        ));
        nodes.push(format!(r#"{{"mesh": {k}}}"#));
    }
    nodes.push(format!(
        r#"{{"camera": 0, "translation": [{}, {}, {}]}}"#,
        eye[0], eye[1], eye[2]
    ));
    let uri = base64::engine::general_purpose::STANDARD.encode(&bytes);
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_specular", "KHR_materials_emissive_strength", "KHR_materials_dispersion", "KHR_materials_clearcoat"],
  "scene": 0,
  "scenes": [{{"nodes": [{}]}}],
  "nodes": [{}],
  "cameras": [{camera}],
  "materials": [{materials}],
  "meshes": [{}],
  "accessors": [{}],
  "bufferViews": [{}],
  "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{uri}"}}]
}}"#,
        (0..nodes.len())
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        nodes.join(", "),
        json_meshes.join(", "),
        accessors.join(", "),
        views.join(", "),
        bytes.len(),
    );
    let path = common::temp("transmission", name);
    std::fs::write(&path, json).unwrap();
    path
}

/// The absorbing glass material: ior 1.5, transmission 1, `roughness`, the volume above,
/// KHR_materials_dispersion's `dispersion` (none at 0).
fn volume_material(roughness: f32, thickness: f32, dispersion: f32) -> String {
    let [r, g, b] = ATTENUATION_COLOR;
    let dispersive = if dispersion > 0.0 {
        format!(r#", "KHR_materials_dispersion": {{"dispersion": {dispersion}}}"#)
    } else {
        String::new()
    };
    format!(
        r#"{{"name": "slab", "pbrMetallicRoughness": {{"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": {roughness}}},
    "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}}{dispersive},
      "KHR_materials_volume": {{"thicknessFactor": {thickness}, "attenuationColor": [{r}, {g}, {b}], "attenuationDistance": {ATTENUATION_DISTANCE}}}}}}}"#
    )
}

/// The slab [−1, 1]² × [−d/2, d/2]: smooth absorbing glass seen by an orthographic camera on +Z
/// looking down −Z.
fn slab_gltf() -> PathBuf {
    let (mut positions, mut indices) = (Vec::new(), Vec::new());
    add_box(
        &mut positions,
        &mut indices,
        [1.0, 1.0, THICKNESS / 2.0],
        [0.0; 3],
    );
    write_gltf(
        "slab.gltf",
        &[(positions, indices, 0)],
        &volume_material(0.0, THICKNESS, 0.0),
        r#"{"type": "orthographic", "orthographic": {"xmag": 0.5, "ymag": 0.5, "znear": 0.01, "zfar": 100}}"#,
        [0.0, 0.0, 5.0],
    )
}

/// A rough absorbing glass block over a white Lambertian floor under a square light facing
/// down (one-sided: the camera above sees through its back face), for the integrators that
/// need emitting triangles; dispersive where `dispersion` > 0.
fn lit_block_gltf(dispersion: f32) -> PathBuf {
    let mut meshes = Vec::new();
    let (mut p, mut i) = (Vec::new(), Vec::new());
    add_box(&mut p, &mut i, [0.6, 0.6, 0.25], [0.1, 0.0, 0.0]);
    meshes.push((p, i, 0));
    let (mut p, mut i) = (Vec::new(), Vec::new());
    add_square(&mut p, &mut i, 2.0, -0.5, true);
    meshes.push((p, i, 1));
    let (mut p, mut i) = (Vec::new(), Vec::new());
    add_square(&mut p, &mut i, 0.4, 1.5, false);
    meshes.push((p, i, 2));
    let materials = format!(
        r#"{},
    {{"name": "floor", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 1}},
      "extensions": {{"KHR_materials_specular": {{"specularFactor": 0}}}}}},
    {{"name": "light", "pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 1}},
      "emissiveFactor": [1, 1, 1], "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 8}}, "KHR_materials_specular": {{"specularFactor": 0}}}}}}"#,
        volume_material(0.3, 0.5, dispersion)
    );
    write_gltf(
        if dispersion > 0.0 {
            "lit-block-dispersive.gltf"
        } else {
            "lit-block.gltf"
        },
        &meshes,
        &materials,
        r#"{"type": "perspective", "perspective": {"yfov": 1.0, "aspectRatio": 1.0, "znear": 0.05}}"#,
        [0.0, 0.0, 3.5],
    )
}

fn slab_settings(seed: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 16,
        spp,
        max_depth: 64,
        seed,
        environment: Vec3::ONE,
        ..RenderSettings::default()
    }
}

/// What the slab returns towards the camera under a uniform environment of radiance 1: with
/// F = F0 = 0.04 at normal incidence on either face and a = exp(−σd) per crossing, the light
/// reflected by the front face, plus the transmitted and internally reflected series
/// (1 − F)²a Σ (F²a²)ᵏ from behind and (1 − F)²F a² Σ (F²a²)ᵏ from the front:
/// F + (1 − F)²·(a + F a²)/(1 − F²a²). (The 1/η² of entering and η² of leaving cancel.)
fn slab_expected() -> Vec3 {
    let f = 0.04f64;
    let channel = |c: f32| {
        let sigma = -(c as f64).ln() / ATTENUATION_DISTANCE as f64;
        let a = (-sigma * THICKNESS as f64).exp();
        f + (1.0 - f) * (1.0 - f) * (a + f * a * a) / (1.0 - f * f * a * a)
    };
    let [r, g, b] = ATTENUATION_COLOR;
    Vec3::new(channel(r) as f32, channel(g) as f32, channel(b) as f32)
}

/// The image's mean per channel and its standard error from the pixels' own variances.
fn image_mean(film: &wavetrace::film::Film) -> ([f64; 3], [f64; 3]) {
    let n = film.pixels.len() as f64;
    let (mut mean, mut var) = ([0f64; 3], [0f64; 3]);
    for p in 0..film.pixels.len() {
        let (m, v) = (film.mean_f64(p), film.variance_of_mean_f64(p));
        for c in 0..3 {
            mean[c] += m[c] / n;
            var[c] += v[c] / (n * n);
        }
    }
    (mean, var.map(f64::sqrt))
}

#[test]
fn a_slab_transmits_exp_minus_sigma_d_times_the_fresnel_terms() {
    let scene = Scene::load(&slab_gltf()).unwrap_or_else(|e| panic!("{e:#}"));
    assert!(scene
        .notes
        .iter()
        .all(|n| !n.contains("KHR_materials_volume")));
    let m = &scene.materials[0];
    assert_eq!(
        (m.thickness, m.attenuation_color, m.attenuation_distance),
        (
            THICKNESS,
            Vec3::from(ATTENUATION_COLOR),
            ATTENUATION_DISTANCE
        )
    );
    let prepared = PreparedScene::new(&scene);
    let film = render_cpu(&prepared, &slab_settings(3, 256)).film;
    assert_eq!(film.dropped, 0);
    let (mean, se) = image_mean(&film);
    let expected = slab_expected();
    let z = normal_quantile_upper(sidak(0.01, 3) / 2.0);
    for c in 0..3 {
        let se = se[c];
        println!(
            "channel {c}: {:.5} ± {se:.5}, expected {:.5}",
            mean[c], expected[c]
        );
        assert!(
            (mean[c] - expected[c] as f64).abs() <= z * se + 1e-6,
            "channel {c}: {} vs {} (se {se})",
            mean[c],
            expected[c]
        );
    }
    // Without the volume the slab is lossless: everything comes back (a = 1 gives 1).
    assert!((slab_expected().max_element() - 1.0).abs() > 0.01);
}

#[test]
fn gpu_matches_cpu_on_the_slab_and_the_attenuation_test() {
    let alpha = sidak(0.01, 2);
    let scene = Scene::load(&slab_gltf()).unwrap_or_else(|e| panic!("{e:#}"));
    let prepared = PreparedScene::new(&scene);
    let cpu = render_cpu(&prepared, &slab_settings(2, 64));
    let Some(gpu) = render_gpu(&prepared, &slab_settings(1, 64), None) else {
        return;
    };
    assert_eq!(gpu.film.dropped, 0);
    assert_agree_at(&gpu.film, &cpu.film, alpha, "volume slab");
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/gltf-samples/valid/extensions/AttenuationTest.glb");
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return;
    }
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    for note in &scene.notes {
        assert!(!note.contains("KHR_materials_volume"), "{note}");
    }
    assert!(scene
        .materials
        .iter()
        .any(|m| m.thickness > 0.0 && m.attenuation_distance.is_finite()));
    let prepared = PreparedScene::new(&scene);
    let settings = |seed| RenderSettings {
        width: 32,
        height: 32,
        spp: 64,
        max_depth: 8,
        seed,
        environment: Vec3::ONE,
        ..RenderSettings::default()
    };
    let cpu = render_cpu(&prepared, &settings(2));
    assert_eq!(cpu.film.dropped, 0);
    let gpu = render_gpu(&prepared, &settings(1), None).unwrap();
    assert_eq!(gpu.film.dropped, 0);
    assert_agree_at(&gpu.film, &cpu.film, alpha, "AttenuationTest.glb");
}

/// The CPU path tracer's batch tiles of `prepared` at `max_depth` (24², independent sampler),
/// checked by `check_path`, then each case's (name, integrator, spp, GPU?) batch tiles against
/// them by Welch tests at family-wise α = 0.01, Šidák-corrected over cases × tiles × channels.
/// Returns early without a GPU.
fn assert_integrators_agree_with_the_path_tracer(
    prepared: &PreparedScene,
    max_depth: u32,
    cases: &[(&str, wavetrace::render::Integrator, u32, bool)],
    check_path: impl Fn(&[[(f64, f64); 3]]),
) {
    use wavetrace::layout::SAMPLER_INDEPENDENT;
    use wavetrace::render::Integrator;
    let settings = |integrator, spp| RenderSettings {
        width: 24,
        height: 24,
        spp,
        max_depth,
        sampler: SAMPLER_INDEPENDENT,
        integrator,
        ..RenderSettings::default()
    };
    let cpu = |s: &RenderSettings| Some(wavetrace::cpu::render(prepared, s).film);
    let gpu = |s: &RenderSettings| render_gpu(prepared, s, None).map(|o| o.film);
    let path = batch_tiles(&settings(Integrator::Path, 8), 1, &cpu).unwrap();
    check_path(&path);
    let per_test = sidak(0.01, cases.len() * path.len() * 3);
    let mut failures = Vec::new();
    for (k, &(name, integrator, spp, on_gpu)) in cases.iter().enumerate() {
        let render: &Render = if on_gpu { &gpu } else { &cpu };
        let Some(ours) = batch_tiles(&settings(integrator, spp), 2 + k as u32, render) else {
            return;
        };
        let min_p = compare_batch_tiles(name, &ours, &path, "path", per_test, &mut failures);
        println!("{name} vs CPU path: smallest p {min_p:.3e} (per-test α {per_test:.2e})");
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn light_tracing_and_bdpt_attenuate_as_the_path_tracer_does() {
    use wavetrace::render::Integrator;
    let scene = Scene::load(&lit_block_gltf(0.0)).unwrap_or_else(|e| panic!("{e:#}"));
    let prepared = PreparedScene::new(&scene);
    let cases = [
        ("CPU light", Integrator::Light, 8, false),
        ("CPU bdpt", Integrator::Bdpt, 4, false),
        ("GPU light", Integrator::Light, 8, true),
        ("GPU bdpt", Integrator::Bdpt, 4, true),
    ];
    assert_integrators_agree_with_the_path_tracer(&prepared, 5, &cases, |path| {
        // The floor seen through the block is tinted by the volume (red absorbed most): the
        // centre tile's blue exceeds its red by more than four standard errors.
        let centre = &path[path.len() / 2];
        println!("path tracer, a centre tile: {centre:?}");
        assert!(centre[2].0 - centre[0].0 > 4.0 * (centre[2].1 + centre[0].1).sqrt());
    });
}

/// KHR_materials_dispersion through a rough block: the path tracer turns a path spectral at its
/// first dispersive vertex, light tracing and BDPT carry one wavelength for the whole sample
/// (src/spectrum.rs); the rough dielectric's pdf then depends on λ inside BDPT's MIS. All four
/// agree with the CPU path tracer per tile.
#[test]
fn light_tracing_and_bdpt_disperse_as_the_path_tracer_does() {
    use wavetrace::render::Integrator;
    let scene = Scene::load(&lit_block_gltf(2.0)).unwrap_or_else(|e| panic!("{e:#}"));
    assert!(scene
        .notes
        .iter()
        .all(|n| !n.contains("KHR_materials_dispersion")));
    let prepared = PreparedScene::new(&scene);
    assert_eq!(
        prepared.frame_params(&RenderSettings::default()).spectral,
        1
    );
    // Four times the samples of the non-dispersive block: the wavelength's weight r(λ)/p(λ)
    // spreads each sample's colour, and a batch mean needs more samples to be near normal (the
    // Welch test's premise) where light tracing reaches a tile through the rough block rarely.
    let cases = [
        ("CPU light", Integrator::Light, 32, false),
        ("CPU bdpt", Integrator::Bdpt, 16, false),
        ("GPU light", Integrator::Light, 32, true),
        ("GPU bdpt", Integrator::Bdpt, 16, true),
    ];
    assert_integrators_agree_with_the_path_tracer(&prepared, 5, &cases, |_| {});
}

/// A square light of strength 4 under a clear coat of `clearcoat`, facing up at z = 0.3 (half
/// size 0.6) over a grey floor at z = 0; seen from above by `camera` at `eye`.
fn coated_light_gltf(name: &str, clearcoat: f32, camera: &str, eye: [f32; 3]) -> PathBuf {
    let (mut light, mut li) = (Vec::new(), Vec::new());
    add_square(&mut light, &mut li, 0.6, 0.3, true);
    let (mut floor, mut fi) = (Vec::new(), Vec::new());
    add_square(&mut floor, &mut fi, 3.0, 0.0, true);
    let materials = format!(
        r#"{{"name": "coated light", "pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 1}},
      "emissiveFactor": [1, 1, 1], "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 4}}, "KHR_materials_specular": {{"specularFactor": 0}},
      "KHR_materials_clearcoat": {{"clearcoatFactor": {clearcoat}, "clearcoatRoughnessFactor": 0.2}}}}}},
    {{"name": "floor", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 1}},
      "extensions": {{"KHR_materials_specular": {{"specularFactor": 0}}}}}}"#
    );
    write_gltf(
        name,
        &[(light, li, 0), (floor, fi, 1)],
        &materials,
        camera,
        eye,
    )
}

#[test]
fn a_clear_coat_darkens_the_emission_below_it() {
    use wavetrace::render::Integrator;
    // Head-on through an orthographic camera inside the light's square: every sample sees the
    // light along its normal, F_c = 0.04, so each pixel is exactly 4·(1 − 0.5·0.04) = 3.92.
    let ortho = r#"{"type": "orthographic", "orthographic": {"xmag": 0.3, "ymag": 0.3, "znear": 0.01, "zfar": 100}}"#;
    let scene = Scene::load(&coated_light_gltf(
        "coated-light-head-on.gltf",
        0.5,
        ortho,
        [0.0, 0.0, 3.0],
    ))
    .unwrap_or_else(|e| panic!("{e:#}"));
    assert!(scene
        .notes
        .iter()
        .all(|n| !n.contains("KHR_materials_clearcoat")));
    let prepared = PreparedScene::new(&scene);
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 4,
        max_depth: 3,
        ..RenderSettings::default()
    };
    let want = 4.0 * (1.0 - 0.5 * 0.04);
    let mut films = vec![("CPU", render_cpu(&prepared, &settings).film)];
    if let Some(out) = render_gpu(&prepared, &settings, None) {
        films.push(("GPU", out.film));
    }
    for (device, film) in &films {
        for p in 0..film.len() {
            let m = film.mean(p);
            assert!(
                (m - Vec3::splat(want)).abs().max_element() < 1e-5 * want,
                "{device}: pixel {p} is {m}, want {want}"
            );
        }
    }
    // A fully coated light low over a floor, seen in perspective: the floor around it is lit at
    // grazing angles, where the coat's Fresnel takes most of the emission. Light tracing and BDPT
    // (light subpaths leave the coated light) agree with the path tracer (emitter hits and
    // next event estimation) per tile.
    let perspective = r#"{"type": "perspective", "perspective": {"yfov": 1.0, "aspectRatio": 1.0, "znear": 0.05}}"#;
    let scene = Scene::load(&coated_light_gltf(
        "coated-light.gltf",
        1.0,
        perspective,
        [0.0, 0.0, 3.5],
    ))
    .unwrap_or_else(|e| panic!("{e:#}"));
    let prepared = PreparedScene::new(&scene);
    let cases = [
        ("CPU light", Integrator::Light, 8, false),
        ("CPU bdpt", Integrator::Bdpt, 4, false),
        ("GPU path", Integrator::Path, 8, true),
        ("GPU light", Integrator::Light, 8, true),
        ("GPU bdpt", Integrator::Bdpt, 4, true),
    ];
    assert_integrators_agree_with_the_path_tracer(&prepared, 4, &cases, |_| {});
}

#[test]
fn a_leaf_lit_from_behind_shines_through_on_every_integrator() {
    use wavetrace::render::Integrator;
    let scene = Scene::load(&common::scene_path("leaf.gltf")).unwrap_or_else(|e| panic!("{e:#}"));
    assert!(scene
        .notes
        .iter()
        .all(|n| !n.contains("KHR_materials_diffuse_transmission")));
    let leaf = scene.materials.iter().find(|m| m.name == "leaf").unwrap();
    assert_eq!(
        (leaf.diffuse_transmission, leaf.diffuse_transmission_color),
        (0.7, Vec3::new(0.5, 0.9, 0.2))
    );
    let prepared = PreparedScene::new(&scene);
    let cases = [
        ("GPU path", Integrator::Path, 8, true),
        ("CPU light", Integrator::Light, 8, false),
        ("CPU bdpt", Integrator::Bdpt, 4, false),
        ("GPU light", Integrator::Light, 8, true),
        ("GPU bdpt", Integrator::Bdpt, 4, true),
    ];
    assert_integrators_agree_with_the_path_tracer(&prepared, 4, &cases, |path| {
        // The leaf's front faces away from the light: the centre tile is lit through the leaf,
        // green (dtColor's G and the base's) well above red, by more than four standard errors.
        let centre = &path[path.len() / 2];
        println!("path tracer, the centre tile: {centre:?}");
        assert!(centre[1].0 - centre[0].0 > 4.0 * (centre[1].1 + centre[0].1).sqrt());
    });
}

/// The thin pane's base colour (transmission 1, ior 1.5, no KHR_materials_volume).
const PANE_COLOR: [f32; 3] = [0.9, 0.6, 0.3];

/// A thin pane's material: `roughness`, transmission 1, no volume (thin-walled).
fn thin_pane_material(roughness: f32) -> String {
    let [r, g, b] = PANE_COLOR;
    format!(
        r#"{{"name": "thin pane", "pbrMetallicRoughness": {{"baseColorFactor": [{r}, {g}, {b}, 1], "metallicFactor": 0, "roughnessFactor": {roughness}}},
    "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}}}}}}"#
    )
}

/// The square [−2, 2]² turned by `tilt` about X (normal (0, −sin, cos)), at the origin.
fn tilted_pane(tilt: f32) -> (Vec<f32>, Vec<u16>) {
    let (sin, cos) = tilt.sin_cos();
    let mut positions = Vec::new();
    for (a, b) in [(-2.0f32, -2.0f32), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0)] {
        positions.extend([a, b * cos, b * sin]);
    }
    (positions, vec![0, 1, 2, 0, 2, 3])
}

#[test]
fn a_smooth_thin_pane_shows_one_minus_fresnel_of_its_colour_times_the_light() {
    // An orthographic camera on +Z looks down −Z through a smooth thin pane tilted by θ at an
    // emitter of radiance L = 2 filling the view behind it: every pixel is (1 − F(θ))·C·L in
    // expectation, F Schlick's at cos θ with F0 = 0.04 (the pane's reflection sees nothing).
    // Solid glass (the same pane bounding a medium) would show (1 − F)·C·L/η² and bend the view.
    let light = r#"{"name": "light", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 1},
      "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}, "KHR_materials_specular": {"specularFactor": 0}}}"#;
    let ortho = r#"{"type": "orthographic", "orthographic": {"xmag": 0.5, "ymag": 0.5, "znear": 0.01, "zfar": 100}}"#;
    let z = normal_quantile_upper(sidak(0.01, 2 * 2 * 3) / 2.0);
    for tilt_deg in [0.0f32, 60.0] {
        let (pane, pi) = tilted_pane(tilt_deg.to_radians());
        let (mut back, mut bi) = (Vec::new(), Vec::new());
        // Wide enough for every straight-through ray, narrow enough that the 60° pane's mirror
        // image (rays leaving at 30° below the horizontal) misses it.
        add_square(&mut back, &mut bi, 1.5, -3.0, true);
        let path = write_gltf(
            &format!("thin-pane-{tilt_deg}.gltf"),
            &[(pane, pi, 0), (back, bi, 1)],
            &format!("{},\n    {light}", thin_pane_material(0.0)),
            ortho,
            [0.0, 0.0, 5.0],
        );
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
        assert_eq!(scene.materials[0].thickness, 0.0, "thin-walled by default");
        let prepared = PreparedScene::new(&scene);
        let settings = |seed| RenderSettings {
            width: 12,
            height: 12,
            spp: 64,
            max_depth: 4,
            seed,
            ..RenderSettings::default()
        };
        let cos = tilt_deg.to_radians().cos() as f64;
        let f = 0.04 + 0.96 * (1.0 - cos).powi(5);
        let want = PANE_COLOR.map(|c| (1.0 - f) * c as f64 * 2.0);
        let mut films = vec![("CPU", render_cpu(&prepared, &settings(1)).film)];
        if let Some(out) = render_gpu(&prepared, &settings(2), None) {
            films.push(("GPU", out.film));
        }
        for (device, film) in &films {
            assert_eq!(film.dropped, 0);
            let (mean, se) = image_mean(film);
            for c in 0..3 {
                println!(
                    "{device}, tilt {tilt_deg}°, channel {c}: {:.5} ± {:.5}, expected {:.5}",
                    mean[c], se[c], want[c]
                );
                assert!(
                    (mean[c] - want[c]).abs() <= z * se[c] + 1e-6,
                    "{device}, tilt {tilt_deg}°, channel {c}: {} vs {} (se {})",
                    mean[c],
                    want[c],
                    se[c]
                );
            }
        }
    }
}

#[test]
fn light_tracing_and_bdpt_see_through_thin_walls_as_the_path_tracer_does() {
    use wavetrace::render::Integrator;
    // A rough thin pane over a white floor under a square light facing down: the floor is lit
    // through the pane (light subpaths cross it in importance mode) and seen through it.
    let (mut pane, mut pi) = (Vec::new(), Vec::new());
    add_square(&mut pane, &mut pi, 0.6, 0.0, true);
    let (mut floor, mut fi) = (Vec::new(), Vec::new());
    add_square(&mut floor, &mut fi, 2.0, -0.5, true);
    let (mut light, mut li) = (Vec::new(), Vec::new());
    add_square(&mut light, &mut li, 0.4, 1.5, false);
    let materials = format!(
        r#"{},
    {{"name": "floor", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 1}},
      "extensions": {{"KHR_materials_specular": {{"specularFactor": 0}}}}}},
    {{"name": "light", "pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 1}},
      "emissiveFactor": [1, 1, 1], "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 8}}, "KHR_materials_specular": {{"specularFactor": 0}}}}}}"#,
        thin_pane_material(0.3)
    );
    let path = write_gltf(
        "lit-thin-pane.gltf",
        &[(pane, pi, 0), (floor, fi, 1), (light, li, 2)],
        &materials,
        r#"{"type": "perspective", "perspective": {"yfov": 1.0, "aspectRatio": 1.0, "znear": 0.05}}"#,
        [0.0, 0.0, 3.5],
    );
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    let prepared = PreparedScene::new(&scene);
    let cases = [
        ("GPU path", Integrator::Path, 8, true),
        ("CPU light", Integrator::Light, 8, false),
        ("CPU bdpt", Integrator::Bdpt, 4, false),
        ("GPU light", Integrator::Light, 8, true),
        ("GPU bdpt", Integrator::Bdpt, 4, true),
    ];
    assert_integrators_agree_with_the_path_tracer(&prepared, 5, &cases, |path| {
        // The floor seen through the pane is tinted by its colour (blue absorbed most): the
        // centre tile's red exceeds its blue by more than four standard errors.
        let centre = &path[path.len() / 2];
        println!("path tracer, the centre tile: {centre:?}");
        assert!(centre[0].0 - centre[2].0 > 4.0 * (centre[0].1 + centre[2].1).sqrt());
    });
}
