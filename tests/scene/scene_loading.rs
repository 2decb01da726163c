//! Scene loading: the committed scenes have the geometry, materials and camera they claim,
//! transforms keep front faces, and every broken file gives an error naming it (never a panic).

use crate::common;

use glam::Vec3;
use std::path::{Path, PathBuf};
use wavetrace::render::PreparedScene;
use wavetrace::scene::{Camera, Projection, Scene, Triangle};

fn crate_root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn load_committed(name: &str) -> Scene {
    let path = crate_root().join("scenes").join(name);
    Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"))
}

fn centroid(t: &Triangle) -> Vec3 {
    (t.p[0] + t.p[1] + t.p[2]) / 3.0
}

fn unit_normal(t: &Triangle) -> Vec3 {
    t.geometric_normal().normalize()
}

fn approx(a: Vec3, b: Vec3, eps: f32) -> bool {
    (a - b).abs().max_element() <= eps
}

// ---------------------------------------------------------------------------------------------
// Committed scenes

#[test]
fn cornell_box_geometry_materials_and_camera() {
    let scene = load_committed("cornell-box.gltf");
    assert_eq!(scene.triangles.len(), 36);
    assert_eq!(scene.dropped_degenerate, 0);
    let material = |t: &Triangle| &scene.materials[t.material as usize];

    // The light: its emission is the radiance the file encodes as factor × strength.
    let radiance = Vec3::new(18.387, 13.9873, 6.75357);
    let lights: Vec<_> = scene
        .triangles
        .iter()
        .filter(|t| material(t).is_emissive())
        .collect();
    assert_eq!(lights.len(), 2);
    for t in &lights {
        let e = material(t).emission;
        assert!(
            ((e - radiance) / radiance).abs().max_element() < 1e-5,
            "light emission {e}"
        );
        assert!(!material(t).double_sided);
        assert!(approx(unit_normal(t), Vec3::NEG_Y, 1e-6));
    }

    // Floor: the two large triangles at y = −1 (the short box's bottom is there too, but small).
    let floor: Vec<_> = scene
        .triangles
        .iter()
        .filter(|t| t.p.iter().all(|p| (p.y + 1.0).abs() < 1e-6) && (t.area() - 2.0).abs() < 1e-5)
        .collect();
    assert_eq!(floor.len(), 2);
    for t in floor {
        assert!(
            approx(unit_normal(t), Vec3::Y, 1e-6),
            "floor normal {}",
            unit_normal(t)
        );
    }

    // Red wall on the left (x = −1) facing +X; green wall at x = +1 facing −X.
    let red = Vec3::new(0.570068, 0.0430135, 0.0443706);
    let green = Vec3::new(0.105421, 0.37798, 0.076425);
    for (albedo, x, normal) in [(red, -1.0, Vec3::X), (green, 1.0, Vec3::NEG_X)] {
        let wall: Vec<_> = scene
            .triangles
            .iter()
            .filter(|t| approx(material(t).base_color, albedo, 1e-6))
            .collect();
        assert_eq!(wall.len(), 2);
        for t in wall {
            assert!(approx(unit_normal(t), normal, 1e-6));
            assert!(t.p.iter().all(|p| (p.x - x).abs() < 1e-6));
        }
    }

    // Boxes: 12 triangles each, every normal pointing away from the box's centre.
    let centres = [Vec3::new(-0.33, -0.4, -0.28), Vec3::new(0.335, -0.7, 0.38)];
    let boxes: Vec<_> = scene
        .triangles
        .iter()
        .filter(|t| centres.iter().any(|c| (centroid(t) - *c).length() < 0.75) && t.area() < 0.5)
        .collect();
    assert_eq!(boxes.len(), 24);
    for centre in centres {
        let faces: Vec<_> = boxes
            .iter()
            .filter(|t| {
                centres
                    .iter()
                    .all(|c| (centroid(t) - centre).length() <= (centroid(t) - *c).length())
            })
            .collect();
        assert_eq!(faces.len(), 12, "box at {centre}");
        for t in faces {
            assert!(
                unit_normal(t).dot(centroid(t) - centre) > 0.0,
                "inward face {t:?} of box at {centre}"
            );
        }
    }

    let cam = scene.camera;
    assert!(approx(cam.position, Vec3::new(0.0, 0.0, 3.9), 1e-6));
    assert!(approx(cam.forward, Vec3::NEG_Z, 1e-6));
    assert!(approx(cam.up, Vec3::Y, 1e-6));
    assert!(approx(cam.right, Vec3::X, 1e-6));
    assert!((cam.yfov().unwrap() - 39.3077f32.to_radians()).abs() < 1e-6);
    assert_eq!(cam.aspect_ratio(), Some(1.0));

    let (lo, hi) = scene.bounds();
    assert!(approx(lo, Vec3::new(-1.0, -1.01, -1.0), 1e-5), "{lo}");
    assert!(approx(hi, Vec3::ONE, 1e-5), "{hi}");
}

