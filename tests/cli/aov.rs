//! AOV layers beside the beauty (issue 59): on a scene whose every pixel's answer is known —
//! an orthographic camera over a textured floor and a card in front of it — each layer holds
//! exactly what the geometry puts under the pixel (IDs, depth, position, uv through its centre;
//! albedo, normal and coverage over its samples); normals of a sphere equal the mesh's
//! interpolated normals, found here by intersecting each pixel's ray with every triangle; the
//! GPU's layers equal the CPU's; `--transparent` leaves alpha 0 exactly where camera rays
//! escape.

use crate::common::{self, wavetrace};
use serde_json::json;
use std::path::{Path, PathBuf};
use wavetrace::layout::*;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::Scene;

/// A triangle mesh of a test scene.
struct Mesh {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Option<Vec<[f32; 2]>>,
    indices: Vec<u32>,
    material: usize,
}

/// The 2 × 2 base colour texture of the floor (sRGB codes; row 0 at the image's top, which
/// glTF's v = 0 names).
const TEXELS: [[u8; 3]; 4] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [128, 128, 128]];
const FLOOR_FACTOR: [f64; 3] = [0.5, 1.0, 0.8];
const CARD_COLOR: [f64; 3] = [0.2, 0.3, 0.4];
/// The orthographic camera's half height (and width): the view spans [−1.5, 1.5]².
const YMAG: f64 = 1.5;
const CAMERA_Z: f64 = 3.0;
const SIZE: u32 = 32;

fn quad(lo: [f32; 2], hi: [f32; 2], z: f32, uvs: bool, material: usize) -> Mesh {
    let positions = vec![
        [lo[0], lo[1], z],
        [hi[0], lo[1], z],
        [hi[0], hi[1], z],
        [lo[0], hi[1], z],
    ];
    // u = (x + 1)/2, v = (1 − y)/2 over the floor's [−1, 1]².
    let uv = |p: &[f32; 3]| [(p[0] + 1.0) / 2.0, (1.0 - p[1]) / 2.0];
    Mesh {
        uvs: uvs.then(|| positions.iter().map(uv).collect()),
        normals: vec![[0.0, 0.0, 1.0]; 4],
        positions,
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
    }
}

/// A UV sphere of radius 1 about the origin, its vertex normals the exact sphere's.
fn sphere(segments: u32, rings: u32) -> Mesh {
    let (mut positions, mut indices) = (Vec::new(), Vec::new());
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            positions.push([
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ]);
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * row + s, (r + 1) * row + s);
            indices.extend([a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    Mesh {
        normals: positions.clone(),
        positions,
        uvs: None,
        indices,
        material: 1,
    }
}

fn b64(bytes: &[u8]) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// Writes a glTF of `meshes` (one node each) seen by an orthographic camera at z = 3 looking
/// down −z; materials 0 (the floor's: `FLOOR_FACTOR` × the texture of `TEXELS`, nearest
/// sampling) and 1 (the card's plain `CARD_COLOR`).
fn write_scene(path: &Path, meshes: &[Mesh]) {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut gltf_meshes) = (Vec::new(), Vec::new(), Vec::new());
    let mut push = |bytes: &[u8],
                    count: usize,
                    ty: &str,
                    component: u32,
                    bounds: Option<([f32; 3], [f32; 3])>| {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}));
        let mut a = json!({"bufferView": views.len() - 1, "componentType": component, "count": count, "type": ty});
        if let Some((lo, hi)) = bounds {
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        accessors.push(a);
        accessors.len() - 1
    };
    for m in meshes {
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in &m.positions {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let n = m.positions.len();
        let pos = push(
            bytemuck::cast_slice(&m.positions),
            n,
            "VEC3",
            5126,
            Some((lo, hi)),
        );
        let nor = push(bytemuck::cast_slice(&m.normals), n, "VEC3", 5126, None);
        let idx = push(
            bytemuck::cast_slice(&m.indices),
            m.indices.len(),
            "SCALAR",
            5125,
            None,
        );
        let mut attributes = json!({"POSITION": pos, "NORMAL": nor});
        if let Some(uvs) = &m.uvs {
            attributes["TEXCOORD_0"] =
                json!(push(bytemuck::cast_slice(uvs), n, "VEC2", 5126, None));
        }
        gltf_meshes.push(json!({"primitives": [{"attributes": attributes, "indices": idx, "material": m.material}]}));
    }
    let texture = {
        let bytes: Vec<u8> = TEXELS.iter().flatten().copied().collect();
        let mut png = Vec::new();
        image::RgbImage::from_raw(2, 2, bytes)
            .unwrap()
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        png
    };
    let mut nodes: Vec<_> = (0..meshes.len()).map(|k| json!({"mesh": k})).collect();
    nodes.push(json!({"camera": 0, "translation": [0.0, 0.0, CAMERA_Z]}));
    let gltf = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": YMAG, "ymag": YMAG, "znear": 0.01, "zfar": 100.0}}],
        "meshes": gltf_meshes,
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [FLOOR_FACTOR[0], FLOOR_FACTOR[1], FLOOR_FACTOR[2], 1.0], "baseColorTexture": {"index": 0}, "metallicFactor": 0.0}},
            {"pbrMetallicRoughness": {"baseColorFactor": [CARD_COLOR[0], CARD_COLOR[1], CARD_COLOR[2], 1.0], "metallicFactor": 0.0}}
        ],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9728, "minFilter": 9728}],
        "images": [{"uri": format!("data:image/png;base64,{}", b64(&texture))}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{}", b64(&bin))}],
    });
    std::fs::write(path, serde_json::to_string_pretty(&gltf).unwrap()).unwrap();
}

