//! Renders that stop at a target noise level or a time limit (`--target-error`, `--adaptive`,
//! `--max-spp`, `--time-limit`): the image is rendered in passes of `spp` samples per pixel, pass
//! p taking sample indices [p·spp, (p+1)·spp), so no random number repeats and the first k
//! passes give, bit for bit, the film of a plain render of k·spp samples. After each pass the
//! film's own accumulators (sum, sum of squares, count: `film.rs`) give each pixel's relative
//! standard error ([`relative_error`]); the render stops when every pixel is below the target,
//! at the sample cap, or after the pass during which the time limit passed. With `adaptive`,
//! each pixel stops on its own: pixels below the target get no samples in later passes.
//!
//! Both integrators run the same loop ([`run`]) with their own pass: the decisions depend only
//! on the films, which are deterministic, so the same seed stops after the same passes with the
//! same image (on one device, whatever `--wavefront`), except where the time limit decides.

use super::settings::RenderSettings;
use crate::film::Film;
use crate::layout::SAMPLER_STRATIFIED;
use anyhow::{bail, Result};
use indicatif::ProgressBar;
use std::fmt;
use std::time::Instant;

/// Default sample cap per pixel (`--max-spp`), rounded down to whole passes of at least one.
pub const DEFAULT_MAX_SPP: u32 = 65536;

/// Largest sample cap per pixel: sample indices stay far below 2³².
pub const MAX_SPP_LIMIT: u32 = 1 << 24;

/// The floor under a pixel's luminance in [`relative_error`], as a fraction of the image's mean
/// luminance after the first pass: pixels darker than a tenth of the image's mean are held to
/// the absolute error allowed at a tenth of the mean. Without a floor a black pixel (mean 0)
/// could never reach any relative error, and a nearly black one would need samples without
/// bound for noise no display shows next to the rest of the image.
pub const ERROR_FLOOR_FRACTION: f64 = 0.1;

/// How a render proceeds in passes.
#[derive(Clone, Debug, PartialEq)]
pub struct Progressive {
    /// Stop when every pixel's [`relative_error`] is below this (> 0).
    pub target_error: Option<f64>,
    /// Each pixel stops on its own once below `target_error`.
    pub adaptive: bool,
    /// At most this many samples per pixel (whole passes: ⌊max_spp / spp⌋ of them).
    pub max_spp: u32,
    /// Stop after the pass during which this many seconds of rendering have passed.
    pub time_limit: Option<f64>,
}

impl Default for Progressive {
    fn default() -> Self {
        Progressive {
            target_error: None,
            adaptive: false,
            max_spp: DEFAULT_MAX_SPP,
            time_limit: None,
        }
    }
}

impl Progressive {
    /// Checks the options against the render's settings; errors name the option at fault.
    pub fn check(&self, settings: &RenderSettings) -> Result<()> {
        if let Some(e) = self.target_error {
            if !(e.is_finite() && e > 0.0) {
                bail!("--target-error {e}: the relative error must be a finite number above 0");
            }
        }
        if let Some(t) = self.time_limit {
            if !(t.is_finite() && t > 0.0) {
                bail!("--time-limit {t}: the limit must be a finite number of seconds above 0");
            }
        }
        if self.adaptive && self.target_error.is_none() {
            bail!("--adaptive needs --target-error: pixels stop when they reach it");
        }
        if self.max_spp == 0 || self.max_spp > MAX_SPP_LIMIT {
            bail!(
                "--max-spp {}: the cap must lie in 1..={MAX_SPP_LIMIT}",
                self.max_spp
            );
        }
        if self.max_spp < settings.spp {
            bail!(
                "--max-spp {} is below --spp {}: each pass renders --spp samples per pixel",
                self.max_spp,
                settings.spp
            );
        }
        if settings.sampler == SAMPLER_STRATIFIED {
            bail!(
                "--sampler stratified places N rooks over exactly --spp samples and cannot be \
                 continued pass after pass; use --sampler sobol (the default) or independent \
                 with --target-error or --time-limit"
            );
        }
        Ok(())
    }

