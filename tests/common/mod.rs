//! Shared by the scene-level tests: the committed scenes, one GPU renderer per test binary
//! (lavapipe in CI) with the validation layer on when installed.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};
use wavetrace::film::Film;
use wavetrace::gpu::compute::TestKernels;
use wavetrace::gpu::{DeviceInfo, GpuOptions, GpuRenderer};
use wavetrace::render::{PreparedScene, RenderOutput, RenderSettings};
use wavetrace::scene::Scene;
use wavetrace::stats::compare_films;

pub fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// `../shared/gltf-samples/valid` (the third-party sample models, never copied here), or `None`
/// with a notice where it is absent (a user's clone): the tests that read it skip.
pub fn gltf_samples() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples/valid");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping: ../shared/gltf-samples/valid not found");
        None
    }
}

/// The files in `dir` whose extension is one of `extensions`, sorted by path.
pub fn files_with_extension(dir: &Path, extensions: &[&str]) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| extensions.contains(&e))
        })
        .collect();
    files.sort();
    files
}

pub fn prepared(name: &str) -> PreparedScene {
    let scene = Scene::load(&scene_path(name)).unwrap_or_else(|e| panic!("loading {name}: {e:#}"));
    PreparedScene::new(&scene)
}

/// The test binary's GPU renderer. A machine without a Vulkan device fails the GPU tests (CI
/// installs lavapipe), unless WAVETRACE_SKIP_GPU=1 says to skip them; then this returns None.
pub fn gpu() -> Option<MutexGuard<'static, GpuRenderer>> {
    static GPU: OnceLock<Option<Mutex<GpuRenderer>>> = OnceLock::new();
    one_device(&GPU, "GPU tests", || {
        let r = GpuRenderer::new(&GpuOptions {
            device_index: None,
            validation: true,
            timing: false,
            count_fetches: false,
        })
        .unwrap_or_else(|e| panic!("no GPU renderer: {e:#}"));
        let (device, validating) = (r.device().clone(), r.validating());
        (r, device, validating)
    })
}

/// The test binary's device for the GLSL-twin kernels: a Vulkan context without the renderer's
/// pipelines, so that a device whose limits cannot hold the renderer (SwiftShader, which
/// `.ci/run` also runs the twin tests on) still checks its arithmetic. Skips as [`gpu`] does.
pub fn test_kernels() -> Option<MutexGuard<'static, TestKernels>> {
    static KERNELS: OnceLock<Option<Mutex<TestKernels>>> = OnceLock::new();
    one_device(&KERNELS, "GPU twin kernels", || {
        let k = TestKernels::new(None, true).unwrap_or_else(|e| panic!("no Vulkan device: {e:#}"));
        // WAVETRACE_TWINS_DEVICE=NAME: the run is meant for that device (`.ci/run` names
        // SwiftShader), so another one is an error rather than a second run on the first.
        if let Ok(want) = std::env::var("WAVETRACE_TWINS_DEVICE") {
            assert!(
                k.device().name.contains(&want),
                "WAVETRACE_TWINS_DEVICE={want}, but the Vulkan device is {}",
                k.device().name
            );
        }
        let (device, validating) = (k.device().clone(), k.validating());
        (k, device, validating)
    })
}

/// Whether WAVETRACE_SKIP_GPU=1 says to skip the GPU tests (said on stderr when it does): for
/// tests that run the binary on the GPU rather than through [`gpu`].
pub fn skip_gpu() -> bool {
    let skip = std::env::var("WAVETRACE_SKIP_GPU").is_ok_and(|v| v == "1");
    if skip {
        eprintln!("skipping GPU tests: WAVETRACE_SKIP_GPU=1");
    }
    skip
}

/// The one `T` of a test binary, made by `open` on first use and named on stderr with its
/// device, or none where WAVETRACE_SKIP_GPU=1.
fn one_device<T>(
    cell: &'static OnceLock<Option<Mutex<T>>>,
    what: &str,
    open: impl FnOnce() -> (T, DeviceInfo, bool),
) -> Option<MutexGuard<'static, T>> {
    let made = cell.get_or_init(|| {
        if skip_gpu() {
            return None;
        }
        let (t, device, validating) = open();
        let layer = if validating { "on" } else { "not installed" };
        eprintln!(
            "{what} on {} ({}), validation layer {layer}",
            device.name, device.driver
        );
        Some(Mutex::new(t))
    });
    made.as_ref()
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

