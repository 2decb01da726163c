//! `wavetrace bench`'s arguments and what its three forms (`bench`, `bench --bvh`,
//! `bench --kernels`) share: the machine the figures belong to, the scenes' names, and the JSON
//! rows that `--json` writes and `--baseline` reads.

use super::options::{parse_radiance, IntegratorArg, LightSamplerArg, SamplerArg};
use anyhow::{Context as _, Result};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Scenes to measure (default: every .gltf in scenes/).
    pub scenes: Vec<PathBuf>,
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: u32,
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..=1_048_576))]
    pub spp: u32,
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=1024))]
    pub max_depth: u32,
    /// Vulkan device index.
    #[arg(long)]
    pub gpu_index: Option<usize>,
    /// Paths in flight per GPU batch.
    #[arg(long)]
    pub wavefront: Option<u32>,
    /// Skip the CPU integrator.
    #[arg(long, conflicts_with = "cpu_only")]
    pub gpu_only: bool,
    /// Skip the GPU (no Vulkan device is opened): the CPU integrator alone.
    #[arg(long)]
    pub cpu_only: bool,
    /// Measure the BVH instead of rendering: each scene's triangles built --builds times (the
    /// median and the best time), the tree's SAH cost, nodes and depth, and what a closest-hit
    /// ray costs in it on the CPU (boxes and triangles tested per ray, M rays/s) for 2^20
    /// random rays through its bounds, in the binary tree (the GPU's fallback walk), in its
    /// 4-wide collapse (the CPU integrators' walk: collapse time, boxes per ray, M rays/s) and
    /// in that collapse quantised (the GPU's walk: boxes per ray, M rays/s).
    #[arg(long)]
    pub bvh: bool,
    /// Make each scene's GPU kernels without rendering (those a render with these settings
    /// uses, specialised alike) and print the driver's statistics of each: registers, spills,
    /// instructions, as the device names them (`VK_KHR_pipeline_executable_properties`, which
    /// AMD's and NVIDIA's drivers offer and lavapipe does not). Submits no work, so it also
    /// runs on a device that compiles but cannot render: Mesa RADV's null device
    /// (`RADV_FORCE_FAMILY=navi31` with RADV's ICD) gives AMD's compiler's view of every
    /// kernel on any machine. With `--baseline` (an earlier `bench --kernels --json`), each
    /// kernel's figures that changed are printed beside the baseline's.
    #[arg(long, conflicts_with_all = ["bvh", "cpu_only", "gpu_only"])]
    pub kernels: bool,
    /// How many times `--bvh` builds each scene's tree after the first (reported apart: it pays
    /// for fresh memory, as a render's one build does; the median and best are of the rest).
    #[arg(long, requires = "bvh", default_value_t = 7, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub builds: u32,
    /// The estimator to measure.
    #[arg(long, value_enum, default_value_t = IntegratorArg::Path)]
    pub integrator: IntegratorArg,
    /// The sampler, as `render --sampler` (independent: the samples Mitsuba's `independent`
    /// sampler draws, for a comparison on the same render).
    #[arg(long, value_enum, default_value_t = SamplerArg::Sobol)]
    pub sampler: SamplerArg,
    /// How next event estimation picks an emitter, as `render --light-sampler` (power: by
    /// emitted power alone; on a scene with one emitting shape, as Mitsuba's path tracer picks).
    #[arg(long, value_enum, default_value_t = LightSamplerArg::Bvh)]
    pub light_sampler: LightSamplerArg,
    /// Radiance of rays that leave the scene (for scenes lit by their surroundings).
    #[arg(long, value_parser = parse_radiance, default_value = "0")]
    pub environment: glam::Vec3,
    /// An environment map (.hdr or .exr) lighting every scene.
    #[arg(long, value_name = "FILE", conflicts_with = "environment")]
    pub env: Option<PathBuf>,
    /// Write every figure as JSON: one object per scene × device (samples/s, rays/s, per-kernel
    /// ms, BVH build ms, device and driver), to track speed between commits.
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<PathBuf>,
    /// A JSON file written by an earlier `bench --json`: print each row's samples/s as a ratio
    /// to the same scene × device there.
    #[arg(long, value_name = "FILE.json")]
    pub baseline: Option<PathBuf>,
    /// Do not count the GPU kernels' scene fetches (one atomic addition per invocation and
    /// kernel), to measure what counting costs on a device.
    #[arg(long)]
    pub no_fetch_counts: bool,
    /// Time each scene's GPU render from its kernels' first dispatch: no untimed warm-up render
    /// first, so that a CPU Vulkan device's kernel compile (lavapipe compiles at the first
    /// dispatch) is measured inside the render, as a render's start-up on a fresh machine.
    #[arg(long)]
    pub no_warm_up: bool,
}

