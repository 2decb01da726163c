//! The GPU renderer: a Vulkan (ash) device, lavapipe included, with the pipelines made for a
//! scene, the setup of a render (buffers, queues, film) and the batches of the wavefront loop
//! recorded and run; `gpu/passes.rs` renders with it, `gpu/trace.rs` runs its walks alone.

use super::bindings::{SceneImages, SceneSplit};
use super::context::Context;
use super::context::DeviceInfo;
use super::memory::Commands;
use super::pipelines::Pipelines;
use super::resources::{RenderBuffers, SUBMIT_TIMEOUT_S};
use super::wavefront::{batches, Recorder};
use crate::layout::{counter, FilmPixel, FrameParams, PathState, QueuedRay, ShadowRay};
use crate::render::{PreparedScene, RenderSettings, RenderStats};
use anyhow::{bail, Result};
use ash::vk;
use indicatif::ProgressBar;
use std::mem::size_of;
use std::time::Instant;

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
    pub(super) commands: Commands,
    pub(super) pipelines: Pipelines,
    pub(super) ctx: Context,
    pub(super) timing: bool,
    pub(super) count_fetches: bool,
    /// At most this many pixels in the GPU film at once (besides the device's storage range).
    pub(super) band_pixel_limit: Option<u64>,
    /// Per `SplitArray`, at most this many bytes in one of its bindings (besides the device's
    /// range).
    pub(super) binding_limits: Option<[u64; 5]>,
    /// How the scene arrays are read where their images fit (`SceneSplit::images`).
    pub(super) scene_images: SceneImages,
    /// Whether kernels are specialised for each scene's features (else made with them all).
    pub(super) specialise: bool,
    /// Whether kernels made for a deeper tree serve a shallower one (`Pipelines::reusable`):
    /// for the frames of a sequence, not for unrelated scenes, whose speed is measured with
    /// kernels of their own.
    pub(super) reuse_deeper: bool,
    /// Whether the kernels that declare one binding per scene array render also where the
    /// device binds them all (`Pipelines::with_kernels`).
    pub(super) one_binding: bool,
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
            reuse_deeper: false,
            one_binding: false,
            commands,
            pipelines,
            ctx,
            timing,
            count_fetches: options.count_fetches,
        })
    }

    /// Lets kernels made for one scene's deeper tree serve the next scenes of the same
    /// features (the frames of a sequence, whose trees differ in depth from pose to pose), and
    /// makes the longest deferred arrays once a second depth comes, so that a sequence compiles
    /// its kernels at most twice. Off by default. Results do not depend on it.
    pub fn set_reuse_deeper_kernels(&mut self, reuse: bool) {
        self.reuse_deeper = reuse;
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
    /// `super::wavefront::kernels` order), where the device reports them.
    pub(super) fn kernel_statistics(
        &self,
        setup: &Setup,
        integrator: crate::render::Integrator,
    ) -> Vec<(String, Vec<crate::render::KernelStatistic>)> {
        let pipelines = setup.pipelines.as_ref().unwrap_or(&self.pipelines);
        super::wavefront::kernels(integrator)
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
        let image_texels = super::bindings::SCENE_IMAGE_WIDTH as u64
            * self.ctx.properties.limits.max_image_dimension2_d as u64;
        // path_pixel_sample's div_mod (convert.glsl) needs a batch's rounds of its pixels below
        // 2^22.
        (range / per_path)
            .min(groups * crate::layout::WORKGROUP_SIZE as u64)
            .min(image_texels)
            .min((1 << 22) - 2) as u32
    }

    /// Checks the wavefront size, chooses the bands and creates the buffers of one render.
    pub(super) fn setup(
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
        let bdpt_stride = super::wavefront::bdpt_vertices_per_path(settings.max_depth) as u64;
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
        let kernels = super::wavefront::kernels(settings.integrator);
        let features = match self.specialise {
            true if self.reuse_deeper => pipelines
                .as_ref()
                .unwrap_or(&self.pipelines)
                .reusable(kernels, scene.gpu_features(settings)),
            true => scene.gpu_features(settings),
            false => crate::layout::FEATURES_ALL,
        };
        let making = Instant::now();
        let made = pipelines
            .as_ref()
            .unwrap_or(&self.pipelines)
            .prepare(kernels, features)?;
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
                .query_count(super::wavefront::query_count(settings.max_depth));
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

    /// The device memory `setup` holds and how its scene lies over the bindings.
    pub(super) fn device_memory(&self, setup: &Setup) -> crate::render::DeviceMemory {
        let report = match self.ctx.allocator.lock() {
            Ok(a) => a.generate_report(),
            Err(_) => return Default::default(),
        };
        let split = super::bindings::SplitArray::ALL
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

    /// Every batch of one band (or of the band's `pixel_count` active pixels), samples
    /// `samples`, each batch recorded into one command buffer and submitted. After a batch that
    /// ends a whole sample pass, stops if `stop` is set; returns the end of the samples
    /// rendered.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run_batches(
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
    pub(super) fn recorder<'a>(&'a self, setup: &'a Setup, pixel_count: u32) -> Recorder<'a> {
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
    pub(super) fn kernels_to_transfers(&self) {
        super::memory::barrier(
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
    pub(super) fn kernel_times<'t>(
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

/// How kernels on `ctx` read the scene arrays: the device's default, or what
/// WAVETRACE_SCENE_IMAGES=buffers|storage|sampled chooses, to measure them.
pub(super) fn scene_images_for(ctx: &Context) -> Result<SceneImages> {
    SceneImages::for_device(
        ctx.is_cpu(),
        std::env::var("WAVETRACE_SCENE_IMAGES").ok().as_deref(),
    )
}

/// How `scene`'s large arrays are laid over `ctx`'s bindings, read as `scene_images` says where
/// their images fit, each binding at most `binding_limits` bytes where given.
pub(super) fn scene_split(
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
        && super::bindings::SceneImage::ALL
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

/// A device's shader compiler without the renderer: makes the kernels a scene renders with
/// (specialised for its features and its arrays' bindings, as a render makes them) and reads
/// the driver's statistics of each, submitting no work (`bench --kernels`). It therefore also
/// runs on a device that compiles but cannot run work, such as Mesa RADV's null device
/// (`RADV_FORCE_FAMILY=navi31`: AMD's compiler, ACO, with no AMD GPU present), whose registers,
/// spills and instruction counts are a real GPU compiler's view of each kernel.
pub struct KernelCompiler {
    pub(super) ctx: Context,
    pub(super) scene_images: SceneImages,
}

/// The kernels one render of a scene is made of, with the driver's statistics of each.
#[derive(Clone, Debug)]
pub struct CompiledKernels {
    /// The features they were specialised for (`PreparedScene::gpu_features`).
    pub features: u32,
    /// Every kernel of the integrator, in `super::wavefront::kernels` order, with its statistics
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
        let names = super::wavefront::kernels(settings.integrator);
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
pub(super) struct Setup {
    pub(super) capacity: u32,
    pub(super) band_rows: u32,
    pub(super) frame: FrameParams,
    pub(super) buffers: RenderBuffers,
    /// Kernels specialised for a scene split across bindings (else the renderer's own).
    pub(super) pipelines: Option<Pipelines>,
    /// The scene's features, for which the kernels were specialised.
    pub(super) features: u32,
    /// How many of the render's kernels its setup made (the others were made for an earlier
    /// render) and how long that took (`RenderStats::kernels_made`).
    pub(super) kernels_made: (usize, f64),
    /// Bindings each `SplitArray` uses.
    pub(super) split_bindings: [u32; 5],
    /// How the kernels read the scene arrays (`SceneImages::describe`).
    pub(super) scene_reads: &'static str,
    pub(super) query_pool: Option<vk::QueryPool>,
}

impl Setup {
    pub(super) fn destroy(self, ctx: &Context) {
        if let Some(pool) = self.query_pool {
            unsafe { ctx.device.destroy_query_pool(pool, None) };
        }
    }
}

/// The film of a render of one band as it stood after its last whole sample pass copied back:
/// samples [start, `end`) of every pixel.
pub(super) struct Checkpoint {
    pub(super) pixels: Vec<FilmPixel>,
    pub(super) end: u32,
    pub(super) taken: Instant,
    pub(super) every: std::time::Duration,
}
