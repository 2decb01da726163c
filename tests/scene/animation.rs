//! Animations (issue 58; src/scene/animation.rs): every model of the sample set's `animation/`
//! folder posed at chosen moments of each of its animations, against triangle corners computed
//! here from the specification with the `gltf` crate's reader — keyframes sampled by formulas
//! of their own (STEP; LINEAR with spherical interpolation written as a·(a⁻¹b)^s; CUBICSPLINE
//! as the Bézier curve with control points v_k, v_k + td·b_k/3, v_k+1 − td·a_k+1/3, v_k+1,
//! which equals the specification's Hermite form), node transforms composed from the roots,
//! morph targets and skins applied as glTF 2.0 §3.7.2.2 and §3.7.3 say. Then the GPU against
//! the CPU per tile at a moment of each animation, and bad animations refused by JSON path.

use crate::common::small_render_agrees;
use glam::{Mat4, Quat, Vec3};
use gltf::animation::util::ReadOutputs;
use gltf::animation::Interpolation;
use std::path::{Path, PathBuf};
use wavetrace::render::PreparedScene;
use wavetrace::scene::{Animations, LoadOptions, Moment, SceneFile};
use wavetrace::stats::sidak;

fn models() -> Option<Vec<PathBuf>> {
    let dir = crate::common::gltf_samples()?.join("animation");
    let mut files = crate::common::files_with_extension(&dir, &["gltf", "glb"]);
    for sub in std::fs::read_dir(&dir).unwrap() {
        let sub = sub.unwrap().path();
        if sub.is_dir() {
            files.extend(crate::common::files_with_extension(&sub, &["gltf", "glb"]));
        }
    }
    files.sort();
    assert!(
        files.len() >= 12,
        "expected the animation samples, found {files:?}"
    );
    Some(files)
}

/// A cubic Bézier of one component by de Casteljau's construction.
fn bezier(p: [f32; 4], s: f32) -> f32 {
    let lerp = |a: f32, b: f32| a + s * (b - a);
    let (a, b, c) = (lerp(p[0], p[1]), lerp(p[1], p[2]), lerp(p[2], p[3]));
    let (d, e) = (lerp(a, b), lerp(b, c));
    lerp(d, e)
}

/// a·(a⁻¹·b)^s along the shorter arc.
fn slerp_by_power(a: Quat, b: Quat, s: f32) -> Quat {
    let b = if a.dot(b) < 0.0 { -b } else { b };
    let d = a.conjugate() * b;
    let (axis, angle) = d.normalize().to_axis_angle();
    if angle.abs() < 1e-7 {
        return a;
    }
    (a * Quat::from_axis_angle(axis, s * angle)).normalize()
}

/// One channel's `width` values (of any number of components) at time `t`.
fn sample(
    times: &[f32],
    values: &[Vec<f32>],
    width: usize,
    interpolation: Interpolation,
    rotation: bool,
    t: f32,
) -> Vec<Vec<f32>> {
    let cubic = interpolation == Interpolation::CubicSpline;
    let vertex = |k: usize, j: usize| -> &Vec<f32> {
        if cubic {
            &values[3 * width * k + width + j]
        } else {
            &values[width * k + j]
        }
    };
    let n = times.len();
    let at_key = |k: usize| (0..width).map(|j| vertex(k, j).clone()).collect();
    if t <= times[0] {
        return at_key(0);
    }
    if t >= times[n - 1] {
        return at_key(n - 1);
    }
    let k = (0..n - 1)
        .find(|&k| times[k] <= t && t < times[k + 1])
        .unwrap();
    let td = times[k + 1] - times[k];
    let s = (t - times[k]) / td;
    (0..width)
        .map(|j| {
            let (a, b) = (vertex(k, j), vertex(k + 1, j));
            match interpolation {
                Interpolation::Step => a.clone(),
                Interpolation::Linear if rotation => {
                    let q = slerp_by_power(Quat::from_slice(a), Quat::from_slice(b), s);
                    q.to_array().to_vec()
                }
                Interpolation::Linear => a.iter().zip(b).map(|(x, y)| x + s * (y - x)).collect(),
                Interpolation::CubicSpline => {
                    let out_tangent = &values[3 * width * k + 2 * width + j];
                    let in_tangent = &values[3 * width * (k + 1) + j];
                    let v: Vec<f32> = (0..a.len())
                        .map(|i| {
                            bezier(
                                [
                                    a[i],
                                    a[i] + td * out_tangent[i] / 3.0,
                                    b[i] - td * in_tangent[i] / 3.0,
                                    b[i],
                                ],
                                s,
                            )
                        })
                        .collect();
                    if rotation {
                        Quat::from_slice(&v).normalize().to_array().to_vec()
                    } else {
                        v
                    }
                }
            }
        })
        .collect()
}

