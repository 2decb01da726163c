//! Every model in ../shared/gltf-samples/valid/ (the Khronos sample models: textures, alpha,
//! vertex colours, normal maps, transmission, cameras) loads, renders on the GPU and on the CPU
//! without a NaN or Inf sample, with no note that a feature of the real-files issue is ignored,
//! and the two integrators agree per tile (Welch tests at family-wise α = 0.01, Šidák-corrected
//! over the models). Skipped with a notice where the folder is absent (a user's clone).

use crate::common;

use crate::common::{assert_agree_at, render_cpu, render_gpu, small_render_agrees};
use glam::Vec3;
use std::path::{Path, PathBuf};
use wavetrace::gpu::SceneImages;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::Scene;
use wavetrace::stats::sidak;

fn samples() -> Option<PathBuf> {
    crate::common::gltf_samples()
}

/// Every .gltf and .glb under `dir`, sorted.
fn models(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if matches!(
                path.extension().and_then(|e| e.to_str()),
                Some("gltf" | "glb")
            ) {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// Notes that would mean a feature this issue covers was ignored.
const FORBIDDEN_NOTES: &[&str] = &[
    "textures are not supported",
    "orthographic",
    "KHR_materials_unlit",
    "KHR_materials_specular",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_materials_anisotropy",
    "KHR_materials_iridescence",
    "KHR_materials_volume",
    "KHR_materials_diffuse_transmission",
];

#[test]
fn every_valid_model_renders_alike_on_gpu_and_cpu() {
    let Some(dir) = samples() else { return };
    let models = models(&dir);
    assert!(
        models.len() >= 20,
        "expected the sample models, found {}",
        models.len()
    );
    let alpha = sidak(0.01, models.len());
    for path in &models {
        let name = path.strip_prefix(&dir).unwrap().display().to_string();
        let scene = match Scene::load(path) {
            Ok(scene) => scene,
            // A material-extension or compressed sample may require an extension wavetrace
            // does not read: it must be refused by name.
            Err(e)
                if (name.starts_with("extensions") || name.starts_with("compressed"))
                    && format!("{e:#}").contains("extensionsRequired") =>
            {
                eprintln!("{name}: refused by name as expected: {e:#}");
                continue;
            }
            Err(e) => panic!("{name}: {e:#}"),
        };
        for note in &scene.notes {
            assert!(
                !FORBIDDEN_NOTES.iter().any(|f| note.contains(f)),
                "{name}: {note}"
            );
        }
        if !small_render_agrees(&PreparedScene::new(&scene), alpha, &name) {
            return;
        }
    }
}

/// Textures scale to hundreds: 300 unit quads on a 20 × 15 grid, each with its own 4 × 4
/// emissive PNG (nearest filtering; all in one texel buffer), seen by an orthographic camera at
/// 4 pixels per unit and `--max-depth 0`: every pixel is exactly one texel, so every pixel of
/// the CPU render must equal its own texture's sRGB-decoded texel (a lookup into another
/// texture's slot would show another value), and the GPU must agree per tile.
#[test]
fn three_hundred_textures_render_exactly_on_gpu_and_cpu() {
    use base64::Engine;
    use image::ImageEncoder;
    const N: usize = 300;
    let (cols, rows) = (20usize, 15usize);
    let dir = std::env::temp_dir().join(format!("wavetrace-many-textures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut positions: Vec<f32> = Vec::new();
    let mut uvs: Vec<f32> = Vec::new();
    for k in 0..N {
        let (x, y) = ((k % cols) as f32, (k / cols) as f32);
        // v = 0 at the quad's top edge (glTF's texture origin is the image's top-left).
        for (dx, dy, u, v) in [
            (0.0, 0.0, 0.0, 1.0),
            (1.0, 0.0, 1.0, 1.0),
            (1.0, 1.0, 1.0, 0.0),
            (0.0, 1.0, 0.0, 0.0),
        ] {
            positions.extend([x + dx, y + dy, 0.0]);
            uvs.extend([u, v]);
        }
    }
    let mut bytes: Vec<u8> = positions
        .iter()
        .chain(&uvs)
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let uv_offset = positions.len() * 4;
    let index_offset = bytes.len();
    // Every quad's primitive indexes its own four vertices.
    for i in [0u16, 1, 2, 0, 2, 3] {
        bytes.extend(i.to_le_bytes());
    }
    let b64 = |data: &[u8]| base64::engine::general_purpose::STANDARD.encode(data);
    let texel = |k: usize, i: usize| -> [u8; 3] {
        let h = (k as u32).wrapping_mul(2654435761) ^ (i as u32).wrapping_mul(40503).rotate_left(7);
        let h = h.wrapping_mul(0x9e37_79b1);
        [(h >> 24) as u8, (h >> 16) as u8, (h >> 8) as u8]
    };
    let images: Vec<serde_json::Value> = (0..N)
        .map(|k| {
            let pixels: Vec<u8> = (0..16)
                .flat_map(|i| {
                    let t = texel(k, i);
                    [t[0], t[1], t[2], 255]
                })
                .collect();
            let mut png = Vec::new();
            image::codecs::png::PngEncoder::new(&mut png)
                .write_image(&pixels, 4, 4, image::ExtendedColorType::Rgba8)
                .unwrap();
            serde_json::json!({"uri": format!("data:image/png;base64,{}", b64(&png))})
        })
        .collect();
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..N + 1).collect::<Vec<_>>()}],
        "nodes": (0..N).map(|k| serde_json::json!({"mesh": k}))
            .chain([serde_json::json!({"camera": 0, "translation": [cols as f32 / 2.0, rows as f32 / 2.0, 5.0]})])
            .collect::<Vec<_>>(),
        "cameras": [{"type": "orthographic", "orthographic": {
            "xmag": cols as f32 / 2.0, "ymag": rows as f32 / 2.0, "znear": 0.01, "zfar": 100.0}}],
        "meshes": (0..N).map(|k| serde_json::json!({"primitives": [{
            "attributes": {"POSITION": 2 * k, "TEXCOORD_0": 2 * k + 1}, "indices": 2 * N, "material": k}]}))
            .collect::<Vec<_>>(),
        "materials": (0..N).map(|k| serde_json::json!({"emissiveFactor": [1, 1, 1],
            "emissiveTexture": {"index": k}, "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}}))
            .collect::<Vec<_>>(),
        "textures": (0..N).map(|k| serde_json::json!({"source": k, "sampler": 0})).collect::<Vec<_>>(),
        "samplers": [{"magFilter": 9728, "minFilter": 9728}],
        "images": images,
        "accessors": (0..N).flat_map(|k| [
            serde_json::json!({"bufferView": 0, "byteOffset": 48 * k, "componentType": 5126, "count": 4, "type": "VEC3",
                "min": [(k % cols) as f32, (k / cols) as f32, 0.0], "max": [(k % cols) as f32 + 1.0, (k / cols) as f32 + 1.0, 0.0]}),
            serde_json::json!({"bufferView": 1, "byteOffset": 32 * k, "componentType": 5126, "count": 4, "type": "VEC2"}),
        ]).chain([serde_json::json!({"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"})])
            .collect::<Vec<_>>(),
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": uv_offset},
            {"buffer": 0, "byteOffset": uv_offset, "byteLength": index_offset - uv_offset},
            {"buffer": 0, "byteOffset": index_offset, "byteLength": bytes.len() - index_offset},
        ],
        "buffers": [{"byteLength": bytes.len(), "uri": format!("data:application/octet-stream;base64,{}", b64(&bytes))}],
    });
    let path = dir.join("many-textures.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(scene.textures.textures.len(), N);
    let prepared = PreparedScene::new(&scene);
    let width = 4 * cols as u32;
    let settings = |seed| RenderSettings {
        width,
        height: 4 * rows as u32,
        spp: 4,
        max_depth: 0,
        seed,
        ..RenderSettings::default()
    };
    let cpu = render_cpu(&prepared, &settings(2));
    let mut wrong = Vec::new();
    for k in 0..N {
        let (cx, cy) = (4 * (k % cols), 4 * (rows - 1 - k / cols));
        for j in 0..4 {
            for i in 0..4 {
                let pixel = (cy + j) * width as usize + cx + i;
                let got = cpu.film.mean(pixel);
                let t = texel(k, 4 * j + i);
                let want = Vec3::from_array(
                    t.map(|c| wavetrace::texture::srgb_to_linear(c as f32 / 255.0)),
                );
                if (got - want).abs().max_element() > 1e-5 && wrong.len() < 10 {
                    wrong.push(format!(
                        "quad {k} texel ({i}, {j}): {got} instead of {want}"
                    ));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    if let Some(gpu) = render_gpu(&prepared, &settings(1), None) {
        assert_eq!(gpu.film.dropped, 0);
        assert_agree_at(&gpu.film, &cpu.film, 0.01, "300 textures");
    }
}

/// A textured, normal-mapped model whose BVH nodes, triangles, vertex indices, vertices and
/// texels are read from storage buffers, each spread over three or four bindings (as a scene
/// larger than the device's storage range is), renders the same bits as the default, which
/// reads them (and the materials and light BVH nodes) from images: neither the split nor the
/// images change what the kernels read, only where.
#[test]
fn a_scene_split_across_bindings_renders_the_same_bits() {
    use wavetrace::gpu::bindings::SPLIT_BINDINGS;
    let Some(dir) = samples() else { return };
    if common::gpu().is_none() {
        return;
    }
    let scene = PreparedScene::new(&Scene::load(&dir.join("DamagedHelmet.glb")).unwrap());
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 2,
        max_depth: 4,
        ..RenderSettings::default()
    };
    let whole = render_gpu(&scene, &settings, None).unwrap();
    // Per array, the smallest power of two of elements per binding that needs at most four.
    let lengths = [
        scene.gpu_bvh().nodes.len(),
        scene.triangles.len(),
        scene.triangle_vertices.len(),
        scene.vertices.len(),
        scene.texels.len(),
    ];
    let sizes = [32, 48, 16, 64, 4];
    let limits = std::array::from_fn(|k| {
        let per_binding = lengths[k].div_ceil(SPLIT_BINDINGS).next_power_of_two();
        (per_binding * sizes[k]) as u64
    });
    let mut gpu = common::gpu().unwrap();
    assert!(gpu.scene_split(&scene).unwrap().images());
    // The images read as storage images and as sampled images: the same texels.
    let default_images = gpu.scene_images();
    for kind in [SceneImages::Storage, SceneImages::Sampled] {
        gpu.set_scene_images(kind);
        let out = gpu
            .render(&scene, &settings, None)
            .unwrap_or_else(|e| panic!("{kind:?} render failed: {e:#}"));
        common::assert_same_bits(&whole.film, &out.film, &format!("{kind:?} vs the default"));
    }
    gpu.set_binding_limits(Some(limits));
    gpu.set_scene_images(SceneImages::Buffers);
    let split = gpu.scene_split(&scene).unwrap();
    let out = gpu.render(&scene, &settings, None);
    // The kernels of one binding per array (a device of fewer storage buffers) refuse it, by name.
    gpu.set_one_binding(true).unwrap();
    let refused = gpu.render(&scene, &settings, None);
    gpu.set_one_binding(false).unwrap();
    gpu.set_binding_limits(None);
    gpu.set_scene_images(default_images);
    let refused = format!(
        "{:#}",
        refused
            .err()
            .expect("one binding per array refuses a split scene")
    );
    assert!(
        refused.contains("take more than one storage binding"),
        "{refused}"
    );
    assert!(!split.images());
    drop(gpu);
    for k in 0..5 {
        let per_binding = split.per_binding(k).expect("every array is split") as usize;
        let bindings = lengths[k].div_ceil(per_binding);
        assert!(
            (3..=SPLIT_BINDINGS).contains(&bindings),
            "array {k}: {bindings} bindings"
        );
    }
    let split_out = out.unwrap_or_else(|e| panic!("split render failed: {e:#}"));
    // gpu-allocator sub-allocates: far fewer device allocations than buffers (each of the 60
    // or so would otherwise be one of the 4096 many drivers allow).
    let memory = split_out.stats.device_memory.clone().unwrap();
    println!("{memory}");
    assert!(memory.buffers >= 40, "{memory}");
    assert!(memory.blocks * 4 <= memory.buffers, "{memory}");
    assert_eq!(whole.stats.extension_rays, split_out.stats.extension_rays);
    common::assert_same_bits(
        &whole.film,
        &split_out.film,
        "buffers split across bindings vs images",
    );
}

/// Kernels made for a scene's features (`PreparedScene::gpu_features`: without the top level's
/// walk, the binary walk, the general BSDF, the alpha lookup, textures, the environment,
/// punctual lights, dispersion, attenuation, a path expression, a thin film, or samplers and
/// light samplers it does not use) render the same bits as kernels made with every feature, on a
/// scene that lacks them all (with each integrator) and on scenes that have each: specialising
/// leaves out only code no ray of the render reaches.
#[test]
fn kernels_specialised_for_a_scene_render_the_same_bits() {
    use wavetrace::layout::*;
    use wavetrace::render::Integrator;
    if common::gpu().is_none() {
        return;
    }
    // (name, file, features it has (0: none but the default sampler's — the Cornell box's
    // light BVH cannot tell its quad's two triangles apart, so its emitters are sampled by
    // power), its sky): committed scenes, then samples where the folder is there.
    let committed = [
        ("cornell-box", "cornell-box.gltf", 0, 0.0),
        ("many-lights", "many-lights.gltf", FEATURE_LIGHT_BVH, 0.0),
        ("instances", "instances.gltf", FEATURE_TOP_LEVEL, 0.0),
        (
            "cornell-materials",
            "cornell-materials.gltf",
            FEATURE_GENERAL_BSDF,
            0.0,
        ),
        ("prism", "prism.gltf", FEATURE_DISPERSION, 0.0),
        (
            "cornell-box under a sky",
            "cornell-box.gltf",
            FEATURE_ENVIRONMENT,
            0.5,
        ),
        // Stratified samples, emitters by power, a path expression (settings below).
        (
            "cornell-box, stratified",
            "cornell-box.gltf",
            FEATURE_STRATIFIED | FEATURE_PATHS,
            0.0,
        ),
    ];
    let sampled = [
        (
            "AlphaBlendModeTest",
            "AlphaBlendModeTest.glb",
            FEATURE_ALPHA,
            0.5,
        ),
        (
            "AttenuationTest",
            "extensions/AttenuationTest.glb",
            FEATURE_VOLUME,
            0.5,
        ),
        (
            "LightsPunctualLamp",
            "LightsPunctualLamp/LightsPunctualLamp.gltf",
            FEATURE_PUNCTUAL | FEATURE_TEXTURES,
            0.0,
        ),
        (
            "IridescenceSuzanne",
            "extensions/IridescenceSuzanne.glb",
            FEATURE_IRIDESCENCE,
            0.5,
        ),
    ];
    let load = |path: PathBuf| PreparedScene::new(&Scene::load(&path).unwrap());
    let mut scenes: Vec<_> = committed
        .into_iter()
        .map(|(name, file, f, sky)| (name, load(common::scene_path(file)), f, sky))
        .collect();
    if let Some(dir) = samples() {
        scenes.extend(
            sampled
                .into_iter()
                .map(|(name, file, f, sky)| (name, load(dir.join(file)), f, sky)),
        );
    }
    for (name, scene, feature, sky) in &scenes {
        // Every integrator where every feature is left out, the path tracer elsewhere.
        let integrators: &[Integrator] = match feature {
            0 => &[Integrator::Path, Integrator::Light, Integrator::Bdpt],
            _ => &[Integrator::Path],
        };
        for &integrator in integrators {
            let stratified = *feature == FEATURE_STRATIFIED | FEATURE_PATHS;
            let settings = RenderSettings {
                width: 16,
                height: 16,
                spp: 2,
                max_depth: 4,
                integrator,
                environment: Vec3::splat(*sky),
                sampler: if stratified {
                    SAMPLER_STRATIFIED
                } else {
                    SAMPLER_SOBOL
                },
                light_sampler: if stratified {
                    LIGHT_SAMPLER_POWER
                } else {
                    LIGHT_SAMPLER_BVH
                },
                paths: stratified.then(|| {
                    std::sync::Arc::new(wavetrace::paths::PathExpr::parse("L(D|S)*DE").unwrap())
                }),
                ..RenderSettings::default()
            };
            let features = scene.gpu_features(&settings);
            // `bench`'s untimed warm-up render of a full-size render makes the same kernels.
            let full = RenderSettings {
                width: 1920,
                height: 1080,
                spp: 1024,
                ..settings.clone()
            };
            assert_eq!(
                scene.gpu_features(&full.warm_up()),
                scene.gpu_features(&full),
                "{name}: the warm-up render's features"
            );
            if *feature == 0 {
                // The default sampler only.
                assert_eq!(
                    features & FEATURE_FLAGS,
                    FEATURE_SOBOL,
                    "{name}: features {features:#x}"
                );
            } else {
                assert_eq!(
                    features & feature,
                    *feature,
                    "{name}: features {features:#x}"
                );
            }
            let specialised = render_gpu(scene, &settings, None).unwrap();
            let mut gpu = common::gpu().unwrap();
            gpu.set_specialise(false);
            let general = gpu.render(scene, &settings, None);
            gpu.set_specialise(true);
            // The kernels a device of fewer storage buffers renders with (SwiftShader), which
            // declare one binding per scene array: the same image.
            gpu.set_one_binding(true).unwrap();
            let one_binding = gpu.render(scene, &settings, None);
            gpu.set_one_binding(false).unwrap();
            drop(gpu);
            let general = general.unwrap_or_else(|e| panic!("{name}: render failed: {e:#}"));
            common::assert_same_bits(
                &specialised.film,
                &general.film,
                &format!("{name}, {integrator:?}: kernels for its features vs every feature"),
            );
            let one_binding =
                one_binding.unwrap_or_else(|e| panic!("{name}: one-binding render failed: {e:#}"));
            common::assert_same_bits(
                &specialised.film,
                &one_binding.film,
                &format!("{name}, {integrator:?}: kernels of one binding per array vs all"),
            );
        }
    }
}

#[test]
fn textures_converge_to_the_supersampled_picture() {
    // At 512 spp the default texture level of detail (a ray cone per sample: the pixel's
    // footprint over √spp) must give the picture the finest level gives (every sample reading
    // level 0, the supersampled texture), tile by tile (Welch tests at family-wise α = 0.01).
    // A cone of the whole pixel (what the renderer did before issue 57) filters the footprint
    // once in the texture and again in the pixel filter, and fails here.
    let Some(dir) = samples() else { return };
    let path = dir.join("DamagedHelmet.glb");
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    let prepared = PreparedScene::new(&scene);
    let settings = |seed, finest_textures| RenderSettings {
        width: 64,
        height: 64,
        spp: 512,
        max_depth: 2,
        seed,
        environment: Vec3::ONE,
        finest_textures,
        ..RenderSettings::default()
    };
    let render = |s: &RenderSettings| match render_gpu(&prepared, s, None) {
        Some(out) => out.film,
        None => render_cpu(&prepared, s).film,
    };
    let cones = render(&settings(1, false));
    let finest = render(&settings(2, true));
    assert_eq!(cones.dropped + finest.dropped, 0);
    assert_agree_at(
        &cones,
        &finest,
        0.01,
        "DamagedHelmet at 512 spp, cones vs finest",
    );
}
