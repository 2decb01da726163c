//! Compressed glTF (issue 57, item 5): Draco meshes, meshopt buffer views, quantized attributes,
//! KTX2 (Basis Universal) and WebP textures.
//!
//! - A compressed sample renders like its uncompressed twin (per tile, Welch tests, Šidák over
//!   the pairs), seen through the same camera: Draco Box and RiggedSimple, quantized
//!   AnimatedMorphCube (../shared/gltf-samples; skipped with a notice where it is absent).
//! - Lossless encodings give the same image bit for bit: a sphere whose buffer views are
//!   meshopt-compressed (the `meshopt` crate's encoders) against the same sphere uncompressed,
//!   and a lossless WebP texture (EXT_texture_webp, with a black PNG fallback that must not be
//!   read) against the PNG of the same texels.
//! - Malformed streams are one error with the JSON path, never a panic: every byte of the Draco
//!   Box's stream and of a meshopt stream flipped in turn, a KTX2 file cut short.

use crate::common::{assert_agree_at, assert_same_bits, render_cpu};
use base64::Engine;
use glam::Vec3;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{LoadOptions, Scene};
use wavetrace::stats::sidak;

fn samples() -> Option<PathBuf> {
    crate::common::gltf_samples()
}

fn settings(seed: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width: 48,
        height: 48,
        spp,
        max_depth: 4,
        seed,
        environment: Vec3::ONE,
        ..RenderSettings::default()
    }
}

fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

fn load_json(source: &Path, doc: &Value) -> anyhow::Result<Scene> {
    Scene::load_from_bytes(
        source,
        serde_json::to_vec(doc).unwrap(),
        &LoadOptions::default(),
    )
}

#[test]
fn compressed_samples_render_like_their_uncompressed_twins() {
    let Some(dir) = samples() else { return };
    let pairs = [
        ("compressed/Box-draco/Box.gltf", "Box.gltf"),
        (
            "compressed/RiggedSimple-draco/RiggedSimple.gltf",
            "animation/RiggedSimple.glb",
        ),
        (
            "compressed/AnimatedMorphCube-quantized/AnimatedMorphCube.gltf",
            "animation/AnimatedMorphCube.glb",
        ),
    ];
    let alpha = sidak(0.01, pairs.len());
    for (compressed, plain) in pairs {
        let plain = Scene::load(&dir.join(plain)).unwrap();
        let mut packed = Scene::load(&dir.join(compressed)).unwrap();
        // The encoders' quantisation moves the bounds a little (Box: ±0.50049 for ±0.5), and
        // with them the framing camera: both are seen through the uncompressed file's camera.
        packed.camera = plain.camera;
        // Box's twins differ in material (the Draco file's is a dielectric, the plain one's
        // the default metal): the geometry is what is compared.
        packed.materials = plain.materials.clone();
        assert_eq!(
            packed.triangles.len() + packed.meshes.len(),
            plain.triangles.len() + plain.meshes.len(),
            "{compressed}"
        );
        let a = render_cpu(&PreparedScene::new(&packed), &settings(1, 64));
        let b = render_cpu(&PreparedScene::new(&plain), &settings(2, 64));
        assert_agree_at(&a.film, &b.film, alpha, compressed);
    }
}

