//! Skins at the file's static pose (issue 58, item 1; src/scene/skin.rs), against positions
//! computed here from the specification (glTF 2.0 §3.7.3: Σₖ wₖ · globalTransform(jointₖ) ·
//! inverseBindMatrixₖ · p, the skinned node's own transform ignored) with the `gltf` crate's
//! reader: SimpleSkin, RiggedSimple and RiggedFigure.

use glam::{Mat4, Vec3};
use wavetrace::scene::Scene;

/// Every node's world transform, from the document's roots.
fn worlds(document: &gltf::Document) -> Vec<Mat4> {
    let mut out = vec![Mat4::IDENTITY; document.nodes().len()];
    let mut stack: Vec<(gltf::Node, Mat4)> = document
        .nodes()
        .filter(|n| {
            document
                .nodes()
                .all(|p| p.children().all(|c| c.index() != n.index()))
        })
        .map(|n| (n, Mat4::IDENTITY))
        .collect();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        out[node.index()] = world;
        stack.extend(node.children().map(|c| (c, world)));
    }
    out
}

/// Every triangle corner of the skinned meshes as the specification places them, in order.
fn expected(path: &std::path::Path) -> Vec<[f32; 3]> {
    let (document, buffers, _) = gltf::import(path).unwrap();
    let worlds = worlds(&document);
    let mut out = Vec::new();
    for node in document.nodes() {
        let (Some(mesh), Some(skin)) = (node.mesh(), node.skin()) else {
            continue;
        };
        let joints: Vec<Mat4> = {
            let reader = skin.reader(|b| Some(&buffers[b.index()]));
            let inverse: Vec<Mat4> = reader
                .read_inverse_bind_matrices()
                .map(|m| m.map(|m| Mat4::from_cols_array_2d(&m)).collect())
                .unwrap_or_else(|| vec![Mat4::IDENTITY; skin.joints().count()]);
            skin.joints()
                .zip(inverse)
                .map(|(j, ibm)| worlds[j.index()] * ibm)
                .collect()
        };
        for primitive in mesh.primitives() {
            let reader = primitive.reader(|b| Some(&buffers[b.index()]));
            let p: Vec<Vec3> = reader.read_positions().unwrap().map(Vec3::from).collect();
            let js: Vec<[u16; 4]> = reader.read_joints(0).unwrap().into_u16().collect();
            let ws: Vec<[f32; 4]> = reader.read_weights(0).unwrap().into_f32().collect();
            let skinned: Vec<Vec3> = (0..p.len())
                .map(|v| {
                    let total: f32 = ws[v].iter().sum();
                    (0..4).fold(Vec3::ZERO, |acc, k| {
                        acc + ws[v][k] / total * joints[js[v][k] as usize].transform_point3(p[v])
                    })
                })
                .collect();
            let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
            out.extend(indices.iter().map(|&i| skinned[i as usize].to_array()));
        }
    }
    out
}

#[test]
fn skinned_meshes_stand_in_the_static_pose_the_joints_give() {
    let Some(dir) = crate::common::gltf_samples() else {
        return;
    };
    for name in ["SimpleSkin.gltf", "RiggedSimple.glb", "RiggedFigure.glb"] {
        let path = dir.join("animation").join(name);
        let scene = Scene::load(&path).unwrap();
        // In triangle order: these files have one skinned mesh, and no triangle is dropped.
        assert_eq!(scene.dropped_degenerate, 0, "{name}");
        let got: Vec<[f32; 3]> = scene
            .triangles
            .iter()
            .flat_map(|t| t.p.map(|p| p.to_array()))
            .collect();
        let want = expected(&path);
        assert_eq!(got.len(), want.len(), "{name}: corners");
        let scale = want.iter().flatten().fold(1.0f32, |m, v| m.max(v.abs()));
        for (k, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (Vec3::from(*g) - Vec3::from(*w)).abs().max_element() <= 1e-5 * scale,
                "{name}: corner {k}: {g:?} vs {w:?}"
            );
        }
    }
}

#[test]
fn bad_skins_are_refused_by_json_path() {
    let Some(dir) = crate::common::gltf_samples() else {
        return;
    };
    let path = dir.join("animation/SimpleSkin.gltf");
    let doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let load = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut doc = doc.clone();
        edit(&mut doc);
        let bytes = serde_json::to_vec(&doc).unwrap();
        Scene::load_from_bytes(&path, bytes, &wavetrace::scene::LoadOptions::default())
            .map(|_| ())
            .map_err(|e| format!("{e:#}"))
    };
    assert_eq!(load(&|_| {}), Ok(()));
    // One joint for two inverse bind matrices.
    let e = load(&|d| d["skins"][0]["joints"] = serde_json::json!([1])).unwrap_err();
    assert!(
        e.contains("skins[0].inverseBindMatrices") && e.contains("2 matrices for 1 joints"),
        "{e}"
    );
    // Joint indices past the skin's two joints: the file's vertices use joints 0 and 1.
    let e = load(&|d| {
        d["skins"][0]["joints"] = serde_json::json!([1]);
        d["skins"][0]
            .as_object_mut()
            .unwrap()
            .remove("inverseBindMatrices");
    })
    .unwrap_err();
    assert!(
        e.contains("attributes.JOINTS_0") && e.contains("out of range"),
        "{e}"
    );
}
