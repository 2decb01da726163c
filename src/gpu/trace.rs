//! The render's own walks without the rest of the wavefront (`bench --bvh`): `extend` alone on
//! given rays for their closest hits, `connect` alone for any hit, timed by their timestamps.

use super::renderer::{GpuRenderer, Setup};
use super::resources::SUBMIT_TIMEOUT_S;
use crate::layout::{PathState, QueuedRay, ShadowRay};
use crate::render::{PreparedScene, RenderSettings};
use anyhow::Result;
use ash::vk;
use std::mem::size_of;
use std::time::Instant;

impl GpuRenderer {
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

    pub(super) fn trace(
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

    pub(super) fn trace_batches(
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
        let row_texels = super::bindings::SCENE_IMAGE_WIDTH as usize;
        let (queue, kernel, ray_bytes, result_bytes) = match any {
            false => (&buffers.rays, "extend", size_of::<QueuedRay>(), 16),
            true => (
                &buffers.shadows,
                "connect",
                size_of::<ShadowRay>(),
                size_of::<PathState>(),
            ),
        };
        let staging = super::memory::Buffer::new(
            ctx,
            "trace_rays",
            (capacity * ray_bytes) as u64,
            U::TRANSFER_SRC,
            super::memory::Location::Host,
        )?;
        let results_back = super::memory::Buffer::new(
            ctx,
            "trace_results",
            (capacity.div_ceil(row_texels) * row_texels * result_bytes) as u64,
            U::TRANSFER_DST,
            super::memory::Location::Host,
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
                let batch = super::wavefront::Batch {
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
