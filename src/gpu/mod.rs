//! (Over 900 lines: the renderer's whole, ranged, banded and progressive renders share one setup; to be split by render kind.)
//! The GPU integrator: Vulkan (ash) on any Vulkan 1.2 device, lavapipe included, running the
//! wavefront kernels of `shaders/wavefront/`.

pub mod bindings;
pub mod compute;
pub mod context;
pub mod fault;
pub mod memory;
pub mod pipelines;
pub mod resources;
pub mod wavefront;

use crate::film::Film;
use crate::layout::{counter, FilmPixel, FrameParams, PathState, QueuedRay, ShadowRay};
use crate::render::progressive::{self, Pass, Progressive, ProgressiveReport};
use crate::render::{PreparedScene, RenderOutput, RenderSettings, RenderStats};
use anyhow::{bail, Result};
use ash::vk;
pub use bindings::SceneImages;
use bindings::SceneSplit;
use context::Context;
pub use context::{list_devices, DeviceInfo, INSTALL_HINT};
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
    /// Count each kernel's scene-image fetches (`RenderStats::kernel_fetches`): one atomic
    /// addition per invocation and kernel.
    pub count_fetches: bool,
}

/// A device with its pipelines built, ready to render any number of scenes.
pub struct GpuRenderer {
    commands: Commands,
    pipelines: Pipelines,
    ctx: Context,
    timing: bool,
    count_fetches: bool,
    /// At most this many pixels in the GPU film at once (besides the device's storage range).
    band_pixel_limit: Option<u64>,
    /// Per `SplitArray`, at most this many bytes in one of its bindings (besides the device's
    /// range).
    binding_limits: Option<[u64; 5]>,
    /// How the scene arrays are read where their images fit (`SceneSplit::images`).
    scene_images: SceneImages,
    /// Whether kernels are specialised for each scene's features (else made with them all).
    specialise: bool,
    /// Whether the kernels that declare one binding per scene array render also where the
    /// device binds them all (`Pipelines::with_kernels`).
    one_binding: bool,
}

impl GpuRenderer {
    pub fn new(options: &GpuOptions) -> Result<GpuRenderer> {
        let ctx = Context::new(options.device_index, options.validation)?;
        let scene_images = scene_images_for(&ctx)?;
        let pipelines = Pipelines::with_kernels(&ctx, &SceneSplit::whole(scene_images), false)?;
        let commands = Commands::new(&ctx)?;
        let timing = options.timing
            && ctx.timestamp_valid_bits > 0
            && ctx.properties.limits.timestamp_compute_and_graphics == vk::TRUE;
        Ok(GpuRenderer {
            band_pixel_limit: None,
            binding_limits: None,
            scene_images,
            specialise: true,
            one_binding: false,
            commands,
            pipelines,
            ctx,
            timing,
            count_fetches: options.count_fetches,
        })
    }

    /// Renders in bands of at most `pixels` pixels (whole rows) even where the device's storage
    /// range allows more; `None` restores the default. Results do not depend on it.
    pub fn set_band_pixel_limit(&mut self, pixels: Option<u64>) {
        self.band_pixel_limit = pixels;
    }

    /// Splits the scene's large arrays (`SplitArray` order) across bindings of at most `bytes`
    /// each even where the device's storage range allows more (`SceneSplit`); `None` restores
    /// the default. Results do not depend on it.
    pub fn set_binding_limits(&mut self, bytes: Option<[u64; 5]>) {
        self.binding_limits = bytes;
    }

    /// Counts each kernel's scene-image fetches (`GpuOptions::count_fetches`) or not.
    pub fn set_count_fetches(&mut self, count: bool) {
        self.count_fetches = count;
    }

    /// Reads the scene arrays from storage images, sampled images (where they fit) or storage
    /// buffers. Results do not depend on it.
    pub fn set_scene_images(&mut self, images: SceneImages) {
        self.scene_images = images;
    }

    /// How the scene arrays are read where their images fit.
    pub fn scene_images(&self) -> SceneImages {
        self.scene_images
    }