/// The floor ([−1, 1]² at z = 0, textured) and the card ([0.25, 0.75]² at z = 1).
fn floor_and_card() -> PathBuf {
    let path = common::temp("aov", "floor-and-card.gltf");
    write_scene(
        &path,
        &[
            quad([-1.0, -1.0], [1.0, 1.0], 0.0, true, 0),
            quad([0.25, 0.25], [0.75, 0.75], 1.0, false, 1),
        ],
    );
    path
}

/// World (x, y) of film point (px, py) in pixels, row 0 at the top.
fn world(px: f64, py: f64) -> (f64, f64) {
    let step = 2.0 * YMAG / SIZE as f64;
    (-YMAG + px * step, YMAG - py * step)
}

/// What lies under world (x, y): 2 the card, 1 the floor, 0 nothing.
fn surface_at(x: f64, y: f64) -> u32 {
    let inside = |lo: f64, hi: f64| x > lo && x < hi && y > lo && y < hi;
    if inside(0.25, 0.75) {
        2
    } else if inside(-1.0, 1.0) {
        1
    } else {
        0
    }
}

/// The surface that covers all of pixel (px, py), if one does (checked on a fine grid of the
/// pixel's points; the surfaces' edges are straight, so a grid with its corners decides).
fn covered_by(px: u32, py: u32) -> Option<u32> {
    let mut found = None;
    for i in 0..=8 {
        for j in 0..=8 {
            let (x, y) = world(px as f64 + i as f64 / 8.0, py as f64 + j as f64 / 8.0);
            let s = surface_at(x, y);
            if found.is_some_and(|f| f != s) {
                return None;
            }
            found = Some(s);
        }
    }
    found
}

/// The sRGB decoding (IEC 61966-2-1) of an 8-bit code.
fn srgb_decode(code: u8) -> f64 {
    let v = code as f64 / 255.0;
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The channels of an EXR by name.
fn exr_channels(path: &Path) -> std::collections::HashMap<String, Vec<f64>> {
    use exr::prelude::*;
    let image = read_first_flat_layer_from_file(path).unwrap();
    image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| {
            let values = match &c.sample_data {
                FlatSamples::U32(v) => v.iter().map(|&x| x as f64).collect(),
                other => other.values_as_f32().map(f64::from).collect(),
            };
            (c.name.to_string(), values)
        })
        .collect()
}

