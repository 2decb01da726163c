//! The CPU reference integrator: the same path tracer as the GPU's wavefront kernels, one path
//! at a time, parallel over image rows with rayon. Same random numbers, same maths, same names.

mod path;

pub use path::{emitted_radiance, path_pixel_sample, sample_pair, trace_path, RayCounts};

use crate::film::Film;
use crate::layout::FilmPixel;
use crate::render::{PreparedScene, RenderOutput, RenderSettings, RenderStats};
use glam::Vec3;
use indicatif::ProgressBar;
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
    let env = environment
        .as_ref()
        .map_or(crate::environment::no_environment(), |(map, _)| {
            map.as_ref()
        });
    let mut film = Film::new(settings.width, settings.height);
    let start = Instant::now();
    let width = settings.width as usize;
    let (counts, dropped) = film
        .pixels
        .par_chunks_mut(width)
        .enumerate()
        .map(|(row, pixels)| {
            let mut counts = RayCounts::default();
            let mut dropped = 0u64;
            for (x, acc) in pixels.iter_mut().enumerate() {
                let pixel = (row * width + x) as u32;
                for sample in 0..settings.spp {
                    let l = trace_path(scene, &frame, env, pixel, sample, &mut counts);
                    if !accumulate(acc, l) {
                        dropped += 1;
                    }
                }
            }
            progress.inc(settings.spp as u64 * pixels.len() as u64);
            (counts, dropped)
        })
        .reduce(
            || (RayCounts::default(), 0),
            |(a, da), (b, db)| (a.merged(&b), da + db),
        );
    film.dropped = dropped;
    let stats = RenderStats {
        seconds: start.elapsed().as_secs_f64(),
        samples: settings.total_samples(),
        extension_rays: counts.extension,
        shadow_rays: counts.shadow,
        dropped,
        kernel_seconds: Vec::new(),
    };
    RenderOutput { film, stats }
}

/// Adds one path's radiance to its pixel, as `accumulate.comp` does; false if it was dropped
/// for being NaN or infinite.
pub fn accumulate(acc: &mut FilmPixel, l: Vec3) -> bool {
    if !l.is_finite() {
        return false;
    }
    for c in 0..3 {
        acc.sum[c] += l[c];
        acc.sum_sq[c] += l[c] * l[c];
    }
    acc.count += 1;
    true
}