    /// Renders with the kernels that declare one binding per scene array (what a device that
    /// binds fewer storage buffers, such as SwiftShader, renders with) also where the device
    /// binds them all, or not; scenes whose arrays need more than one binding are then refused.
    /// Results do not depend on it.
    pub fn set_one_binding(&mut self, one_binding: bool) -> Result<()> {
        if one_binding != self.one_binding {
            self.pipelines =
                Pipelines::with_kernels(&self.ctx, &self.pipelines.split, one_binding)?;
            self.one_binding = one_binding;
        }
        Ok(())
    }

    /// Makes each scene's kernels without the code of features it lacks (the default,
    /// `PreparedScene::gpu_features`), or with every feature. Results do not depend on it.
    pub fn set_specialise(&mut self, specialise: bool) {
        self.specialise = specialise;
    }

    /// The driver's statistics of each kernel `setup` renders an `integrator` with (in
    /// `wavefront::kernels` order), where the device reports them.
    fn kernel_statistics(
        &self,
        setup: &Setup,
        integrator: crate::render::Integrator,
    ) -> Vec<(String, Vec<crate::render::KernelStatistic>)> {
        let pipelines = setup.pipelines.as_ref().unwrap_or(&self.pipelines);
        wavefront::kernels(integrator)
            .iter()
            .map(|&name| (name.to_string(), pipelines.statistics(name, setup.features)))
            .filter(|(_, statistics)| !statistics.is_empty())
            .collect()
    }