/// A UV sphere of `rings` × `segments` quads: positions, normals, texture coordinates, u16
/// indices.
fn sphere(rings: u32, segments: u32) -> (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<[f32; 2]>, Vec<u16>) {
    let (mut p, mut n, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * j as f32 / segments as f32;
            let d = [
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ];
            p.push(d);
            n.push(d);
            uv.push([j as f32 / segments as f32, i as f32 / rings as f32]);
        }
    }
    for i in 0..rings {
        for j in 0..segments {
            let a = (i * (segments + 1) + j) as u16;
            let b = a + segments as u16 + 1;
            idx.extend([a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    (p, n, uv, idx)
}

/// The sphere as glTF, its four views (positions, normals, uvs, indices) either plain in one
/// buffer or compressed into buffer 0 and decoded into a fallback buffer 1, the indices by
/// `meshopt` ("TRIANGLES" or "INDICES"). `texture` is the material's base colour: (images,
/// textures) JSON.
fn sphere_gltf(meshopt: Option<&str>, texture: Option<(Value, Value)>) -> Value {
    let index_mode = meshopt.unwrap_or("TRIANGLES");
    let meshopt = meshopt.is_some();
    let (p, n, uv, idx) = sphere(24, 48);
    let bytes = |v: &[u8]| v.to_vec();
    let views: Vec<(Vec<u8>, usize, usize, &str)> = vec![
        (bytes(bytemuck::cast_slice(&p)), 12, p.len(), "ATTRIBUTES"),
        (bytes(bytemuck::cast_slice(&n)), 12, n.len(), "ATTRIBUTES"),
        (bytes(bytemuck::cast_slice(&uv)), 8, uv.len(), "ATTRIBUTES"),
        (bytes(bytemuck::cast_slice(&idx)), 2, idx.len(), index_mode),
    ];
    let mut plain = Vec::new();
    let mut packed = Vec::new();
    let mut buffer_views = Vec::new();
    for (data, stride, count, mode) in &views {
        let offset = plain.len();
        plain.extend_from_slice(data);
        plain.resize(plain.len().next_multiple_of(4), 0);
        let mut view = json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len()});
        if meshopt {
            let encoded = match *stride {
                12 => meshopt::encode_vertex_buffer(bytemuck::cast_slice::<u8, [f32; 3]>(data)),
                8 => meshopt::encode_vertex_buffer(bytemuck::cast_slice::<u8, [f32; 2]>(data)),
                _ if index_mode == "TRIANGLES" => {
                    let indices: Vec<u32> = idx.iter().map(|&i| i as u32).collect();
                    meshopt::encode_index_buffer(&indices, p.len())
                }
                _ => {
                    let indices: Vec<u32> = idx.iter().map(|&i| i as u32).collect();
                    meshopt::encode_index_sequence(&indices, p.len())
                }
            }
            .unwrap();
            view["buffer"] = json!(1);
            view["extensions"] = json!({"EXT_meshopt_compression": {
                "buffer": 0, "byteOffset": packed.len(), "byteLength": encoded.len(),
                "byteStride": stride, "count": count, "mode": mode}});
            packed.extend_from_slice(&encoded);
            packed.resize(packed.len().next_multiple_of(4), 0);
        }
        buffer_views.push(view);
    }
    let buffers = if meshopt {
        json!([
            {"byteLength": packed.len(), "uri": data_uri(&packed)},
            {"byteLength": plain.len(), "extensions": {"EXT_meshopt_compression": {"fallback": true}}}
        ])
    } else {
        json!([{"byteLength": plain.len(), "uri": data_uri(&plain)}])
    };
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                     "indices": 3, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 0.4, 1.0], "roughnessFactor": 0.5}}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": p.len(), "type": "VEC3",
             "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5126, "count": n.len(), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": uv.len(), "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": idx.len(), "type": "SCALAR"}
        ],
        "bufferViews": buffer_views,
        "buffers": buffers,
    });
    if meshopt {
        doc["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
        doc["extensionsRequired"] = json!(["EXT_meshopt_compression"]);
    }
    if let Some((images, textures)) = texture {
        doc["images"] = images;
        doc["textures"] = textures;
        doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    }
    doc
}

fn source() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scene/sphere.gltf")
}

#[test]
fn meshopt_compressed_views_give_the_same_image_bit_for_bit() {
    let plain = load_json(&source(), &sphere_gltf(None, None)).unwrap();
    // TRIANGLES may rotate a triangle's corners (meshoptimizer's index codec keeps triangles,
    // not their first corner): the same triangles, each up to rotation.
    let rotated = load_json(&source(), &sphere_gltf(Some("TRIANGLES"), None)).unwrap();
    assert_eq!(rotated.triangles.len(), plain.triangles.len());
    for (t, (a, b)) in plain.triangles.iter().zip(&rotated.triangles).enumerate() {
        assert!(
            (0..3).any(|r| (0..3).all(|k| a.p[k] == b.p[(k + r) % 3])),
            "triangle {t}: {:?} against {:?}",
            a.p,
            b.p
        );
    }
    // INDICES keeps the order: the same image bit for bit.
    let packed = load_json(&source(), &sphere_gltf(Some("INDICES"), None)).unwrap();
    assert_eq!(packed.triangles.len(), plain.triangles.len());
    let a = render_cpu(&PreparedScene::new(&plain), &settings(3, 4));
    let b = render_cpu(&PreparedScene::new(&packed), &settings(3, 4));
    assert_same_bits(&a.film, &b.film, "meshopt sphere");
}

