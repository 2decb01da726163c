//! Sequences (issue 58, item 4; src/cmd/sequence.rs): the frames of `--frames A..B --fps F`
//! equal the same `--time` rendered alone bit for bit (on the CPU and on the GPU), `--shard
//! I/N` splits the frames so that each is rendered once, and the options that ask for a moment
//! are checked by name.

use crate::common::{self, assert_bitwise_equal, wavetrace};
use std::path::PathBuf;

fn box_animated() -> Option<PathBuf> {
    Some(common::gltf_samples()?.join("animation/BoxAnimated.glb"))
}

fn run(args: &[&str]) -> String {
    let o = wavetrace(args);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "wavetrace {args:?}:\n{text}");
    text
}

fn small<'a>(device: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "--device", device, "--width", "24", "--height", "16", "--spp", "4",
    ];
    v.extend_from_slice(extra);
    v
}

/// Renders `frames` of `scene` at `fps` as a sequence on `device`, then each `(frame, time)` of
/// `cases` alone with `--time`, and checks each pair bit for bit; returns what the sequence
/// printed.
fn assert_frames_equal_moments(
    scene: &str,
    device: &str,
    tag: &str,
    frames: &str,
    fps: &str,
    cases: &[(u32, &str)],
) -> String {
    let pattern = common::temp("cli", &format!("{tag}-##.exr"));
    let text = run(&[
        vec!["render", scene, "--frames", frames, "--fps", fps, "-o"],
        vec![pattern.to_str().unwrap()],
        small(device, &[]),
    ]
    .concat());
    for &(frame, time) in cases {
        let alone = common::temp("cli", &format!("{tag}-t{time}.exr"));
        let out = alone.to_str().unwrap();
        run(&[
            vec!["render", scene, "--time", time, "-o", out],
            small(device, &[]),
        ]
        .concat());
        let framed = common::temp("cli", &format!("{tag}-{frame:02}.exr"));
        assert_bitwise_equal(&framed, &alone);
    }
    text
}

#[test]
fn frames_equal_their_moment_rendered_alone_bit_for_bit() {
    let Some(scene) = box_animated() else { return };
    let scene = scene.to_str().unwrap();
    for device in ["cpu", "gpu"] {
        if device == "gpu" && common::skip_gpu() {
            continue;
        }
        let tag = format!("box-{device}");
        let cases = [(3, "0.75"), (4, "1"), (5, "1.25")];
        let text = assert_frames_equal_moments(scene, device, &tag, "3..5", "4", &cases);
        assert!(text.contains("frame 4 (t = 1 s)"), "{text}");
        // A moment differs from the static pose (the box moves).
        let rest = common::temp("cli", &format!("box-{device}-rest.exr"));
        run(&[
            vec!["render", scene, "-o", rest.to_str().unwrap()],
            small(device, &[]),
        ]
        .concat());
        let a = common::read_exr_file(&rest);
        let b = common::read_exr_file(&common::temp("cli", &format!("box-{device}-04.exr")));
        assert_ne!(a.record.settings, b.record.settings);
        assert!(
            a.film
                .pixels
                .iter()
                .zip(&b.film.pixels)
                .any(|(p, q)| p.sum != q.sum),
            "{device}: the moment at 1 s looks like the static pose"
        );
    }
}

/// On the GPU a sequence whose trees deepen from frame to frame makes its kernels again with the
/// longest deferred arrays (`Pipelines::reusable`) and keeps them for later frames: those frames
/// are still bit for bit their moments rendered alone with kernels made for their own trees.
#[test]
fn frames_rendered_with_reused_kernels_equal_their_moment_alone() {
    let Some(dir) = common::gltf_samples() else {
        return;
    };
    if common::skip_gpu() {
        return;
    }
    let scene = dir.join("animation/RecursiveSkeletons.glb");
    let scene = scene.to_str().unwrap();
    let cases = [(5, "1.25"), (8, "2")];
    assert_frames_equal_moments(scene, "gpu", "skeletons", "0..8", "4", &cases);
}

