//! The seam between a render and what runs it: the CPU reference (`cpu::CpuBackend`) and a
//! Vulkan device (`gpu::GpuBackend`) answer the same two calls, so a command that renders has one
//! branch, as pbrt-v4's `RenderCPU` and `RenderWavefront` stand behind one `Integrator::Render`.

use super::prepared::PreparedScene;
use super::progressive::{Progressive, ProgressiveReport};
use super::settings::RenderSettings;
use super::stats::RenderOutput;
use anyhow::Result;
use indicatif::ProgressBar;
use std::ops::Range;
use std::sync::atomic::AtomicBool;

/// Something that renders a prepared scene.
pub trait Backend {
    /// What renders, as `render` names it after "on": "the CPU (2 threads)", or a device's name,
    /// Vulkan version and driver.
    fn describe(&self) -> String;

    /// Renders samples `samples` of the `settings.spp` of every pixel, advancing `progress`, and
    /// stops after a whole pass once `stop` is set; returns the output and the end of the samples
    /// rendered (every pixel holds `samples.start..end`, in sample order).
    fn render_range(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        samples: Range<u32>,
        progress: &ProgressBar,
        stop: &AtomicBool,
    ) -> Result<(RenderOutput, u32)>;

    /// Renders in passes of `settings.spp` samples per pixel until `options` say stop
    /// (`--target-error`, `--adaptive`, `--time-limit`, `--max-spp`).
    fn render_progressive(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        options: &Progressive,
        progress: &ProgressBar,
    ) -> Result<(RenderOutput, ProgressiveReport)>;
}