#[test]
fn cornell_box_light_table_has_the_two_light_triangles() {
    let prepared = PreparedScene::new(&load_committed("cornell-box.gltf"));
    let table = &prepared.lights;
    assert_eq!(table.len(), 2);
    for entry in table {
        assert!((entry.pmf - 0.5).abs() < 1e-6);
    }
    assert_eq!(table[1].cdf, 1.0);
    let pmf_sum: f32 = prepared.triangles.iter().map(|t| t.light_pmf).sum();
    assert!((pmf_sum - 1.0).abs() < 1e-6);
}

#[test]
fn furnace_sphere_faces_inwards() {
    let scene = load_committed("furnace.gltf");
    assert_eq!(scene.triangles.len(), 1280);
    for t in &scene.triangles {
        assert!(unit_normal(t).dot(centroid(t)) < 0.0, "outward face {t:?}");
    }
    let (lo, hi) = scene.bounds();
    assert!(
        lo.min_element() >= -1.0 - 1e-6 && hi.max_element() <= 1.0 + 1e-6,
        "{lo} {hi}"
    );
    let m = &scene.materials[0];
    assert_eq!(
        (m.base_color, m.emission, m.double_sided),
        (Vec3::splat(0.5), Vec3::splat(0.5), false)
    );
    assert_eq!(scene.camera.position, Vec3::ZERO);
    assert!((scene.camera.yfov().unwrap() - 60f32.to_radians()).abs() < 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Hand-made files

/// Writes `json` to a fresh temporary file; `tag` keeps parallel tests apart.
fn temp_file(tag: &str, extension: &str, bytes: &[u8]) -> PathBuf {
    let path = std::env::temp_dir().join(format!(
        "wavetrace-test-{}-{tag}.{extension}",
        std::process::id()
    ));
    std::fs::write(&path, bytes).unwrap();
    path
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |acc, (i, &b)| acc | (b as u32) << (16 - 8 * i));
        for i in 0..4 {
            out.push(if i <= chunk.len() {
                ALPHABET[(n >> (18 - 6 * i) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    out
}

/// The unit square [−1,1]² at z = 0, counter-clockwise seen from +Z, as positions + u16 indices.
fn quad_buffer() -> Vec<u8> {
    let positions: [f32; 12] = [
        -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
    ];
    let indices: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut bytes: Vec<u8> = positions.iter().flat_map(|x| x.to_le_bytes()).collect();
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    bytes
}

/// Base64 of the quad's index bytes as they appear in its data URI (they start at byte 48, a
/// multiple of 3, so their encoding is a substring of the buffer's).
fn index_base64(indices: &[u16; 6]) -> String {
    base64(
        &indices
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect::<Vec<u8>>(),
    )
}

/// A one-quad glTF; `node` is the JSON of node 0 (without "mesh"), `extra` more root members.
fn quad_gltf(node: &str, primitive_extra: &str, extra: &str) -> String {
    quad_gltf_with_buffer(&quad_buffer(), node, primitive_extra, extra)
}

fn quad_gltf_with_buffer(buffer: &[u8], node: &str, primitive_extra: &str, extra: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}}, {extra}
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0 {node}}}],
  "meshes": [{{"name": "quad", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1 {primitive_extra}}}]}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1,-1,0], "max": [1,1,0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
  "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}]
}}"#,
        buffer.len(),
        base64(buffer)
    )
}

