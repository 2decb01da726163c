//! What a render reports beside its film: samples, rays, time per kernel and per host phase,
//! the driver's statistics of each kernel, the device memory it used and a fault that ended it.

use crate::film::Film;

/// Counts and timings of one render.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub seconds: f64,
    pub samples: u64,
    pub extension_rays: u64,
    pub shadow_rays: u64,
    /// Non-finite samples dropped from the film.
    pub dropped: u64,
    /// GPU only: (kernel, seconds) summed over all its dispatches, where timestamps exist.
    pub kernel_seconds: Vec<(String, f64)>,
    /// GPU only, with `GpuOptions::count_fetches`: (kernel, scene-image texels it fetched).
    pub kernel_fetches: Vec<(String, u64)>,
    /// GPU only, where timestamps exist: the render's wall time outside its kernels, by phase
    /// (`HOST_PHASES`: the film's clear or upload, the time between the kernels' first and last
    /// timestamps and the submissions' ends, the film's read-back), and the submissions.
    pub host_seconds: Vec<(String, f64)>,
    pub submissions: u64,
    /// GPU only: the error that ended the render early (a lost device, exhausted memory); the
    /// film holds the samples finished before it.
    pub fault: Option<String>,
    /// GPU only: the device memory the render held and how its scene lay over the bindings.
    pub device_memory: Option<DeviceMemory>,
    /// GPU only: the features its kernels were made for (`PreparedScene::gpu_features`).
    pub kernel_features: Option<u32>,
    /// GPU only: how many of its kernels the render made before its first sample (pipelines
    /// not made for an earlier render of the renderer) and the seconds that took, which
    /// `seconds` leaves out: on lavapipe nearly all of a small render's start-up
    /// (docs/perf-log/2026-12-05-lavapipe-start-up.md).
    pub kernels_made: Option<(usize, f64)>,
    /// GPU only, on a device that reports them: per kernel, the driver's statistics of its
    /// compiled code (`VK_KHR_pipeline_executable_properties`).
    pub kernel_statistics: Vec<(String, Vec<KernelStatistic>)>,
}

/// One statistic a Vulkan driver reports of a compiled kernel, named and described by the
/// driver (NVIDIA's register count and local memory, Mesa's instruction counts, …).
#[derive(Clone, Debug, PartialEq)]
pub struct KernelStatistic {
    pub name: String,
    pub description: String,
    pub value: StatisticValue,
}

impl KernelStatistic {
    /// Whether it is a hash that identifies the compiled code (RADV's "Driver pipeline hash" and
    /// "Hash"), which the printed lines leave out (the JSON keeps them).
    pub fn is_hash(&self) -> bool {
        self.name.to_lowercase().contains("hash")
    }
}

/// A driver statistic's value, in the four forms Vulkan gives them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StatisticValue {
    Bool(bool),
    Int(i64),
    Uint(u64),
    Float(f64),
}

impl std::fmt::Display for StatisticValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StatisticValue::Bool(b) => write!(f, "{}", if *b { "yes" } else { "no" }),
            StatisticValue::Int(v) => write!(f, "{v}"),
            StatisticValue::Uint(v) => write!(f, "{v}"),
            StatisticValue::Float(v) => write!(f, "{v:.3}"),
        }
    }
}

impl StatisticValue {
    /// The value as JSON: a boolean or a number.
    pub fn to_json(self) -> serde_json::Value {
        match self {
            StatisticValue::Bool(b) => b.into(),
            StatisticValue::Int(v) => v.into(),
            StatisticValue::Uint(v) => v.into(),
            StatisticValue::Float(v) => v.into(),
        }
    }
}

/// A kernel's statistics in one line: `name value` pairs, comma-separated, without hashes
/// ([`KernelStatistic::is_hash`]).
pub fn statistics_line(statistics: &[KernelStatistic]) -> String {
    statistics
        .iter()
        .filter(|s| !s.is_hash())
        .map(|s| format!("{} {}", s.name, s.value))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The device memory of one GPU render, once its buffers exist and the scene is uploaded.
#[derive(Clone, Debug, Default)]
pub struct DeviceMemory {
    /// The render's buffers and the bytes they use.
    pub buffers: usize,
    pub allocated: u64,
    /// Bytes of the memory blocks they are sub-allocated from, and how many blocks (device
    /// allocations) that is.
    pub reserved: u64,
    pub blocks: usize,
    /// The scene arrays spread over several bindings: (what, bindings).
    pub split: Vec<(String, u32)>,
    /// Where the kernels read the scene arrays from: storage images, sampled images or storage
    /// buffers (`gpu::SceneImages`).
    pub scene_reads: &'static str,
}

impl std::fmt::Display for DeviceMemory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
        write!(
            f,
            "GPU memory: {:.1} MiB in {} buffers, {:.1} MiB in {} allocations",
            mib(self.allocated),
            self.buffers,
            mib(self.reserved),
            self.blocks
        )?;
        if !self.split.is_empty() {
            let parts: Vec<String> = self
                .split
                .iter()
                .map(|(what, n)| format!("{what} over {n}"))
                .collect();
            write!(f, "; bindings: {}", parts.join(", "))?;
        }
        if !self.scene_reads.is_empty() {
            write!(f, "; scene read from {}", self.scene_reads)?;
        }
        Ok(())
    }
}

/// The phases of a GPU render's wall time outside its kernels (`RenderStats::host_seconds`).
pub const HOST_PHASES: [&str; 3] = ["film setup", "between batches", "film read-back"];

impl RenderStats {
    /// Adds `seconds` to the host phase `name` (one of `HOST_PHASES`).
    pub fn add_host(&mut self, name: &str, seconds: f64) {
        debug_assert!(HOST_PHASES.contains(&name), "{name}");
        match self.host_seconds.iter_mut().find(|(n, _)| n == name) {
            Some((_, s)) => *s += seconds,
            None => self.host_seconds.push((name.to_string(), seconds)),
        }
    }

    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-9)
    }
    pub fn rays_per_second(&self) -> f64 {
        (self.extension_rays + self.shadow_rays) as f64 / self.seconds.max(1e-9)
    }
}

/// A finished render.
pub struct RenderOutput {
    pub film: Film,
    pub stats: RenderStats,
}