    /// The most passes the sample cap allows (at least one).
    pub fn max_passes(&self, spp: u32) -> u32 {
        (self.max_spp / spp.max(1)).max(1)
    }
}

/// Luminance weights (Rec. 709 primaries, as `lights::luminance`).
const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// The pixel's mean luminance, from the film's per-channel means.
pub fn mean_luminance(film: &Film, pixel: usize) -> f64 {
    let m = film.mean_f64(pixel);
    (0..3).map(|c| LUMINANCE[c] * m[c]).sum()
}

/// Standard error of the pixel's mean luminance, bounded from the film's per-channel
/// accumulators: the film keeps no covariance between channels, and for Y = Σ w_c X_c,
/// Var(Y) = Σ_c Σ_d w_c w_d Cov(X_c, X_d) ≤ (Σ_c w_c σ_c)² by Cauchy–Schwarz, so
/// √(variance of the mean of Y) ≤ Σ_c w_c √(variance_of_mean_c); equal when the channels are
/// perfectly correlated (grey surfaces under grey light). Infinite with fewer than 2 samples.
pub fn luminance_standard_error(film: &Film, pixel: usize) -> f64 {
    if film.pixels[pixel].count < 2 {
        return f64::INFINITY;
    }
    let v = film.variance_of_mean_f64(pixel);
    (0..3).map(|c| LUMINANCE[c] * v[c].sqrt()).sum()
}

/// The floor under pixel luminances in [`relative_error`]: [`ERROR_FLOOR_FRACTION`] of the
/// mean over pixels of their mean luminance (computed once, after the first pass).
pub fn error_floor(film: &Film) -> f64 {
    let n = film.len().max(1) as f64;
    let mean: f64 = (0..film.len())
        .map(|p| mean_luminance(film, p))
        .sum::<f64>()
        / n;
    ERROR_FLOOR_FRACTION * mean.max(0.0)
}

/// The pixel's relative standard error: [`luminance_standard_error`] over
/// max(mean luminance, `floor`). 0 when the standard error is 0 (every sample equal, e.g. a
/// black background), infinite with fewer than 2 samples or when the standard error is
/// positive over a zero denominator; never NaN.
pub fn relative_error(film: &Film, pixel: usize, floor: f64) -> f64 {
    let se = luminance_standard_error(film, pixel);
    if se == 0.0 {
        return 0.0;
    }
    let e = se / mean_luminance(film, pixel).max(floor);
    if e.is_nan() || e < 0.0 {
        f64::INFINITY
    } else {
        e
    }
}

/// Why a render stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// Every pixel's error is below the target.
    TargetReached,
    /// The next pass would exceed `--max-spp`.
    MaxSpp,
    /// The time limit passed during the last pass.
    TimeLimit,
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopReason::TargetReached => "target error reached",
            StopReason::MaxSpp => "max spp reached",
            StopReason::TimeLimit => "time limit",
        })
    }
}

/// How a render in passes ended.
#[derive(Clone, Debug, PartialEq)]
pub struct ProgressiveReport {
    pub passes: u32,
    pub reason: StopReason,
    /// The target, if any.
    pub target_error: Option<f64>,
    /// The luminance floor of [`relative_error`].
    pub floor: f64,
    /// Samples traced per pixel (dropped NaN/Inf samples included), row-major.
    pub pixel_samples: Vec<u32>,
    /// Pixels sampled in each pass.
    pub active_per_pass: Vec<u32>,
    /// The largest [`relative_error`] at the end and its pixel (x, y), the first in row-major
    /// order among equals.
    pub worst_error: f64,
    pub worst_pixel: (u32, u32),
    /// Pixels whose error is not below the target at the end (0 without a target).
    pub pixels_above: u32,
}

