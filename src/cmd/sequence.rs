//! `wavetrace render --frames A..B --fps F`: frames of an animation, one image each. The file
//! is read, parsed and its textures decoded once (`SceneFile`), the device and its kernels
//! built once (the backend), the environment made once; each frame poses the nodes at
//! F / fps seconds, bakes the moving meshes, rebuilds the BVH and light tree, uploads and
//! renders with the same seed as every other frame — so a frame equals the same `--time`
//! rendered alone, bit for bit, on whichever shard renders it.

use super::options::RenderArgs;
use super::prepare::{check_output, default_scene, open, prepare_at, resolve_device};
use super::report::Progress;
use super::shards::{record, stop_flag, INTERRUPTED_EXIT};
use anyhow::{bail, Context as _, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The frames shard `i` of `n` renders of `first..=last`: a contiguous share, ⌊i·count/n⌋ to
/// ⌊(i+1)·count/n⌋ (as `--shard` splits samples), so every frame is rendered by exactly one
/// shard.
pub(crate) fn shard_frames(first: u32, last: u32, shard: Option<(u32, u32)>) -> Vec<u32> {
    let count = (last - first) as u64 + 1;
    let (i, n) = shard.unwrap_or((0, 1));
    let start = first as u64 + i as u64 * count / n as u64;
    let end = first as u64 + (i as u64 + 1) * count / n as u64;
    (start..end).map(|f| f as u32).collect()
}

/// The image of frame `frame`: the last run of `#` in the file name replaced by the frame
/// number, zero-padded to the run's length; without one, `_####` before the extension.
pub(crate) fn frame_path(pattern: &Path, frame: u32) -> PathBuf {
    let name = pattern
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match name.rfind('#') {
        Some(end) => {
            let start = name[..end].rfind(|c| c != '#').map_or(0, |k| k + 1);
            let width = end + 1 - start;
            format!("{}{frame:0width$}{}", &name[..start], &name[end + 1..])
        }
        None => match name.rsplit_once('.') {
            Some((stem, ext)) => format!("{stem}_{frame:04}.{ext}"),
            None => format!("{name}_{frame:04}"),
        },
    };
    pattern.with_file_name(name)
}

/// `render --frames`: the scene (default: the Cornell box, which has no animation) on the
/// device `--device` picks.
pub(crate) fn render_sequence(args: &RenderArgs) -> Result<()> {
    let (first, last) = args.frames.expect("called for --frames");
    let path = args.scene.clone().map_or_else(default_scene, Ok)?;
    let path = path.as_path();
    let device = resolve_device(args.device, args.opts.gpu_index.as_ref().map(|_| 0));
    if !args.opts.path_layers()?.is_empty() {
        bail!("--aov NAME=EXPR renders its layers beside one image: it does not combine with --frames");
    }
    let aovs = super::render::aov_passes(args);
    if !aovs.is_empty() && super::render::multi_gpu(&args.opts.gpu_index).is_some() {
        bail!(
            "--aov PROPERTY, --transparent and --denoise render on one device: give --gpu-index N"
        );
    }
    let denoiser = match args.out.denoise {
        true => Some(wavetrace::denoise::Denoiser::load()?),
        false => None,
    };
    if args.output.as_deref() == Some(std::path::Path::new("-")) {
        bail!("--frames writes one file per frame: -o - (standard output) holds one image");
    }
    let write_options = args.out.write_options()?;
    let pattern = args.output.clone().unwrap_or_else(|| {
        PathBuf::from(format!(
            "{}_####.png",
            path.file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("render")
        ))
    });
    check_output(&pattern)?;
    super::render::check_layer_output(&aovs, &pattern)?;
    let frames = shard_frames(first, last, args.shard);
    let cold = Instant::now();
    let opened = open(path, &args.opts)?;
    let animations = opened.file.animations();
    if animations.is_empty() {
        bail!(
            "{}: the file has no animations: --frames renders moments of one",
            path.display()
        );
    }
    let open_s = cold.elapsed().as_secs_f64();
    let backend = super::render::backend(args, device, false)?;
    let backend_s = cold.elapsed().as_secs_f64() - open_s;
    println!(
        "{}: frames {first}..{last} at {} fps{}, {} spp each, on {}; read in {open_s:.2} s, \
         device ready in {backend_s:.2} s",
        path.display(),
        args.fps,
        match args.shard {
            Some((i, n)) => format!(" (shard {i}/{n}: {} frames)", frames.len()),
            None => String::new(),
        },
        args.opts.spp,
        backend.describe()
    );
    let budget = &opened.options.budget;
    let mut baseline = None;
    let stop = stop_flag(false);
    for &frame in &frames {
        // What one frame reserved is given back before the next (the first frame's, with the
        // environment, stays).
        if let Some(b) = baseline {
            budget.release(budget.used().saturating_sub(b));
        }
        let output = frame_path(&pattern, frame);
        if args.skip_existing && output.exists() {
            println!("frame {frame}: {} exists, left out", output.display());
            continue;
        }
        let started = Instant::now();
        let time = (frame as f64 / args.fps) as f32;
        let moment = args.opts.moment_at(time);
        let (_scene, prepared, settings) = prepare_at(
            path,
            &opened,
            &moment,
            &args.opts,
            device,
            baseline.is_none(),
        )?;
        let prepare_s = started.elapsed().as_secs_f64();
        let mut settings = settings;
        if args.out.transparent {
            settings.debug_flags |= wavetrace::layout::FLAG_TRANSPARENT_BACKGROUND;
        }
        if !aovs.is_empty() && settings.integrator != wavetrace::render::Integrator::Path {
            bail!("--aov PROPERTY, --transparent and --denoise need --integrator path");
        }
        let progress = Progress::new(
            settings.pixel_count() * settings.spp as u64,
            args.progress_mode(),
        );
        let (out, end) =
            backend.render_range(&prepared, &settings, 0..settings.spp, &progress.bar, stop)?;
        drop(progress);
        if let Some(fault) = out.stats.fault {
            bail!("frame {frame}: {fault}; the frame is not written");
        }
        if end < settings.spp {
            eprintln!(
                "stopped early: frame {frame} is not written (it held samples 0..{end} of {}); \
                 the same command with --skip-existing renders it and the frames after it",
                settings.spp
            );
            std::process::exit(INTERRUPTED_EXIT);
        }
        let mut record = record(&args.opts, path, &prepared, &settings, device, &moment)?;
        record.samples = Some(wavetrace::shard::SampleRange::new(0, end));
        record.dropped = out.film.dropped;
        // Written beside and renamed into place, so that a frame's file is whole or absent.
        let partial = output.with_file_name(format!(
            ".partial-{}",
            output
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or("frame.png")
        ));
        let mut attributes = record.attributes();
        let (film, layers) = super::render::aov_layers_and_denoise(
            args,
            &*backend,
            &prepared,
            &settings,
            out.film,
            end,
            denoiser.as_ref(),
            &mut attributes,
        )?;
        wavetrace::image_io::write_output(&film, &layers, &partial, &write_options, &attributes)?;
        std::fs::rename(&partial, &output)
            .with_context(|| format!("moving {} to {}", partial.display(), output.display()))?;
        println!(
            "frame {frame} (t = {time} s): posed and prepared in {prepare_s:.3} s, rendered in \
             {:.3} s ({:.3} M samples/s); wrote {}",
            out.stats.seconds,
            out.stats.samples_per_second() * 1e-6,
            output.display()
        );
        if baseline.is_none() {
            baseline = Some(budget.used());
        }
    }
    println!(
        "{} frames in {:.2} s",
        frames.len(),
        cold.elapsed().as_secs_f64()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_names() {
        let p = |s: &str, f| frame_path(Path::new(s), f).display().to_string();
        assert_eq!(p("out/walk_####.png", 7), "out/walk_0007.png");
        assert_eq!(p("f##.exr", 123), "f123.exr");
        assert_eq!(p("a#b_###.png", 5), "a#b_005.png");
        assert_eq!(p("walk.png", 12), "walk_0012.png");
    }

    #[test]
    fn shards_split_the_frames_once() {
        for (first, last, n) in [(1, 48, 5), (0, 2, 4), (10, 10, 1), (3, 100, 7)] {
            let all: Vec<u32> = (0..n)
                .flat_map(|i| shard_frames(first, last, Some((i, n))))
                .collect();
            assert_eq!(all, (first..=last).collect::<Vec<_>>());
        }
    }
}
