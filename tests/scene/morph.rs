//! Morph targets at the file's static pose (issue 58, item 2; src/scene/morph.rs), against
//! positions computed here from the specification (glTF 2.0 §3.7.2.2: base + Σ wᵢ·Δᵢ, weights
//! the node's, else the mesh's) with the `gltf` crate's own reader, not the loader's:
//! MorphPrimitivesTest (mesh weight 0.5, two primitives) and AnimatedMorphCube with weights
//! written into the file; a node's weights override the mesh's; a wrong count is refused by
//! JSON path.

use glam::{Mat4, Vec3};
use serde_json::json;
use std::path::Path;
use wavetrace::scene::{LoadOptions, Scene};

/// Every triangle corner's world position the specification gives for `doc` (its buffers as
/// read by `gltf::import_slice`), with `weights` overriding the mesh's where given, sorted.
fn expected(glb: &[u8], node_weights: Option<&[f32]>) -> Vec<[f32; 3]> {
    let (document, buffers, _) = gltf::import_slice(glb).unwrap();
    let mut out = Vec::new();
    for node in document.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        // World transform: the node's local transform under each ancestor's.
        let mut world = Mat4::from_cols_array_2d(&node.transform().matrix());
        let mut at = node.index();
        while let Some(parent) = document
            .nodes()
            .find(|n| n.children().any(|c| c.index() == at))
        {
            world = Mat4::from_cols_array_2d(&parent.transform().matrix()) * world;
            at = parent.index();
        }
        let weights: Vec<f32> = node_weights
            .map(<[f32]>::to_vec)
            .or_else(|| mesh.weights().map(<[f32]>::to_vec))
            .unwrap_or_default();
        for primitive in mesh.primitives() {
            let reader = primitive.reader(|b| Some(&buffers[b.index()]));
            let mut p: Vec<Vec3> = reader.read_positions().unwrap().map(Vec3::from).collect();
            for (target, w) in reader.read_morph_targets().zip(&weights) {
                let (deltas, _, _) = target;
                if let Some(deltas) = deltas {
                    for (p, d) in p.iter_mut().zip(deltas) {
                        *p += *w * Vec3::from(d);
                    }
                }
            }
            let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
            out.extend(
                indices
                    .iter()
                    .map(|&i| world.transform_point3(p[i as usize]).to_array()),
            );
        }
    }
    out.sort_by(|a, b| a.partial_cmp(b).unwrap());
    out
}

fn corners(scene: &Scene) -> Vec<[f32; 3]> {
    let mut out: Vec<[f32; 3]> = scene
        .triangles
        .iter()
        .flat_map(|t| t.p.map(|p| p.to_array()))
        .collect();
    out.sort_by(|a, b| a.partial_cmp(b).unwrap());
    out
}

fn assert_close(got: &[[f32; 3]], want: &[[f32; 3]], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: corners");
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        let tolerance = 1e-5 * Vec3::from(*w).abs().max_element().max(1.0);
        assert!(
            (Vec3::from(*g) - Vec3::from(*w)).abs().max_element() <= tolerance,
            "{what}: corner {k}: {g:?} vs {w:?}"
        );
    }
}