impl ProgressiveReport {
    pub fn min_spp(&self) -> u32 {
        self.pixel_samples.iter().copied().min().unwrap_or(0)
    }
    pub fn max_spp(&self) -> u32 {
        self.pixel_samples.iter().copied().max().unwrap_or(0)
    }
    pub fn mean_spp(&self) -> f64 {
        self.total_samples() as f64 / self.pixel_samples.len().max(1) as f64
    }
    /// Samples traced over all pixels.
    pub fn total_samples(&self) -> u64 {
        self.pixel_samples.iter().map(|&s| s as u64).sum()
    }
}

impl fmt::Display for ProgressiveReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "stopped after {} pass{}: {}; samples per pixel min {}, mean {:.1}, max {}; \
             worst relative error {:.4e} at pixel ({}, {})",
            self.passes,
            if self.passes == 1 { "" } else { "es" },
            self.reason,
            self.min_spp(),
            self.mean_spp(),
            self.max_spp(),
            self.worst_error,
            self.worst_pixel.0,
            self.worst_pixel.1
        )?;
        if let Some(e) = self.target_error {
            write!(f, " (target {e:e}, luminance floor {:.4e}", self.floor)?;
            if self.pixels_above > 0 {
                write!(f, "; {} pixels above the target", self.pixels_above)?;
            }
            f.write_str(")")?;
        }
        Ok(())
    }
}

/// One pass to render: samples [first_sample, first_sample + spp) of `active` (row-major pixel
/// indices, increasing), or of every pixel when `active` is None.
#[derive(Clone, Copy, Debug)]
pub struct Pass<'a> {
    pub index: u32,
    pub first_sample: u32,
    pub active: Option<&'a [u32]>,
}

