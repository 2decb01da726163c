//! Renders that stop at a target noise level (`--target-error`, `--adaptive`, `--max-spp`,
//! `--time-limit`; `src/render/progressive.rs`) on the Cornell box: the bound is reached on CPU and GPU,
//! passes continue each pixel's sample sequence exactly (a pixel's accumulators are, bit for bit,
//! those of a plain render with its sample count), the decisions and the image are the same on
//! every run and whatever the wavefront size or film band, an adaptive render agrees with a plain
//! one per tile (α = 0.01, Šidák), it spends fewer samples, and the command line reports and
//! refuses as it should.

use crate::common;

use crate::common::{assert_agree_at, gpu, prepared, render_cpu, render_gpu, wavetrace};
use indicatif::ProgressBar;
use wavetrace::cpu::{render_progressive, trace_path, RayCounts};
use wavetrace::film::accumulate;
use wavetrace::film::Film;
use wavetrace::layout::FilmPixel;
use wavetrace::render::progressive::{relative_error, Progressive, ProgressiveReport, StopReason};
use wavetrace::render::{PreparedScene, RenderOutput, RenderSettings};

/// The target relative error of the tests.
const E: f64 = 0.1;

fn settings(seed: u32) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 16,
        spp: 16,
        max_depth: 7,
        seed,
        ..RenderSettings::default()
    }
}

fn options(adaptive: bool) -> Progressive {
    Progressive {
        target_error: Some(E),
        adaptive,
        ..Progressive::default()
    }
}

fn cpu_progressive(
    scene: &PreparedScene,
    s: &RenderSettings,
    p: &Progressive,
) -> (RenderOutput, ProgressiveReport) {
    render_progressive(scene, s, p, &ProgressBar::hidden())
}

/// A GPU render in passes with at most `band_pixels` pixels in the film at a time; None without
/// a GPU.
fn gpu_progressive(
    scene: &PreparedScene,
    s: &RenderSettings,
    p: &Progressive,
    wavefront: Option<u32>,
    band_pixels: Option<u64>,
) -> Option<(RenderOutput, ProgressiveReport)> {
    let mut gpu = gpu()?;
    gpu.set_band_pixel_limit(band_pixels);
    let out = gpu.render_progressive(scene, s, wavefront, p, &ProgressBar::hidden());
    gpu.set_band_pixel_limit(None);
    Some(out.unwrap_or_else(|e| panic!("GPU render in passes failed: {e:#}")))
}

/// Every pixel's relative error below the target at the end.
fn assert_reached(film: &Film, report: &ProgressiveReport, what: &str) {
    println!("{what}: {report}");
    assert_eq!(report.reason, StopReason::TargetReached, "{what}: {report}");
    assert!(report.worst_error < E, "{what}: {report}");
    assert_eq!(report.pixels_above, 0, "{what}: {report}");
    for p in 0..film.len() {
        let e = relative_error(film, p, report.floor);
        assert!(e < E, "{what}: pixel {p} has relative error {e} ≥ {E}");
    }
    assert_eq!(film.dropped, 0, "{what}: dropped NaN/Inf samples");
}

fn assert_same_bits(a: &[FilmPixel], b: &[FilmPixel], what: &str) {
    assert_eq!(a.len(), b.len());
    for (i, (pa, pb)) in a.iter().zip(b).enumerate() {
        assert_eq!(
            bytemuck::bytes_of(pa),
            bytemuck::bytes_of(pb),
            "{what}: pixel {i} differs"
        );
    }
}

/// The report's decisions: passes, reason, samples per pixel and pixels per pass.
fn assert_same_decisions(a: &ProgressiveReport, b: &ProgressiveReport, what: &str) {
    assert_eq!(a.passes, b.passes, "{what}: passes");
    assert_eq!(a.reason, b.reason, "{what}: reason");
    assert_eq!(
        a.pixel_samples, b.pixel_samples,
        "{what}: samples per pixel"
    );
    assert_eq!(
        a.active_per_pass, b.active_per_pass,
        "{what}: pixels per pass"
    );
    assert_eq!(a.floor.to_bits(), b.floor.to_bits(), "{what}: floor");
}

