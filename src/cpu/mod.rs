//! The CPU reference integrator: the same path tracer as the GPU's wavefront kernels, one path
//! at a time, parallel over image rows with rayon. Same random numbers, same maths, same names.

pub mod bidir;
mod path;

use crate::film::{accumulate, Film};
use crate::render::progressive::{self, Progressive, ProgressiveReport};
use crate::render::{Integrator, PreparedScene, RenderOutput, RenderSettings, RenderStats};
use indicatif::ProgressBar;
pub use path::{
    emitted_radiance, path_pixel_sample, sample_pair, trace_path, trace_path_matching, RayCounts,
};
use rayon::prelude::*;
use std::time::Instant;

/// Renders every sample of every pixel on the CPU.
pub fn render(scene: &PreparedScene, settings: &RenderSettings) -> RenderOutput {
    render_with_progress(scene, settings, &ProgressBar::hidden())
}

/// [`render`], advancing `progress` by each finished row's samples.
pub fn render_with_progress(
    scene: &PreparedScene,
    settings: &RenderSettings,
    progress: &ProgressBar,
) -> RenderOutput {
    let frame = scene.frame_params(settings);
    let environment = settings.environment_map();
    let env = crate::lights::environment::map_or_none(&environment);
    let mut film = Film::new(settings.width, settings.height);
    let start = Instant::now();
    let (counts, dropped) = add_samples(
        scene,
        settings,
        &frame,
        env,
        &mut film,
        0..settings.spp,
        progress,
    );
    film.dropped = dropped;
    let stats = cpu_stats(start, settings.total_samples(), &counts, dropped);
    RenderOutput { film, stats }
}

/// Renders samples `samples` of the `settings.spp` of every pixel (the samplers stratify over
/// all `settings.spp`, so a range renders exactly those samples of the whole render), in
/// chunks of whole sample passes; after each chunk stops early if `stop` is set. Returns the
/// film and the end of the samples rendered: every pixel holds samples
/// [samples.start, end), each pixel's in sample order, so the film equals, bit for bit, that of
/// a render of [samples.start, end) (and of [`render`] for 0..spp).
pub fn render_range(
    scene: &PreparedScene,
    settings: &RenderSettings,
    samples: std::ops::Range<u32>,
    progress: &ProgressBar,
    stop: &std::sync::atomic::AtomicBool,
) -> (RenderOutput, u32) {
    let frame = scene.frame_params(settings);
    let environment = settings.environment_map();
    let env = crate::lights::environment::map_or_none(&environment);
    let mut film = Film::new(settings.width, settings.height);
    let start = Instant::now();
    // Chunks of about 2^16 paths: short enough to stop soon, long enough for rayon.
    let chunk = (65536 / settings.pixel_count().max(1)).clamp(1, u32::MAX as u64) as u32;
    let (mut counts, mut dropped) = (RayCounts::default(), 0);
    let mut end = samples.start;
    while end < samples.end && !stop.load(std::sync::atomic::Ordering::Relaxed) {
        let next = end.saturating_add(chunk).min(samples.end);
        let (c, d) = add_samples(scene, settings, &frame, env, &mut film, end..next, progress);
        counts = counts.merged(&c);
        dropped += d;
        end = next;
    }
    film.dropped = dropped;
    let stats = cpu_stats(
        start,
        settings.pixel_count() * (end - samples.start) as u64,
        &counts,
        dropped,
    );
    (RenderOutput { film, stats }, end)
}

/// Adds samples `samples` of every pixel to `film` with the settings' integrator (and
/// `--paths`); returns the rays traced and the samples dropped.
fn add_samples(
    scene: &PreparedScene,
    settings: &RenderSettings,
    frame: &crate::layout::FrameParams,
    env: &crate::lights::environment::EnvironmentMap,
    film: &mut Film,
    samples: std::ops::Range<u32>,
    progress: &ProgressBar,
) -> (RayCounts, u64) {
    if settings.integrator == Integrator::Path {
        let paths = settings.paths.as_deref().map(|p| &p.reversed);
        render_samples(scene, frame, env, paths, film, samples, None, progress)
    } else {
        let bidir = bidir::Bidir::from_settings(scene, frame, settings);
        bidir::render_samples(&bidir, film, samples, progress, None)
    }
}