/// A model rendered small (40 × 32 pixels, 64 spp, depth 4, under a white sky) on the CPU and
/// on the GPU, neither dropping a sample, agreeing per tile at family-wise level `alpha`;
/// false where there is no GPU (after the CPU render).
pub fn small_render_agrees(scene: &PreparedScene, alpha: f64, what: &str) -> bool {
    let settings = |seed| RenderSettings {
        width: 40,
        height: 32,
        spp: 64,
        max_depth: 4,
        seed,
        environment: glam::Vec3::ONE,
        ..RenderSettings::default()
    };
    let cpu = render_cpu(scene, &settings(2));
    assert_eq!(cpu.film.dropped, 0, "{what}: CPU dropped NaN/Inf samples");
    let Some(gpu) = render_gpu(scene, &settings(1), None) else {
        return false;
    };
    assert_eq!(gpu.film.dropped, 0, "{what}: GPU dropped NaN/Inf samples");
    assert_agree_at(&gpu.film, &cpu.film, alpha, what);
    true
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

/// The film (exact sums), the mean and variance layers and the record of an EXR written by
/// wavetrace.
pub struct ExrFile {
    pub film: Film,
    pub image: wavetrace::image_io::ImageData,
    pub record: wavetrace::shard::Record,
}

pub fn read_exr_file(path: &Path) -> ExrFile {
    let (film, attributes) = wavetrace::image_io::read_film_exact(path)
        .unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
    let image = wavetrace::image_io::read_exr(path).unwrap();
    let record = wavetrace::shard::Record::from_attributes(path, &attributes)
        .unwrap()
        .unwrap_or_else(|| panic!("{}: no wavetrace.* attributes", path.display()));
    ExrFile {
        film,
        image,
        record,
    }
}

/// Checks that two EXRs hold the same samples of the same render, summed in different orders:
/// equal settings, ranges and counts, and sums, means and variances within what f32
/// summation order allows. For n non-negative terms every order of recursive summation is
/// within (n−1)·u·Σx of the exact sum (Higham, Accuracy and Stability of Numerical Algorithms,
/// 2nd ed., eq. 4.4; u = 2⁻²⁴), so two orders differ by at most 2(n−1)·u·Σx; the mean and
/// variance layers add their own rounding to f32 (u each) to what the sums' difference
/// propagates through mean = s/n and variance of the mean = (q − s²/n)/(n(n−1)).
/// Radiance is non-negative, so the bound holds for the sums and sums of squares alike.
pub fn assert_same_samples(a: &Path, b: &Path) {
    let (fa, fb) = (read_exr_file(a), read_exr_file(b));
    let what = format!("{} vs {}", a.display(), b.display());
    assert_eq!(fa.record.settings, fb.record.settings, "{what}: settings");
    assert_eq!(
        fa.record.samples, fb.record.samples,
        "{what}: sample ranges"
    );
    assert_eq!(fa.record.dropped, 0, "{what}: dropped samples");
    assert_eq!(fb.record.dropped, 0, "{what}: dropped samples");
    let u = 2f64.powi(-24);
    let (va, vb) = (fa.image.variance.unwrap(), fb.image.variance.unwrap());
    let mut largest_relative = 0f64;
    for (i, (p, q)) in fa.film.pixels.iter().zip(&fb.film.pixels).enumerate() {
        assert_eq!(p.count, q.count, "{what}: pixel {i} count");
        let n = p.count as f64;
        let gamma = 2.0 * (n - 1.0).max(0.0) * u;
        for c in 0..3 {
            let (s1, s2) = (p.sum[c] as f64, q.sum[c] as f64);
            let (q1, q2) = (p.sum_sq[c] as f64, q.sum_sq[c] as f64);
            let ds = gamma * s1.max(s2);
            let dq = gamma * q1.max(q2);
            assert!(
                s1 >= 0.0 && s2 >= 0.0,
                "{what}: pixel {i}: negative radiance sum"
            );
            assert!(
                (s1 - s2).abs() <= ds,
                "{what}: pixel {i} channel {c}: sums {s1} vs {s2} (bound {ds})"
            );
            assert!(
                (q1 - q2).abs() <= dq,
                "{what}: pixel {i} channel {c}: sums of squares {q1} vs {q2} (bound {dq})"
            );
            if s1.max(s2) > 0.0 {
                largest_relative = largest_relative.max((s1 - s2).abs() / s1.max(s2));
            }
            if n == 0.0 {
                continue;
            }
            let (m1, m2) = (fa.image.mean[i][c] as f64, fb.image.mean[i][c] as f64);
            let dm = ds / n + u * (m1.abs() + m2.abs());
            assert!(
                (m1 - m2).abs() <= dm,
                "{what}: pixel {i} channel {c}: means {m1} vs {m2} (bound {dm})"
            );
            if n >= 2.0 {
                let (v1, v2) = (va[i][c] as f64, vb[i][c] as f64);
                let s = s1.max(s2);
                let dv = (dq + (2.0 * s * ds + ds * ds) / n) / (n * (n - 1.0)) + u * (v1 + v2);
                assert!(
                    (v1 - v2).abs() <= dv,
                    "{what}: pixel {i} channel {c}: variances {v1} vs {v2} (bound {dv})"
                );
            }
        }
    }
    println!("{what}: same samples; largest relative difference of a sum {largest_relative:.3e}");
}

/// Checks that two EXRs are the same bits: accumulators, layers and record.
/// Fails naming the first pixel whose accumulators differ in a bit.
pub fn assert_same_bits(a: &Film, b: &Film, what: &str) {
    assert_eq!(a.pixels.len(), b.pixels.len(), "{what}: sizes");
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        assert_eq!(
            bytemuck::bytes_of(p),
            bytemuck::bytes_of(q),
            "{what}: pixel {i} differs"
        );
    }
}