/// The pass loop shared by both integrators: calls `render_pass` to add each pass's samples to
/// `film` (empty at the start) and decides after each pass whether to go on. `settings` must
/// have passed [`Progressive::check`].
pub fn run(
    settings: &RenderSettings,
    options: &Progressive,
    film: &mut Film,
    progress: &ProgressBar,
    mut render_pass: impl FnMut(Pass, &mut Film) -> Result<()>,
) -> Result<ProgressiveReport> {
    let start = Instant::now();
    let pixels = film.len();
    let spp = settings.spp;
    let max_passes = options.max_passes(spp);
    let mut active: Vec<u32> = (0..pixels as u32).collect();
    let mut pixel_samples = vec![0u32; pixels];
    let mut active_per_pass = Vec::new();
    let mut floor = 0.0;
    let mut passes = 0u32;
    let reason = loop {
        let listed = options.adaptive && active.len() < pixels;
        progress.set_length(active.len() as u64 * spp as u64);
        progress.set_position(0);
        render_pass(
            Pass {
                index: passes,
                first_sample: passes * spp,
                active: listed.then_some(active.as_slice()),
            },
            film,
        )?;
        for &p in &active {
            pixel_samples[p as usize] += spp;
        }
        active_per_pass.push(active.len() as u32);
        passes += 1;
        if passes == 1 {
            floor = error_floor(film);
        }
        if let Some(target) = options.target_error {
            let below = |p: &u32| relative_error(film, *p as usize, floor) < target;
            if options.adaptive {
                active.retain(|p| !below(p));
            } else if active.iter().all(below) {
                active.clear();
            }
        }
        progress.set_message(format!("pass {passes}: {} pixels to go", active.len()));
        if active.is_empty() {
            break StopReason::TargetReached;
        }
        if passes >= max_passes {
            break StopReason::MaxSpp;
        }
        if options
            .time_limit
            .is_some_and(|t| start.elapsed().as_secs_f64() >= t)
        {
            break StopReason::TimeLimit;
        }
    };
    let (mut worst_error, mut worst) = (f64::NEG_INFINITY, 0usize);
    let mut pixels_above = 0;
    for p in 0..pixels {
        let e = relative_error(film, p, floor);
        if e > worst_error {
            (worst_error, worst) = (e, p);
        }
        if options.target_error.is_some_and(|t| e >= t) {
            pixels_above += 1;
        }
    }
    let width = film.width.max(1) as usize;
    Ok(ProgressiveReport {
        passes,
        reason,
        target_error: options.target_error,
        floor,
        pixel_samples,
        active_per_pass,
        worst_error: worst_error.max(0.0),
        worst_pixel: ((worst % width) as u32, (worst / width) as u32),
        pixels_above,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn relative_error_of_known_samples() {
        let mut film = Film::new(3, 1);
        // Pixel 0: grey samples 1, 3 (mean 2, sample variance 2, variance of the mean 1).
        film.add_sample(0, Vec3::splat(1.0));
        film.add_sample(0, Vec3::splat(3.0));
        // Pixel 1: black, two samples; pixel 2: one sample.
        film.add_sample(1, Vec3::ZERO);
        film.add_sample(1, Vec3::ZERO);
        film.add_sample(2, Vec3::ONE);
        assert!((luminance_standard_error(&film, 0) - 1.0).abs() < 1e-12);
        assert!((relative_error(&film, 0, 0.0) - 0.5).abs() < 1e-12);
        // The floor replaces a smaller mean.
        assert!((relative_error(&film, 0, 4.0) - 0.25).abs() < 1e-12);
        assert_eq!(relative_error(&film, 1, 0.0), 0.0);
        assert_eq!(relative_error(&film, 2, 1.0), f64::INFINITY);
        // Mean luminance (2 + 0 + 1) / 3 = 1, times the fraction.
        assert!((error_floor(&film) - ERROR_FLOOR_FRACTION).abs() < 1e-12);
    }

    #[test]
    fn the_luminance_bound_is_exact_for_proportional_channels() {
        let mut film = Film::new(1, 1);
        for v in [0.5f32, 1.5, 4.0, 2.0] {
            film.add_sample(0, Vec3::new(v, 2.0 * v, 3.0 * v));
        }
        // Y = (0.2126 + 1.4304 + 0.2166) v: its standard error is that factor times v's.
        let k = 0.2126 + 2.0 * 0.7152 + 3.0 * 0.0722;
        let (s, q) = (8.0f64, 0.25 + 2.25 + 16.0 + 4.0);
        let se_v = ((q - s * s / 4.0) / 3.0 / 4.0).sqrt();
        assert!((luminance_standard_error(&film, 0) - k * se_v).abs() < 1e-9);
    }

    #[test]
    fn options_are_checked() {
        let settings = RenderSettings {
            spp: 16,
            ..RenderSettings::default()
        };
        let ok = Progressive {
            target_error: Some(0.1),
            ..Progressive::default()
        };
        assert!(ok.check(&settings).is_ok());
        assert_eq!(ok.max_passes(16), 4096);
        assert_eq!(ok.max_passes(100_000), 1);
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let p = Progressive {
                target_error: Some(bad),
                ..ok.clone()
            };
            let e = p.check(&settings).unwrap_err().to_string();
            assert!(e.contains("--target-error"), "{e}");
        }
        let p = Progressive {
            max_spp: 8,
            ..ok.clone()
        };
        assert!(p
            .check(&settings)
            .unwrap_err()
            .to_string()
            .contains("--max-spp"));
        let p = Progressive {
            adaptive: true,
            target_error: None,
            time_limit: Some(1.0),
            ..ok.clone()
        };
        assert!(p
            .check(&settings)
            .unwrap_err()
            .to_string()
            .contains("--adaptive"));
        let stratified = RenderSettings {
            sampler: SAMPLER_STRATIFIED,
            ..settings.clone()
        };
        assert!(ok
            .check(&stratified)
            .unwrap_err()
            .to_string()
            .contains("stratified"));
    }

    /// A pass that adds `value(pixel, sample)` for each sample of the pass, as an integrator
    /// would.
    fn synthetic(
        spp: u32,
        value: impl Fn(u32, u32) -> f32,
    ) -> impl FnMut(Pass, &mut Film) -> Result<()> {
        move |pass: Pass, film: &mut Film| {
            let all: Vec<u32> = (0..film.len() as u32).collect();
            for &p in pass.active.unwrap_or(&all) {
                for s in pass.first_sample..pass.first_sample + spp {
                    film.add_sample(p as usize, Vec3::splat(value(p, s)));
                }
            }
            Ok(())
        }
    }

    #[test]
    fn adaptive_passes_skip_converged_pixels_and_stop_at_the_target() {
        let settings = RenderSettings {
            width: 4,
            height: 1,
            spp: 4,
            ..RenderSettings::default()
        };
        // Pixel 0 is constant, pixel 1 alternates 1 ± 0.5, pixels 2 and 3 alternate 1 ± 0.125
        // (dyadic values: the f32 sums are exact). n samples of 1 ± a (n even) have mean 1 and
        // variance of the mean a²/(n − 1), so the relative error is a/√(n − 1).
        let value = |p: u32, s: u32| {
            let sign = if s.is_multiple_of(2) { 1.0 } else { -1.0 };
            match p {
                0 => 1.0,
                1 => 1.0 + 0.5 * sign,
                _ => 1.0 + 0.125 * sign,
            }
        };
        let options = Progressive {
            target_error: Some(0.02),
            adaptive: true,
            ..Progressive::default()
        };
        let mut film = Film::new(4, 1);
        let report = run(
            &settings,
            &options,
            &mut film,
            &ProgressBar::hidden(),
            synthetic(4, value),
        )
        .unwrap();
        assert_eq!(report.reason, StopReason::TargetReached);
        assert!(report.worst_error < 0.02);
        // Pixel 0 stops after the first pass; 0.125/√(n − 1) < 0.02 from n = 41 on, so pixels 2
        // and 3 stop after 11 passes (44 samples); 0.5/√(n − 1) < 0.02 from n = 627 on: pixel 1
        // stops after 157 passes (628 samples).
        assert_eq!(report.pixel_samples[0], 4);
        assert_eq!(report.pixel_samples[2], 44);
        assert_eq!(report.pixel_samples[3], 44);
        assert_eq!(report.pixel_samples[1], 628);
        assert_eq!(report.passes, 157);
        assert_eq!(report.active_per_pass[..3], [4, 3, 3]);
        // Without --adaptive every pixel gets every pass.
        let mut whole = Film::new(4, 1);
        let plain = run(
            &settings,
            &Progressive {
                adaptive: false,
                ..options.clone()
            },
            &mut whole,
            &ProgressBar::hidden(),
            synthetic(4, value),
        )
        .unwrap();
        assert_eq!(plain.passes, 157);
        assert!(plain.pixel_samples.iter().all(|&s| s == 628));
        assert!(plain.total_samples() > report.total_samples());
    }

    #[test]
    fn the_sample_cap_stops_pixels_that_never_converge() {
        let settings = RenderSettings {
            width: 2,
            height: 1,
            spp: 3,
            ..RenderSettings::default()
        };
        let options = Progressive {
            target_error: Some(1e-6),
            adaptive: true,
            max_spp: 10,
            time_limit: None,
        };
        let mut film = Film::new(2, 1);
        let report = run(
            &settings,
            &options,
            &mut film,
            &ProgressBar::hidden(),
            synthetic(3, |_, s| (s % 2) as f32),
        )
        .unwrap();
        assert_eq!(report.reason, StopReason::MaxSpp);
        assert_eq!(report.passes, 3);
        assert_eq!(report.pixel_samples, vec![9, 9]);
        assert!(report.worst_error > 1e-6);
        assert_eq!(report.pixels_above, 2);
        assert!(report.to_string().contains("max spp reached"));
    }
}