fn render_cli(scene: &Path, out: &Path, extra: &[&str]) {
    let size = SIZE.to_string();
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--device",
        "cpu",
        "--width",
        &size,
        "--height",
        &size,
        "--spp",
        "16",
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = wavetrace(&args);
    assert!(
        o.status.success(),
        "wavetrace {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Every layer of `--aov` on the floor and the card, against what the geometry puts there.
#[test]
fn aov_layers_hold_what_the_geometry_puts_under_each_pixel() {
    let scene = floor_and_card();
    let out = common::temp("aov", "layers.exr");
    render_cli(
        &scene,
        &out,
        &[
            "--env",
            "none",
            "--aov",
            "albedo,normal,depth",
            "--aov",
            "position,uv,material,instance,alpha",
        ],
    );
    let ch = exr_channels(&out);
    for name in [
        "R",
        "G",
        "B",
        "count",
        "albedo.R",
        "normal.Z",
        "depth.Z",
        "position.X",
        "uv.U",
        "material.id",
        "instance.id",
        "alpha.A",
    ] {
        if name == "alpha.A" {
            // Coverage is the image's alpha, not a layer of its own.
            assert!(
                ch.contains_key("A") && !ch.contains_key(name),
                "channels: {:?}",
                ch.keys()
            );
        } else {
            assert!(ch.contains_key(name), "no channel {name}: {:?}", ch.keys());
        }
    }
    let tight = |got: f64, want: f64, what: &str, px: u32, py: u32| {
        assert!(
            (got - want).abs() <= 1e-5 * want.abs().max(1.0),
            "{what} at pixel ({px}, {py}): {got}, expected {want}"
        );
    };
    let (mut fully, mut partly) = (0, 0);
    for py in 0..SIZE {
        for px in 0..SIZE {
            let i = (py * SIZE + px) as usize;
            let (x, y) = world(px as f64 + 0.5, py as f64 + 0.5);
            // Through the pixel's centre: exact.
            let s = surface_at(x, y);
            assert_eq!(ch["material.id"][i], s as f64, "material at ({px}, {py})");
            assert_eq!(
                ch["instance.id"][i],
                (s > 0) as u32 as f64,
                "instance at ({px}, {py})"
            );
            let z = [0.0, 0.0, 1.0][s as usize];
            let depth = if s > 0 { CAMERA_Z - z } else { 0.0 };
            tight(ch["depth.Z"][i], depth, "depth", px, py);
            let position = if s > 0 { [x, y, z] } else { [0.0; 3] };
            for (c, axis) in ["X", "Y", "Z"].iter().enumerate() {
                tight(
                    ch[&format!("position.{axis}")][i],
                    position[c],
                    "position",
                    px,
                    py,
                );
            }
            if s == 1 {
                tight(ch["uv.U"][i], (x + 1.0) / 2.0, "u", px, py);
                tight(ch["uv.V"][i], (1.0 - y) / 2.0, "v", px, py);
            }
            // Over the pixel's samples: exact where one surface covers the pixel.
            let Some(cover) = covered_by(px, py) else {
                partly += 1;
                let a = ch["A"][i];
                assert!(
                    (0.0..=1.0).contains(&a),
                    "alpha {a} at the edge ({px}, {py})"
                );
                continue;
            };
            fully += 1;
            tight(ch["A"][i], (cover > 0) as u32 as f64, "alpha", px, py);
            let normal = if cover > 0 { [0.0, 0.0, 1.0] } else { [0.0; 3] };
            for (c, axis) in ["X", "Y", "Z"].iter().enumerate() {
                tight(
                    ch[&format!("normal.{axis}")][i],
                    normal[c],
                    "normal",
                    px,
                    py,
                );
            }
            let albedo = match cover {
                0 => [0.0; 3],
                2 => CARD_COLOR,
                _ => {
                    // The texel quadrant: x < 0 is column 0, y > 0 row 0 (v < 1/2).
                    let texel = TEXELS[(x > 0.0) as usize + 2 * (y < 0.0) as usize];
                    let mut a = [0.0; 3];
                    for c in 0..3 {
                        a[c] = FLOOR_FACTOR[c] * srgb_decode(texel[c]);
                    }
                    a
                }
            };
            for (c, name) in ["R", "G", "B"].iter().enumerate() {
                tight(
                    ch[&format!("albedo.{name}")][i],
                    albedo[c],
                    "albedo",
                    px,
                    py,
                );
            }
        }
    }
    println!("{fully} pixels covered by one surface, {partly} at edges");
    assert!(fully > 800 && partly > 50, "{fully} {partly}");
}

/// A prepared scene of `path` and settings at `SIZE`² recording `aov`.
fn prepared(path: &Path) -> PreparedScene {
    PreparedScene::new(&Scene::load(path).unwrap())
}

fn aov_settings(aov: u32, centre: bool, spp: u32) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp,
        aov,
        debug_flags: if centre { FLAG_PIXEL_CENTRE } else { 0 },
        ..Default::default()
    }
}

