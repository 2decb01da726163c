//! The GPU integrator: Vulkan (ash) on any Vulkan 1.2 device, lavapipe included, running the
//! wavefront kernels of `shaders/wavefront/`.

pub mod context;
pub mod memory;
pub mod pipelines;
pub mod wavefront;

pub use context::{list_devices, DeviceInfo, INSTALL_HINT};

use crate::film::Film;
use crate::layout::{counter, FilmPixel, HitRecord, PathState, QueuedRay, ShadowRay};
use crate::render::{PreparedScene, RenderOutput, RenderSettings, RenderStats};
use anyhow::{bail, Result};
use ash::vk;
use context::Context;
use indicatif::ProgressBar;
use memory::{Buffer, Commands, Location};
use pipelines::{Binding, Pipelines};
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

/// Longest a batch may run before the render is abandoned as hung.
const BATCH_TIMEOUT_S: u64 = 300;

/// A device with its pipelines built, ready to render any number of scenes.
pub struct GpuRenderer {
    commands: Commands,
    pipelines: Pipelines,
    ctx: Context,
    timing: bool,
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
            commands,
            pipelines,
            ctx,
            timing,
        })
    }

    pub fn device(&self) -> &DeviceInfo {
        &self.ctx.info
    }

    pub fn validating(&self) -> bool {
        self.ctx.validating()
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
        let pixel_count = settings.pixel_count();
        let film_bytes = pixel_count * size_of::<FilmPixel>() as u64;
        let range = ctx.properties.limits.max_storage_buffer_range as u64;
        if film_bytes > range {
            bail!(
                "a {}×{} film needs {} MiB in one storage buffer but {} allows {} MiB: render a smaller image or use --device cpu",
                settings.width,
                settings.height,
                film_bytes >> 20,
                ctx.info.name,
                range >> 20
            );
        }
        let capacity = wavefront.unwrap_or_else(|| self.default_wavefront());
        if capacity == 0 || capacity > self.max_wavefront() {
            bail!(
                "--wavefront {capacity}: this device takes 1 to {} paths in flight",
                self.max_wavefront()
            );
        }
        let cap = capacity as u64;
        let frame = scene.frame_params(settings);

        use vk::BufferUsageFlags as U;
        let storage = U::STORAGE_BUFFER | U::TRANSFER_DST | U::TRANSFER_SRC;
        let device_buffer =
            |name: &str, bytes: u64| Buffer::new(ctx, name, bytes, storage, Location::Device);
        let frame_buf =
            Buffer::with_data(ctx, "frame", bytemuck::bytes_of(&frame), U::UNIFORM_BUFFER)?;
        let nodes = device_buffer(
            "bvh_nodes",
            std::mem::size_of_val(scene.bvh.nodes.as_slice()) as u64,
        )?;
        let triangles = device_buffer(
            "triangles",
            std::mem::size_of_val(scene.triangles.as_slice()) as u64,
        )?;
        let materials = device_buffer(
            "materials",
            std::mem::size_of_val(scene.materials.as_slice()) as u64,
        )?;
        let lights = device_buffer(
            "lights",
            std::mem::size_of_val(scene.lights.as_slice()) as u64,
        )?;
        let paths = device_buffer("paths", cap * size_of::<PathState>() as u64)?;
        let rays = device_buffer("rays", 2 * cap * size_of::<QueuedRay>() as u64)?;
        let hits = device_buffer("hits", cap * size_of::<HitRecord>() as u64)?;
        let shadows = device_buffer("shadow_rays", cap * size_of::<ShadowRay>() as u64)?;
        let film = device_buffer("film", film_bytes)?;
        let counters = device_buffer("counters", 4 * counter::COUNT as u64)?;
        let args = Buffer::new(
            ctx,
            "dispatch_args",
            16 * crate::layout::args::COUNT as u64,
            U::STORAGE_BUFFER | U::INDIRECT_BUFFER,
            Location::Device,
        )?;
        let counters_back = Buffer::new(
            ctx,
            "counters_readback",
            counters.size,
            U::TRANSFER_DST,
            Location::Host,
        )?;
        self.pipelines.bind_buffers(&[
            (Binding::Frame, frame_buf.buffer),
            (Binding::BvhNodes, nodes.buffer),
            (Binding::Triangles, triangles.buffer),
            (Binding::Materials, materials.buffer),
            (Binding::Lights, lights.buffer),
            (Binding::Paths, paths.buffer),
            (Binding::Rays, rays.buffer),
            (Binding::Hits, hits.buffer),
            (Binding::Shadows, shadows.buffer),
            (Binding::Film, film.buffer),
            (Binding::Counters, counters.buffer),
            (Binding::Args, args.buffer),
        ]);

        // Upload the scene and clear the film.
        let staged: Vec<(Buffer, &Buffer)> = [
            (bytemuck::cast_slice::<_, u8>(&scene.bvh.nodes), &nodes),
            (bytemuck::cast_slice(&scene.triangles), &triangles),
            (bytemuck::cast_slice(&scene.materials), &materials),
            (bytemuck::cast_slice(&scene.lights), &lights),
        ]
        .into_iter()
        .filter(|(data, _)| !data.is_empty())
        .map(|(data, dst)| {
            Ok((
                Buffer::with_data(ctx, "staging", data, U::TRANSFER_SRC)?,
                dst,
            ))
        })
        .collect::<Result<_>>()?;
        self.commands.begin()?;
        for (src, dst) in &staged {
            self.commands.copy(src, dst, src.size.min(dst.size));
        }
        unsafe {
            ctx.device
                .cmd_fill_buffer(self.commands.cmd, film.buffer, 0, vk::WHOLE_SIZE, 0)
        };
        self.commands
            .submit_and_wait(ctx, "the scene upload", BATCH_TIMEOUT_S)?;
        drop(staged);

        let query_pool = if self.timing {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(3 + 5 * (settings.max_depth + 1));
            Some(unsafe { ctx.device.create_query_pool(&info, None) }?)
        } else {
            None
        };
        let result = self.run_batches(
            settings,
            capacity,
            pixel_count as u32,
            &counters,
            &counters_back,
            &args,
            query_pool,
            progress,
        );
        if let Some(pool) = query_pool {
            unsafe { ctx.device.destroy_query_pool(pool, None) };
        }
        let mut stats = result?;

        // Read the film back.
        let film_back = Buffer::new(
            ctx,
            "film_readback",
            film_bytes,
            U::TRANSFER_DST,
            Location::Host,
        )?;
        self.commands.begin()?;
        self.commands.copy(&film, &film_back, film_bytes);
        self.commands
            .submit_and_wait(ctx, "the film read-back", BATCH_TIMEOUT_S)?;
        let pixels: Vec<FilmPixel> =
            bytemuck::pod_collect_to_vec(&film_back.read(film_bytes as usize));
        ctx.check_validation()?;
        stats.samples = settings.total_samples();
        let film = Film::from_pixels(settings.width, settings.height, pixels, stats.dropped);
        Ok(RenderOutput { film, stats })
    }

    #[allow(clippy::too_many_arguments)]
    fn run_batches(
        &self,
        settings: &RenderSettings,
        capacity: u32,
        pixel_count: u32,
        counters: &Buffer,
        counters_back: &Buffer,
        args: &Buffer,
        query_pool: Option<vk::QueryPool>,
        progress: &ProgressBar,
    ) -> Result<RenderStats> {
        let ctx = &self.ctx;
        let mut stats = RenderStats::default();
        let mut kernel_seconds: Vec<(String, f64)> = Vec::new();
        let start = Instant::now();
        for batch in batches(pixel_count, settings.spp, capacity) {
            self.commands.begin()?;
            let mut recorder = Recorder {
                device: &ctx.device,
                labels: ctx.labels.as_ref(),
                pipelines: &self.pipelines,
                cmd: self.commands.cmd,
                args,
                counters,
                pixel_count,
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
            unsafe {
                let barrier = [vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                    .dst_access_mask(vk::AccessFlags::TRANSFER_READ)];
                ctx.device.cmd_pipeline_barrier(
                    self.commands.cmd,
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &barrier,
                    &[],
                    &[],
                );
            }
            self.commands.copy(counters, counters_back, counters.size);
            self.commands
                .submit_and_wait(ctx, "a wavefront batch", BATCH_TIMEOUT_S)?;
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
                    match kernel_seconds.iter_mut().find(|(n, _)| n == name) {
                        Some((_, s)) => *s += dt,
                        None => kernel_seconds.push((name.to_string(), dt)),
                    }
                }
            }
        }
        stats.seconds = start.elapsed().as_secs_f64();
        stats.kernel_seconds = kernel_seconds;
        Ok(stats)
    }
}