pub fn assert_bitwise_equal(a: &Path, b: &Path) {
    let (fa, fb) = (read_exr_file(a), read_exr_file(b));
    let what = format!("{} vs {}", a.display(), b.display());
    assert_eq!(fa.record.settings, fb.record.settings, "{what}: settings");
    assert_eq!(fa.record.samples, fb.record.samples, "{what}: ranges");
    let bits = |f: &Film| -> Vec<u32> {
        f.pixels
            .iter()
            .flat_map(|p| {
                p.sum
                    .iter()
                    .chain(&p.sum_sq)
                    .map(|v| v.to_bits())
                    .chain([p.count])
                    .collect::<Vec<_>>()
            })
            .collect()
    };
    assert!(
        bits(&fa.film) == bits(&fb.film),
        "{what}: accumulators differ"
    );
    assert!(fa.image == fb.image, "{what}: layers differ");
}

const TILE: u32 = 8;
pub const BATCHES: u32 = 12;

/// Welch tests of two [`batch_tiles`] results, tile by tile and channel by channel, at per-test
/// level `per_test`: each failure as a line naming `name`, the tile, the channel and both
/// means (`ours` first, then `reference`, called `what`) is pushed onto `failures`; returns the
/// smallest p.
pub fn compare_batch_tiles(
    name: &str,
    ours: &[[(f64, f64); 3]],
    reference: &[[(f64, f64); 3]],
    what: &str,
    per_test: f64,
    failures: &mut Vec<String>,
) -> f64 {
    let df = (BATCHES - 1) as f64;
    let mut min_p = 1.0f64;
    for (t, (a, b)) in ours.iter().zip(reference).enumerate() {
        for c in 0..3 {
            let (_, _, p) = wavetrace::stats::welch_t_test(a[c].0, a[c].1, df, b[c].0, b[c].1, df);
            min_p = min_p.min(p);
            if p < per_test {
                failures.push(format!(
                    "{name}: tile {t} channel {c}: {:.5} vs {what} {:.5} (p = {p:.2e})",
                    a[c].0, b[c].0
                ));
            }
        }
    }
    min_p
}

/// Per 8 × 8 tile and channel: the mean over `BATCHES` independent renders (seeds of their own)
/// and the variance of that mean from the spread of the batch means — light tracing and BDPT
/// splat into many pixels, so a per-pixel variance would understate a tile's (as
/// tests/integrators/bidir.rs does with its own).
pub fn batch_tiles(
    settings: &RenderSettings,
    seed: u32,
    render: &dyn Fn(&RenderSettings) -> Option<wavetrace::film::Film>,
) -> Option<Vec<[(f64, f64); 3]>> {
    let (w, h) = (settings.width, settings.height);
    let tx = w.div_ceil(TILE);
    let tiles = (tx * h.div_ceil(TILE)) as usize;
    let mut means = vec![[Vec::new(), Vec::new(), Vec::new()]; tiles];
    for b in 0..BATCHES {
        let film = render(&RenderSettings {
            seed: seed * 1000 + b,
            ..settings.clone()
        })?;
        assert_eq!(film.dropped, 0, "{:?} dropped samples", settings.integrator);
        let mut sum = vec![[0.0f64; 3]; tiles];
        let mut count = vec![0f64; tiles];
        for y in 0..h {
            for x in 0..w {
                let m = film.mean_f64((x + y * w) as usize);
                let t = ((x / TILE) + (y / TILE) * tx) as usize;
                for c in 0..3 {
                    sum[t][c] += m[c];
                }
                count[t] += 1.0;
            }
        }
        for t in 0..tiles {
            for c in 0..3 {
                means[t][c].push(sum[t][c] / count[t]);
            }
        }
    }
    Some(
        means
            .iter()
            .map(|chans| {
                chans.clone().map(|v| {
                    let n = v.len() as f64;
                    let mean = v.iter().sum::<f64>() / n;
                    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
                    (mean, var / n)
                })
            })
            .collect(),
    )
}

/// The disagreements of a twin test (GPU function against its Rust twin): every one counted by
/// what disagreed, the first 20 written out. A device whose arithmetic differs from lavapipe's
/// (fused multiply-adds, its own division and transcendentals) shows in the counts whether a
/// check fails in a borderline case or in many.
#[derive(Default)]
pub struct Disagreements {
    shown: Vec<String>,
    counts: std::collections::BTreeMap<String, usize>,
}

impl Disagreements {
    pub fn add(&mut self, what: &str, message: impl FnOnce() -> String) {
        *self.counts.entry(what.to_string()).or_default() += 1;
        if self.shown.len() < 20 {
            self.shown.push(message());
        }
    }

    /// Panics with the counts and the first disagreements, if there are any, of `cases` cases.
    pub fn assert_none(&self, cases: usize, title: &str) {
        if self.counts.is_empty() {
            return;
        }
        let counts: Vec<String> = self
            .counts
            .iter()
            .map(|(what, n)| format!("  {what}: {n} of {cases} cases"))
            .collect();
        panic!(
            "{title}:\n{}\nthe first {}:\n{}",
            counts.join("\n"),
            self.shown.len(),
            self.shown.join("\n")
        );
    }
}