/// Every node's local matrix and morph weights at `t` of the animations `which` (None: all).
fn pose(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    which: Option<usize>,
    t: f32,
) -> (Vec<Mat4>, Vec<Option<Vec<f32>>>) {
    let mut trs: Vec<(Vec3, Quat, Vec3)> = document
        .nodes()
        .map(|n| {
            let (t, r, s) = n.transform().decomposed();
            (Vec3::from(t), Quat::from_array(r), Vec3::from(s))
        })
        .collect();
    let mut moved = vec![false; trs.len()];
    let mut weights: Vec<Option<Vec<f32>>> = document
        .nodes()
        .map(|n| {
            n.weights()
                .or_else(|| n.mesh().and_then(|m| m.weights()))
                .map(<[f32]>::to_vec)
        })
        .collect();
    for animation in document.animations() {
        if which.is_some_and(|w| w != animation.index()) {
            continue;
        }
        for channel in animation.channels() {
            let reader = channel.reader(|b| Some(&buffers[b.index()]));
            let times: Vec<f32> = reader.read_inputs().unwrap().collect();
            let interpolation = channel.sampler().interpolation();
            let node = channel.target().node().index();
            let (values, rotation): (Vec<Vec<f32>>, bool) = match reader.read_outputs().unwrap() {
                ReadOutputs::Translations(v) => (v.map(|v| v.to_vec()).collect(), false),
                ReadOutputs::Scales(v) => (v.map(|v| v.to_vec()).collect(), false),
                ReadOutputs::Rotations(v) => (v.into_f32().map(|v| v.to_vec()).collect(), true),
                ReadOutputs::MorphTargetWeights(v) => {
                    (v.into_f32().map(|w| vec![w]).collect(), false)
                }
            };
            let per_key = values.len()
                / times.len()
                / if interpolation == Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
            let got = sample(&times, &values, per_key, interpolation, rotation, t);
            use gltf::animation::Property;
            match channel.target().property() {
                Property::Translation => trs[node].0 = Vec3::from_slice(&got[0]),
                Property::Rotation => trs[node].1 = Quat::from_slice(&got[0]),
                Property::Scale => trs[node].2 = Vec3::from_slice(&got[0]),
                Property::MorphTargetWeights => {
                    weights[node] = Some(got.iter().map(|v| v[0]).collect());
                    continue;
                }
            }
            moved[node] = true;
        }
    }
    let locals = document
        .nodes()
        .zip(trs.iter().zip(&moved))
        .map(|(n, ((t, r, s), &moved))| {
            if moved {
                Mat4::from_scale_rotation_translation(*s, r.normalize(), *t)
            } else {
                Mat4::from_cols_array_2d(&n.transform().matrix())
            }
        })
        .collect();
    (locals, weights)
}