fn load_text(tag: &str, json: &str) -> (PathBuf, anyhow::Result<Scene>) {
    let path = temp_file(tag, "gltf", json.as_bytes());
    let result = Scene::load(&path);
    std::fs::remove_file(&path).ok();
    (path, result)
}

fn expect_error(tag: &str, json: &str, needles: &[&str]) {
    let (path, result) = load_text(tag, json);
    let message = format!(
        "{:#}",
        result
            .err()
            .unwrap_or_else(|| panic!("{tag}: loaded, expected an error"))
    );
    for needle in [path.file_name().unwrap().to_str().unwrap()]
        .iter()
        .chain(needles)
    {
        assert!(
            message.contains(needle),
            "{tag}: message lacks {needle:?}: {message}"
        );
    }
}

#[test]
fn quad_loads_with_framing_camera_and_default_material() {
    let (_, scene) = load_text("plain", &quad_gltf("", "", ""));
    let scene = scene.unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert!(scene
        .triangles
        .iter()
        .all(|t| approx(unit_normal(t), Vec3::Z, 1e-6)));
    assert_eq!(scene.materials.len(), 1);
    // glTF's default material: every property at its default.
    let m = &scene.materials[0];
    assert_eq!(m.base_color, Vec3::ONE);
    assert_eq!(
        (m.metallic, m.roughness, m.ior, m.specular),
        (1.0, 1.0, 1.5, 1.0)
    );
    assert!(scene.triangles.iter().all(|t| t.material == 0));
    let cam = scene.camera;
    assert_eq!((cam.forward, cam.up), (Vec3::NEG_Z, Vec3::Y));
    assert!(cam.position.z > 1.0 && cam.position.x == 0.0 && cam.position.y == 0.0);
}

