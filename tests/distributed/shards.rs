//! Shards, merge and resume through the command line: `render --sample-range/--shard`,
//! `wavetrace merge`, `render --resume`, a signal during a render, and the Kubernetes Indexed
//! Job's commands (tools/k8s/) run as local processes.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common;

use crate::common::{assert_bitwise_equal, assert_same_samples, read_exr_file, wavetrace};
use wavetrace::shard::SampleRange;

fn temp(name: &str) -> PathBuf {
    common::temp("shards", name)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Renders the Cornell box with `extra` options to `out`; panics unless it succeeds.
fn render(device: &str, size: u32, spp: u32, extra: &[&str], out: &Path) {
    let o = run_render(device, size, spp, extra, out);
    assert!(o.status.success(), "render {extra:?}: {}", stderr(&o));
}

fn run_render(device: &str, size: u32, spp: u32, extra: &[&str], out: &Path) -> Output {
    run_render_with(device, size, spp, extra, out, None)
}

/// `render` of the Cornell box, with the environment variable `env` (name, value) if given.
fn run_render_with(
    device: &str,
    size: u32,
    spp: u32,
    extra: &[&str],
    out: &Path,
    env: Option<(&str, &str)>,
) -> Output {
    let (size, spp) = (size.to_string(), spp.to_string());
    let mut args = vec![
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        device,
        "--width",
        &size,
        "--height",
        &size,
        "--spp",
        &spp,
        "--max-depth",
        "4",
        "-o",
        out.to_str().unwrap(),
    ];
    if device == "gpu" {
        args.push("--validate");
    }
    args.extend_from_slice(extra);
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_wavetrace"));
    command.args(&args).current_dir(env!("CARGO_MANIFEST_DIR"));
    if let Some((name, value)) = env {
        command.env(name, value);
    }
    command.output().expect("the wavetrace binary runs")
}

fn merge(shards: &[&Path], out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["merge"];
    args.extend(shards.iter().map(|p| p.to_str().unwrap()));
    args.extend(["-o", out.to_str().unwrap()]);
    args.extend_from_slice(extra);
    wavetrace(&args)
}

/// Shards of 0..spp in three pieces merge, in any order, into the single render (to f32
/// summation order), and two orders give the same bits.
fn shards_merge_into_the_single_render(device: &str, size: u32, spp: u32) {
    let path = |name: &str| temp(&format!("{device}-{name}"));
    let full = path("full.exr");
    render(device, size, spp, &[], &full);
    let cut = [0, spp / 3, spp / 2 + 1, spp];
    let shards: Vec<PathBuf> = (0..3)
        .map(|k| {
            let out = path(&format!("shard{k}.exr"));
            let range = format!("{}..{}", cut[k], cut[k + 1]);
            render(device, size, spp, &["--sample-range", &range], &out);
            let f = read_exr_file(&out);
            assert_eq!(f.record.samples, Some(SampleRange::new(cut[k], cut[k + 1])));
            assert!(f.film.pixels.iter().all(|p| p.count == cut[k + 1] - cut[k]));
            out
        })
        .collect();
    let (a, b) = (path("merged-a.exr"), path("merged-b.exr"));
    let o = merge(&[&shards[2], &shards[0], &shards[1]], &a, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = merge(&[&shards[1], &shards[2], &shards[0]], &b, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_bitwise_equal(&a, &b);
    assert_same_samples(&a, &full);
    // One shard of every sample is the single render itself, bit for bit.
    let whole = path("whole-range.exr");
    render(
        device,
        size,
        spp,
        &["--sample-range", &format!("0..{spp}")],
        &whole,
    );
    assert_bitwise_equal(&whole, &full);
}

#[test]
fn cpu_shards_merge_into_the_single_render() {
    shards_merge_into_the_single_render("cpu", 32, 16);
}

#[test]
fn gpu_shards_merge_into_the_single_render() {
    if common::skip_gpu() {
        return;
    }
    shards_merge_into_the_single_render("gpu", 16, 8);
}

#[test]
fn the_stratified_sampler_keeps_the_total_spp_in_shards() {
    let full = temp("strat-full.exr");
    let extra = ["--sampler", "stratified"];
    render("cpu", 16, 12, &extra, &full);
    let (a, b, m) = (
        temp("strat-a.exr"),
        temp("strat-b.exr"),
        temp("strat-m.exr"),
    );
    render(
        "cpu",
        16,
        12,
        &["--sampler", "stratified", "--shard", "0/2"],
        &a,
    );
    render(
        "cpu",
        16,
        12,
        &["--sampler", "stratified", "--shard", "1/2"],
        &b,
    );
    let o = merge(&[&b, &a], &m, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_samples(&m, &full);
}

#[test]
fn merge_refuses_other_settings_overlaps_and_missing_samples() {
    let r = |name: &str, spp: u32, extra: &[&str]| {
        let out = temp(name);
        render("cpu", 8, spp, extra, &out);
        out
    };
    let a = r("ref-a.exr", 16, &["--sample-range", "0..8"]);
    let b = r("ref-b.exr", 16, &["--sample-range", "8..16"]);
    let b_seed = r(
        "ref-b-seed.exr",
        16,
        &["--sample-range", "8..16", "--seed", "1"],
    );
    let b_spp = r("ref-b-spp.exr", 32, &["--sample-range", "8..16"]);
    let overlap = r("ref-overlap.exr", 16, &["--sample-range", "4..16"]);
    let tail = r("ref-tail.exr", 16, &["--sample-range", "12..16"]);
    let out = temp("ref-out.exr");
    let refused = |shards: &[&Path], extra: &[&str], needles: &[&str]| {
        let _ = std::fs::remove_file(&out);
        let o = merge(shards, &out, extra);
        let err = stderr(&o);
        assert!(!o.status.success(), "merge of {shards:?} should fail");
        for n in needles {
            assert!(err.contains(n), "expected '{n}' in: {err}");
        }
        assert!(!out.exists(), "a refused merge wrote {}", out.display());
    };
    let name = |p: &Path| p.display().to_string();
    refused(
        &[&a, &b_seed],
        &[],
        &[&name(&a), &name(&b_seed), "seed 0 vs 1"],
    );
    refused(&[&a, &b_spp], &[], &[&name(&b_spp), "spp 16 vs 32"]);
    refused(
        &[&overlap, &a],
        &[],
        &[&name(&a), &name(&overlap), "overlap", "4..8"],
    );
    refused(
        &[&tail, &a],
        &[],
        &["samples 8..12 are in no shard", &name(&a), &name(&tail)],
    );
    refused(
        &[&a],
        &[],
        &["samples 8..16 of the render's 16 are in no shard"],
    );
    // --partial writes a larger shard of what is there.
    let o = merge(&[&a], &out, &["--partial"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        read_exr_file(&out).record.samples,
        Some(SampleRange::new(0, 8))
    );
    let o = merge(&[&b, &a], &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A render in passes has no fixed range: refused by merge, and the options do not combine.
    let passes = r(
        "ref-passes.exr",
        4,
        &["--target-error", "0.5", "--max-spp", "8"],
    );
    refused(&[&passes], &[], &[&name(&passes), "--target-error"]);
    let o = run_render(
        "cpu",
        8,
        16,
        &["--target-error", "0.1", "--sample-range", "0..8"],
        &out,
    );
    assert!(
        !o.status.success() && stderr(&o).contains("cannot be combined with"),
        "{}",
        stderr(&o)
    );
    let o = run_render(
        "cpu",
        8,
        16,
        &["--adaptive", "--target-error", "0.1", "--shard", "0/2"],
        &out,
    );
    assert!(
        !o.status.success() && stderr(&o).contains("cannot be combined with"),
        "{}",
        stderr(&o)
    );
    // Ranges outside --spp and shards to PNG are refused.
    let o = run_render("cpu", 8, 16, &["--sample-range", "8..20"], &out);
    assert!(
        !o.status.success() && stderr(&o).contains("only --spp 16"),
        "{}",
        stderr(&o)
    );
    let o = run_render("cpu", 8, 16, &["--shard", "1/2"], &temp("shard.png"));
    assert!(
        !o.status.success() && stderr(&o).contains(".exr"),
        "{}",
        stderr(&o)
    );
}

/// A render stopped after some samples (as a signal stops it) writes the samples done with its
/// range; --resume renders the rest, and the result holds the same samples as one render.
fn resume_completes_a_partial(device: &str, size: u32) {
    let path = |name: &str| temp(&format!("{device}-resume-{name}"));
    let (full, partial, done) = (path("full.exr"), path("partial.exr"), path("done.exr"));
    render(device, size, 12, &[], &full);
    let o = run_render(device, size, 12, &["--stop-after", "5"], &partial);
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(stderr(&o).contains("--resume"), "{}", stderr(&o));
    let p = read_exr_file(&partial);
    assert_eq!(p.record.samples, Some(SampleRange::new(0, 5)));
    assert_eq!(p.record.target, Some(SampleRange::new(0, 12)));
    // Other settings than the partial's are refused, naming what differs.
    let o = run_render(
        device,
        size,
        12,
        &["--resume", partial.to_str().unwrap(), "--seed", "7"],
        &done,
    );
    assert!(
        !o.status.success() && stderr(&o).contains("seed 0 vs 7"),
        "{}",
        stderr(&o)
    );
    // A partial is not a finished shard.
    let o = merge(&[&partial], &path("m.exr"), &["--partial"]);
    assert!(
        !o.status.success() && stderr(&o).contains("--resume"),
        "{}",
        stderr(&o)
    );
    let o = run_render(
        device,
        size,
        12,
        &["--resume", partial.to_str().unwrap()],
        &done,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        read_exr_file(&done).record.samples,
        Some(SampleRange::new(0, 12))
    );
    assert_same_samples(&done, &full);
}

#[test]
fn cpu_resume_completes_a_partial_render() {
    resume_completes_a_partial("cpu", 24);
    // A stopped shard resumes to that shard, written over the partial by default.
    let (shard, partial) = (temp("shard-4-12.exr"), temp("shard-partial.exr"));
    render("cpu", 16, 16, &["--sample-range", "4..12"], &shard);
    let o = run_render(
        "cpu",
        16,
        16,
        &["--sample-range", "4..12", "--stop-after", "3"],
        &partial,
    );
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert_eq!(
        read_exr_file(&partial).record.samples,
        Some(SampleRange::new(4, 7))
    );
    let o = wavetrace(&[
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--width",
        "16",
        "--spp",
        "16",
        "--max-depth",
        "4",
        "--resume",
        partial.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        read_exr_file(&partial).record.samples,
        Some(SampleRange::new(4, 12))
    );
    assert_same_samples(&partial, &shard);
    // Stopped before its first sample (a signal during loading): an empty partial resumes too.
    let (full, empty) = (temp("empty-full.exr"), temp("empty-partial.exr"));
    render("cpu", 16, 4, &[], &full);
    let o = run_render("cpu", 16, 4, &["--stop-after", "0"], &empty);
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    let e = read_exr_file(&empty);
    assert_eq!(e.record.samples, Some(SampleRange::new(0, 0)));
    assert!(e.film.pixels.iter().all(|p| p.count == 0));
    let o = run_render("cpu", 16, 4, &["--resume", empty.to_str().unwrap()], &empty);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_bitwise_equal(&empty, &full);
}

#[test]
fn gpu_resume_completes_a_partial_render() {
    if common::skip_gpu() {
        return;
    }
    resume_completes_a_partial("gpu", 16);
}

/// Sends `signal` to a render of far more samples than it can finish once it has started, and
/// checks that it writes the samples done, with their range, resumable.
fn a_signal_writes_a_resumable_partial(device: &str, signal: i32) {
    use std::io::BufRead;
    let out = temp(&format!("{device}-signal-{signal}.exr"));
    let mut args = vec![
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        device,
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "1000000",
        "--max-depth",
        "4",
        "-o",
        out.to_str().unwrap(),
    ];
    if device == "gpu" {
        args.extend(["--wavefront", "4096"]);
    }
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args(&args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until it renders (its "rendering …" line), let it take some samples, then signal.
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    for line in lines.by_ref() {
        if line.unwrap().starts_with("rendering") {
            break;
        }
    }
    std::thread::sleep(std::time::Duration::from_millis(500));
    assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{rest:?} {}", stderr(&o));
    assert!(stderr(&o).contains("--resume"), "{}", stderr(&o));
    let f = read_exr_file(&out);
    let held = f.record.samples.unwrap();
    assert_eq!(held.start, 0);
    assert!(held.end < 1_000_000, "{held}");
    assert_eq!(f.record.target, Some(SampleRange::new(0, 1_000_000)));
    assert!(
        f.film.pixels.iter().all(|p| p.count == held.end),
        "counts = {held}"
    );
    println!(
        "{device}: stopped by signal {signal} after {} samples per pixel",
        held.end
    );
    // The samples done are those of a render of that range, bit for bit (each pixel's samples
    // are summed in order from the first).
    if held.end > 0 {
        let again = temp(&format!("{device}-signal-{signal}-range.exr"));
        let mut args = args.clone();
        let range = format!("0..{}", held.end);
        let o_at = args.iter().position(|a| *a == "-o").unwrap();
        args[o_at + 1] = again.to_str().unwrap();
        args.extend(["--sample-range", &range]);
        let o = wavetrace(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let g = read_exr_file(&again);
        assert!(
            g.film.pixels == f.film.pixels,
            "the partial differs from a render of {range}"
        );
    }
}

#[test]
fn sigterm_during_a_cpu_render_writes_a_resumable_partial() {
    a_signal_writes_a_resumable_partial("cpu", libc::SIGTERM);
}

#[test]
fn sigint_during_a_gpu_render_writes_a_resumable_partial() {
    if common::skip_gpu() {
        return;
    }
    a_signal_writes_a_resumable_partial("gpu", libc::SIGINT);
}

/// `--gpu-index 0,0` (issue 14, item 3): the samples split over two Vulkan devices — here the
/// same lavapipe twice, in two threads — merge into the single render, to f32 summation order,
/// and each device's share is reported.
#[test]
fn a_render_split_over_devices_is_the_single_render() {
    if common::skip_gpu() {
        return;
    }
    let (one, two) = (temp("devices-one.exr"), temp("devices-two.exr"));
    render("gpu", 16, 6, &[], &one);
    let o = run_render("gpu", 16, 6, &["--gpu-index", "0,0"], &two);
    assert!(o.status.success(), "{}", stderr(&o));
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("samples 0..3") && said.contains("samples 3..6"),
        "{said}"
    );
    assert_same_samples(&two, &one);
}

/// `render` on the GPU with `WAVETRACE_FAULT` set (src/gpu/fault.rs).
fn run_render_with_fault(fault: &str, size: u32, spp: u32, extra: &[&str], out: &Path) -> Output {
    run_render_with(
        "gpu",
        size,
        spp,
        extra,
        out,
        Some(("WAVETRACE_FAULT", fault)),
    )
}

/// The same for an image of several bands, as one larger than a storage binding is rendered
/// (`--band-pixels`, test-only: 32 × 32 in bands of 10 rows). Such an image is rendered sample
/// by sample over its bands, so it holds the same bits as one band, and a device lost in the
/// tenth batch of the render (the second band of the third sweep; one batch per band and sample) leaves the
/// two whole sweeps before it, which --resume completes into what one render gives.
#[test]
fn gpu_faults_in_an_image_of_several_bands_keep_whole_samples() {
    if common::gpu().is_none() {
        return;
    }
    let (whole, banded, partial) = (
        temp("bands-whole.exr"),
        temp("bands-full.exr"),
        temp("bands-partial.exr"),
    );
    let bands = ["--wavefront", "2048", "--band-pixels", "320"];
    render("gpu", 32, 6, &bands[..2], &whole);
    render("gpu", 32, 6, &bands, &banded);
    // (The process's first batch is the kernels' warm-up on a few pixels, render.rs.)
    let o = run_render_with_fault("device-lost@11", 32, 6, &bands, &partial);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("(VK_ERROR_DEVICE_LOST)")
            && err.contains("holds the samples 0..2 finished before it"),
        "{err}"
    );
    let mut resume = bands.to_vec();
    resume.extend(["--resume", partial.to_str().unwrap()]);
    render("gpu", 32, 6, &resume, &partial);
    assert_bitwise_equal(&whole, &banded);
    // (A resumed film adds the partial's sums to the rest's, as a merge does.)
    assert_same_samples(&partial, &whole);
}

/// Faults end cleanly (issue 14, item 5): a device lost in the render's fourth batch (two passes each)
/// ends the render with a message naming it and an EXR of the six samples finished before it,
/// which --resume completes into what one render gives; memory exhausted while the buffers are
/// made names the buffer. Never a panic.
#[test]
fn gpu_faults_end_cleanly_and_keep_the_finished_samples() {
    if common::gpu().is_none() {
        return;
    }
    let (full, partial) = (temp("fault-full.exr"), temp("fault-partial.exr"));
    let wavefront = ["--wavefront", "2048"];
    render("gpu", 32, 12, &wavefront, &full);
    // (The process's first batch is the kernels' warm-up on a few pixels, render.rs.)
    let o = run_render_with_fault("device-lost@5", 32, 12, &wavefront, &partial);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("the GPU was lost during a wavefront batch (VK_ERROR_DEVICE_LOST)")
            && err.contains("holds the samples 0..6 finished before it")
            && err.contains("--resume"),
        "{err}"
    );
    let p = read_exr_file(&partial);
    assert_eq!(p.record.samples, Some(SampleRange::new(0, 6)));
    let mut resume = wavefront.to_vec();
    resume.extend(["--resume", partial.to_str().unwrap()]);
    render("gpu", 32, 12, &resume, &partial);
    assert_same_samples(&partial, &full);

    // Lost in the first batch, before any whole pass: a film of no samples, still written.
    let none = temp("fault-none.exr");
    let o = run_render_with_fault("device-lost@1", 32, 12, &wavefront, &none);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("holds the samples 0..0 finished before it"),
        "{err}"
    );
    let p = read_exr_file(&none);
    assert_eq!(p.record.samples, Some(SampleRange::new(0, 0)));

    for buffer in ["film", "bvh_nodes", "rays"] {
        let out = temp(&format!("fault-{buffer}.exr"));
        let o = run_render_with_fault(&format!("oom@{buffer}"), 16, 2, &[], &out);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(
            err.contains(&format!("out of GPU memory allocating buffer '{buffer}'")),
            "{err}"
        );
    }
}