/// The triangle corners of the default scene at `t` of the animations `which`, in the loader's
/// order (nodes depth-first, children in file order; primitives and indices in order).
fn expected(path: &Path, which: Option<usize>, t: f32) -> Vec<Vec3> {
    let (document, buffers, _) = gltf::import(path).unwrap();
    let (locals, weights) = pose(&document, &buffers, which, t);
    // World transforms of every node (joints may lie outside the scene's tree).
    let mut worlds = locals.clone();
    let roots: Vec<usize> = (0..locals.len())
        .filter(|&i| {
            document
                .nodes()
                .all(|p| p.children().all(|c| c.index() != i))
        })
        .collect();
    let mut stack: Vec<(usize, Mat4)> = roots.iter().map(|&r| (r, Mat4::IDENTITY)).collect();
    while let Some((i, parent)) = stack.pop() {
        worlds[i] = parent * locals[i];
        let node = document.nodes().nth(i).unwrap();
        stack.extend(node.children().map(|c| (c.index(), worlds[i])));
    }
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .unwrap();
    let mut order = Vec::new();
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    stack.reverse();
    while let Some(node) = stack.pop() {
        order.push(node.index());
        let mut children: Vec<gltf::Node> = node.children().collect();
        children.reverse();
        stack.extend(children);
    }
    let mut corners = Vec::new();
    for i in order {
        let node = document.nodes().nth(i).unwrap();
        let Some(mesh) = node.mesh() else { continue };
        for primitive in mesh.primitives() {
            assert_eq!(primitive.mode(), gltf::mesh::Mode::Triangles);
            let reader = primitive.reader(|b| Some(&buffers[b.index()]));
            let mut p: Vec<Vec3> = reader.read_positions().unwrap().map(Vec3::from).collect();
            let w = weights[i].clone().unwrap_or_default();
            for (target, wk) in reader.read_morph_targets().zip(&w) {
                if let Some(deltas) = target.0 {
                    for (p, d) in p.iter_mut().zip(deltas) {
                        *p += *wk * Vec3::from(d);
                    }
                }
            }
            let skinned = match (node.skin(), reader.read_joints(0)) {
                (Some(skin), Some(joints)) => {
                    let sr = skin.reader(|b| Some(&buffers[b.index()]));
                    let ibm: Vec<Mat4> = sr
                        .read_inverse_bind_matrices()
                        .map(|m| m.map(|m| Mat4::from_cols_array_2d(&m)).collect())
                        .unwrap_or_else(|| vec![Mat4::IDENTITY; skin.joints().count()]);
                    let jm: Vec<Mat4> = skin
                        .joints()
                        .zip(ibm)
                        .map(|(j, ibm)| worlds[j.index()] * ibm)
                        .collect();
                    let js: Vec<[u16; 4]> = joints.into_u16().collect();
                    let ws: Vec<[f32; 4]> = reader.read_weights(0).unwrap().into_f32().collect();
                    Some(
                        (0..p.len())
                            .map(|v| {
                                let total: f32 = ws[v].iter().map(|w| w.max(0.0)).sum();
                                (0..4).fold(Vec3::ZERO, |acc, k| {
                                    let w = ws[v][k].max(0.0) / total;
                                    acc + w * jm[js[v][k] as usize].transform_point3(p[v])
                                })
                            })
                            .collect::<Vec<Vec3>>(),
                    )
                }
                _ => None,
            };
            let placed: Vec<Vec3> = skinned
                .unwrap_or_else(|| p.iter().map(|&p| worlds[i].transform_point3(p)).collect());
            let indices: Vec<u32> = match reader.read_indices() {
                Some(ix) => ix.into_u32().collect(),
                None => (0..placed.len() as u32).collect(),
            };
            corners.extend(indices.iter().map(|&k| placed[k as usize]));
        }
    }
    corners
}

/// Moments to check of an animation spanning `start..end`: its first keyframe, two inside
/// (away from keyframes by choice of fractions), and past its end (held at the last).
fn moments(start: f32, end: f32) -> [f32; 4] {
    let span = end - start;
    [start, start + 0.37 * span, start + 0.813 * span, end + 0.5]
}

#[test]
fn every_animated_sample_is_posed_as_the_specification_says() {
    let Some(models) = models() else { return };
    let options = LoadOptions {
        instancing: false,
        ..LoadOptions::default()
    };
    let mut checked = 0;
    for path in &models {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let file = SceneFile::open(path, &options).unwrap();
        let animations = file.animations();
        let mut cases: Vec<(Option<usize>, f32)> = Vec::new();
        for a in &animations {
            cases.extend(moments(a.start, a.end).map(|t| (Some(a.index), t)));
        }
        // Every animation at once, or the static pose of a file without any (MorphPrimitivesTest).
        let end = animations.iter().map(|a| a.end).fold(0.0f32, f32::max);
        cases.push((None, 0.5 * end));
        for (which, t) in cases {
            let moment = match which {
                Some(i) => Moment {
                    animations: Animations::One(i.to_string()),
                    time: t,
                },
                None if animations.is_empty() => Moment::rest(),
                None => Moment {
                    animations: Animations::All,
                    time: t,
                },
            };
            let what = format!("{name} {:?} at {t} s", moment.animations);
            let scene = file.scene(&moment, &options).unwrap();
            assert_eq!(scene.dropped_degenerate, 0, "{what}");
            let got: Vec<Vec3> = scene.triangles.iter().flat_map(|t| t.p).collect();
            let want = expected(path, which, t);
            assert_eq!(got.len(), want.len(), "{what}: corners");
            // f32 rounding along joint chains and weighted sums: relative to the scene's size.
            let scale = want
                .iter()
                .fold(1.0f32, |m, v| m.max(v.abs().max_element()));
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(
                    (*g - *w).abs().max_element() <= 1e-4 * scale,
                    "{what}: corner {k}: {g} vs {w}"
                );
            }
            checked += 1;
        }
    }
    println!("{checked} moments of {} files checked", models.len());
}

