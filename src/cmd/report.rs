//! What a render prints: its statistics (`--stats`: per-kernel time, texel fetches, the
//! deferred arrays, the host's phases) and its progress: a bar on a terminal, lines a log
//! keeps elsewhere.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use wavetrace::render::RenderStats;

/// A kernel's scene-image fetches per ray it handles: shadow rays for the connect kernels,
/// extension rays for the others (`RenderStats::kernel_fetches`).
pub(crate) fn fetches_per_ray(stats: &RenderStats, kernel: &str) -> Option<(f64, &'static str)> {
    let (_, n) = stats.kernel_fetches.iter().find(|(k, _)| k == kernel)?;
    let (rays, what) = match kernel.starts_with("connect") {
        true => (stats.shadow_rays, "shadow"),
        false => (stats.extension_rays, "extension"),
    };
    Some((*n as f64 / rays.max(1) as f64, what))
}

/// The deferred arrays kernels made for `features` keep per lane: the bottom levels', and the
/// top level's where there is one ("16", "16, top level 2").
pub(crate) fn deferred_slots(features: u32) -> String {
    use wavetrace::layout::{qbvh_stack_size, tlas_stack_size, FEATURE_TOP_LEVEL};
    match features & FEATURE_TOP_LEVEL != 0 {
        true => format!(
            "{}, top level {}",
            qbvh_stack_size(features),
            tlas_stack_size(features)
        ),
        false => qbvh_stack_size(features).to_string(),
    }
}

pub(crate) fn print_stats(stats: &RenderStats, per_kernel: bool) {
    println!(
        "done in {:.3} s: {:.3} M samples/s, {:.3} M rays/s ({} extension + {} shadow rays); {} NaN/Inf samples dropped",
        stats.seconds,
        stats.samples_per_second() * 1e-6,
        stats.rays_per_second() * 1e-6,
        stats.extension_rays,
        stats.shadow_rays,
        stats.dropped
    );
    if let Some(memory) = stats.device_memory.as_ref().filter(|_| per_kernel) {
        println!("{memory}");
    }
    if let Some(features) = stats.kernel_features.filter(|_| per_kernel) {
        let names = wavetrace::layout::feature_names(features);
        println!(
            "kernels made for: {}; deferred slots per lane: {}{}",
            match names.len() {
                0 => "no optional feature (the plain path)".to_string(),
                _ => names.join(", "),
            },
            deferred_slots(features),
            stats.kernels_made.map_or(String::new(), kernels_made_words)
        );
    }
    if per_kernel && !stats.kernel_seconds.is_empty() {
        let total: f64 = stats.kernel_seconds.iter().map(|(_, s)| s).sum();
        for (name, s) in &stats.kernel_seconds {
            println!(
                "  {name:<17} {:>10.3} ms  {:>5.1} %{}",
                s * 1e3,
                100.0 * s / total.max(1e-12),
                fetches_per_ray(stats, name).map_or(String::new(), |(f, rays)| format!(
                    "  {f:>6.1} scene fetches per {rays} ray"
                ))
            );
            if let Some((_, statistics)) = stats.kernel_statistics.iter().find(|(k, _)| k == name) {
                println!(
                    "  {:<17} driver: {}",
                    "",
                    wavetrace::render::statistics_line(statistics)
                );
            }
        }
        if let Some(host) = host_phases(stats) {
            println!("  outside the kernels: {host}");
        }
    }
}

/// How many pipelines the render made before its first sample and how long that took
/// (`RenderStats::kernels_made`), in words.
pub(crate) fn kernels_made_words((made, seconds): (usize, f64)) -> String {
    match made {
        0 => "; its pipelines made for an earlier render".to_string(),
        1 => format!("; 1 pipeline made before the render, in {seconds:.3} s"),
        n => format!("; {n} pipelines made before the render, in {seconds:.3} s"),
    }
}