/// The shading normals of a sphere through each pixel's centre equal the mesh's: the vertex
/// normals interpolated at the point where the pixel's ray (straight down −z) meets its
/// triangle, found here by testing every triangle; pixels within a hair of an edge between
/// triangles are left out. On the CPU and, with a device, the GPU.
#[test]
fn sphere_normals_equal_the_mesh_interpolated_normals() {
    let path = common::temp("aov", "sphere.gltf");
    let mesh = sphere(24, 12);
    let (positions, normals, indices) = (
        mesh.positions.clone(),
        mesh.normals.clone(),
        mesh.indices.clone(),
    );
    write_scene(&path, &[mesh]);
    let scene = prepared(&path);
    let settings = aov_settings(AOV_NORMAL, true, 1);
    let mut films = vec![("CPU", common::render_cpu(&scene, &settings).film)];
    if let Some(gpu) = common::render_gpu(&scene, &settings, None) {
        films.push(("GPU", gpu.film));
    }
    let v = |k: u32| glam::DVec3::from(positions[k as usize].map(f64::from));
    let n = |k: u32| glam::DVec3::from(normals[k as usize].map(f64::from));
    let mut checked = 0;
    for py in 0..SIZE {
        for px in 0..SIZE {
            let (x, y) = world(px as f64 + 0.5, py as f64 + 0.5);
            // The nearest (highest z) triangle under (x, y), by 2-D barycentrics.
            let mut best: Option<(f64, glam::DVec3, f64)> = None;
            for t in indices.chunks(3) {
                let (a, b, c) = (v(t[0]), v(t[1]), v(t[2]));
                let d = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
                if d.abs() < 1e-12 {
                    continue;
                }
                let wb = ((x - a.x) * (c.y - a.y) - (c.x - a.x) * (y - a.y)) / d;
                let wc = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) / d;
                let wa = 1.0 - wb - wc;
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let z = wa * a.z + wb * b.z + wc * c.z;
                if best.is_none_or(|(bz, _, _)| z > bz) {
                    let normal = (wa * n(t[0]) + wb * n(t[1]) + wc * n(t[2])).normalize();
                    best = Some((z, normal, wa.min(wb).min(wc)));
                }
            }
            let i = (py * SIZE + px) as usize;
            for (device, film) in &films {
                let got = film.mean_f64(i);
                match best {
                    None => assert_eq!(got, [0.0; 3], "{device}: ({px}, {py}) is off the sphere"),
                    Some((_, _, margin)) if margin < 1e-4 => {}
                    Some((_, want, _)) => {
                        for c in 0..3 {
                            assert!(
                                (got[c] - want[c]).abs() < 1e-4,
                                "{device}: normal at ({px}, {py}) is {got:?}, the mesh's {want:?}"
                            );
                        }
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 300, "only {checked} pixels checked");
}

/// The GPU's layers equal the CPU's, from the same random numbers: IDs bit for bit, the rest
/// to float rounding; on the floor and card, and on the committed instancing scene, whose
/// placements the top level reorders (the IDs are the placements' own numbers).
#[test]
fn gpu_layers_equal_the_cpu_layers() {
    if common::gpu().is_none() {
        return;
    }
    let floor = floor_and_card();
    let scenes = [prepared(&floor), common::prepared("instances.gltf")];
    for (k, scene) in scenes.iter().enumerate() {
        for (aov, centre) in [
            (AOV_BASE_COLOR, false),
            (AOV_NORMAL, false),
            (AOV_ALPHA, false),
            (AOV_EMISSION, false),
            (AOV_DEPTH, true),
            (AOV_POSITION, true),
            (AOV_UV, true),
            (AOV_MATERIAL, true),
            (AOV_INSTANCE, true),
        ] {
            let settings = aov_settings(aov, centre, if centre { 1 } else { 4 });
            let cpu = common::render_cpu(scene, &settings).film;
            let gpu = common::render_gpu(scene, &settings, None).unwrap().film;
            let mut ids = std::collections::BTreeSet::new();
            for i in 0..cpu.len() {
                let (c, g) = (cpu.mean_f64(i), gpu.mean_f64(i));
                if matches!(aov, AOV_MATERIAL | AOV_INSTANCE) {
                    assert_eq!(c, g, "scene {k}, AOV {aov}: pixel {i}");
                    assert_eq!(
                        c[0],
                        c[0].round(),
                        "scene {k}, AOV {aov}: pixel {i} is no ID"
                    );
                    ids.insert(c[0] as u32);
                } else {
                    for ch in 0..3 {
                        assert!(
                            (c[ch] - g[ch]).abs() <= 1e-4 * c[ch].abs().max(1.0),
                            "scene {k}, AOV {aov}: pixel {i}: CPU {c:?}, GPU {g:?}"
                        );
                    }
                }
            }
            if aov == AOV_INSTANCE && k == 1 {
                assert!(ids.len() > 3, "instances.gltf shows placements {ids:?}");
            }
        }
    }
}

/// `--transparent`: alpha 0 exactly where every camera ray of a pixel escapes, 1 where none
/// does, in the EXR's A and the PNG's alpha; the background is black there while the
/// environment still lights the scene; without it the environment shows.
#[test]
fn transparent_background_is_alpha_zero_where_camera_rays_escape() {
    let scene = floor_and_card();
    let exr = common::temp("aov", "transparent.exr");
    let png = common::temp("aov", "transparent.png");
    let opaque = common::temp("aov", "opaque.exr");
    let lit = "--environment";
    render_cli(&scene, &exr, &[lit, "0.5", "--transparent"]);
    render_cli(
        &scene,
        &png,
        &[lit, "0.5", "--transparent", "--view", "standard"],
    );
    render_cli(&scene, &opaque, &[lit, "0.5"]);
    let (t, o) = (exr_channels(&exr), exr_channels(&opaque));
    assert!(!o.contains_key("A"), "an opaque render has no alpha");
    let shown = image::open(&png).unwrap().to_rgba8();
    let (mut empty, mut full) = (0, 0);
    for py in 0..SIZE {
        for px in 0..SIZE {
            let i = (py * SIZE + px) as usize;
            let alpha = t["A"][i];
            let png_alpha = shown.get_pixel(px, py).0[3];
            match covered_by(px, py) {
                Some(0) => {
                    empty += 1;
                    assert_eq!(alpha, 0.0, "({px}, {py})");
                    assert_eq!(png_alpha, 0, "({px}, {py})");
                    assert_eq!([t["R"][i], t["G"][i], t["B"][i]], [0.0; 3], "({px}, {py})");
                    assert_eq!(o["R"][i], 0.5, "the environment shows at ({px}, {py})");
                }
                Some(_) => {
                    full += 1;
                    assert_eq!(alpha, 1.0, "({px}, {py})");
                    assert_eq!(png_alpha, 255, "({px}, {py})");
                    assert!(t["R"][i] > 0.0, "the environment lights ({px}, {py})");
                }
                None => assert!(
                    (0.0..=1.0).contains(&alpha),
                    "alpha {alpha} at ({px}, {py})"
                ),
            }
        }
    }
    assert!(empty > 100 && full > 300, "{empty} empty, {full} covered");
}

/// Depth, position and ID layers cannot go beside a PNG; a path layer may not take an AOV's
/// name; --aov PROPERTY needs the path tracer.
#[test]
fn aov_layers_that_cannot_be_written_are_refused() {
    let scene = floor_and_card();
    for (out, args, expect) in [
        (
            "refused.png",
            vec!["--aov", "depth"],
            "write an .exr to keep it",
        ),
        (
            "refused.exr",
            vec!["--aov", "albedo=LE"],
            "names a channel or layer",
        ),
        (
            "refused.exr",
            vec!["--aov", "normal", "--integrator", "bdpt"],
            "need --integrator path",
        ),
        (
            "refused.exr",
            vec!["--aov", "albedo,shine"],
            "neither a property",
        ),
    ] {
        let out = common::temp("aov", out);
        let size = "8";
        // (BDPT refuses an orthographic camera before anything else: the Cornell box's is not.)
        let file = match args.contains(&"bdpt") {
            true => "scenes/cornell-box.gltf",
            false => scene.to_str().unwrap(),
        };
        let mut all = vec![
            "render",
            file,
            "--device",
            "cpu",
            "--width",
            size,
            "--spp",
            "1",
            "-o",
            out.to_str().unwrap(),
        ];
        all.extend(args.iter().copied());
        let o = wavetrace(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err.contains(expect), "{args:?}: {err}");
    }
}
