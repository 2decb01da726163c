//! Shared by the scene-level tests: the committed scenes, one GPU renderer per test binary
//! (lavapipe in CI) with the validation layer on when installed.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};
use wavetrace::film::Film;
use wavetrace::gpu::{GpuOptions, GpuRenderer};
use wavetrace::render::{PreparedScene, RenderOutput, RenderSettings};
use wavetrace::scene::Scene;
use wavetrace::stats::compare_films;

pub fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

pub fn prepared(name: &str) -> PreparedScene {
    let scene = Scene::load(&scene_path(name)).unwrap_or_else(|e| panic!("loading {name}: {e:#}"));
    PreparedScene::new(&scene)
}

/// The test binary's GPU renderer. A machine without a Vulkan device fails the GPU tests (CI
/// installs lavapipe), unless WAVETRACE_SKIP_GPU=1 says to skip them; then this returns None.
pub fn gpu() -> Option<MutexGuard<'static, GpuRenderer>> {
    static GPU: OnceLock<Option<Mutex<GpuRenderer>>> = OnceLock::new();
    let gpu = GPU.get_or_init(|| {
        if std::env::var("WAVETRACE_SKIP_GPU").is_ok_and(|v| v == "1") {
            eprintln!("skipping GPU tests: WAVETRACE_SKIP_GPU=1");
            return None;
        }
        let r = GpuRenderer::new(&GpuOptions {
            device_index: None,
            validation: true,
            timing: false,
        })
        .unwrap_or_else(|e| panic!("no GPU renderer: {e:#}"));
        eprintln!(
            "GPU tests on {} ({}), validation layer {}",
            r.device().name,
            r.device().driver,
            if r.validating() {
                "on"
            } else {
                "not installed"
            }
        );
        Some(Mutex::new(r))
    });
    gpu.as_ref()
        .map(|m| m.lock().unwrap_or_else(|e| e.into_inner()))
}

pub fn render_gpu(
    scene: &PreparedScene,
    settings: &RenderSettings,
    wavefront: Option<u32>,
) -> Option<RenderOutput> {
    let gpu = gpu()?;
    Some(
        gpu.render(scene, settings, wavefront)
            .unwrap_or_else(|e| panic!("GPU render failed: {e:#}")),
    )
}

/// A GPU render whose film holds at most `band_pixels` pixels at a time.
pub fn render_gpu_banded(
    scene: &PreparedScene,
    settings: &RenderSettings,
    band_pixels: u64,
) -> Option<RenderOutput> {
    let mut gpu = gpu()?;
    gpu.set_band_pixel_limit(Some(band_pixels));
    let out = gpu.render(scene, settings, None);
    gpu.set_band_pixel_limit(None);
    Some(out.unwrap_or_else(|e| panic!("banded GPU render failed: {e:#}")))
}

pub fn render_cpu(scene: &PreparedScene, settings: &RenderSettings) -> RenderOutput {
    wavetrace::cpu::render(scene, settings)
}

/// Renders `gpu_settings` on the GPU and `cpu_settings` on the CPU (their seeds must differ, so
/// the films are independent samples), checks that neither dropped a sample and that they agree;
/// returns the CPU film, or `None` without a GPU.
pub fn gpu_agrees_with_cpu(
    scene: &PreparedScene,
    gpu_settings: &RenderSettings,
    cpu_settings: &RenderSettings,
    what: &str,
) -> Option<Film> {
    assert_ne!(
        gpu_settings.seed, cpu_settings.seed,
        "the two sides need different seeds"
    );
    let gpu = render_gpu(scene, gpu_settings, None)?;
    let cpu = render_cpu(scene, cpu_settings);
    assert_eq!(gpu.film.dropped, 0, "GPU dropped NaN/Inf samples");
    assert_eq!(cpu.film.dropped, 0, "CPU dropped NaN/Inf samples");
    assert_agree(&gpu.film, &cpu.film, what);
    Some(cpu.film)
}

/// Fails with the comparison's report (which tiles, which channels) unless the films agree.
pub fn assert_agree(gpu: &Film, cpu: &Film, what: &str) {
    assert_agree_at(gpu, cpu, 0.01, what);
}

/// [`assert_agree`] at family-wise level `alpha` over the tiles × channels of this comparison
/// (a test making several comparisons passes α Šidák-corrected over them).
pub fn assert_agree_at(gpu: &Film, cpu: &Film, alpha: f64, what: &str) {
    let cmp = compare_films(gpu, cpu, 8, alpha).unwrap();
    println!("{what}: {cmp}");
    assert!(cmp.passed(), "{what}:\n{cmp}");
}

/// Runs the wavetrace binary from the crate root.
pub fn wavetrace(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the wavetrace binary runs")
}

/// A path for `name` in a temporary folder of this test binary (`group` names the binary).
pub fn temp(group: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wavetrace-{group}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}
