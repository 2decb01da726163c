//! The command line as users and scripts meet it: outputs, exit codes and error messages.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common;

use crate::common::wavetrace;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn temp(name: &str) -> PathBuf {
    common::temp("cli", name)
}

#[test]
fn cpu_render_writes_an_exr_with_variance() {
    let out = temp("cpu.exr");
    let o = wavetrace(&[
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--width",
        "24",
        "--height",
        "16",
        "--spp",
        "4",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("samples/s") && stdout.contains("rays/s") && stdout.contains("dropped"),
        "{stdout}"
    );
    let image = wavetrace::image_io::read_exr(&out).unwrap();
    assert_eq!((image.width, image.height), (24, 16));
    assert!(image.variance.is_some(), "the EXR has no variance layer");
}

#[test]
fn gpu_render_writes_a_png() {
    if common::skip_gpu() {
        return;
    }
    let out = temp("gpu.png");
    let o = wavetrace(&[
        "render",
        "--device",
        "gpu",
        "--width",
        "16",
        "--spp",
        "2",
        "--validate",
        "--stats",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let png = image::open(&out).unwrap();
    assert_eq!((png.width(), png.height()), (16, 16));
    // A fresh process makes every kernel of the path tracer and dispatches each once on a
    // few pixels before its first sample, and says how long that took, which "done in" leaves
    // out; --stats then finds them made.
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("kernels ready in "), "{stdout}");
    assert!(
        stdout.contains("; its pipelines made for an earlier render"),
        "{stdout}"
    );
}

#[test]
fn a_camera_placed_by_hand_sees_another_view() {
    // The Cornell box (its own camera on +Z looking in) from the default view, turned 30° by
    // --orbit, and from a point of our choice: three different images, each lit.
    let render = |name: &str, extra: &[&str]| {
        let out = temp(name);
        let mut args = vec![
            "render",
            "scenes/cornell-box.gltf",
            "--device",
            "cpu",
            "--width",
            "12",
            "--height",
            "12",
            "--spp",
            "2",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = wavetrace(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        wavetrace::image_io::read_exr(&out).unwrap().mean
    };
    let own = render("own-camera.exr", &[]);
    let orbit = render("orbit.exr", &["--orbit", "30,10"]);
    let by_hand = render(
        "from.exr",
        &["--from", "0.5,0.2,3", "--look-at", "0,0,0", "--fov", "50"],
    );
    assert!(own != orbit && own != by_hand && orbit != by_hand);
    for image in [&own, &orbit, &by_hand] {
        assert!(image.iter().any(|p| p.iter().any(|&c| c > 0.0)));
    }
}

#[test]
fn energy_compensation_is_on_unless_turned_off() {
    // cornell-materials' rough copper box: brighter with compensation (the default) than with
    // --energy-compensation off, and `on` is the default's image bit for bit.
    let render = |name: &str, extra: &[&str]| {
        let out = temp(name);
        let mut args = vec![
            "render",
            "scenes/cornell-materials.gltf",
            "--device",
            "cpu",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "4",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = wavetrace(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        wavetrace::image_io::read_exr(&out).unwrap().mean
    };
    let default = render("ec-default.exr", &[]);
    let on = render("ec-on.exr", &["--energy-compensation", "on"]);
    let off = render("ec-off.exr", &["--energy-compensation", "off"]);
    assert_eq!(default, on);
    assert_ne!(on, off);
    let o = wavetrace(&["render", "--energy-compensation", "maybe"]);
    assert!(!o.status.success() && stderr(&o).contains("--energy-compensation"));
}

#[test]
fn bad_input_fails_with_a_message_naming_it() {
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["render", "no/such/scene.gltf"], "no/such/scene.gltf"),
        (vec!["render", "--width", "0"], "--width"),
        (
            vec!["render", "--spp", "4", "--width", "8", "-o", "out.bmp"],
            "out.bmp",
        ),
        (vec!["render", "--environment", "nan"], "--environment"),
        (vec!["render", "--aperture", "-1"], "--aperture"),
        (vec!["render", "--focus-distance", "0"], "--focus-distance"),
        (vec!["render", "--orbit", "0,100"], "--orbit"),
        (vec!["render", "--orbit", "10"], "--orbit"),
        (vec!["render", "--fov", "180"], "--fov"),
        (vec!["render", "--from", "0,0,1"], "--look-at"),
        (
            vec!["render", "--from", "0,0,nan", "--look-at", "0,0,0"],
            "--from",
        ),
        (
            vec![
                "render",
                "--from",
                "1,1,1",
                "--look-at",
                "1,1,1",
                "--device",
                "cpu",
            ],
            "cornell-box.gltf",
        ),
        (
            vec![
                "render",
                "--from",
                "0,3,0",
                "--look-at",
                "0,0,0",
                "--device",
                "cpu",
            ],
            "parallel",
        ),
    ];
    for (args, needle) in cases {
        let o = wavetrace(&args);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(
            stderr(&o).contains(needle),
            "{args:?}: message does not name {needle}: {}",
            stderr(&o)
        );
        assert!(
            !stderr(&o).contains("panicked"),
            "{args:?} panicked: {}",
            stderr(&o)
        );
    }
    let invalid = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/gltf-samples/invalid/mesh__primitive_no_position.gltf");
    if invalid.exists() {
        let o = wavetrace(&["render", invalid.to_str().unwrap(), "--device", "cpu"]);
        assert!(!o.status.success());
        assert!(
            stderr(&o).contains("mesh__primitive_no_position.gltf"),
            "{}",
            stderr(&o)
        );
    } else {
        eprintln!("skipping: ../shared/gltf-samples not found");
    }
}

#[test]
fn unknown_camera_fails_listing_the_cameras() {
    let out = temp("camera.png");
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            "scenes/cornell-box.gltf",
            "--device",
            "cpu",
            "--width",
            "8",
            "--spp",
            "1",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        wavetrace(&args)
    };
    let o = render(&["--camera", "front"]);
    assert!(!o.status.success(), "an unknown --camera rendered");
    let e = stderr(&o);
    assert!(
        e.contains("--camera front")
            && e.contains(r#"cameras[0] ("camera") on nodes[8] ("camera")"#),
        "{e}"
    );
    // By index and by name.
    for which in ["0", "camera"] {
        let o = render(&["--camera", which]);
        assert!(o.status.success(), "--camera {which}: {}", stderr(&o));
    }
    // A thin lens on an orthographic camera is refused.
    let cameras =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples/valid/Cameras.gltf");
    if cameras.exists() {
        let o = wavetrace(&[
            "render",
            cameras.to_str().unwrap(),
            "--device",
            "cpu",
            "--width",
            "8",
            "--spp",
            "1",
            "--camera",
            "1",
            "--aperture",
            "0.1",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(!o.status.success());
        let e = stderr(&o);
        assert!(
            e.contains("--aperture") && e.contains("orthographic"),
            "{e}"
        );
    } else {
        eprintln!("skipping: ../shared/gltf-samples not found");
    }
}

#[test]
fn no_vulkan_driver_gives_advice_and_a_failure() {
    let o = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args([
            "render",
            "--device",
            "gpu",
            "--width",
            "8",
            "--spp",
            "1",
            "-o",
            temp("none.png").to_str().unwrap(),
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("--device cpu") && e.contains("install-vulkan.sh"),
        "{e}"
    );
}

/// The default device, auto, says what it chose: with no Vulkan driver at all, the CPU (and
/// the render succeeds); on a machine whose only Vulkan device is a CPU driver, also the CPU.
#[test]
fn device_auto_says_what_it_chose() {
    let o = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args(["render", "--width", "8", "--spp", "1", "-o"])
        .arg(temp("auto-none.png"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("device auto: cpu"), "{}", stderr(&o));
    let o = wavetrace(&[
        "render",
        "--width",
        "8",
        "--spp",
        "1",
        "-o",
        temp("auto.png").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    let gpus: Vec<_> = wavetrace::gpu::list_devices()
        .unwrap_or_default()
        .into_iter()
        .filter(|d| d.usable && d.kind != "cpu")
        .collect();
    let want = if gpus.is_empty() {
        "device auto: cpu"
    } else {
        "device auto: gpu"
    };
    assert!(e.contains(want), "{e}");
}

#[test]
fn compare_tells_agreeing_renders_from_different_ones() {
    let render = |name: &str, device: &str, seed: &str, depth: &str| {
        let out = temp(name);
        let o = wavetrace(&[
            "render",
            "--device",
            device,
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "64",
            "--seed",
            seed,
            "--max-depth",
            depth,
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        out
    };
    let gpu = common::skip_gpu();
    let a = render("a.exr", if gpu { "cpu" } else { "gpu" }, "1", "6");
    let b = render("b.exr", "cpu", "2", "6");
    let direct = render("direct.exr", "cpu", "3", "1");
    let same = wavetrace(&["compare", a.to_str().unwrap(), b.to_str().unwrap()]);
    assert_eq!(
        same.status.code(),
        Some(0),
        "{}{}",
        String::from_utf8_lossy(&same.stdout),
        stderr(&same)
    );
    let differ = wavetrace(&["compare", a.to_str().unwrap(), direct.to_str().unwrap()]);
    assert_eq!(
        differ.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&differ.stdout)
    );
    assert!(
        String::from_utf8_lossy(&differ.stdout).contains("tile"),
        "the report names no tile"
    );
    // Both outcomes also report the error against the second film (tools/gallery reads it).
    for o in [&same, &differ] {
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            out.contains("relative MSE = ") && out.contains("; MSE = "),
            "{out}"
        );
    }
    let png = temp("x.png");
    std::fs::write(&png, b"not an exr").unwrap();
    let error = wavetrace(&["compare", a.to_str().unwrap(), png.to_str().unwrap()]);
    assert_eq!(error.status.code(), Some(2));
    assert!(stderr(&error).contains("x.png"), "{}", stderr(&error));
}

/// A bench of the smallest committed scene at a size that takes milliseconds.
const TINY_LEAF_BENCH: [&str; 7] = [
    "scenes/leaf.gltf",
    "--width",
    "16",
    "--height",
    "16",
    "--spp",
    "2",
];

/// The standard output of `wavetrace bench` of [`TINY_LEAF_BENCH`] and `args`, run from the
/// repository root; fails the test where it fails.
fn tiny_bench(args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .arg("bench")
        .args(TINY_LEAF_BENCH)
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `bench --cpu-only` opens no Vulkan device (it runs where there is no driver at all) and
/// writes CPU rows only, with the JSON fields a later `--baseline` reads.
#[test]
fn bench_cpu_only_needs_no_vulkan() {
    let json = temp("bench-cpu.json");
    let o = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args(["bench", "--cpu-only"])
        .args(TINY_LEAF_BENCH)
        .arg("--json")
        .arg(&json)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = doc["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 1, "{doc}");
    assert_eq!(rows[0]["device"], "cpu");
    assert!(rows[0]["samples_per_second"].as_f64().unwrap() > 0.0);
    assert_eq!(
        (&rows[0]["sampler"], &rows[0]["light_sampler"]),
        (&"sobol".into(), &"bvh".into())
    );
}

/// `bench` renders each scene once untimed before timing its GPU row (lavapipe compiles a
/// kernel at its first dispatch, and each scene's kernels are its own) and reports how long
/// that took, in the row and its JSON; `--no-warm-up` times the render from its first dispatch
/// and reports none. The CPU rows have no warm-up.
#[test]
fn bench_warms_each_scene_up_before_timing_its_gpu_render() {
    if common::skip_gpu() {
        return;
    }
    for (extra, warmed) in [(None, true), (Some("--no-warm-up"), false)] {
        let json = temp(&format!("bench-warm-up-{warmed}.json"));
        let mut args = vec!["scenes/prism.gltf", "--json", json.to_str().unwrap()];
        args.extend(extra);
        let out = tiny_bench(&args);
        let doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let rows = doc["rows"].as_array().unwrap();
        assert_eq!(rows.len(), 4, "{doc}");
        for row in rows {
            let warm_up = &row["warm_up_ms"];
            if row["device"] == "gpu" && warmed {
                assert!(warm_up.as_f64().is_some_and(|ms| ms > 0.0), "{row}");
            } else {
                assert!(warm_up.is_null(), "{row}");
            }
        }
        assert_eq!(
            out.matches("warm-up before timing").count(),
            if warmed { 2 } else { 0 },
            "{out}"
        );
    }
}

/// `bench --sampler --light-sampler` measures that sampling, records it in its JSON rows, and
/// prints a `--baseline` ratio only against rows sampled alike.
#[test]
fn bench_baseline_ratios_compare_rows_sampled_alike() {
    let json = temp("bench-independent.json");
    let bench = |extra: &[&str]| {
        let mut args = vec![
            "--cpu-only",
            "--sampler",
            "independent",
            "--light-sampler",
            "power",
        ];
        args.extend(extra);
        let out = tiny_bench(&args);
        // The leaf's row: scene, device and five figures, then the ratio where there is one.
        let row = out
            .lines()
            .find(|l| l.starts_with("leaf "))
            .unwrap()
            .to_owned();
        (out, row.split_whitespace().count())
    };
    let (out, _) = bench(&["--json", json.to_str().unwrap()]);
    assert!(
        out.contains("independent sampler, power light sampler"),
        "{out}"
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(doc["rows"][0]["sampler"], "independent", "{doc}");
    assert_eq!(doc["rows"][0]["light_sampler"], "power", "{doc}");
    // The run's processor is recorded beside its figures.
    let cpu = doc["cpu"].as_str().unwrap();
    assert!(
        !cpu.is_empty() && out.contains(&format!("cpu = {cpu}, ")),
        "{doc}\n{out}"
    );
    let (same_machine, alike) = bench(&["--baseline", json.to_str().unwrap()]);
    assert_eq!(alike, 7);
    assert!(
        !same_machine.contains("note: the baseline's machine"),
        "{same_machine}"
    );
    // The committed baseline was sampled with the defaults: no ratio; and it does not name its
    // processor, which the run says.
    let (other_machine, unlike) = bench(&["--baseline", "tools/bench-baseline.json"]);
    assert_eq!(unlike, 6);
    assert!(
        other_machine.contains(
            "note: the baseline's machine may not be this one (it does not name its processor"
        ),
        "{other_machine}"
    );
    // A baseline from another processor is said to be one.
    let mut moved = doc.clone();
    moved["cpu"] = "another processor".into();
    let moved_json = temp("bench-moved.json");
    std::fs::write(&moved_json, moved.to_string()).unwrap();
    let (moved_out, moved_cols) = bench(&["--baseline", moved_json.to_str().unwrap()]);
    assert_eq!(moved_cols, 7);
    assert!(
        moved_out.contains(&format!(
            "its processor was another processor, this one is {cpu}"
        )),
        "{moved_out}"
    );
}

/// `bench --bvh` measures the three walks on the same seeded rays and writes them to JSON: the
/// quantised nodes' boxes contain the full-precision ones, so on average a ray tests at least
/// as many of them, and, the quantisation being tight, not many more (the figures are the same
/// on every run of a build: the rays are seeded and the walks deterministic). With a GPU, the
/// row also has the render's own walks on those rays — the GPU's `extend` and the CPU
/// reference's — whose hits agree (on llvmpipe, every one bit for bit).
#[test]
fn bench_bvh_reports_the_quantised_walk() {
    let json = temp("bench-bvh.json");
    let o = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args([
            "bench",
            "--bvh",
            "scenes/cornell-box.gltf",
            "--builds",
            "1",
            "--json",
        ])
        .arg(&json)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let row = &doc["rows"][0];
    let field = |k: &str| row[k].as_f64().unwrap_or_else(|| panic!("{k} in {row}"));
    let (wide, quant) = (
        field("wide_boxes_per_ray"),
        field("quantized_boxes_per_ray"),
    );
    assert!(wide > 1.0 && quant >= wide && quant <= 1.1 * wide, "{row}");
    assert!(field("quantized_rays_per_second") > 0.0, "{row}");
    if common::skip_gpu() {
        return;
    }
    let gpu = doc["gpu"].as_str().unwrap_or_default();
    assert!(field("gpu_rays_per_second") > 0.0, "{row}");
    assert!(field("cpu_reference_rays_per_second") > 0.0, "{row}");
    let rays = doc["rays"].as_f64().unwrap();
    assert!(field("gpu_any_rays_per_second") > 0.0, "{row}");
    assert!(
        field("any_blocked") > 0.0 && field("any_blocked") < rays,
        "{row}"
    );
    if gpu.contains("llvmpipe") {
        assert_eq!(field("gpu_hits_same"), rays, "{row}");
        assert_eq!(field("gpu_any_same"), rays, "{row}");
    } else {
        // A GPU that fuses a multiply and an add may send a ray through an edge to the
        // neighbouring triangle (tests/integrators/gpu_vs_cpu.rs, the_gpu_walk_finds_the_cpu_references_hits).
        assert!(field("gpu_hits_other_triangle") * 1000.0 <= rays, "{row}");
        assert!(field("gpu_any_other") * 1000.0 <= rays, "{row}");
    }
}

/// Runs `python3 ARGS` in the repository; `None` (with a notice) where python3 is not installed.
fn python(args: &[&str]) -> Option<std::process::Output> {
    let o = Command::new("python3")
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output();
    if o.is_err() {
        eprintln!("skipping: python3 is not installed");
    }
    o.ok()
}

/// `tools/issue_targets.py` runs two builds' benches and BVH builds in rounds of alternating order
/// and tables each figure and ratio with its range (skipped without python3).
#[test]
fn issue_targets_tables_a_build_against_itself() {
    let bin = env!("CARGO_BIN_EXE_wavetrace");
    let mut args = vec![
        "tools/issue_targets.py",
        bin,
        bin,
        "--rounds",
        "2",
        "--no-mitsuba",
    ];
    args.extend(["--terrain", "scenes/leaf.gltf", "--cpu-only"]);
    args.extend(TINY_LEAF_BENCH);
    let Some(o) = python(&args) else { return };
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for row in [
        "| cpu M samples/s, earlier | ",
        "| cpu later / earlier | ",
        "| BVH build earlier / later | ",
    ] {
        let found = out.lines().filter(|l| l.starts_with(row)).count();
        assert_eq!(found, 1, "{out}");
    }
    assert!(!out.contains("| gpu"), "{out}");
}

/// `tools/ab_bench.py` runs two builds' benches in pairs of alternating order and tables the
/// pair ratios; a build against itself gives one CPU row per scene (skipped without python3).
#[test]
fn ab_bench_tables_a_build_against_itself() {
    let bin = env!("CARGO_BIN_EXE_wavetrace");
    let mut args = vec!["tools/ab_bench.py", bin, bin, "--pairs", "2", "--cpu-only"];
    args.extend(TINY_LEAF_BENCH);
    let Some(o) = python(&args) else { return };
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("2 pairs in ABBA order"), "{out}");
    let rows: Vec<&str> = out.lines().filter(|l| l.starts_with("| leaf |")).collect();
    assert_eq!(rows.len(), 1, "{out}");
    assert!(rows[0].starts_with("| leaf | cpu | "), "{out}");
    // A scene that does not load is the bench's error, passed on with a non-zero exit.
    let missing = ["tools/ab_bench.py", bin, bin, "--pairs", "1", "--cpu-only"];
    let o = python(&[&missing[..], &["scenes/no-such-scene.gltf"]].concat()).unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no-such-scene.gltf"), "{}", stderr(&o));
}

/// This machine's Mesa RADV ICD file (AMD's Vulkan driver), where installed.
fn radv_icd() -> Option<PathBuf> {
    ["/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d"]
        .iter()
        .filter_map(|dir| std::fs::read_dir(dir).ok())
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("radeon_icd") && n.ends_with(".json"))
        })
}

/// `wavetrace ARGS` from the repository root on Mesa RADV's null device (`RADV_FORCE_FAMILY=navi31`
/// with the RADV ICD file `icd`).
fn on_radv_null_device(icd: &Path, args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("VK_DRIVER_FILES", icd)
        .env("VK_ICD_FILENAMES", icd)
        .env("RADV_FORCE_FAMILY", "navi31")
        .output()
        .unwrap()
}

/// `bench --kernels` makes every committed scene's kernels on a real GPU compiler without
/// rendering: on Mesa RADV's null device (`RADV_FORCE_FAMILY=navi31`: AMD's compiler, ACO, with
/// no AMD GPU; it cannot run work, so the command must submit none) every kernel of the path
/// tracer and of BDPT comes back with its registers, and none spills vector registers or uses
/// scratch memory, which on a GPU is per-lane memory traffic on every access: a change that
/// makes a kernel spill fails here, on any machine. A render there ends in one clear error.
/// `.ci/run` sets WAVETRACE_NEED_RADV=1, so CI cannot skip it; elsewhere a Mesa without RADV
/// skips it with a notice.
#[test]
fn bench_kernels_reports_a_gpu_compilers_registers_without_rendering() {
    if common::skip_gpu() {
        return;
    }
    let Some(icd) = radv_icd() else {
        assert!(
            std::env::var("WAVETRACE_NEED_RADV").is_err(),
            "Mesa's RADV is required (WAVETRACE_NEED_RADV) but no radeon_icd*.json is installed"
        );
        eprintln!("skipping: no Mesa RADV ICD (radeon_icd*.json) installed");
        return;
    };
    let scenes = common::files_with_extension(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"),
        &["gltf"],
    );
    assert!(scenes.len() >= 9, "{scenes:?}");
    for integrator in [
        wavetrace::render::Integrator::Path,
        wavetrace::render::Integrator::Bdpt,
    ] {
        let name = format!("{integrator:?}").to_lowercase();
        let json = temp(&format!("kernels-{name}.json"));
        // bench --kernels --integrator NAME OPTION FILE SCENES…
        let bench = |option: &str, file: &Path| {
            let words = ["bench", "--kernels", "--integrator", name.as_str(), option];
            let mut args: Vec<&std::ffi::OsStr> = words.iter().map(std::ffi::OsStr::new).collect();
            args.push(file.as_os_str());
            args.extend(scenes.iter().map(|p| p.as_os_str()));
            let o = on_radv_null_device(&icd, &args);
            assert!(o.status.success(), "{}", stderr(&o));
            String::from_utf8_lossy(&o.stdout).into_owned()
        };
        bench("--json", &json);
        let doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert!(
            doc["gpu"].as_str().unwrap().contains("RADV"),
            "{}",
            doc["gpu"]
        );
        let rows = doc["rows"].as_array().unwrap();
        assert_eq!(rows.len(), scenes.len(), "{doc}");
        for row in rows {
            let statistics = row["kernel_statistics"].as_object().unwrap();
            let kernels: Vec<&str> = statistics.keys().map(String::as_str).collect();
            let mut expected = wavetrace::gpu::wavefront::kernels(integrator).to_vec();
            expected.sort_unstable();
            let mut kernels_sorted = kernels.clone();
            kernels_sorted.sort_unstable();
            assert_eq!(kernels_sorted, expected, "{}", row["scene"]);
            for (kernel, s) in statistics {
                let at = format!("{} {name} {kernel}: {s}", row["scene"]);
                assert!(s["VGPRs"].as_u64().is_some_and(|v| v > 0), "{at}");
                assert_eq!(s["Spilled VGPRs"].as_u64(), Some(0), "{at}");
                assert_eq!(s["Scratch size"].as_u64(), Some(0), "{at}");
            }
        }
        // The same kernels made again compare as the same against that run (`--baseline`).
        let stdout = bench("--baseline", &json);
        let kernels = wavetrace::gpu::wavefront::kernels(integrator).len();
        assert_eq!(
            stdout.matches("against the baseline: the same").count(),
            kernels * scenes.len(),
            "{stdout}"
        );
    }
    // Rendering there is refused with one error naming the device, not a crash: the device
    // cannot even make a fence, and the context it opened is closed without waiting on a queue
    // that never ran anything (which the null device does not survive).
    let out = temp("null-device.png");
    let render = "render scenes/cornell-box.gltf --device gpu --width 8 --height 8 --spp 1 -o";
    let mut args: Vec<&std::ffi::OsStr> = render.split(' ').map(std::ffi::OsStr::new).collect();
    args.push(out.as_os_str());
    let o = on_radv_null_device(&icd, &args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("RADV") && stderr(&o).contains("cannot render"),
        "{}",
        stderr(&o)
    );
}