    /// How `scene`'s large arrays are laid over this device's bindings.
    pub fn scene_split(&self, scene: &PreparedScene) -> Result<SceneSplit> {
        scene_split(&self.ctx, self.scene_images, self.binding_limits, scene)
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
    /// A GPU with 8 GiB of device memory or more gets 2^21 for the path tracer (about 0.9 GiB
    /// of buffers): on an H200 the Cornell box at 1024², 64 spp ran at 144, 199 and 216 M
    /// samples/s with 2^18, 2^20 and 2^21 paths in flight, each batch's last bounces being
    /// short dispatches. Light tracing and BDPT keep 2^20 there: 2^21 paths of BDPT's subpath
    /// vertices would take 3.8 GB at depth 8, and 2^21 was measured for the path tracer only.
    pub fn default_wavefront(&self, integrator: crate::render::Integrator) -> u32 {
        let memory = &self.ctx.memory_properties;
        let device_local = memory.memory_heaps[..memory.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0);
        let large = device_local >= 8 << 30 && integrator == crate::render::Integrator::Path;
        let preferred = match (self.ctx.is_cpu(), large) {
            (true, _) => 1 << 17,
            (false, false) => 1 << 20,
            (false, true) => 1 << 21,
        };
        preferred.min(self.max_wavefront())
    }

    pub fn max_wavefront(&self) -> u32 {
        let range = self.ctx.properties.limits.max_storage_buffer_range as u64;
        let per_path = (2 * size_of::<QueuedRay>())
            .max(size_of::<ShadowRay>())
            .max(size_of::<PathState>()) as u64;
        let groups = self.ctx.properties.limits.max_compute_work_group_count[0].min(65535) as u64;
        // The hit records' image: a texel a path, in rows of SCENE_IMAGE_WIDTH.
        let image_texels = bindings::SCENE_IMAGE_WIDTH as u64
            * self.ctx.properties.limits.max_image_dimension2_d as u64;
        // path_pixel_sample's div_mod (convert.glsl) needs a batch's rounds of its pixels below
        // 2^22.
        (range / per_path)
            .min(groups * crate::layout::WORKGROUP_SIZE as u64)
            .min(image_texels)
            .min((1 << 22) - 2) as u32
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

    /// Checks the wavefront size, chooses the bands and creates the buffers of one render.
    fn setup(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
        wavefront: Option<u32>,
        active_list: bool,
    ) -> Result<Setup> {
        let ctx = &self.ctx;
        let capacity = wavefront.unwrap_or_else(|| self.default_wavefront(settings.integrator));
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
        let env = crate::lights::environment::map_or_none(&environment);
        let splatting = settings.integrator != crate::render::Integrator::Path;
        // BDPT keeps both subpaths of every path in flight, as many as one storage binding
        // holds.
        let bdpt_stride = wavefront::bdpt_vertices_per_path(settings.max_depth) as u64;
        let capacity = if settings.integrator == crate::render::Integrator::Bdpt {
            let per_path = bdpt_stride * size_of::<crate::layout::BdptVertex>() as u64;
            capacity.min((range / per_path).max(1) as u32)
        } else {
            capacity
        };
        // A splatting batch holds whole passes (or a run of pixels of one pass, `batches`), each
        // with its own splat image: the splats of one sample index make one film sample.
        let (capacity, splat_passes) = match splatting {
            false => (capacity, 0),
            true if capacity < band_pixels => (capacity, 1),
            true => {
                let passes = (capacity / band_pixels)
                    .min((range / (24 * band_pixels as u64)) as u32)
                    .max(1);
                (passes * band_pixels, passes)
            }
        };
        let bdpt_vertices = if settings.integrator == crate::render::Integrator::Bdpt {
            capacity as u64 * bdpt_stride
        } else {
            0
        };
        // A scene larger than one binding gets kernels specialised for its split.
        let split = self.scene_split(scene)?;
        // The renderer's own kernels where they were made for this split.
        let pipelines = match split == self.pipelines.split {
            true => None,
            false => Some(Pipelines::with_kernels(ctx, &split, self.one_binding)?),
        };
        let features = match self.specialise {
            true => scene.gpu_features(settings),
            false => crate::layout::FEATURES_ALL,
        };
        let making = Instant::now();
        let made = pipelines
            .as_ref()
            .unwrap_or(&self.pipelines)
            .prepare(wavefront::kernels(settings.integrator), features)?;
        let kernels_made = (made, making.elapsed().as_secs_f64());
        let buffers = RenderBuffers::new(
            ctx,
            pipelines.as_ref().unwrap_or(&self.pipelines),
            &split,
            &self.commands,
            scene,
            env,
            capacity as u64,
            band_pixels as u64,
            if active_list { band_pixels as u64 } else { 0 },
            splat_passes as u64 * band_pixels as u64,
            bdpt_vertices,
            settings.paths.as_deref(),
        )?;
        let query_pool = if self.timing {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(wavefront::query_count(settings.max_depth));
            Some(unsafe { ctx.device.create_query_pool(&info, None) }?)
        } else {
            None
        };
        Ok(Setup {
            capacity,
            band_rows,
            frame: FrameParams {
                count_fetches: self.count_fetches as u32,
                tlas_wide_root: scene.gpu_bvh().tlas_wide_root,
                ..scene.frame_params(settings)
            },
            split_bindings: buffers.split_bindings,
            scene_reads: split.reads.describe(),
            buffers,
            pipelines,
            features,
            kernels_made,
            query_pool,
        })
    }

    /// The closest hits of `rays` (origin, unit direction) as the GPU's `extend` finds them —
    /// the render's kernel, made for the scene's features, alone: no shading, no queues between
    /// kernels — and the kernel's time. `bench --bvh`'s GPU walk: it sets the traversal's rate
    /// on a device beside the wavefront's, and its hits beside the CPU reference's. Ray i is
    /// pixel i of a 1024² image at sample 0 (1024² + i, sample 1, past it) and depth 0, for the
    /// alpha key and the culling of camera rays (`surface::alpha_key` with `seed`).
    pub fn trace_closest(
        &self,
        scene: &PreparedScene,
        rays: &[(glam::Vec3, glam::Vec3)],
        seed: u32,
        rounds: u32,
    ) -> Result<Traced> {
        let rays: Vec<(glam::Vec3, glam::Vec3, f32)> =
            rays.iter().map(|&(o, d)| (o, d, f32::MAX)).collect();
        self.trace(scene, &rays, false, seed, rounds)
    }

    /// Whether anything blocks each of `rays` (origin, unit direction, t_max) as the GPU's
    /// `connect` finds it, alone, and the kernel's time (`Traced::blocked`):
    /// [`GpuRenderer::trace_closest`] for shadow rays (their alpha key's `shadow` set).
    pub fn trace_any(
        &self,
        scene: &PreparedScene,
        rays: &[(glam::Vec3, glam::Vec3, f32)],
        seed: u32,
        rounds: u32,
    ) -> Result<Traced> {
        self.trace(scene, rays, true, seed, rounds)
    }

    fn trace(
        &self,
        scene: &PreparedScene,
        rays: &[(glam::Vec3, glam::Vec3, f32)],
        any: bool,
        seed: u32,
        rounds: u32,
    ) -> Result<Traced> {
        let settings = RenderSettings {
            width: 1024,
            height: 1024,
            spp: 1,
            max_depth: 0,
            seed,
            ..RenderSettings::default()
        };
        let capacity = (rays.len() as u32).clamp(1, self.max_wavefront());
        let setup = self.setup(scene, &settings, Some(capacity), false)?;
        let result = self.trace_batches(&settings, &setup, rays, any, rounds);
        setup.destroy(&self.ctx);
        result
    }

    fn trace_batches(
        &self,
        settings: &RenderSettings,
        setup: &Setup,
        rays: &[(glam::Vec3, glam::Vec3, f32)],
        any: bool,
        rounds: u32,
    ) -> Result<Traced> {
        use vk::BufferUsageFlags as U;
        let ctx = &self.ctx;
        let buffers = &setup.buffers;
        let frame = Self::band_frame(setup, settings.width, (0, settings.height));
        buffers.frame.write(bytemuck::bytes_of(&frame));
        let capacity = setup.capacity as usize;
        let row_texels = bindings::SCENE_IMAGE_WIDTH as usize;
        let (queue, kernel, ray_bytes, result_bytes) = match any {
            false => (&buffers.rays, "extend", size_of::<QueuedRay>(), 16),
            true => (
                &buffers.shadows,
                "connect",
                size_of::<ShadowRay>(),
                size_of::<PathState>(),
            ),
        };
        let staging = memory::Buffer::new(
            ctx,
            "trace_rays",
            (capacity * ray_bytes) as u64,
            U::TRANSFER_SRC,
            memory::Location::Host,
        )?;
        let results_back = memory::Buffer::new(
            ctx,
            "trace_results",
            (capacity.div_ceil(row_texels) * row_texels * result_bytes) as u64,
            U::TRANSFER_DST,
            memory::Location::Host,
        )?;
        let (mut hits, mut blocked) = (Vec::new(), Vec::new());
        let mut best: Option<f64> = None;
        for round in 0..rounds.max(1) {
            let mut kernel_seconds = 0.0;
            for (b, chunk) in rays.chunks(capacity).enumerate() {
                let rays = chunk.iter().enumerate();
                let bytes = match any {
                    false => staging.write_pod(rays.map(|(i, (origin, dir, _))| QueuedRay {
                        origin: origin.to_array(),
                        path: i as u32,
                        dir: dir.to_array(),
                        pad: 0,
                    })),
                    true => staging.write_pod(rays.map(|(i, (origin, dir, t_max))| ShadowRay {
                        origin: origin.to_array(),
                        path: i as u32,
                        dir: dir.to_array(),
                        t_max: *t_max,
                        contribution: [1.0, 0.0, 0.0],
                        pad: 0,
                    })),
                };
                self.commands.begin()?;
                self.commands.copy(&staging, queue, bytes as u64);
                if any {
                    // connect adds an unoccluded ray's contribution to its path's radiance.
                    unsafe {
                        ctx.device.cmd_fill_buffer(
                            self.commands.cmd,
                            buffers.paths.buffer,
                            0,
                            vk::WHOLE_SIZE,
                            0,
                        )
                    };
                }
                let mut recorder = self.recorder(setup, frame.band_pixel_count);
                let batch = wavefront::Batch {
                    first_sample: 0,
                    first_pixel: (b * capacity) as u32,
                    size: chunk.len() as u32,
                };
                match any {
                    false => recorder.record_trace(batch),
                    true => recorder.record_trace_any(batch),
                }
                let timed = std::mem::take(&mut recorder.timed);
                self.kernels_to_transfers();
                match any {
                    false => {
                        let rows = chunk.len().div_ceil(row_texels) as u32;
                        self.commands
                            .copy_rows_from_image(&buffers.hit_image, &results_back, rows);
                    }
                    true => self.commands.copy(
                        &buffers.paths,
                        &results_back,
                        (chunk.len() * result_bytes) as u64,
                    ),
                }
                let started = Instant::now();
                self.commands
                    .submit_batch(ctx, "tracing rays", SUBMIT_TIMEOUT_S)?;
                kernel_seconds += match setup.query_pool {
                    Some(pool) => self
                        .kernel_times(pool, &timed)?
                        .filter(|(name, _)| *name == kernel)
                        .map(|(_, dt)| dt)
                        .sum::<f64>(),
                    None => started.elapsed().as_secs_f64(),
                };
                if round > 0 {
                    continue;
                }
                match any {
                    false => {
                        let texels: Vec<[u32; 4]> = results_back.read_pod(16 * chunk.len());
                        hits.extend(texels.iter().map(|h| crate::layout::HitRecord {
                            t: f32::from_bits(h[0]),
                            triangle: h[1],
                            u: f32::from_bits(h[2]),
                            v: f32::from_bits(h[3]),
                            ..Default::default()
                        }));
                    }
                    true => {
                        // connect added the ray's contribution where nothing blocked it.
                        let paths: Vec<PathState> =
                            results_back.read_pod(chunk.len() * result_bytes);
                        blocked.extend(paths.iter().map(|p| p.radiance[0] == 0.0));
                    }
                }
            }
            best = Some(best.map_or(kernel_seconds, |b: f64| b.min(kernel_seconds)));
        }
        self.ctx.check_validation()?;
        Ok(Traced {
            hits,
            blocked,
            kernel_seconds: best.unwrap_or(0.0),
            timed: setup.query_pool.is_some(),
        })
    }

    /// The device memory `setup` holds and how its scene lies over the bindings.
    fn device_memory(&self, setup: &Setup) -> crate::render::DeviceMemory {
        let report = match self.ctx.allocator.lock() {
            Ok(a) => a.generate_report(),
            Err(_) => return Default::default(),
        };
        let split = bindings::SplitArray::ALL
            .into_iter()
            .zip(setup.split_bindings)
            .filter(|(_, n)| *n > 1)
            .map(|(array, n)| (array.what().to_string(), n))
            .collect();
        crate::render::DeviceMemory {
            buffers: report.allocations.len(),
            allocated: report.total_allocated_bytes,
            reserved: report.total_capacity_bytes,
            blocks: report.blocks.len(),
            split,
            scene_reads: setup.scene_reads,
        }
    }

    /// The bands of the image: (first row, rows).
    fn bands(settings: &RenderSettings, band_rows: u32) -> Vec<(u32, u32)> {
        (0..settings.height)
            .step_by(band_rows as usize)
            .map(|first_row| (first_row, band_rows.min(settings.height - first_row)))
            .collect()
    }

    /// The frame constants of the band starting at `first_row`.
    fn band_frame(setup: &Setup, width: u32, (first_row, rows): (u32, u32)) -> FrameParams {
        FrameParams {
            band_first_pixel: first_row * width,
            band_pixel_count: rows * width,
            ..setup.frame
        }
    }

    /// Renders the image band by band: clear the band's film, run its batches, read it back.
    /// Stops early (see `run_batches`) only when the image is one band; returns the end of the
    /// samples rendered.
    fn render_bands(
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
                every: if fault::injected() {
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
    fn render_sweeps(
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
    fn read_film(&self, buffers: &RenderBuffers, film_bytes: u64) -> Result<Vec<FilmPixel>> {
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
    fn render_pass(
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

    /// Every batch of one band (or of the band's `pixel_count` active pixels), samples
    /// `samples`, each batch recorded into one command buffer and submitted. After a batch that
    /// ends a whole sample pass, stops if `stop` is set; returns the end of the samples
    /// rendered.
    #[allow(clippy::too_many_arguments)]
    fn run_batches(
        &self,
        settings: &RenderSettings,
        setup: &Setup,
        samples: std::ops::Range<u32>,
        pixel_count: u32,
        progress: &ProgressBar,
        stats: &mut RenderStats,
        stop: &std::sync::atomic::AtomicBool,
        mut checkpoint: Option<&mut Checkpoint>,
    ) -> Result<u32> {
        let first_sample = samples.start;
        let ctx = &self.ctx;
        let (capacity, buffers, query_pool) = (setup.capacity, &setup.buffers, setup.query_pool);
        let (counters, counters_back) = (&buffers.counters, &buffers.counters_back);
        for mut batch in batches(pixel_count, samples.len() as u32, capacity) {
            // A batch that starts at pixel 0 starts a sample pass: every pixel has the same samples.
            if batch.first_pixel == 0 && stop.load(std::sync::atomic::Ordering::Relaxed) {
                return Ok(batch.first_sample + first_sample);
            }
            batch.first_sample += first_sample;
            let submitted = Instant::now();
            self.commands.begin()?;
            let mut recorder = self.recorder(setup, pixel_count);
            // (A batch of whole passes ends each of them.)
            let pass_done = batch.first_pixel + batch.size >= pixel_count;
            match settings.integrator {
                crate::render::Integrator::Path => recorder.record_batch(batch, settings.max_depth),
                crate::render::Integrator::Light => {
                    recorder.record_light_batch(batch, settings.max_depth, pass_done)
                }
                crate::render::Integrator::Bdpt => {
                    recorder.record_bdpt_batch(batch, settings.max_depth, pass_done)
                }
            }
            let timed = std::mem::take(&mut recorder.timed);
            self.kernels_to_transfers();
            self.commands.copy(counters, counters_back, counters.size);
            self.commands
                .submit_batch(ctx, "a wavefront batch", SUBMIT_TIMEOUT_S)?;
            let batch_seconds = submitted.elapsed().as_secs_f64();
            stats.submissions += 1;
            let c: Vec<u32> = counters_back.read_pod(counters.size as usize);
            stats.extension_rays += c[counter::TOTAL_EXTENSION_RAYS as usize] as u64;
            stats.shadow_rays += c[counter::TOTAL_SHADOW_RAYS as usize] as u64;
            stats.dropped += c[counter::DROPPED_SAMPLES as usize] as u64;
            if self.count_fetches {
                for (k, (name, _)) in crate::kernels::KERNELS.iter().enumerate() {
                    let at = (counter::FETCHES + 2 * k as u32) as usize;
                    let n = c[at] as u64 | (c[at + 1] as u64) << 32;
                    match stats.kernel_fetches.iter_mut().find(|(m, _)| m == name) {
                        Some((_, total)) => *total += n,
                        None if n > 0 => stats.kernel_fetches.push((name.to_string(), n)),
                        None => {}
                    }
                }
            }
            progress.inc(batch.size as u64);
            if let Some(c) = checkpoint.as_deref_mut() {
                let passes_done = batch.first_pixel + batch.size >= pixel_count;
                if passes_done && c.taken.elapsed() >= c.every {
                    let bytes = pixel_count as u64 * size_of::<FilmPixel>() as u64;
                    c.pixels = self.read_film(buffers, bytes)?;
                    c.end = batch.first_sample + (batch.size / pixel_count).max(1);
                    c.taken = Instant::now();
                }
            }
            if let Some(pool) = query_pool {
                let mut kernels = 0.0;
                for (name, dt) in self.kernel_times(pool, &timed)? {
                    kernels += dt;
                    match stats.kernel_seconds.iter_mut().find(|(n, _)| n == name) {
                        Some((_, s)) => *s += dt,
                        None => stats.kernel_seconds.push((name.to_string(), dt)),
                    }
                }
                stats.add_host("between batches", (batch_seconds - kernels).max(0.0));
            }
        }
        Ok(samples.end)
    }

    /// A recorder of `setup`'s kernels into the renderer's command buffer, its descriptor set
    /// bound: `pixel_count` pixels in the band.
    fn recorder<'a>(&'a self, setup: &'a Setup, pixel_count: u32) -> Recorder<'a> {
        let ctx = &self.ctx;
        let pipelines = setup.pipelines.as_ref().unwrap_or(&self.pipelines);
        unsafe {
            ctx.device.cmd_bind_descriptor_sets(
                self.commands.cmd,
                vk::PipelineBindPoint::COMPUTE,
                pipelines.layout,
                0,
                &[pipelines.set],
                &[],
            );
        }
        Recorder {
            device: &ctx.device,
            labels: ctx.labels.as_ref(),
            pipelines,
            cmd: self.commands.cmd,
            args: &setup.buffers.args,
            counters: &setup.buffers.counters,
            pixel_count,
            features: setup.features,
            timestamps: setup.query_pool,
            timed: Vec::new(),
        }
    }

    /// Makes the kernels' writes visible to the transfers recorded after it (read-backs).
    fn kernels_to_transfers(&self) {
        memory::barrier(
            &self.ctx.device,
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
    }

    /// Each timed dispatch of a finished submission and its seconds, from the timestamps the
    /// recorder wrote into `pool` (one before the first dispatch, one after each).
    fn kernel_times<'t>(
        &self,
        pool: vk::QueryPool,
        timed: &'t [&'static str],
    ) -> Result<impl Iterator<Item = (&'static str, f64)> + 't> {
        let ctx = &self.ctx;
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
        Ok(timed
            .iter()
            .enumerate()
            .map(move |(k, name)| (*name, ticks[k + 1].saturating_sub(ticks[k]) as f64 * period)))
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

/// The film of a render of one band as it stood after its last whole sample pass copied back:
/// samples [start, `end`) of every pixel.
struct Checkpoint {
    pixels: Vec<FilmPixel>,
    end: u32,
    taken: Instant,
    every: std::time::Duration,
}

/// How kernels on `ctx` read the scene arrays: the device's default, or what
/// WAVETRACE_SCENE_IMAGES=buffers|storage|sampled chooses, to measure them.
fn scene_images_for(ctx: &Context) -> Result<SceneImages> {
    SceneImages::for_device(
        ctx.is_cpu(),
        std::env::var("WAVETRACE_SCENE_IMAGES").ok().as_deref(),
    )
}

/// How `scene`'s large arrays are laid over `ctx`'s bindings, read as `scene_images` says where
/// their images fit, each binding at most `binding_limits` bytes where given.
fn scene_split(
    ctx: &Context,
    scene_images: SceneImages,
    binding_limits: Option<[u64; 5]>,
    scene: &PreparedScene,
) -> Result<SceneSplit> {
    let range = ctx.properties.limits.max_storage_buffer_range as u64;
    let len = |n: usize| n as u64;
    // Arrays read from images need no buffer.
    let max_rows = ctx.properties.limits.max_image_dimension2_d as u64;
    let images = scene_images != SceneImages::Buffers
        && bindings::SceneImage::ALL
            .iter()
            .all(|i| i.rows(scene) <= max_rows);
    let in_buffers = |n: usize| if images { 0 } else { len(n) };
    let mut split = SceneSplit::plan(
        [
            in_buffers(scene.gpu_bvh().nodes.len()),
            in_buffers(scene.triangles.len()),
            in_buffers(scene.triangle_vertices.len()),
            in_buffers(scene.vertices.len()),
            in_buffers(scene.texels.len()),
        ],
        [
            size_of::<crate::layout::BvhNode>() as u64,
            size_of::<crate::layout::GpuTriangle>() as u64,
            16,
            size_of::<crate::layout::GpuVertex>() as u64,
            4,
        ],
        binding_limits
            .unwrap_or([u64::MAX; 5])
            .map(|b| b.min(range)),
    )?;
    split.reads = match images {
        true => scene_images,
        false => SceneImages::Buffers,
    };
    Ok(split)
}

/// What [`GpuRenderer::trace_closest`] or [`GpuRenderer::trace_any`] found, in ray order, and
/// the seconds its kernel took, the best of the rounds.
pub struct Traced {
    /// `trace_closest`: each ray's hit (`triangle` = `NO_HIT` on a miss; the instance is not
    /// read back). Empty for `trace_any`.
    pub hits: Vec<crate::layout::HitRecord>,
    /// `trace_any`: whether something blocks each ray. Empty for `trace_closest`.
    pub blocked: Vec<bool>,
    pub kernel_seconds: f64,
    /// Whether `kernel_seconds` are the kernel's timestamps (else the submissions' wall time).
    pub timed: bool,
}

/// A device's shader compiler without the renderer: makes the kernels a scene renders with
/// (specialised for its features and its arrays' bindings, as a render makes them) and reads
/// the driver's statistics of each, submitting no work (`bench --kernels`). It therefore also
/// runs on a device that compiles but cannot run work, such as Mesa RADV's null device
/// (`RADV_FORCE_FAMILY=navi31`: AMD's compiler, ACO, with no AMD GPU present), whose registers,
/// spills and instruction counts are a real GPU compiler's view of each kernel.
pub struct KernelCompiler {
    ctx: Context,
    scene_images: SceneImages,
}

/// The kernels one render of a scene is made of, with the driver's statistics of each.
#[derive(Clone, Debug)]
pub struct CompiledKernels {
    /// The features they were specialised for (`PreparedScene::gpu_features`).
    pub features: u32,
    /// Every kernel of the integrator, in `wavefront::kernels` order, with its statistics
    /// (empty where the device reports none).
    pub kernels: Vec<(String, Vec<crate::render::KernelStatistic>)>,
}

impl KernelCompiler {
    pub fn new(device_index: Option<usize>) -> Result<KernelCompiler> {
        let ctx = Context::new(device_index, false)?;
        let scene_images = scene_images_for(&ctx)?;
        Ok(KernelCompiler { ctx, scene_images })
    }

    pub fn device(&self) -> &DeviceInfo {
        &self.ctx.info
    }

    /// Whether the device reports its kernels' statistics
    /// (`VK_KHR_pipeline_executable_properties`).
    pub fn reports_statistics(&self) -> bool {
        self.ctx.executable_properties.is_some()
    }

    /// Makes the kernels that render `scene` with `settings` would use and reads their
    /// statistics.
    pub fn compile(
        &self,
        scene: &PreparedScene,
        settings: &RenderSettings,
    ) -> Result<CompiledKernels> {
        let split = scene_split(&self.ctx, self.scene_images, None, scene)?;
        let pipelines = Pipelines::with_kernels(&self.ctx, &split, false)?;
        let features = scene.gpu_features(settings);
        let names = wavefront::kernels(settings.integrator);
        pipelines.prepare(names, features)?;
        Ok(CompiledKernels {
            features,
            kernels: names
                .iter()
                .map(|&name| (name.to_string(), pipelines.statistics(name, features)))
                .collect(),
        })
    }
}

/// What one render holds between its passes: the paths in flight, the band height, the frame
/// constants of the whole image, the buffers and the timestamp pool.
struct Setup {
    capacity: u32,
    band_rows: u32,
    frame: FrameParams,
    buffers: RenderBuffers,
    /// Kernels specialised for a scene split across bindings (else the renderer's own).
    pipelines: Option<Pipelines>,
    /// The scene's features, for which the kernels were specialised.
    features: u32,
    /// How many of the render's kernels its setup made (the others were made for an earlier
    /// render) and how long that took (`RenderStats::kernels_made`).
    kernels_made: (usize, f64),
    /// Bindings each `SplitArray` uses.
    split_bindings: [u32; 5],
    /// How the kernels read the scene arrays (`SceneImages::describe`).
    scene_reads: &'static str,
    query_pool: Option<vk::QueryPool>,
}

impl Setup {
    fn destroy(self, ctx: &Context) {
        if let Some(pool) = self.query_pool {
            unsafe { ctx.device.destroy_query_pool(pool, None) };
        }
    }
}