#[test]
fn shards_render_each_frame_once() {
    let Some(scene) = box_animated() else { return };
    let scene = scene.to_str().unwrap();
    let dir = common::temp("cli", "shards");
    std::fs::create_dir_all(&dir).unwrap();
    let pattern = dir.join("f_####.png");
    for shard in ["0/3", "1/3", "2/3"] {
        run(&[
            vec![
                "render",
                scene,
                "--frames",
                "10..16",
                "--shard",
                shard,
                "-o",
                pattern.to_str().unwrap(),
            ],
            small("cpu", &[]),
        ]
        .concat());
    }
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let want: Vec<String> = (10..=16).map(|f| format!("f_{f:04}.png")).collect();
    assert_eq!(names, want);
}

#[test]
fn moments_are_checked_by_name() {
    let Some(scene) = box_animated() else { return };
    let scene = scene.to_str().unwrap();
    let fail = |args: &[&str]| {
        let o = wavetrace(args);
        assert!(!o.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let e = fail(
        &[
            vec!["render", scene, "--animation", "Walk"],
            small("cpu", &[]),
        ]
        .concat(),
    );
    assert!(
        e.contains("--animation Walk") && e.contains("its animations are: animations[0], 0 to"),
        "{e}"
    );
    let e = fail(
        &[
            vec!["render", "scenes/cornell-box.gltf", "--time", "1"],
            small("cpu", &[]),
        ]
        .concat(),
    );
    assert!(e.contains("the file has no animations"), "{e}");
    let e = fail(
        &[
            vec!["render", "scenes/cornell-box.gltf", "--frames", "1..3"],
            small("cpu", &[]),
        ]
        .concat(),
    );
    assert!(e.contains("has no animations"), "{e}");
    let e = fail(&[vec!["render", scene, "--frames", "5..2"], small("cpu", &[])].concat());
    assert!(e.contains("the last frame comes before the first"), "{e}");
    let e = fail(
        &[
            vec!["render", scene, "--frames", "1..2", "--time", "1"],
            small("cpu", &[]),
        ]
        .concat(),
    );
    assert!(e.contains("cannot be used with"), "{e}");
}

/// Every frame of a sequence carries the AOV layers and the alpha a single render does: frame
/// 2's layers equal those of `--time` alone, bit for bit.
#[test]
fn frames_carry_their_layers() {
    let Some(scene) = box_animated() else { return };
    let scene = scene.to_str().unwrap();
    let pattern = common::temp("cli", "layered-#.exr");
    let layers = ["--aov", "depth,normal,material", "--transparent"];
    run(&[
        vec!["render", scene, "--frames", "1..2", "--fps", "4", "-o"],
        vec![pattern.to_str().unwrap()],
        small("cpu", &layers),
    ]
    .concat());
    let alone = common::temp("cli", "layered-alone.exr");
    run(&[
        vec![
            "render",
            scene,
            "--time",
            "0.5",
            "-o",
            alone.to_str().unwrap(),
        ],
        small("cpu", &layers),
    ]
    .concat());
    let framed = common::temp("cli", "layered-2.exr");
    assert_bitwise_equal(&framed, &alone);
    let channel = |path: &std::path::Path, name: &str| {
        let image = exr::prelude::read_first_flat_layer_from_file(path).unwrap();
        let found = image
            .layer_data
            .channel_data
            .list
            .iter()
            .find(|c| c.name == *name);
        let samples = found.unwrap_or_else(|| panic!("{} has no {name}", path.display()));
        samples
            .sample_data
            .values_as_f32()
            .map(f32::to_bits)
            .collect::<Vec<_>>()
    };
    for name in ["depth.Z", "normal.X", "material.id", "A"] {
        assert!(
            channel(&framed, name) == channel(&alone, name),
            "frame 2's {name} differs from --time 0.5 alone"
        );
    }
}