/// The GPU render's wall time outside its kernels (`RenderStats::host_seconds`), in words.
pub(crate) fn host_phases(stats: &RenderStats) -> Option<String> {
    if stats.host_seconds.is_empty() {
        return None;
    }
    let phases: Vec<String> = stats
        .host_seconds
        .iter()
        .map(|(name, s)| match name.as_str() {
            "between batches" => format!(
                "{name} {:.1} ms ({} submission{})",
                s * 1e3,
                stats.submissions,
                if stats.submissions == 1 { "" } else { "s" }
            ),
            _ => format!("{name} {:.1} ms", s * 1e3),
        })
        .collect();
    Some(phases.join(", "))
}

/// A progress bar over the render's samples on stderr (hidden when stderr is not a terminal);
/// renders in passes restart it each pass, with the pass in its message.
pub(crate) fn progress_bar(samples: u64) -> ProgressBar {
    let bar = ProgressBar::new(samples);
    if let Ok(style) = ProgressStyle::with_template(
        "{bar:40} {percent:>3}%  {elapsed_precise} elapsed, {eta} left  {msg}",
    ) {
        bar.set_style(style);
    }
    bar
}

/// How a render reports its progress (`--quiet`, `--progress-interval`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ProgressMode {
    pub quiet: bool,
    /// Seconds between lines where stderr is not a terminal; None: a line per 10 %.
    pub interval: Option<f64>,
}

/// The progress of one render: the bar the backends advance, drawn on a terminal; elsewhere
/// (a CI log, a batch job's file) a thread that prints a line to stderr per 10 % of the
/// samples, or every `--progress-interval` seconds, with the rate and the time left. Stops
/// (and clears the bar) when dropped.
pub(crate) struct Progress {
    pub bar: ProgressBar,
    reporter: Option<(std::thread::JoinHandle<()>, Arc<AtomicBool>)>,
}

impl Progress {
    pub fn new(samples: u64, mode: ProgressMode) -> Progress {
        let bar = progress_bar(samples);
        if mode.quiet {
            bar.set_draw_target(ProgressDrawTarget::hidden());
            return Progress {
                bar,
                reporter: None,
            };
        }
        if std::io::stderr().is_terminal() {
            return Progress {
                bar,
                reporter: None,
            };
        }
        bar.set_draw_target(ProgressDrawTarget::hidden());
        let done = Arc::new(AtomicBool::new(false));
        let (watched, stop) = (bar.clone(), done.clone());
        let reporter = std::thread::spawn(move || report_lines(&watched, &stop, mode.interval));
        Progress {
            bar,
            reporter: Some((reporter, done)),
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        if let Some((thread, done)) = self.reporter.take() {
            done.store(true, Ordering::Relaxed);
            let _ = thread.join();
        }
        self.bar.finish_and_clear();
    }
}

/// Prints progress lines until `done`: at each 10 % of the samples (or every `interval`
/// seconds), none at 0 % or after the end (the render's own lines say that).
fn report_lines(bar: &ProgressBar, done: &AtomicBool, interval: Option<f64>) {
    let (mut last_line, mut next_tenth) = (Instant::now(), 1u64);
    let mut length = bar.length().unwrap_or(0);
    while !done.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(100));
        let (position, total) = (bar.position(), bar.length().unwrap_or(0));
        if total != length {
            // Renders in passes restart the bar each pass.
            (length, next_tenth) = (total, 1);
        }
        if total == 0 || position >= total {
            continue;
        }
        let due = match interval {
            Some(seconds) => last_line.elapsed().as_secs_f64() >= seconds,
            None => position * 10 >= next_tenth * total,
        };
        if !due {
            continue;
        }
        while next_tenth * total <= position * 10 {
            next_tenth += 1;
        }
        last_line = Instant::now();
        let seconds = bar.elapsed().as_secs_f64();
        let rate = position as f64 / seconds.max(1e-9);
        let left = (total - position) as f64 / rate.max(1e-9);
        let message = bar.message();
        eprintln!(
            "progress: {:>3} % ({position} of {total} samples) in {seconds:.1} s, {:.3} M samples/s, about {left:.0} s left{}",
            100 * position / total,
            rate * 1e-6,
            match message.is_empty() {
                true => String::new(),
                false => format!("  {message}"),
            }
        );
    }
}
