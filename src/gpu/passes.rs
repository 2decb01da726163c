//! Renders on the GPU: a whole render, a range of samples (a shard, or stopped by a signal at a
//! whole pass), renders in passes to a target error, each film band by band (a film larger than
//! one storage binding) with checkpoints; and [`GpuBackend`], the renderer behind the render seam.

use super::renderer::{Checkpoint, GpuRenderer, Setup};
use super::resources::{RenderBuffers, SUBMIT_TIMEOUT_S};
use crate::film::Film;
use crate::layout::{FilmPixel, FrameParams};
use crate::render::progressive::{self, Pass, Progressive, ProgressiveReport};
use crate::render::{PreparedScene, RenderOutput, RenderSettings, RenderStats};
use anyhow::{bail, Result};
use ash::vk;
use indicatif::ProgressBar;
use std::mem::size_of;
use std::time::Instant;

impl GpuRenderer {
    /// Renders `settings.spp` samples of every pixel with at most `wavefront` paths in flight.
    pub fn render(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        wavefront: Option<u32>,
    ) -> Result<RenderOutput> {
        self.render_with_progress(scene, settings, wavefront, &ProgressBar::hidden())
    }

    /// [`GpuRenderer::render`], advancing `progress` by each finished batch's samples.
    pub fn render_with_progress(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        wavefront: Option<u32>,
        progress: &ProgressBar,
    ) -> Result<RenderOutput> {
        let never = std::sync::atomic::AtomicBool::new(false);
        let (out, _) = self.render_range_with_progress(
            scene,
            settings,
            wavefront,
            0..settings.spp,
            progress,
            &never,
        )?;
        if let Some(fault) = out.stats.fault {
            bail!("{fault}");
        }
        Ok(out)
    }

