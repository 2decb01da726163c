//! The GPU integrator: Vulkan (ash) on any Vulkan 1.2 device, lavapipe included, running the
//! wavefront kernels of `shaders/wavefront/`.

pub mod compute;
pub mod context;
pub mod memory;
pub mod pipelines;
pub mod resources;
pub mod wavefront;

pub use context::{list_devices, DeviceInfo, INSTALL_HINT};

use crate::film::Film;
use crate::layout::{counter, FilmPixel, FrameParams, PathState, QueuedRay, ShadowRay};
use crate::render::{PreparedScene, RenderOutput, RenderSettings, RenderStats};
use anyhow::{bail, Result};
use ash::vk;
use context::Context;
use indicatif::ProgressBar;
use memory::Commands;
use pipelines::Pipelines;
use resources::{RenderBuffers, SUBMIT_TIMEOUT_S};
use std::mem::size_of;
use std::time::Instant;
use wavefront::{batches, Recorder};

/// How the GPU integrator runs.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Device index as `wavetrace devices` lists them; `None` picks the best.
    pub device_index: Option<usize>,
    /// Enable the Khronos validation layer when installed; its errors fail the render.
    pub validation: bool,
    /// Timestamp every dispatch for per-kernel times.
    pub timing: bool,
}

/// A device with its pipelines built, ready to render any number of scenes.
pub struct GpuRenderer {
    commands: Commands,
    pipelines: Pipelines,
    ctx: Context,
    timing: bool,
    /// At most this many pixels in the GPU film at once (besides the device's storage range).
    band_pixel_limit: Option<u64>,
}

impl GpuRenderer {
    pub fn new(options: &GpuOptions) -> Result<GpuRenderer> {
        let ctx = Context::new(options.device_index, options.validation)?;
        let pipelines = Pipelines::new(&ctx)?;
        let commands = Commands::new(&ctx)?;
        let timing = options.timing
            && ctx.timestamp_valid_bits > 0
            && ctx.properties.limits.timestamp_compute_and_graphics == vk::TRUE;
        Ok(GpuRenderer {
            band_pixel_limit: None,
            commands,
            pipelines,
            ctx,
            timing,
        })
    }

    /// Renders in bands of at most `pixels` pixels (whole rows) even where the device's storage
    /// range allows more; `None` restores the default. Results do not depend on it.
    pub fn set_band_pixel_limit(&mut self, pixels: Option<u64>) {
        self.band_pixel_limit = pixels;
    }

    pub fn device(&self) -> &DeviceInfo {
        &self.ctx.info
    }

    pub fn validating(&self) -> bool {
        self.ctx.validating()
    }

    /// The Vulkan context (device, queue, validation messages).
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// The default number of paths in flight: smaller on CPU devices, bounded by the storage
    /// range of one binding (the ray queues hold two rays per path) and by 65535 workgroups.
    pub fn default_wavefront(&self) -> u32 {
        let preferred = if self.ctx.is_cpu() { 1 << 17 } else { 1 << 20 };
        preferred.min(self.max_wavefront())
    }