#[test]
fn cpu_reaches_the_target_and_passes_continue_each_pixels_samples() {
    let scene = prepared("cornell-box.gltf");
    let s = settings(1);
    let (plain, plain_report) = cpu_progressive(&scene, &s, &options(false));
    assert_reached(&plain.film, &plain_report, "CPU");
    let n = plain_report.passes * s.spp;
    assert!(plain_report.pixel_samples.iter().all(|&c| c == n));
    // The passes are the samples [0, n) of a plain render.
    let whole = render_cpu(
        &scene,
        &RenderSettings {
            spp: n,
            ..s.clone()
        },
    );
    assert_same_bits(
        &plain.film.pixels,
        &whole.film.pixels,
        "CPU passes vs plain",
    );

    let (adaptive, report) = cpu_progressive(&scene, &s, &options(true));
    assert_reached(&adaptive.film, &report, "CPU --adaptive");
    // Each pixel holds samples [0, its count) in order, whatever pass gave them.
    let frame = scene.frame_params(&s);
    let env = wavetrace::lights::environment::no_environment();
    let mut counts = RayCounts::default();
    for (p, acc) in adaptive.film.pixels.iter().enumerate() {
        let mut expected = FilmPixel::default();
        for sample in 0..report.pixel_samples[p] {
            let l = trace_path(&scene, &frame, env, p as u32, sample, &mut counts);
            accumulate(&mut expected, l);
        }
        assert_eq!(
            bytemuck::bytes_of(acc),
            bytemuck::bytes_of(&expected),
            "pixel {p} ({} samples) differs from its samples traced in order",
            report.pixel_samples[p]
        );
    }
    assert!(report.min_spp() < report.max_spp());
    println!(
        "CPU, E = {E}: {} samples without --adaptive, {} with ({:.2}×)",
        plain_report.total_samples(),
        report.total_samples(),
        plain_report.total_samples() as f64 / report.total_samples() as f64
    );
    assert!(report.total_samples() < plain_report.total_samples());
    assert_eq!(adaptive.stats.samples, report.total_samples());

    let (again, again_report) = cpu_progressive(&scene, &s, &options(true));
    assert_same_decisions(&report, &again_report, "two CPU runs");
    assert_same_bits(&adaptive.film.pixels, &again.film.pixels, "two CPU runs");
}

#[test]
fn gpu_reaches_the_target_and_decides_the_same_whatever_the_wavefront_and_bands() {
    let scene = prepared("cornell-box.gltf");
    let s = settings(2);
    let Some((plain, plain_report)) = gpu_progressive(&scene, &s, &options(false), None, None)
    else {
        return;
    };
    assert_reached(&plain.film, &plain_report, "GPU");
    let n = plain_report.passes * s.spp;
    let whole = render_gpu(
        &scene,
        &RenderSettings {
            spp: n,
            ..s.clone()
        },
        None,
    )
    .unwrap();
    assert_same_bits(
        &plain.film.pixels,
        &whole.film.pixels,
        "GPU passes vs plain",
    );

    let (adaptive, report) = gpu_progressive(&scene, &s, &options(true), None, None).unwrap();
    assert_reached(&adaptive.film, &report, "GPU --adaptive");
    println!(
        "GPU, E = {E}: {} samples without --adaptive, {} with ({:.2}×)",
        plain_report.total_samples(),
        report.total_samples(),
        plain_report.total_samples() as f64 / report.total_samples() as f64
    );
    assert!(report.total_samples() < plain_report.total_samples());
    // Two runs, other wavefront sizes (37 splits passes inside a pixel run) and bands of
    // 3 rows (48 pixels: six bands, the last of one row, each with its share of the list).
    for (wavefront, band, what) in [
        (None, None, "a second GPU run"),
        (Some(1000), None, "--wavefront 1000"),
        (Some(37), None, "--wavefront 37"),
        (None, Some(48), "bands of 3 rows"),
    ] {
        let (other, other_report) =
            gpu_progressive(&scene, &s, &options(true), wavefront, band).unwrap();
        assert_same_decisions(&report, &other_report, what);
        assert_same_bits(&adaptive.film.pixels, &other.film.pixels, what);
    }
    // Pixels that stopped early hold, bit for bit, a plain render's pixels of their sample
    // count: the active list sends each path to its pixel and sample.
    // The two sample counts most pixels stopped at after the first pass.
    let mut by_count: Vec<(usize, u32)> = Vec::new();
    for &c in report.pixel_samples.iter().filter(|&&c| c > s.spp) {
        match by_count.iter_mut().find(|(_, k)| *k == c) {
            Some((n, _)) => *n += 1,
            None => by_count.push((1, c)),
        }
    }
    by_count.sort_unstable_by(|a, b| b.cmp(a));
    assert!(by_count.len() >= 2, "pixels stopped at {by_count:?}");
    for k in [by_count[0].1, by_count[1].1] {
        let reference = render_gpu(
            &scene,
            &RenderSettings {
                spp: k,
                ..s.clone()
            },
            None,
        )
        .unwrap();
        let mut checked = 0;
        for (p, &c) in report.pixel_samples.iter().enumerate() {
            if c == k {
                assert_eq!(
                    bytemuck::bytes_of(&adaptive.film.pixels[p]),
                    bytemuck::bytes_of(&reference.film.pixels[p]),
                    "pixel {p} of {k} samples differs from a plain render of {k} spp"
                );
                checked += 1;
            }
        }
        println!("{checked} pixels of {k} samples equal a plain render's");
    }
}