    /// Renders samples `samples` of the `settings.spp` of every pixel (the samplers stratify
    /// over all `settings.spp`). When `stop` is set it stops at the next whole sample pass
    /// (images of several bands: the next sample of every band, `render_sweeps`); returns the
    /// output and the end of the samples rendered: every pixel holds samples
    /// [samples.start, end). A device lost or memory exhausted returns the samples finished
    /// before it (the last film copied back, at most a few seconds or one sweep old) with the
    /// error in `stats.fault`; the caller reports it.
    pub fn render_range_with_progress(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        wavefront: Option<u32>,
        samples: std::ops::Range<u32>,
        progress: &ProgressBar,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<(RenderOutput, u32)> {
        let splatting = settings.integrator != crate::render::Integrator::Path;
        if splatting {
            crate::render::check(scene, settings).map_err(|e| anyhow::anyhow!(e))?;
        }
        let setup = self.setup(scene, settings, wavefront, false)?;
        if splatting && setup.band_rows < settings.height {
            setup.destroy(&self.ctx);
            bail!(
                "--integrator {} splats anywhere on the image, so the whole film must fit one \
                 storage binding of {}: render {}×{} with --device cpu",
                settings.integrator.name(),
                self.ctx.info.name,
                settings.width,
                settings.height
            );
        }
        let result = self.render_bands(settings, &setup, samples.clone(), progress, stop);
        setup.destroy(&self.ctx);
        let (pixels, mut stats, end) = result?;
        self.ctx.check_validation()?;
        stats.samples = settings.pixel_count() * (end - samples.start) as u64;
        let film = Film::from_pixels(settings.width, settings.height, pixels, stats.dropped);
        Ok((RenderOutput { film, stats }, end))
    }

    /// Renders in passes of `settings.spp` samples per pixel until `options` say stop
    /// (`progressive.rs`): pass p adds samples [p·spp, (p+1)·spp) of the pixels still active,
    /// band by band; with `--adaptive` the paths of a pass go round the list of active pixels
    /// (`Binding::ActivePixels`). `options` must have passed [`Progressive::check`].
    pub fn render_progressive(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        wavefront: Option<u32>,
        options: &Progressive,
        progress: &ProgressBar,
    ) -> Result<(RenderOutput, ProgressiveReport)> {
        let setup = self.setup(scene, settings, wavefront, options.adaptive)?;
        let mut film = Film::new(settings.width, settings.height);
        let mut stats = RenderStats {
            device_memory: Some(self.device_memory(&setup)),
            kernel_features: Some(setup.features),
            kernels_made: Some(setup.kernels_made),
            kernel_statistics: self.kernel_statistics(&setup, settings.integrator),
            ..RenderStats::default()
        };
        let start = Instant::now();
        let result = progressive::run(settings, options, &mut film, progress, |pass, film| {
            self.render_pass(settings, &setup, pass, film, progress, &mut stats)
        });
        setup.destroy(&self.ctx);
        let report = result?;
        self.ctx.check_validation()?;
        stats.seconds = start.elapsed().as_secs_f64();
        stats.samples = report.total_samples();
        film.dropped = stats.dropped;
        Ok((RenderOutput { film, stats }, report))
    }

    /// The bands of the image: (first row, rows).
    pub(super) fn bands(settings: &RenderSettings, band_rows: u32) -> Vec<(u32, u32)> {
        (0..settings.height)
            .step_by(band_rows as usize)
            .map(|first_row| (first_row, band_rows.min(settings.height - first_row)))
            .collect()
    }

    /// The frame constants of the band starting at `first_row`.
    pub(super) fn band_frame(
        setup: &Setup,
        width: u32,
        (first_row, rows): (u32, u32),
    ) -> FrameParams {
        FrameParams {
            band_first_pixel: first_row * width,
            band_pixel_count: rows * width,
            ..setup.frame
        }
    }

    /// Renders the image band by band: clear the band's film, run its batches, read it back.
    /// Stops early (see `run_batches`) only when the image is one band; returns the end of the
    /// samples rendered.
    pub(super) fn render_bands(
        &self,
        settings: &RenderSettings,
        setup: &Setup,
        samples: std::ops::Range<u32>,
        progress: &ProgressBar,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<(Vec<FilmPixel>, RenderStats, u32)> {
        let ctx = &self.ctx;
        let buffers = &setup.buffers;
        let mut pixels = Vec::new();
        let mut stats = RenderStats {
            device_memory: Some(self.device_memory(setup)),
            kernel_features: Some(setup.features),
            kernels_made: Some(setup.kernels_made),
            kernel_statistics: self.kernel_statistics(setup, settings.integrator),
            ..RenderStats::default()
        };
        let start = Instant::now();
        let bands = Self::bands(settings, setup.band_rows);
        if bands.len() > 1 {
            let result =
                self.render_sweeps(settings, setup, &bands, samples, progress, &mut stats, stop);
            stats.seconds = start.elapsed().as_secs_f64();
            return result.map(|(pixels, end)| (pixels, stats, end));
        }
        let mut end = samples.end;
        for band in bands {
            let frame = Self::band_frame(setup, settings.width, band);
            buffers.frame.write(bytemuck::bytes_of(&frame));
            let film_bytes = frame.band_pixel_count as u64 * size_of::<FilmPixel>() as u64;
            self.commands.begin()?;
            unsafe {
                ctx.device.cmd_fill_buffer(
                    self.commands.cmd,
                    buffers.film.buffer,
                    0,
                    film_bytes,
                    0,
                );
                ctx.device.cmd_fill_buffer(
                    self.commands.cmd,
                    buffers.splats.buffer,
                    0,
                    vk::WHOLE_SIZE,
                    0,
                );
            };
            self.commands
                .submit_and_wait(ctx, "clearing the film", SUBMIT_TIMEOUT_S)?;
            stats.add_host("film setup", start.elapsed().as_secs_f64());

            // The film is copied back at whole passes, so that a lost device or exhausted memory
            // still leaves the samples finished (`RenderStats::fault`).
            // (Empty until the first checkpoint: a render that fails before it returns a
            // cleared film.)
            let mut checkpoint = Some(Checkpoint {
                pixels: Vec::new(),
                end: samples.start,
                taken: Instant::now(),
                every: if super::fault::injected() {
                    std::time::Duration::ZERO
                } else {
                    CHECKPOINT_INTERVAL
                },
            });
            let ran = self.run_batches(
                settings,
                setup,
                samples.clone(),
                frame.band_pixel_count,
                progress,
                &mut stats,
                stop,
                checkpoint.as_mut(),
            );
            end = match (ran, checkpoint) {
                (Ok(e), _) => e,
                (Err(e), Some(mut c)) => {
                    stats.fault = Some(format!("{e:#}"));
                    stats.seconds = start.elapsed().as_secs_f64();
                    c.pixels
                        .resize(frame.band_pixel_count as usize, FilmPixel::default());
                    return Ok((c.pixels, stats, c.end));
                }
                (Err(e), None) => return Err(e),
            };
            let read = Instant::now();
            let film = self.read_film(buffers, film_bytes)?;
            stats.add_host("film read-back", read.elapsed().as_secs_f64());
            match pixels.is_empty() {
                true => pixels = film,
                false => pixels.extend(film),
            }
        }
        stats.seconds = start.elapsed().as_secs_f64();
        Ok((pixels, stats, end))
    }

    /// An image of several bands, sample by sample: each sweep adds one sample to every band
    /// in turn (uploading the band's sums, rendering, copying them back), so that after every
    /// sweep the whole film holds the same samples. A lost device or exhausted memory returns
    /// the film of the last whole sweep (with the error in `stats.fault`); `stop` ends the
    /// render after the sweep it is set in. Each pixel's samples are added in sample order
    /// either way, so the sums are those of a render band after band.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn render_sweeps(
        &self,
        settings: &RenderSettings,
        setup: &Setup,
        bands: &[(u32, u32)],
        samples: std::ops::Range<u32>,
        progress: &ProgressBar,
        stats: &mut RenderStats,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<(Vec<FilmPixel>, u32)> {
        let ctx = &self.ctx;
        let buffers = &setup.buffers;
        let never = std::sync::atomic::AtomicBool::new(false);
        let total = settings.pixel_count() as usize;
        // `done`: the film after the last whole sweep; `next`: the sweep under way.
        let mut done = vec![FilmPixel::default(); total];
        let mut next = vec![FilmPixel::default(); total];
        for sample in samples.clone() {
            if sample > samples.start && stop.load(std::sync::atomic::Ordering::Relaxed) {
                return Ok((done, sample));
            }
            for &band in bands {
                let frame = Self::band_frame(setup, settings.width, band);
                let (first, count) = (
                    frame.band_first_pixel as usize,
                    frame.band_pixel_count as usize,
                );
                let film_bytes = count as u64 * size_of::<FilmPixel>() as u64;
                let swept = (|| -> Result<Vec<FilmPixel>> {
                    let film_setup = Instant::now();
                    buffers.frame.write(bytemuck::bytes_of(&frame));
                    buffers
                        .film_back
                        .write(bytemuck::cast_slice(&done[first..first + count]));
                    self.commands.begin()?;
                    self.commands
                        .copy(&buffers.film_back, &buffers.film, film_bytes);
                    self.commands
                        .submit_and_wait(ctx, "the film upload", SUBMIT_TIMEOUT_S)?;
                    stats.add_host("film setup", film_setup.elapsed().as_secs_f64());
                    self.run_batches(
                        settings,
                        setup,
                        sample..sample + 1,
                        frame.band_pixel_count,
                        progress,
                        stats,
                        &never,
                        None,
                    )?;
                    let read = Instant::now();
                    let film = self.read_film(buffers, film_bytes);
                    stats.add_host("film read-back", read.elapsed().as_secs_f64());
                    film
                })();
                match swept {
                    Ok(pixels) => next[first..first + count].copy_from_slice(&pixels),
                    Err(e) => {
                        stats.fault = Some(format!("{e:#}"));
                        return Ok((done, sample));
                    }
                }
            }
            std::mem::swap(&mut done, &mut next);
        }
        Ok((done, samples.end))
    }

    /// The first `film_bytes` of the GPU film.
    pub(super) fn read_film(
        &self,
        buffers: &RenderBuffers,
        film_bytes: u64,
    ) -> Result<Vec<FilmPixel>> {
        self.commands.begin()?;
        self.commands
            .copy(&buffers.film, &buffers.film_back, film_bytes);
        self.commands
            .submit_and_wait(&self.ctx, "the film read-back", SUBMIT_TIMEOUT_S)?;
        Ok(buffers.film_back.read_pod(film_bytes as usize))
    }

    /// One pass of a render in passes, band by band: the band's accumulators go to the GPU film
    /// (cleared on the first pass; kept there between passes when the image is one band), the
    /// band's active pixels to the list, the pass's batches run and the band comes back into
    /// `film`.
    pub(super) fn render_pass(
        &self,
        settings: &RenderSettings,
        setup: &Setup,
        pass: Pass,
        film: &mut Film,
        progress: &ProgressBar,
        stats: &mut RenderStats,
    ) -> Result<()> {
        let ctx = &self.ctx;
        let buffers = &setup.buffers;
        let bands = Self::bands(settings, setup.band_rows);
        let one_band = bands.len() == 1;
        for band in bands {
            let mut frame = Self::band_frame(setup, settings.width, band);
            let first = frame.band_first_pixel as usize;
            let count = frame.band_pixel_count as usize;
            // The band's share of the active list, made band-local.
            let listed: Option<Vec<u32>> = pass.active.map(|list| {
                let lo = list.partition_point(|&p| (p as usize) < first);
                let hi = list.partition_point(|&p| (p as usize) < first + count);
                list[lo..hi].iter().map(|&p| p - first as u32).collect()
            });
            let slots = match &listed {
                Some(l) if l.is_empty() => continue,
                Some(l) => l.len() as u32,
                None => frame.band_pixel_count,
            };
            frame.active_pixel_count = if listed.is_some() { slots } else { 0 };
            buffers.frame.write(bytemuck::bytes_of(&frame));
            let film_bytes = count as u64 * size_of::<FilmPixel>() as u64;
            let film_setup = Instant::now();
            self.commands.begin()?;
            let cmd = self.commands.cmd;
            if pass.index == 0 {
                unsafe {
                    ctx.device
                        .cmd_fill_buffer(cmd, buffers.film.buffer, 0, film_bytes, 0)
                };
            } else if !one_band {
                buffers
                    .film_back
                    .write(bytemuck::cast_slice(&film.pixels[first..first + count]));
                self.commands
                    .copy(&buffers.film_back, &buffers.film, film_bytes);
            }
            if let Some(l) = &listed {
                let bytes: &[u8] = bytemuck::cast_slice(l);
                buffers.active_upload.write(bytes);
                self.commands.copy(
                    &buffers.active_upload,
                    &buffers.active_pixels,
                    bytes.len() as u64,
                );
            }
            self.commands.submit_and_wait(
                ctx,
                "the film and active-pixel upload",
                SUBMIT_TIMEOUT_S,
            )?;
            stats.add_host("film setup", film_setup.elapsed().as_secs_f64());
            let never = std::sync::atomic::AtomicBool::new(false);
            let samples = pass.first_sample..pass.first_sample + settings.spp;
            self.run_batches(
                settings, setup, samples, slots, progress, stats, &never, None,
            )?;
            let read = Instant::now();
            film.pixels[first..first + count]
                .copy_from_slice(&self.read_film(buffers, film_bytes)?);
            stats.add_host("film read-back", read.elapsed().as_secs_f64());
        }
        Ok(())
    }
}

/// A Vulkan device behind the render seam: the renderer and the paths it keeps in flight per
/// batch (`--wavefront`; `None` for the device's default).
pub struct GpuBackend {
    pub renderer: GpuRenderer,
    pub wavefront: Option<u32>,
}

impl crate::render::Backend for GpuBackend {
    fn describe(&self) -> String {
        let d = self.renderer.device();
        format!("{} (Vulkan {}, {})", d.name, d.api_version, d.driver)
    }

    fn render_range(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        samples: std::ops::Range<u32>,
        progress: &ProgressBar,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<(RenderOutput, u32)> {
        self.renderer.render_range_with_progress(
            scene,
            settings,
            self.wavefront,
            samples,
            progress,
            stop,
        )
    }

    fn render_progressive(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        options: &Progressive,
        progress: &ProgressBar,
    ) -> Result<(RenderOutput, ProgressiveReport)> {
        self.renderer
            .render_progressive(scene, settings, self.wavefront, options, progress)
    }
}

/// How often a render of one band copies its film back while it runs (see `Checkpoint`).
const CHECKPOINT_INTERVAL: std::time::Duration = std::time::Duration::from_secs(2);