/// A GLB's JSON chunk edited by `edit`, the binary chunk kept.
fn edit_glb(glb: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let length = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut doc: serde_json::Value = serde_json::from_slice(&glb[20..20 + length]).unwrap();
    edit(&mut doc);
    let mut text = serde_json::to_vec(&doc).unwrap();
    text.resize(text.len().next_multiple_of(4), b' ');
    let rest = &glb[20 + length..];
    let mut out = Vec::new();
    out.extend_from_slice(&glb[..8]);
    out.extend(((20 + text.len() + rest.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&text);
    out.extend(rest);
    out
}

#[test]
fn morph_targets_take_the_static_pose_weights() {
    let Some(dir) = crate::common::gltf_samples() else {
        return;
    };
    let options = LoadOptions::default();
    let load = |path: &Path, bytes: Vec<u8>| Scene::load_from_bytes(path, bytes, &options);

    // MorphPrimitivesTest: the mesh's weight 0.5 on both primitives.
    let path = dir.join("animation/MorphPrimitivesTest.glb");
    let glb = std::fs::read(&path).unwrap();
    let scene = load(&path, glb.clone()).unwrap();
    let want = expected(&glb, None);
    assert_close(&corners(&scene), &want, "MorphPrimitivesTest");
    // A test that can fail: the base pose is not the morphed one.
    assert_ne!(
        want,
        expected(&glb, Some(&[0.0])),
        "the target moves nothing"
    );

    // AnimatedMorphCube: weights (0, 0) in the file; (0.3, 0.9) on the mesh, then (1, 0.25)
    // on the node, which wins.
    let path = dir.join("animation/AnimatedMorphCube.glb");
    let glb = std::fs::read(&path).unwrap();
    let mesh = edit_glb(&glb, |d| d["meshes"][0]["weights"] = json!([0.3, 0.9]));
    assert_close(
        &corners(&load(&path, mesh.clone()).unwrap()),
        &expected(&mesh, None),
        "AnimatedMorphCube, mesh weights",
    );
    let node = edit_glb(&mesh, |d| d["nodes"][0]["weights"] = json!([1.0, 0.25]));
    let got = corners(&load(&path, node.clone()).unwrap());
    assert_close(
        &got,
        &expected(&node, Some(&[1.0, 0.25])),
        "AnimatedMorphCube, node weights",
    );
    assert_ne!(got, corners(&load(&path, mesh).unwrap()));

    // Three weights for two targets.
    let bad = edit_glb(&glb, |d| d["nodes"][0]["weights"] = json!([1.0, 0.0, 0.5]));
    let e = format!("{:#}", load(&path, bad).unwrap_err());
    assert!(
        e.contains("nodes[0].weights") && e.contains("2 morph targets"),
        "{e}"
    );
}

/// TEXCOORD_0 and COLOR_0 deltas (glTF 2.0 §3.7.2.2), which the `gltf` crate's typed model
/// drops: a triangle whose one target moves its texture coordinates by (1, 2) and its colour
/// by (0.5, 0, 0, 0), at mesh weight 0.5 — and a target naming an accessor that does not exist
/// refused by JSON path.
#[test]
fn texture_coordinate_and_colour_deltas_move_the_vertices() {
    use base64::Engine;
    let floats: Vec<f32> = [
        // POSITION
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].as_slice(),
        // TEXCOORD_0
        &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
        // COLOR_0 (VEC4)
        &[0.2, 0.2, 0.2, 1.0, 0.2, 0.2, 0.2, 1.0, 0.2, 0.2, 0.2, 1.0],
        // target TEXCOORD_0 deltas
        &[1.0, 2.0, 1.0, 2.0, 1.0, 2.0],
        // target COLOR_0 deltas
        &[0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0],
    ]
    .concat();
    let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
    let view = |offset: usize, length: usize| json!({"buffer": 0, "byteOffset": offset, "byteLength": length});
    let doc = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"weights": [0.5], "primitives": [{
            "attributes": {"POSITION": 0, "TEXCOORD_0": 1, "COLOR_0": 2},
            "targets": [{"TEXCOORD_0": 3, "COLOR_0": 4}]
        }]}],
        "buffers": [{"byteLength": bytes.len(), "uri": format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bytes))}],
        "bufferViews": [view(0, 36), view(36, 24), view(60, 48), view(108, 24), view(132, 48)],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 4, "componentType": 5126, "count": 3, "type": "VEC4"}
        ]
    });
    let load = |doc: &serde_json::Value| {
        Scene::load_from_bytes(
            Path::new("morph-attributes.gltf"),
            serde_json::to_vec(doc).unwrap(),
            &LoadOptions::default(),
        )
    };
    let scene = load(&doc).unwrap();
    let t = &scene.triangles[0];
    for (k, &v) in t.vertices.iter().enumerate() {
        let vertex = &scene.vertices[v as usize];
        let base_uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]][k];
        assert_eq!(
            [vertex.uv[0], vertex.uv[1]],
            [base_uv[0] + 0.5, base_uv[1] + 1.0],
            "corner {k}"
        );
        assert_eq!(vertex.color, [0.45, 0.2, 0.2, 1.0], "corner {k}");
    }
    let mut bad = doc.clone();
    bad["meshes"][0]["primitives"][0]["targets"][0]["COLOR_0"] = json!(9);
    let e = format!("{:#}", load(&bad).unwrap_err());
    assert!(
        e.contains("meshes[0].primitives[0].targets[0].COLOR_0: index 9 is out of range"),
        "{e}"
    );
}