/// Adds samples `samples` of every pixel (or of the pixels `active` marks) to `film`, rows in
/// parallel, each pixel's samples in order; returns the rays traced and the samples dropped.
#[allow(clippy::too_many_arguments)]
fn render_samples(
    scene: &PreparedScene,
    frame: &crate::layout::FrameParams,
    env: &crate::lights::environment::EnvironmentMap,
    paths: Option<&crate::paths::Dfa>,
    film: &mut Film,
    samples: std::ops::Range<u32>,
    active: Option<&[bool]>,
    progress: &ProgressBar,
) -> (RayCounts, u64) {
    let width = film.width as usize;
    film.pixels
        .par_chunks_mut(width)
        .enumerate()
        .map(|(row, pixels)| {
            let mut counts = RayCounts::default();
            let mut dropped = 0u64;
            let mut traced = 0u64;
            for (x, acc) in pixels.iter_mut().enumerate() {
                let pixel = (row * width + x) as u32;
                if active.is_some_and(|a| !a[pixel as usize]) {
                    continue;
                }
                for sample in samples.clone() {
                    let l =
                        trace_path_matching(scene, frame, env, pixel, sample, &mut counts, paths);
                    if !accumulate(acc, l) {
                        dropped += 1;
                    }
                }
                traced += samples.len() as u64;
            }
            progress.inc(traced);
            (counts, dropped)
        })
        .reduce(
            || (RayCounts::default(), 0),
            |(a, da), (b, db)| (a.merged(&b), da + db),
        )
}

/// Renders with `--integrator light|bdpt` keeping every (s, t) strategy's contributions apart
/// (`--bdpt-strategies`).
pub fn render_strategies(
    scene: &PreparedScene,
    settings: &RenderSettings,
    progress: &ProgressBar,
) -> (RenderOutput, bidir::StrategyFilms) {
    let frame = scene.frame_params(settings);
    let mut film = Film::new(settings.width, settings.height);
    let mut strategies = bidir::StrategyFilms::default();
    let start = Instant::now();
    let b = bidir::Bidir::from_settings(scene, &frame, settings);
    let (counts, dropped) = bidir::render_samples(
        &b,
        &mut film,
        0..settings.spp,
        progress,
        Some(&mut strategies),
    );
    film.dropped = dropped;
    let stats = cpu_stats(start, settings.total_samples(), &counts, dropped);
    (RenderOutput { film, stats }, strategies)
}

/// Renders in passes of `settings.spp` samples per pixel until `options` say stop
/// (`progressive.rs`): pass p adds samples [p·spp, (p+1)·spp) of the pixels still active.
/// `options` must have passed [`Progressive::check`].
pub fn render_progressive(
    scene: &PreparedScene,
    settings: &RenderSettings,
    options: &Progressive,
    progress: &ProgressBar,
) -> (RenderOutput, ProgressiveReport) {
    let frame = scene.frame_params(settings);
    let environment = settings.environment_map();
    let env = crate::lights::environment::map_or_none(&environment);
    let mut film = Film::new(settings.width, settings.height);
    let start = Instant::now();
    let mut counts = RayCounts::default();
    let mut dropped = 0;
    let mut mask = Vec::new();
    let report = progressive::run(settings, options, &mut film, progress, |pass, film| {
        let active = pass.active.map(|list| {
            mask.clear();
            mask.resize(film.len(), false);
            for &p in list {
                mask[p as usize] = true;
            }
            mask.as_slice()
        });
        let first = pass.first_sample;
        let (c, d) = render_samples(
            scene,
            &frame,
            env,
            settings.paths.as_deref().map(|p| &p.reversed),
            film,
            first..first + settings.spp,
            active,
            progress,
        );
        counts = counts.merged(&c);
        dropped += d;
        Ok(())
    })
    .expect("CPU passes do not fail");
    film.dropped = dropped;
    let stats = cpu_stats(start, report.total_samples(), &counts, dropped);
    (RenderOutput { film, stats }, report)
}

/// The statistics of a CPU render that started at `start`.
fn cpu_stats(start: Instant, samples: u64, counts: &RayCounts, dropped: u64) -> RenderStats {
    RenderStats {
        seconds: start.elapsed().as_secs_f64(),
        samples,
        extension_rays: counts.extension,
        shadow_rays: counts.shadow,
        dropped,
        ..RenderStats::default()
    }
}

/// The CPU reference behind the render seam, on all of rayon's threads.
pub struct CpuBackend;

impl crate::render::Backend for CpuBackend {
    fn describe(&self) -> String {
        format!("the CPU ({} threads)", rayon::current_num_threads())
    }

    fn render_range(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        samples: std::ops::Range<u32>,
        progress: &ProgressBar,
        stop: &std::sync::atomic::AtomicBool,
    ) -> anyhow::Result<(RenderOutput, u32)> {
        Ok(render_range(scene, settings, samples, progress, stop))
    }

    fn render_progressive(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        options: &Progressive,
        progress: &ProgressBar,
    ) -> anyhow::Result<(RenderOutput, ProgressiveReport)> {
        Ok(render_progressive(scene, settings, options, progress))
    }
}