/// A 32 × 32 RGBA pattern, encoded by `format`.
fn pattern(format: image::ImageFormat, side: u32) -> Vec<u8> {
    let img = image::RgbaImage::from_fn(side, side, |x, y| {
        image::Rgba([(x * 8) as u8, (y * 8) as u8, ((x ^ y) * 8) as u8, 255])
    });
    let mut out = std::io::Cursor::new(Vec::new());
    match format {
        image::ImageFormat::WebP => img
            .write_with_encoder(image::codecs::webp::WebPEncoder::new_lossless(&mut out))
            .unwrap(),
        _ => img.write_to(&mut out, format).unwrap(),
    }
    out.into_inner()
}

fn image_json(bytes: &[u8], mime: &str) -> Value {
    json!({"uri": data_uri(bytes).replace("application/octet-stream", mime)})
}

#[test]
fn a_lossless_webp_texture_gives_the_png_image_bit_for_bit() {
    let png = pattern(image::ImageFormat::Png, 32);
    let webp = pattern(image::ImageFormat::WebP, 32);
    let black = {
        let mut out = std::io::Cursor::new(Vec::new());
        image::RgbaImage::from_pixel(1, 1, image::Rgba([0, 0, 0, 255]))
            .write_to(&mut out, image::ImageFormat::Png)
            .unwrap();
        out.into_inner()
    };
    let with_png = sphere_gltf(
        None,
        Some((
            json!([image_json(&png, "image/png")]),
            json!([{"source": 0}]),
        )),
    );
    // The WebP image, with a black PNG as the fallback a loader without the extension reads.
    let mut with_webp = sphere_gltf(
        None,
        Some((
            json!([
                image_json(&black, "image/png"),
                image_json(&webp, "image/webp")
            ]),
            json!([{"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}}]),
        )),
    );
    with_webp["extensionsUsed"] = json!(["EXT_texture_webp"]);
    let a = load_json(&source(), &with_png).unwrap();
    let b = load_json(&source(), &with_webp).unwrap();
    assert_eq!(a.textures.texels, b.textures.texels, "decoded texels");
    let a = render_cpu(&PreparedScene::new(&a), &settings(4, 4));
    let b = render_cpu(&PreparedScene::new(&b), &settings(4, 4));
    assert_same_bits(&a.film, &b.film, "WebP sphere");
}

/// A load that fails must fail with an error naming a JSON path, and never by a panic the
/// loader caught.
fn assert_clean(result: anyhow::Result<Scene>, what: &str) {
    if let Err(e) = result {
        let message = format!("{e:#}");
        assert!(
            !message.contains("failed on this file"),
            "{what}: a panic: {message}"
        );
        assert!(
            message.contains("[") && message.contains("]"),
            "{what}: no JSON path in {message}"
        );
    }
}

#[test]
fn every_flipped_byte_of_a_draco_stream_is_decoded_or_refused_cleanly() {
    let Some(dir) = samples() else { return };
    let source = dir.join("compressed/Box-draco/Box.gltf");
    let doc: Value = serde_json::from_slice(&std::fs::read(&source).unwrap()).unwrap();
    let bin = std::fs::read(dir.join("compressed/Box-draco/Box.bin")).unwrap();
    let stream = doc["bufferViews"][0]["byteLength"].as_u64().unwrap() as usize;
    let mut refused = 0;
    for i in 0..stream {
        for flip in [0x01u8, 0x80, 0xff] {
            let mut bytes = bin.clone();
            bytes[i] ^= flip;
            let mut doc = doc.clone();
            doc["buffers"][0]["uri"] = json!(data_uri(&bytes));
            let result = load_json(&source, &doc);
            refused += result.is_err() as usize;
            assert_clean(result, &format!("byte {i} ^ {flip:#x}"));
        }
    }
    // Cut short at every length.
    for len in 0..stream {
        let mut doc = doc.clone();
        doc["bufferViews"][0]["byteLength"] = json!(len);
        let result = load_json(&source, &doc);
        assert!(result.is_err(), "a stream of {len} bytes decoded");
        assert_clean(result, &format!("{len} bytes"));
    }
    eprintln!("Draco Box: {refused} of {} flips refused", 3 * stream);
}

#[test]
fn every_flipped_byte_of_a_meshopt_stream_is_decoded_or_refused_cleanly() {
    let doc = sphere_gltf(Some("TRIANGLES"), None);
    let uri = doc["buffers"][0]["uri"].as_str().unwrap();
    let packed = base64::engine::general_purpose::STANDARD
        .decode(uri.split_once(',').unwrap().1)
        .unwrap();
    // The index stream (the last view) and the first bytes of each vertex stream.
    let mut offsets = Vec::new();
    for view in doc["bufferViews"].as_array().unwrap() {
        let ext = &view["extensions"]["EXT_meshopt_compression"];
        let (start, len) = (
            ext["byteOffset"].as_u64().unwrap() as usize,
            ext["byteLength"].as_u64().unwrap() as usize,
        );
        offsets.extend(start..start + len.min(64));
    }
    for i in offsets {
        let mut bytes = packed.clone();
        bytes[i] ^= 0x5a;
        let mut doc = doc.clone();
        doc["buffers"][0]["uri"] = json!(data_uri(&bytes));
        assert_clean(load_json(&source(), &doc), &format!("byte {i}"));
    }
}

#[test]
fn ktx2_textures_decode_and_a_truncated_one_is_refused_by_path() {
    let Some(dir) = samples() else { return };
    let lamp = dir.join("compressed/StainedGlassLamp-ktx2/StainedGlassLamp.gltf");
    let scene = Scene::load(&lamp).unwrap();
    assert!(
        scene.textures.textures.len() >= 10,
        "{}",
        scene.textures.textures.len()
    );
    // Transcoded texels vary (not a constant fallback colour).
    let texels = &scene.textures.texels;
    assert!(texels.iter().any(|&t| t != texels[0]));
    // The same file with one texture cut to half its bytes, copied beside its other files.
    let work = crate::common::temp("compressed", "lamp");
    std::fs::create_dir_all(&work).unwrap();
    for entry in std::fs::read_dir(lamp.parent().unwrap()).unwrap() {
        let path = entry.unwrap().path();
        let mut bytes = std::fs::read(&path).unwrap();
        if path.file_name().unwrap() == "StainedGlassLamp_base_basecolor.ktx2" {
            bytes.truncate(bytes.len() / 2);
        }
        std::fs::write(work.join(path.file_name().unwrap()), bytes).unwrap();
    }
    let e = Scene::load(&work.join("StainedGlassLamp.gltf")).unwrap_err();
    let message = format!("{e:#}");
    assert!(
        message.contains("images[") && message.contains("KTX2"),
        "{message}"
    );
    std::fs::remove_dir_all(&work).ok();
}

/// Seeds for the coverage-guided fuzzer (docs/security.md, "Fuzzing") that reach every decoder:
/// the meshopt sphere (TRIANGLES and INDICES), the WebP sphere and a quad with one of
/// StainedGlassLamp's KTX2 textures, each one self-contained `.gltf`. Written by
/// `WAVETRACE_FUZZ_SEEDS=DIR cargo test --release --test scene write_fuzz_seeds -- --ignored`
/// (tools/fuzz/seed.sh runs it).
#[test]
#[ignore = "writes fuzz seeds; run by tools/fuzz/seed.sh"]
fn write_fuzz_seeds() {
    let dir = PathBuf::from(std::env::var("WAVETRACE_FUZZ_SEEDS").expect("WAVETRACE_FUZZ_SEEDS"));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |name: &str, doc: &Value| {
        std::fs::write(dir.join(name), serde_json::to_vec(doc).unwrap()).unwrap()
    };
    write(
        "meshopt-triangles.gltf",
        &sphere_gltf(Some("TRIANGLES"), None),
    );
    write("meshopt-indices.gltf", &sphere_gltf(Some("INDICES"), None));
    let webp = pattern(image::ImageFormat::WebP, 8);
    let mut doc = sphere_gltf(
        None,
        Some((
            json!([image_json(&webp, "image/webp")]),
            json!([{"extensions": {"EXT_texture_webp": {"source": 0}}}]),
        )),
    );
    doc["extensionsUsed"] = json!(["EXT_texture_webp"]);
    doc["extensionsRequired"] = json!(["EXT_texture_webp"]);
    write("webp.gltf", &doc);
    if let Some(samples) = samples() {
        let ktx2 = std::fs::read(samples.join(
            "compressed/StainedGlassLamp-ktx2/StainedGlassLamp_bulbs_occlusion-rough-metal.ktx2",
        ))
        .unwrap();
        let mut doc = sphere_gltf(
            None,
            Some((
                json!([image_json(&ktx2, "image/ktx2")]),
                json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]),
            )),
        );
        doc["extensionsUsed"] = json!(["KHR_texture_basisu"]);
        doc["extensionsRequired"] = json!(["KHR_texture_basisu"]);
        write("ktx2.gltf", &doc);
    }
}