#[test]
fn interpolation_test_lists_its_nine_animations() {
    let Some(dir) = crate::common::gltf_samples() else {
        return;
    };
    let file = SceneFile::open(
        &dir.join("animation/InterpolationTest.glb"),
        &LoadOptions::default(),
    )
    .unwrap();
    let names: Vec<String> = file
        .animations()
        .iter()
        .map(|a| a.name.clone().unwrap())
        .collect();
    for mode in ["Step", "Linear", "CubicSpline"] {
        for what in ["Scale", "Rotation", "Translation"] {
            assert!(names.contains(&format!("{mode} {what}")), "{names:?}");
        }
    }
    let e = file
        .scene(
            &Moment {
                animations: Animations::One("Bounce".into()),
                time: 0.0,
            },
            &LoadOptions::default(),
        )
        .unwrap_err();
    let e = format!("{e:#}");
    assert!(
        e.contains("--animation Bounce") && e.contains("\"Step Scale\""),
        "{e}"
    );
}

#[test]
fn every_animated_sample_renders_alike_on_gpu_and_cpu() {
    let Some(models) = models() else { return };
    let mut cases = Vec::new();
    for path in &models {
        let file = SceneFile::open(path, &LoadOptions::default()).unwrap();
        for a in file.animations() {
            cases.push((path.clone(), a.index, 0.5 * (a.start + a.end)));
        }
    }
    let alpha = sidak(0.01, cases.len());
    for (path, index, t) in &cases {
        let options = LoadOptions::default();
        let file = SceneFile::open(path, &options).unwrap();
        let moment = Moment {
            animations: Animations::One(index.to_string()),
            time: *t,
        };
        let scene = file.scene(&moment, &options).unwrap();
        let what = format!(
            "{} animations[{index}] at {t} s",
            path.file_name().unwrap().to_string_lossy()
        );
        if !small_render_agrees(&PreparedScene::new(&scene), alpha, &what) {
            return;
        }
    }
}

/// A triangle on a node that one animation moves, its keyframe times and values given as
/// floats in a `data:` buffer; `edit` changes the document before it is loaded.
fn animated_triangle(
    times: &[f32],
    values: &[[f32; 3]],
    edit: &dyn Fn(&mut serde_json::Value),
) -> anyhow::Result<wavetrace::scene::Scene> {
    use base64::Engine;
    let mut bytes: Vec<u8> = Vec::new();
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        bytes.extend(p.iter().flat_map(|v| v.to_le_bytes()));
    }
    let t_offset = bytes.len();
    bytes.extend(times.iter().flat_map(|v| v.to_le_bytes()));
    let v_offset = bytes.len();
    bytes.extend(values.iter().flatten().flat_map(|v| v.to_le_bytes()));
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    );
    let mut doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "translation": [0, 0, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "buffers": [{"uri": uri, "byteLength": bytes.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": t_offset, "byteLength": 4 * times.len()},
            {"buffer": 0, "byteOffset": v_offset, "byteLength": 12 * values.len()}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": times.len(), "type": "SCALAR",
             "min": [times[0]], "max": [times[times.len() - 1]]},
            {"bufferView": 2, "componentType": 5126, "count": values.len(), "type": "VEC3"}
        ],
        "animations": [{
            "name": "Slide",
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
            "samplers": [{"input": 1, "output": 2, "interpolation": "LINEAR"}]
        }]
    });
    edit(&mut doc);
    let options = LoadOptions::default();
    let bytes = serde_json::to_vec(&doc).unwrap();
    let file = SceneFile::from_bytes(Path::new("animated-triangle.gltf"), bytes, &options)?;
    file.scene(
        &Moment {
            animations: Animations::All,
            time: 0.5,
        },
        &options,
    )
}