/// The host's processor as `bench` records it beside its figures: /proc/cpuinfo's first
/// "model name" on Linux, else the architecture. Speed figures belong to a machine (a change of
/// virtual machine from one processor to another moved this project's Cornell box figures by
/// more than most changes do), so a `--baseline` from another processor is said to be one.
pub(crate) fn host_cpu() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines()
                .find_map(|l| l.strip_prefix("model name")?.split_once(':'))
                .map(|(_, name)| name.trim().to_owned())
        })
        .filter(|name| !name.is_empty())
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned())
}

/// What differs between the machine of a `bench --json` document and this run's, as a notice
/// (`None` where the processor, its threads and the GPU, where this run opened one, are the
/// same): ratios against it then compare machines as well as builds.
pub(crate) fn baseline_machine_notice(
    doc: &serde_json::Value,
    cpu: &str,
    threads: usize,
    gpu: Option<&str>,
) -> Option<String> {
    let their_cpu = doc["cpu"].as_str();
    let their_threads = doc["cpu_threads"].as_u64();
    let their_gpu = doc["gpu"].as_str();
    let mut differs = Vec::new();
    match their_cpu {
        None => differs.push("it does not name its processor".to_owned()),
        Some(c) if c != cpu => differs.push(format!("its processor was {c}, this one is {cpu}")),
        Some(_) => {}
    }
    if let Some(t) = their_threads.filter(|&t| t != threads as u64) {
        differs.push(format!("it ran {t} CPU threads, this run {threads}"));
    }
    if let (Some(theirs), Some(ours)) = (their_gpu, gpu) {
        if theirs != ours {
            differs.push(format!("its GPU was {theirs}, this one is {ours}"));
        }
    }
    (!differs.is_empty()).then(|| {
        format!(
            "note: the baseline's machine may not be this one ({}): its ratios compare the machines as well as the builds",
            differs.join("; ")
        )
    })
}

/// An option's value as the command line spells it.
pub(crate) fn value_name(v: &impl clap::ValueEnum) -> String {
    v.to_possible_value()
        .map_or(String::new(), |p| p.get_name().to_owned())
}

/// A JSON document with "rows" (as `written_by` writes it) and those rows.
pub(crate) fn read_rows_json(
    file: &Path,
    written_by: &str,
) -> Result<(serde_json::Value, Vec<serde_json::Value>)> {
    let text =
        std::fs::read_to_string(file).with_context(|| format!("reading {}", file.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", file.display()))?;
    let rows = v["rows"]
        .as_array()
        .with_context(|| {
            format!(
                "{}: no \"rows\" (write it with {written_by})",
                file.display()
            )
        })?
        .clone();
    Ok((v, rows))
}

/// A scene's name in `bench`'s rows: its file name without the extension.
pub(crate) fn scene_name(path: &Path) -> String {
    path.file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("?")
        .to_owned()
}

/// Kernels' statistics as JSON: kernel → statistic name → value (`bench --json`'s
/// `kernel_statistics`).
pub(crate) fn statistics_json(
    kernels: &[(String, Vec<wavetrace::render::KernelStatistic>)],
) -> serde_json::Map<String, serde_json::Value> {
    kernels
        .iter()
        .map(|(k, list)| {
            let values = list.iter().map(|s| (s.name.clone(), s.value.to_json()));
            (k.clone(), serde_json::Value::Object(values.collect()))
        })
        .collect()
}

/// A kernel's statistics that differ from a baseline's (`before`: name → value, as
/// `bench --kernels --json` writes them), "name before → now" (hashes left out), or "the same".
pub(crate) fn statistics_changes(
    before: &serde_json::Value,
    now: &[wavetrace::render::KernelStatistic],
) -> String {
    let changed: Vec<String> = now
        .iter()
        .filter(|s| !s.is_hash())
        .filter_map(|s| {
            let old = before.get(&s.name)?;
            let new = s.value.to_json();
            (*old != new).then(|| format!("{} {old} → {new}", s.name))
        })
        .collect();
    match changed.is_empty() {
        true => "the same".to_string(),
        false => changed.join(", "),
    }
}