#[test]
fn mirroring_node_keeps_the_front_face() {
    // Mirroring x maps the +Z-facing quad to a +Z-facing quad; without the vertex swap its
    // winding would make it face −Z.
    let (_, scene) = load_text(
        "mirror",
        &quad_gltf(r#", "scale": [-1, 1, 1], "translation": [0, 0, 2]"#, "", ""),
    );
    let scene = scene.unwrap();
    assert_eq!(scene.triangles.len(), 2);
    for t in &scene.triangles {
        assert!(approx(unit_normal(t), Vec3::Z, 1e-6), "{}", unit_normal(t));
        assert!(t.p.iter().all(|p| p.z == 2.0));
    }
}

#[test]
fn rotated_camera_node() {
    // Camera rotated 90° about +Y: looks down −X; quad child of the root node.
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let json = quad_gltf(
        &format!(
            r#", "children": [1]}}, {{"camera": 0, "rotation": [0, {s}, 0, {s}], "translation": [5, 0, 0]"#
        ),
        "",
        r#""cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}}],"#,
    );
    let (_, scene) = load_text("camera", &json);
    let cam = scene.unwrap().camera;
    assert!(approx(cam.position, Vec3::new(5.0, 0.0, 0.0), 1e-6));
    assert!(approx(cam.forward, Vec3::NEG_X, 1e-6), "{}", cam.forward);
    assert!(approx(cam.right, Vec3::NEG_Z, 1e-6), "{}", cam.right);
    assert_eq!((cam.yfov().unwrap(), cam.aspect_ratio()), (0.5, None));
}

#[test]
fn every_camera_instance_is_kept_and_chosen_by_index_or_name() {
    // Node 0 (the quad) has children 1 ("Side", orthographic cameras[1]) and 2 ("Top",
    // perspective cameras[0]): traversal meets cameras[1] first, so it is the default.
    let json = quad_gltf(
        r#", "children": [1, 2]}, {"name": "Side", "camera": 1, "translation": [0, 0, 5]},
           {"name": "Top", "camera": 0, "translation": [0, 4, 0], "rotation": [-0.7071068, 0, 0, 0.7071068]"#,
        "",
        r#""cameras": [
             {"name": "Main", "type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1, "aspectRatio": 2}},
             {"name": "Ortho", "type": "orthographic", "orthographic": {"xmag": 3, "ymag": 1.5, "znear": 0.25, "zfar": 100}}],"#,
    );
    let (_, scene) = load_text("cameras", &json);
    let mut scene = scene.unwrap();
    let labels: Vec<String> = scene.cameras.iter().map(|c| c.label.clone()).collect();
    assert_eq!(
        labels,
        [
            r#"cameras[1] ("Ortho") on nodes[1] ("Side")"#,
            r#"cameras[0] ("Main") on nodes[2] ("Top")"#
        ]
    );
    let ortho = scene.camera;
    assert_eq!(
        ortho.projection,
        Projection::Orthographic {
            xmag: 3.0,
            ymag: 1.5
        }
    );
    assert_eq!((ortho.znear, ortho.aspect_ratio()), (0.25, Some(2.0)));
    assert!(approx(ortho.position, Vec3::new(0.0, 0.0, 5.0), 1e-6));
    assert!(
        scene.notes.is_empty(),
        "an orthographic camera is no longer noted: {:?}",
        scene.notes
    );

    scene.select_camera("0").unwrap();
    let top = scene.camera;
    assert_eq!(
        (top.yfov(), top.aspect_ratio(), top.znear),
        (Some(0.5), Some(2.0), 0.1)
    );
    assert!(approx(top.forward, Vec3::NEG_Y, 1e-6), "{}", top.forward);
    for (which, expected) in [("1", ortho), ("Main", top), ("Side", ortho), ("Top", top)] {
        scene.select_camera(which).unwrap();
        assert_eq!(scene.camera, expected, "--camera {which}");
    }
    for unknown in ["2", "Front", ""] {
        let e = format!("{:#}", scene.select_camera(unknown).unwrap_err());
        assert!(
            e.contains(&format!("--camera {unknown}"))
                && labels.iter().all(|l| e.contains(l.as_str())),
            "{e}"
        );
    }
    // A file without cameras keeps the framing camera, and --camera says there is none.
    let (_, plain) = load_text("no-cameras", &quad_gltf("", "", ""));
    let mut plain = plain.unwrap();
    assert!(plain.cameras.is_empty());
    assert_eq!(plain.camera, Camera::framing(plain.bounds()));
    let e = format!("{:#}", plain.select_camera("0").unwrap_err());
    assert!(e.contains("has no cameras"), "{e}");
}

#[test]
fn glb_with_binary_chunk_loads() {
    let buffer = quad_buffer();
    let json = quad_gltf("", "", "").replace(
        &format!(
            r#""uri": "data:application/octet-stream;base64,{}""#,
            base64(&buffer)
        ),
        "\"name\": \"bin\"",
    );
    let mut json = json.into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + buffer.len();
    let mut glb = Vec::new();
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend((total as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json);
    glb.extend((buffer.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&buffer);
    let path = temp_file("binary", "glb", &glb);
    let scene = Scene::load(&path);
    std::fs::remove_file(&path).ok();
    assert_eq!(scene.unwrap_or_else(|e| panic!("{e:#}")).triangles.len(), 2);
}

#[test]
fn malformed_inputs_name_the_object_and_problem() {
    let quad = quad_gltf("", "", "");
    expect_error(
        "loop",
        &quad.replace(
            r#""nodes": [{"mesh": 0 }]"#,
            r#""nodes": [{"mesh": 0, "children": [1]}, {"children": [0]}]"#,
        ),
        &["node loop", "nodes[0]"],
    );
    expect_error(
        "two-parents",
        &quad.replace(
            r#""scenes": [{"nodes": [0]}]"#,
            r#""scenes": [{"nodes": [0, 0]}]"#,
        ),
        &["nodes[0]", "reached"],
    );
    expect_error(
        "required-ext",
        &quad_gltf(
            "",
            "",
            r#""extensionsRequired": ["EXT_lights_image_based"], "extensionsUsed": ["EXT_lights_image_based"],"#,
        ),
        &["EXT_lights_image_based"],
    );
    // An archived extension is refused by name, with the reason and the way out.
    expect_error(
        "required-spec-gloss",
        &quad_gltf(
            "",
            "",
            r#""extensionsRequired": ["KHR_materials_pbrSpecularGlossiness"], "extensionsUsed": ["KHR_materials_pbrSpecularGlossiness"],"#,
        ),
        &[
            "extensionsRequired",
            "KHR_materials_pbrSpecularGlossiness",
            "archived",
            "KHR_materials_specular",
        ],
    );
    // Only used: the file loads, and the note says what is ignored and why.
    let (_, used) = load_text(
        "used-spec-gloss",
        &quad_gltf(
            "",
            "",
            r#""extensionsUsed": ["KHR_materials_pbrSpecularGlossiness"],"#,
        ),
    );
    let notes = used.unwrap_or_else(|e| panic!("{e:#}")).notes;
    assert!(
        notes.iter().any(|n| n.contains("ignored glTF extensions")
            && n.contains("KHR_materials_pbrSpecularGlossiness")
            && n.contains("archived")),
        "{notes:?}"
    );
    expect_error(
        "overflow",
        &quad_gltf(
            r#", "scale": [1e38, 1, 1], "translation": [3e38, 0, 0]"#,
            "",
            "",
        ),
        &["non-finite", "meshes[0].primitives[0]", "mesh \"quad\""],
    );
    let mut nan = quad_buffer();
    nan[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
    expect_error(
        "nan",
        &quad_gltf_with_buffer(&nan, "", "", ""),
        &["vertex 1", "non-finite", "NaN"],
    );
    expect_error(
        "bad-index",
        &quad.replace(
            &index_base64(&[0, 1, 2, 0, 2, 3]),
            &index_base64(&[0, 1, 2, 0, 2, 9]),
        ),
        &["index 9", "out of range", "accessors[1]"],
    );
    // gltf-json 1.4 itself would panic on this one.
    expect_error(
        "dangling-position",
        &quad.replace(r#""POSITION": 0"#, r#""POSITION": 7"#),
        &[
            "meshes[0].primitives[0].attributes.POSITION",
            "index 7 is out of range",
        ],
    );
    expect_error(
        "no-position",
        &quad.replace(r#""POSITION": 0"#, r#""NORMAL": 0"#),
        &["attributes[\"POSITION\"]", "meshes[0].primitives[0]"],
    );
    expect_error(
        "bad-yfov",
        &quad_gltf(
            r#", "camera": 0"#,
            "",
            r#""cameras": [{"type": "perspective", "perspective": {"yfov": 3.5, "znear": 0.1}}],"#,
        ),
        &["cameras[0]", "yfov"],
    );
    expect_error(
        "empty-scene",
        &quad.replace(
            r#""scenes": [{"nodes": [0]}]"#,
            r#""scenes": [{"nodes": []}]"#,
        ),
        &["no triangles"],
    );
    expect_error(
        "short-view",
        &quad.replace(
            r#""byteOffset": 48, "byteLength": 12"#,
            r#""byteOffset": 48, "byteLength": 10"#,
        ),
        &["bufferViews[1]"],
    );
    expect_error(
        "bad-base64",
        &quad.replace("base64,", "base64,*"),
        &["buffers[0]", "base64"],
    );
    expect_error(
        "missing-bin",
        &quad.replace(r#""uri": "data:"#, r#""uri": "nowhere.bin", "x": "data:"#),
        &["nowhere.bin"],
    );
}

#[test]
fn other_topologies_and_index_widths() {
    // u8 indices as a strip, and the same vertices without indices as a fan: both cover the
    // quad with +Z normals.
    let strip = quad_gltf("", r#", "mode": 5"#, "")
        .replace(
            r#""componentType": 5123, "count": 6"#,
            r#""componentType": 5121, "count": 4"#,
        )
        .replace(
            r#""byteOffset": 48, "byteLength": 12"#,
            r#""byteOffset": 48, "byteLength": 4"#,
        )
        .replace(
            &index_base64(&[0, 1, 2, 0, 2, 3]),
            &base64(&[0, 1, 3, 2, 0, 0, 0, 0, 0, 0, 0, 0]),
        );
    let (_, scene) = load_text("strip", &strip);
    let scene = scene.unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(scene.triangles.len(), 2);
    assert!(scene
        .triangles
        .iter()
        .all(|t| approx(unit_normal(t), Vec3::Z, 1e-6)));

    let fan = quad_gltf("", r#", "mode": 6"#, "").replace(r#", "indices": 1"#, "");
    let (_, scene) = load_text("fan", &fan);
    let scene = scene.unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(scene.triangles.len(), 2);
    assert!(scene
        .triangles
        .iter()
        .all(|t| approx(unit_normal(t), Vec3::Z, 1e-6)));

    let lines = quad_gltf("", r#", "mode": 1"#, "");
    expect_error("lines", &lines, &["no triangles", "1 point/line"]);
}

#[test]
fn missing_and_empty_files_name_the_path() {
    let missing = std::env::temp_dir().join("wavetrace-test-does-not-exist.gltf");
    let message = format!("{:#}", Scene::load(&missing).unwrap_err());
    assert!(
        message.contains(&missing.display().to_string()),
        "{message}"
    );

    let empty = temp_file("empty", "gltf", b"");
    let message = format!("{:#}", Scene::load(&empty).unwrap_err());
    std::fs::remove_file(&empty).ok();
    assert!(
        message.contains(&empty.display().to_string()) && message.contains("empty"),
        "{message}"
    );
}

// ---------------------------------------------------------------------------------------------
// Third-party corpus (../shared/gltf-samples, see its README)

/// Invalid files a lenient loader may accept, with the reason. Empty: every invalid sample
/// either breaks something we read or has no scene with triangles.
const LENIENT_ALLOW_LIST: &[(&str, &str)] = &[];

/// Invalid samples that break what the texture reader reads, with the JSON path their error
/// must name (the other invalid samples need only name the file; tests/hostile holds the
/// generated texture and attribute cases).
const INVALID_SAMPLE_PATHS: &[(&str, &str)] = &[(
    "material__unresolved_basecolor.gltf",
    "materials[0].pbrMetallicRoughness.baseColorTexture.index",
)];

fn samples_dir() -> Option<PathBuf> {
    let dir = crate_root().join("../shared/gltf-samples");
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipping: ../shared/gltf-samples not found");
        None
    }
}

fn gltf_files(dir: &Path) -> Vec<PathBuf> {
    common::files_with_extension(dir, &["gltf", "glb"])
}

#[test]
fn invalid_samples_give_errors_naming_the_file() {
    let Some(dir) = samples_dir() else { return };
    let files = gltf_files(&dir.join("invalid"));
    assert!(!files.is_empty());
    for (file, _) in INVALID_SAMPLE_PATHS {
        assert!(
            files.iter().any(|p| p.ends_with(file)),
            "{file} is not in the corpus"
        );
    }
    let mut failures = Vec::new();
    for path in files {
        let name = path.file_name().unwrap().to_str().unwrap().to_owned();
        match std::panic::catch_unwind(|| Scene::load(&path)) {
            Err(_) => failures.push(format!("{name}: panicked")),
            Ok(Ok(_)) if LENIENT_ALLOW_LIST.iter().any(|(f, _)| *f == name) => {}
            Ok(Ok(_)) => failures.push(format!("{name}: loaded without error")),
            Ok(Err(e)) => {
                let message = format!("{e:#}");
                println!("{name}: {message}");
                if !message.contains(&name) {
                    failures.push(format!("{name}: message does not name the file: {message}"));
                }
                if let Some((_, path)) = INVALID_SAMPLE_PATHS.iter().find(|(f, _)| *f == name) {
                    if !message.contains(path) {
                        failures.push(format!("{name}: message does not name {path}: {message}"));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn valid_samples_load() {
    let Some(dir) = samples_dir() else { return };
    let files = gltf_files(&dir.join("valid"));
    assert!(!files.is_empty());
    for path in files {
        let name = path.display();
        let scene = std::panic::catch_unwind(|| Scene::load(&path))
            .unwrap_or_else(|_| panic!("{name}: panicked"))
            .unwrap_or_else(|e| panic!("{e:#}"));
        assert!(scene.rendered_triangles() > 0, "{name}");
        let (lo, hi) = scene.bounds();
        assert!(lo.is_finite() && hi.is_finite(), "{name}");
        println!(
            "{name}: {} triangles, {} materials",
            scene.triangles.len(),
            scene.materials.len()
        );
    }
}

#[test]
fn cameras_sample_has_a_perspective_and_an_orthographic_camera() {
    let path = crate_root().join("../shared/gltf-samples/valid/Cameras.gltf");
    if !path.exists() {
        eprintln!("skipping: ../shared/gltf-samples not found");
        return;
    }
    let mut scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(scene.cameras.len(), 2);
    assert_eq!(
        scene.camera.projection,
        Projection::Perspective {
            yfov: 0.7,
            aspect_ratio: Some(1.0)
        }
    );
    // --camera 1: the orthographic one, on node 2.
    scene.select_camera("1").unwrap();
    let cam = scene.camera;
    assert_eq!(
        cam.projection,
        Projection::Orthographic {
            xmag: 1.0,
            ymag: 1.0
        }
    );
    assert_eq!(cam.znear, 0.01);
    assert!(approx(cam.position, Vec3::new(0.5, 0.5, 3.0), 1e-6));
    assert!(approx(cam.forward, Vec3::NEG_Z, 1e-6));
    assert_eq!(scene.cameras[1].label, "cameras[1] on nodes[2]");
}

#[test]
fn textures_are_read_without_notes() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples/valid/BoxTextured.gltf");
    if !path.exists() {
        eprintln!("skipping: ../shared/gltf-samples not found");
        return;
    }
    let scene = Scene::load(&path).unwrap();
    assert!(scene.notes.is_empty(), "{:?}", scene.notes);
    assert_eq!(scene.textures.textures.len(), 1);
    let texture = scene.textures.textures[0];
    // Its embedded PNG is 211 × 211: a full mip chain down to 1 × 1 has 8 levels.
    assert_eq!(
        (texture.width, texture.height, texture.levels),
        (211, 211, 8)
    );
    assert_eq!(texture.srgb, 1);
    assert!(scene.materials[0].textures.base_color.is_some());
    let plain = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.gltf"))
        .unwrap();
    assert!(plain.notes.is_empty(), "{:?}", plain.notes);
}

/// The committed scenes are exactly what tools/gen_scenes.py writes, no more and no fewer
/// (skipped without python3).
#[test]
fn committed_scenes_match_their_generator() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::env::temp_dir().join(format!("wavetrace-gen-scenes-{}", std::process::id()));
    let status = std::process::Command::new("python3")
        .arg(root.join("tools/gen_scenes.py"))
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .status();
    let Ok(status) = status else {
        eprintln!("skipping: python3 is not installed");
        return;
    };
    assert!(status.success(), "tools/gen_scenes.py failed");
    let names = |dir: &Path| -> Vec<String> {
        gltf_files(dir)
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect()
    };
    let generated_names = names(&out);
    assert_eq!(
        generated_names,
        [
            "caustic.gltf",
            "cornell-box.gltf",
            "cornell-materials.gltf",
            "furnace.gltf",
            "instances.gltf",
            "leaf.gltf",
            "many-lights.gltf",
            "prism.gltf",
            "veach-mis.gltf"
        ]
    );
    assert_eq!(names(&root.join("scenes")), generated_names);
    for name in &generated_names {
        let generated = std::fs::read(out.join(name)).unwrap();
        let committed = std::fs::read(root.join("scenes").join(name)).unwrap();
        assert!(
            generated == committed,
            "scenes/{name} differs from what tools/gen_scenes.py writes; run it and commit"
        );
    }
    std::fs::remove_dir_all(&out).ok();
}
