//! The glTF material extensions on the Khronos test models in
//! ../shared/gltf-samples/valid/extensions/ (third-party test data, credited in that folder's
//! README.md): each covered model loads with its extension's factors and textures and no
//! "ignored" note for it, and the GPU agrees with the CPU reference per tile (Welch tests at
//! family-wise α = 0.01, Šidák-corrected over the models of this file). Skipped with a notice
//! where the folder is absent (a user's clone).

use crate::common::{assert_agree_at, render_cpu, render_gpu};
use glam::Vec3;
use std::path::PathBuf;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::Scene;
use wavetrace::stats::sidak;

/// The models this file renders, and the extensions each must not call ignored.
const MODELS: &[(&str, &[&str])] = &[
    ("UnlitTest.glb", &["KHR_materials_unlit"]),
    ("SpecularTest.glb", &["KHR_materials_specular"]),
    ("ClearCoatTest.glb", &["KHR_materials_clearcoat"]),
    ("ClearCoatCarPaint.glb", &["KHR_materials_clearcoat"]),
    ("SheenCloth/SheenCloth.gltf", &["KHR_materials_sheen"]),
    ("AnisotropyStrengthTest.glb", &["KHR_materials_anisotropy"]),
    ("AnisotropyRotationTest.glb", &["KHR_materials_anisotropy"]),
    ("IridescenceSuzanne.glb", &["KHR_materials_iridescence"]),
    (
        "TransmissionRoughnessTest.glb",
        &[
            "KHR_materials_transmission",
            "KHR_materials_ior",
            "KHR_materials_volume",
        ],
    ),
];

fn model(name: &str) -> Option<PathBuf> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/gltf-samples/valid/extensions")
        .join(name);
    if path.exists() {
        Some(path)
    } else {
        eprintln!("skipping: {} not found", path.display());
        None
    }
}