#[test]
fn adaptive_renders_agree_with_a_plain_render() {
    let scene = prepared("cornell-box.gltf");
    // An independent reference: another seed, 512 spp everywhere.
    let reference = render_cpu(
        &scene,
        &RenderSettings {
            spp: 512,
            ..settings(3)
        },
    );
    let (cpu, _) = cpu_progressive(&scene, &settings(4), &options(true));
    let gpu = gpu_progressive(&scene, &settings(5), &options(true), None, None);
    // Family-wise α = 0.01 over the comparisons made, Šidák.
    let comparisons = if gpu.is_some() { 2 } else { 1 };
    let alpha = 1.0 - 0.99f64.powf(1.0 / comparisons as f64);
    assert_agree_at(&cpu.film, &reference.film, alpha, "CPU --adaptive vs plain");
    if let Some((gpu, _)) = gpu {
        assert_agree_at(&gpu.film, &reference.film, alpha, "GPU --adaptive vs plain");
    }
}

#[test]
fn the_time_limit_stops_a_render_that_cannot_reach_its_target() {
    let scene = prepared("cornell-box.gltf");
    let s = RenderSettings {
        width: 4,
        height: 4,
        spp: 1,
        ..settings(6)
    };
    // 10⁻¹² is out of reach, and 65536 passes take far longer than a millisecond.
    let p = Progressive {
        target_error: Some(1e-12),
        time_limit: Some(1e-3),
        ..Progressive::default()
    };
    let (_, report) = cpu_progressive(&scene, &s, &p);
    println!("{report}");
    assert_eq!(report.reason, StopReason::TimeLimit);
    if let Some((_, report)) = gpu_progressive(&scene, &s, &p, None, None) {
        println!("GPU: {report}");
        assert_eq!(report.reason, StopReason::TimeLimit);
    }
}

#[test]
fn the_sample_cap_stops_a_render_that_cannot_reach_its_target() {
    let scene = prepared("cornell-box.gltf");
    let s = RenderSettings {
        width: 8,
        height: 8,
        spp: 4,
        ..settings(7)
    };
    let p = Progressive {
        target_error: Some(1e-12),
        max_spp: 18,
        ..Progressive::default()
    };
    let (out, report) = cpu_progressive(&scene, &s, &p);
    println!("{report}");
    assert_eq!(report.reason, StopReason::MaxSpp);
    assert_eq!(report.passes, 4);
    assert!(report.pixel_samples.iter().all(|&c| c == 16));
    assert_eq!(out.film.total_samples(), 16 * 64);
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `render --device cpu` of an 8×8 Cornell box at `spp` with `extra` options.
fn cli_render(spp: &str, extra: &[&str]) -> std::process::Output {
    let out = common::temp("adaptive", "cli.exr");
    let mut args = vec![
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        spp,
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    wavetrace(&args)
}

#[test]
fn the_command_line_reports_how_the_render_stopped() {
    let o = cli_render("8", &["--target-error", "0.3", "--adaptive"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    println!("{text}");
    for part in [
        "stopped after ",
        "target error reached",
        "samples per pixel min ",
        "worst relative error ",
        "target relative error 0.3 per pixel",
    ] {
        assert!(text.contains(part), "no '{part}' in:\n{text}");
    }
    let o = cli_render("1", &["--target-error", "1e-12", "--time-limit", "0.001"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("time limit"), "{}", stdout(&o));
    let o = cli_render("4", &["--time-limit", "0.001", "--max-spp", "8"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("time limit") || text.contains("max spp reached"),
        "{text}"
    );
}

#[test]
fn the_command_line_refuses_bad_values() {
    for bad in ["0", "-0.5", "NaN", "inf", "abc"] {
        let o = cli_render("4", &["--target-error", bad]);
        assert!(!o.status.success(), "--target-error {bad} was accepted");
        assert!(stderr(&o).contains("--target-error"), "{}", stderr(&o));
    }
    for bad in ["0", "-1", "NaN"] {
        let o = cli_render("4", &["--time-limit", bad]);
        assert!(!o.status.success(), "--time-limit {bad} was accepted");
        assert!(stderr(&o).contains("--time-limit"), "{}", stderr(&o));
    }
    let cases: [(&[&str], &str); 5] = [
        (&["--adaptive"], "--target-error"),
        (&["--max-spp", "64"], "--max-spp"),
        (&["--target-error", "0.1", "--max-spp", "2"], "--max-spp"),
        (&["--target-error", "0.1", "--max-spp", "0"], "--max-spp"),
        (
            &["--target-error", "0.1", "--sampler", "stratified"],
            "stratified",
        ),
    ];
    for (args, expected) in cases {
        let o = cli_render("4", args);
        assert!(!o.status.success(), "{args:?} was accepted");
        assert!(
            stderr(&o).contains(expected),
            "{args:?}: no '{expected}' in {}",
            stderr(&o)
        );
    }
}