    pub fn max_wavefront(&self) -> u32 {
        let range = self.ctx.properties.limits.max_storage_buffer_range as u64;
        let per_path = (2 * size_of::<QueuedRay>())
            .max(size_of::<ShadowRay>())
            .max(size_of::<PathState>()) as u64;
        let groups = self.ctx.properties.limits.max_compute_work_group_count[0].min(65535) as u64;
        (range / per_path).min(groups * crate::layout::WORKGROUP_SIZE as u64) as u32
    }

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
        let ctx = &self.ctx;
        let capacity = wavefront.unwrap_or_else(|| self.default_wavefront());
        if capacity == 0 || capacity > self.max_wavefront() {
            bail!(
                "--wavefront {capacity}: this device takes 1 to {} paths in flight",
                self.max_wavefront()
            );
        }
        // The film is rendered in bands of whole rows that fit one storage binding.
        let range = ctx.properties.limits.max_storage_buffer_range as u64;
        let band_limit = self
            .band_pixel_limit
            .unwrap_or(u64::MAX)
            .min(range / size_of::<FilmPixel>() as u64);
        let band_rows =
            (band_limit / settings.width as u64).clamp(1, settings.height as u64) as u32;
        let band_pixels = band_rows * settings.width;
        let environment = settings.environment_map();
        let env = environment
            .as_ref()
            .map_or(crate::environment::no_environment(), |(map, _)| {
                map.as_ref()
            });
        let buffers = RenderBuffers::new(
            ctx,
            &self.pipelines,
            &self.commands,
            scene,
            env,
            capacity as u64,
            band_pixels as u64,
        )?;
        let query_pool = if self.timing {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(wavefront::query_count(settings.max_depth));
            Some(unsafe { ctx.device.create_query_pool(&info, None) }?)
        } else {
            None
        };
        let result = self.render_bands(
            scene, settings, capacity, band_rows, &buffers, query_pool, progress,
        );
        if let Some(pool) = query_pool {
            unsafe { ctx.device.destroy_query_pool(pool, None) };
        }
        let (pixels, mut stats) = result?;
        ctx.check_validation()?;
        stats.samples = settings.total_samples();
        let film = Film::from_pixels(settings.width, settings.height, pixels, stats.dropped);
        Ok(RenderOutput { film, stats })
    }

    /// Renders the image band by band: clear the band's film, run its batches, read it back.
    #[allow(clippy::too_many_arguments)]
    fn render_bands(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        capacity: u32,
        band_rows: u32,
        buffers: &RenderBuffers,
        query_pool: Option<vk::QueryPool>,
        progress: &ProgressBar,
    ) -> Result<(Vec<FilmPixel>, RenderStats)> {
        let ctx = &self.ctx;
        let mut pixels = Vec::with_capacity(settings.pixel_count() as usize);
        let mut stats = RenderStats::default();
        let start = Instant::now();
        for first_row in (0..settings.height).step_by(band_rows as usize) {
            let rows = band_rows.min(settings.height - first_row);
            let frame = FrameParams {
                band_first_pixel: first_row * settings.width,
                band_pixel_count: rows * settings.width,
                ..scene.frame_params(settings)
            };
            buffers.frame.write(bytemuck::bytes_of(&frame));
            let film_bytes = frame.band_pixel_count as u64 * size_of::<FilmPixel>() as u64;
            self.commands.begin()?;
            unsafe {
                ctx.device
                    .cmd_fill_buffer(self.commands.cmd, buffers.film.buffer, 0, film_bytes, 0)
            };
            self.commands
                .submit_and_wait(ctx, "clearing the film", SUBMIT_TIMEOUT_S)?;

            self.run_batches(
                settings,
                capacity,
                frame.band_pixel_count,
                buffers,
                query_pool,
                progress,
                &mut stats,
            )?;

            self.commands.begin()?;
            self.commands
                .copy(&buffers.film, &buffers.film_back, film_bytes);
            self.commands
                .submit_and_wait(ctx, "the film read-back", SUBMIT_TIMEOUT_S)?;
            pixels.extend(bytemuck::pod_collect_to_vec::<u8, FilmPixel>(
                &buffers.film_back.read(film_bytes as usize),
            ));
        }
        stats.seconds = start.elapsed().as_secs_f64();
        Ok((pixels, stats))
    }

    /// Every batch of one band, each recorded into one command buffer and submitted.
    #[allow(clippy::too_many_arguments)]
    fn run_batches(
        &self,
        settings: &RenderSettings,
        capacity: u32,
        band_pixels: u32,
        buffers: &RenderBuffers,
        query_pool: Option<vk::QueryPool>,
        progress: &ProgressBar,
        stats: &mut RenderStats,
    ) -> Result<()> {
        let ctx = &self.ctx;
        let (counters, counters_back, args) =
            (&buffers.counters, &buffers.counters_back, &buffers.args);
        for batch in batches(band_pixels, settings.spp, capacity) {
            self.commands.begin()?;
            let mut recorder = Recorder {
                device: &ctx.device,
                labels: ctx.labels.as_ref(),
                pipelines: &self.pipelines,
                cmd: self.commands.cmd,
                args,
                counters,
                pixel_count: band_pixels,
                timestamps: query_pool,
                timed: Vec::new(),
            };
            unsafe {
                ctx.device.cmd_bind_descriptor_sets(
                    self.commands.cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    self.pipelines.layout,
                    0,
                    &[self.pipelines.set],
                    &[],
                );
            }
            recorder.record_batch(batch, settings.max_depth);
            let timed = std::mem::take(&mut recorder.timed);
            memory::barrier(
                &ctx.device,
                self.commands.cmd,
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::AccessFlags::SHADER_WRITE,
                ),
                (
                    vk::PipelineStageFlags::TRANSFER,
                    vk::AccessFlags::TRANSFER_READ,
                ),
            );
            self.commands.copy(counters, counters_back, counters.size);
            self.commands
                .submit_and_wait(ctx, "a wavefront batch", SUBMIT_TIMEOUT_S)?;
            let c: Vec<u32> =
                bytemuck::pod_collect_to_vec(&counters_back.read(counters.size as usize));
            stats.extension_rays += c[counter::TOTAL_EXTENSION_RAYS as usize] as u64;
            stats.shadow_rays += c[counter::TOTAL_SHADOW_RAYS as usize] as u64;
            stats.dropped += c[counter::DROPPED_SAMPLES as usize] as u64;
            progress.inc(batch.size as u64);
            if let Some(pool) = query_pool {
                let mut ticks = vec![0u64; timed.len() + 1];
                unsafe {
                    ctx.device.get_query_pool_results(
                        pool,
                        0,
                        &mut ticks,
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                }?;
                let period = ctx.properties.limits.timestamp_period as f64 * 1e-9;
                for (k, name) in timed.iter().enumerate() {
                    let dt = ticks[k + 1].saturating_sub(ticks[k]) as f64 * period;
                    match stats.kernel_seconds.iter_mut().find(|(n, _)| n == name) {
                        Some((_, s)) => *s += dt,
                        None => stats.kernel_seconds.push((name.to_string(), dt)),
                    }
                }
            }
        }
        Ok(())
    }
}