fn load(name: &str) -> Option<Scene> {
    let path = model(name)?;
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{name}: {e:#}"));
    let covered = MODELS.iter().find(|m| m.0 == name).map_or(&[][..], |m| m.1);
    for note in &scene.notes {
        assert!(
            !covered.iter().any(|e| note.contains(e)),
            "{name}: a covered extension is reported as ignored: {note}"
        );
    }
    Some(scene)
}

#[test]
fn unlit_materials_emit_their_base_colour_and_nothing_else() {
    let Some(scene) = load("UnlitTest.glb") else {
        return;
    };
    assert!(scene.materials.iter().all(|m| m.unlit));
    for m in &scene.materials {
        assert_eq!(m.emission, m.base_color, "{}", m.name);
    }
    // Seen directly (no scattering), a fully covered pixel is exactly its material's base
    // colour: the brightest red pixel is the orange material, the brightest blue the blue one.
    let prepared = PreparedScene::new(&scene);
    let settings = RenderSettings {
        width: 32,
        height: 32,
        spp: 4,
        max_depth: 0,
        seed: 1,
        environment: Vec3::ZERO,
        ..RenderSettings::default()
    };
    let film = render_cpu(&prepared, &settings).film;
    let means: Vec<Vec3> = (0..film.pixels.len()).map(|p| film.mean(p)).collect();
    for (channel, name) in [(0, "Orange"), (2, "Blue")] {
        let brightest = means
            .iter()
            .max_by(|a, b| a[channel].total_cmp(&b[channel]))
            .unwrap();
        let m = scene.materials.iter().find(|m| m.name == name).unwrap();
        assert!(
            (*brightest - m.base_color).abs().max_element() < 1e-5,
            "{name}: {brightest} vs base colour {}",
            m.base_color
        );
    }
}

#[test]
fn specular_factors_and_textures_are_read() {
    let Some(scene) = load("SpecularTest.glb") else {
        return;
    };
    let m = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap();
    assert_eq!(m("M1.2_specFac").specular, 0.051269);
    assert!(scene
        .materials
        .iter()
        .any(|m| m.specular_color != Vec3::ONE));
    assert!(scene
        .materials
        .iter()
        .any(|m| m.textures.specular.is_some()));
    assert!(scene
        .materials
        .iter()
        .any(|m| m.textures.specular_color.is_some()));
}

#[test]
fn clearcoat_factors_and_textures_are_read() {
    let Some(scene) = load("ClearCoatTest.glb") else {
        return;
    };
    let m = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap();
    assert_eq!(m("Simple_Base").clearcoat, 0.0);
    assert_eq!(
        (
            m("Simple_Coated").clearcoat,
            m("Simple_Coated").clearcoat_roughness
        ),
        (1.0, 0.03)
    );
    assert!(m("Partial_Coated").textures.clearcoat.is_some());
    assert!(m("RoughVariations_Coated")
        .textures
        .clearcoat_roughness
        .is_some());
    assert!(m("CoatNorm_Coated").textures.clearcoat_normal.is_some());
    assert!(m("CoatNorm_Coated").textures.normal.is_none());
    assert!(m("BaseNorm_Coated").textures.clearcoat_normal.is_none());
    // The car paint requires the extension and has a base normal map but none for its coat.
    let Some(car) = load("ClearCoatCarPaint.glb") else {
        return;
    };
    let paint = &car.materials[0];
    assert_eq!((paint.clearcoat, paint.clearcoat_roughness), (1.0, 0.0));
    assert!(paint.textures.normal.is_some() && paint.textures.clearcoat_normal.is_none());
}

#[test]
fn sheen_factors_and_textures_are_read() {
    let Some(scene) = load("SheenCloth/SheenCloth.gltf") else {
        return;
    };
    let cloth = &scene.materials[0];
    assert_eq!((cloth.sheen_color, cloth.sheen_roughness), (Vec3::ONE, 1.0));
    // One image as sRGB colour and as linear roughness (A): two decoded textures.
    let (c, r) = (
        cloth.textures.sheen_color.unwrap(),
        cloth.textures.sheen_roughness.unwrap(),
    );
    let refs = &scene.textures.refs;
    assert_ne!(refs[c as usize].texture, refs[r as usize].texture);
}

#[test]
fn anisotropy_factors_and_textures_are_read() {
    let Some(scene) = load("AnisotropyStrengthTest.glb") else {
        return;
    };
    let strengths: Vec<f32> = scene.materials.iter().map(|m| m.anisotropy).collect();
    assert!(strengths.contains(&0.0) && strengths.contains(&1.0));
    assert!(strengths.iter().any(|&s| (s - 0.5).abs() < 1e-6));
    let Some(scene) = load("AnisotropyRotationTest.glb") else {
        return;
    };
    let m = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap();
    assert_eq!(m("Aniso Tangents").anisotropy, 0.5);
    assert_eq!(m("Aniso Tangents").anisotropy_rotation, 0.0);
    assert!(
        (m("Aniso Tan + Rotation").anisotropy_rotation - std::f32::consts::FRAC_PI_6).abs() < 1e-6
    );
    assert!(m("Aniso Tan + Texture").textures.anisotropy.is_some());
    assert!(m("Aniso Tan + Rotation + Texture")
        .textures
        .anisotropy
        .is_some());
    assert!(m("Aniso Tangents").textures.anisotropy.is_none());
}

#[test]
fn iridescence_factors_and_textures_are_read() {
    // The model requires the extension: it loads only where wavetrace reads it.
    let Some(scene) = load("IridescenceSuzanne.glb") else {
        return;
    };
    assert!(scene.materials.iter().all(|m| m.iridescence == 1.0));
    let ior: Vec<f32> = scene.materials.iter().map(|m| m.iridescence_ior).collect();
    assert!(ior.contains(&1.33) && ior.contains(&1.8), "{ior:?}");
    let textured = scene
        .materials
        .iter()
        .find(|m| m.textures.iridescence_thickness.is_some())
        .expect("a thickness texture");
    assert_eq!(
        (
            textured.iridescence_thickness_min,
            textured.iridescence_thickness_max
        ),
        (200.0, 600.0)
    );
    assert!(scene
        .materials
        .iter()
        .any(|m| m.iridescence_thickness_max == 400.0 && m.iridescence_thickness_min == 100.0));
}

#[test]
fn gpu_matches_cpu_on_each_covered_model() {
    let alpha = sidak(0.01, MODELS.len());
    for (name, _) in MODELS {
        let Some(scene) = load(name) else {
            return;
        };
        let prepared = PreparedScene::new(&scene);
        let settings = |seed| RenderSettings {
            width: 32,
            height: 32,
            spp: 64,
            max_depth: 4,
            seed,
            environment: Vec3::ONE,
            ..RenderSettings::default()
        };
        let cpu = render_cpu(&prepared, &settings(2));
        assert_eq!(cpu.film.dropped, 0, "{name}: CPU dropped NaN/Inf samples");
        let Some(gpu) = render_gpu(&prepared, &settings(1), None) else {
            return;
        };
        assert_eq!(gpu.film.dropped, 0, "{name}: GPU dropped NaN/Inf samples");
        assert_agree_at(&gpu.film, &cpu.film, alpha, name);
    }
}
