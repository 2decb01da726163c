//! The command line as users and scripts meet it: outputs, exit codes and error messages.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn wavetrace(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the wavetrace binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wavetrace-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
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
    if std::env::var("WAVETRACE_SKIP_GPU").is_ok_and(|v| v == "1") {
        return;
    }
    let out = temp("gpu.png");
    let o = wavetrace(&[
        "render",
        "--width",
        "16",
        "--spp",
        "2",
        "--validate",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let png = image::open(&out).unwrap();
    assert_eq!((png.width(), png.height()), (16, 16));
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
fn no_vulkan_driver_gives_advice_and_a_failure() {
    let o = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args([
            "render",
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