#[test]
fn a_linear_translation_moves_the_triangle_halfway() {
    let scene = animated_triangle(&[0.0, 1.0], &[[0.0; 3], [2.0, 4.0, 6.0]], &|_| {}).unwrap();
    assert_eq!(scene.triangles[0].p[0], Vec3::new(1.0, 2.0, 3.0));
}

#[test]
fn bad_animations_are_refused_by_json_path() {
    let err = |times: &[f32], values: &[[f32; 3]], edit: &dyn Fn(&mut serde_json::Value)| {
        format!("{:#}", animated_triangle(times, values, edit).unwrap_err())
    };
    let two = [[0.0f32; 3], [1.0; 3]];
    let e = err(&[0.0, 0.0], &two, &|_| {});
    assert!(
        e.contains("animations[0].channels[0]") && e.contains("keyframe times must increase"),
        "{e}"
    );
    let e = err(&[0.0, 1.0], &two, &|d| {
        d["animations"][0]["samplers"][0]["interpolation"] = "CUBICSPLINE".into()
    });
    assert!(
        e.contains("animations[0].channels[0]")
            && e.contains("sampler 0: output = accessors[2]")
            && e.contains("2 elements, but 2 keyframes of CubicSpline interpolation need 6"),
        "{e}"
    );
    let e = err(
        &[0.0, 1.0],
        &two,
        &|d| {
            d["nodes"][0] =
                serde_json::json!({"mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]})
        },
    );
    assert!(e.contains("target.node: nodes[0] has a matrix"), "{e}");
    let e = err(&[0.0, 1.0], &two, &|d| {
        d["animations"][0]["channels"][0]["target"]["path"] = "weights".into()
    });
    assert!(e.contains("has no mesh with morph targets"), "{e}");
    let e = err(&[0.0, f32::NAN], &two, &|d| {
        d["accessors"][1]["max"] = serde_json::json!([1.0])
    });
    assert!(e.contains("keyframe 1's time is NaN"), "{e}");
    // A file without animations asked for a moment of one.
    let e = err(&[0.0, 1.0], &two, &|d| {
        d.as_object_mut().unwrap().remove("animations");
    });
    assert!(e.contains("the file has no animations"), "{e}");
}

/// A camera and a spot light on children of a node that an animation moves: both follow it.
#[test]
fn cameras_and_lights_move_with_their_nodes() {
    let scene = animated_triangle(&[0.0, 2.0], &[[0.0; 3], [4.0, 0.0, -2.0]], &|d| {
        d["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
        d["extensions"] = serde_json::json!({"KHR_lights_punctual": {"lights": [
            {"type": "spot", "intensity": 10, "spot": {"outerConeAngle": 0.5}}
        ]}});
        d["cameras"] = serde_json::json!([{"type": "perspective",
            "perspective": {"yfov": 0.8, "znear": 0.1}}]);
        d["nodes"] = serde_json::json!([
            {"mesh": 0},
            {"translation": [1, 2, 3], "children": [2, 3]},
            {"camera": 0, "translation": [0, 0, 5]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 1, 0]}
        ]);
        d["scenes"][0]["nodes"] = serde_json::json!([0, 1]);
        d["animations"][0]["channels"][0]["target"]["node"] = serde_json::json!(1);
    })
    .unwrap();
    // At 0.5 s the keyframes give node 1 the translation (1, 0, −0.5), replacing its own.
    let moved = Vec3::new(1.0, 0.0, -0.5);
    let camera = scene.camera.position;
    assert!(
        (camera - (moved + Vec3::Z * 5.0)).length() < 1e-6,
        "{camera}"
    );
    let light = Vec3::from(scene.punctual[0].position);
    assert!((light - (moved + Vec3::Y)).length() < 1e-6, "{light}");
}
