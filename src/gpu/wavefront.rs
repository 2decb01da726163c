//! The wavefront loop, recorded into one command buffer per batch with no host round trip:
//! generate → (dispatch_args → extend → shade → dispatch_args → connect) per bounce → accumulate.
//! One function per kernel, named as the kernel; every dispatch is labelled and timestamped.

use super::memory::{barrier, Buffer};
use super::pipelines::Pipelines;
use crate::layout::{args, counter, DispatchParams, ALPHA_LIGHT_WALK, WORKGROUP_SIZE};
use crate::render::Integrator;
use ash::vk;

/// Which paths a batch holds (see `DispatchParams`).
#[derive(Clone, Copy, Debug)]
pub struct Batch {
    pub first_sample: u32,
    pub first_pixel: u32,
    pub size: u32,
}

/// Splits `spp` passes over `pixel_count` pixels into batches of at most `capacity` paths: whole
/// passes when a pass fits, else runs of pixels inside one pass.
pub fn batches(pixel_count: u32, spp: u32, capacity: u32) -> Vec<Batch> {
    let mut out = Vec::new();
    if pixel_count <= capacity {
        let passes = (capacity / pixel_count).max(1);
        let mut s = 0;
        while s < spp {
            let k = passes.min(spp - s);
            out.push(Batch {
                first_sample: s,
                first_pixel: 0,
                size: k * pixel_count,
            });
            s += k;
        }
    } else {
        for s in 0..spp {
            let mut p = 0;
            while p < pixel_count {
                let size = capacity.min(pixel_count - p);
                out.push(Batch {
                    first_sample: s,
                    first_pixel: p,
                    size,
                });
                p += size;
            }
        }
    }
    out
}

/// Timestamps one batch writes at most: one before the first kernel and one after each
/// dispatch. The path tracer records generate, (2 + 1 + 2) per bounce and accumulate; BDPT
/// generate_light, 3 per light bounce, generate, 3 per camera bounce, 4 per strategy and
/// accumulate_splats.
pub fn query_count(max_depth: u32) -> u32 {
    let path = 1 + 5 * (max_depth + 1) + 1;
    let strategies = bdpt_strategies(max_depth).count() as u32;
    let bdpt = 1 + 3 * max_depth + 1 + 3 * (max_depth + 1) + 4 * strategies + 1;
    1 + path.max(bdpt)
}

/// Slots of `BdptVertex` per BDPT path: its light subpath's max_depth + 1 vertices and its
/// camera subpath's max_depth + 2 (`bdpt.glsl`, `bdpt_stride`).
pub fn bdpt_vertices_per_path(max_depth: u32) -> u32 {
    2 * max_depth + 3
}

/// The (s, t) strategies `connect_bdpt` runs, one dispatch each, in the order of
/// `bdpt_strategy` (`bdpt.glsl`): for every path length k = s + t − 2 ≤ max_depth,
/// s = 0 … k + 1, but (1, 1).
pub fn bdpt_strategies(max_depth: u32) -> impl Iterator<Item = (u32, u32)> {
    (0..=max_depth).flat_map(|k| {
        let last = if k == 0 { 0 } else { k + 1 };
        (0..=last).map(move |s| (s, k + 2 - s))
    })
}

/// Records the kernels of one batch into a command buffer.
pub struct Recorder<'a> {
    pub device: &'a ash::Device,
    pub labels: Option<&'a ash::ext::debug_utils::Device>,
    pub pipelines: &'a Pipelines,
    pub cmd: vk::CommandBuffer,
    pub args: &'a Buffer,
    pub counters: &'a Buffer,
    /// Pixels in the image (accumulate runs one thread per pixel of the batch).
    pub pixel_count: u32,
    /// The scene's features (`PreparedScene::gpu_features`): which pipelines to bind.
    pub features: u32,
    /// Timestamp pool and the kernel name of each interval, when timing.
    pub timestamps: Option<vk::QueryPool>,
    pub timed: Vec<&'static str>,
}

/// The kernels that [`Recorder`] dispatches for `integrator`: the pipelines a render creates,
/// the longest to compile first (lavapipe, Cornell box: shade 0.9 s, shade_light 0.7,
/// connect_bdpt 0.5, shade_camera 0.45, connect 0.4, extend and connect_light 0.3,
/// generate_light 0.2, the others under 0.01), since they are compiled side by side.
pub fn kernels(integrator: Integrator) -> &'static [&'static str] {
    match integrator {
        Integrator::Path => &[
            "shade",
            "connect",
            "extend",
            "generate",
            "dispatch_args",
            "accumulate",
        ],
        Integrator::Light => &[
            "shade_light",
            "extend",
            "connect_light",
            "generate_light",
            "dispatch_args",
            "accumulate_splats",
        ],
        Integrator::Bdpt => &[
            "shade_light",
            "connect_bdpt",
            "shade_camera",
            "extend",
            "connect_light",
            "generate_light",
            "generate",
            "dispatch_args",
            "accumulate_splats",
        ],
    }
}

impl Recorder<'_> {
    /// One batch: the whole wavefront loop up to `max_depth` bounces.
    pub fn record_batch(&mut self, batch: Batch, max_depth: u32) {
        self.reset_counters(batch.size);
        self.start_timing(max_depth);
        self.generate(batch);
        for depth in 0..=max_depth {
            self.extend(batch, depth);
            self.shade(batch, depth);
            if depth < max_depth {
                self.connect(batch, depth);
            }
        }
        self.accumulate(batch);
    }

    /// The closest hits of the batch's rays, already in queue 0 (`bench --bvh`'s GPU walk):
    /// `extend` alone, as a render's first bounce runs it.
    pub fn record_trace(&mut self, batch: Batch) {
        self.reset_counters(batch.size);
        self.start_timing(0);
        self.extend(batch, 0);
    }

    /// The occlusion of the batch's shadow rays, already in the shadow queue (`bench --bvh`'s
    /// GPU any-hit walk): `connect` alone, with the queue's length set to the batch's.
    pub fn record_trace_any(&mut self, batch: Batch) {
        self.reset_counters_to(counter::SHADOW, batch.size);
        self.start_timing(0);
        self.connect(batch, 0);
    }

    /// One batch of light tracing (`--integrator light`): generate_light → connect_light, then
    /// (extend → shade_light → connect_light) per scattering vertex; at the end of a pass
    /// (`pass_done`) the splat sums of each of the batch's passes become one film sample per
    /// pixel (accumulate_splats).
    /// Light rays' alpha keys are ALPHA_LIGHT_WALK + d: `extend` reads params.depth, whose low
    /// bit still picks the queue.
    pub fn record_light_batch(&mut self, batch: Batch, max_depth: u32, pass_done: bool) {
        self.generate_light(batch, max_depth);
        // connect_light's params.depth is the strategy's code 64 s + t (its alpha key).
        self.connect_light(batch, 64 + 1);
        for depth in 0..max_depth {
            self.extend(batch, ALPHA_LIGHT_WALK | depth);
            self.shade_light(batch, depth);
            self.connect_light(batch, 64 * (depth + 2) + 1);
        }
        self.accumulate_splats(batch, pass_done);
    }

    /// One batch of bidirectional path tracing (`--integrator bdpt`): the light subpaths
    /// (generate_light, then extend → shade_light per vertex, storing every vertex), the camera
    /// subpaths (generate, then extend → shade_camera per vertex, storing every vertex), then
    /// connect_bdpt evaluates every (s, t) strategy of every path, one dispatch row per strategy,
    /// and splats its weighted contribution; at the end of a pass accumulate_splats makes the
    /// sums one film sample per pixel, as for light tracing.
    pub fn record_bdpt_batch(&mut self, batch: Batch, max_depth: u32, pass_done: bool) {
        self.generate_light(batch, max_depth);
        for depth in 0..max_depth {
            self.extend(batch, ALPHA_LIGHT_WALK | depth);
            self.shade_light(batch, depth);
        }
        // Queue 0 starts full for the camera subpaths.
        self.set_queue_counters(batch.size);
        self.generate(batch);
        for depth in 0..=max_depth {
            self.extend(batch, depth);
            self.shade_camera(batch, depth);
        }
        // One strategy at a time, so that its shadow rays fit the queue of batch.size.
        for (j, (s, t)) in bdpt_strategies(max_depth).enumerate() {
            self.clear_shadow_queue(batch);
            self.connect_bdpt(batch, j as u32);
            self.connect_light(batch, 64 * s + t);
        }
        self.accumulate_splats(batch, pass_done);
    }

    /// The start of a splatting batch: counters reset (queue 0 fills as generate_light finds
    /// emitters), timing, and the light subpaths' origins.
    fn generate_light(&mut self, batch: Batch, max_depth: u32) {
        self.reset_counters(0);
        self.start_timing(max_depth);
        self.dispatch(
            "generate_light",
            params(batch, 0),
            batch.size.div_ceil(WORKGROUP_SIZE),
        );
    }

    /// The end of a splatting batch that ends its passes: their splat sums into the film.
    fn accumulate_splats(&mut self, batch: Batch, pass_done: bool) {
        if pass_done {
            self.dispatch(
                "accumulate_splats",
                params(batch, 0),
                self.pixel_count.div_ceil(WORKGROUP_SIZE),
            );
        }
    }

    /// Empties the shadow queue (a dispatch_args that only clears).
    fn clear_shadow_queue(&mut self, batch: Batch) {
        let mut p = params(batch, 0);
        p.counter = counter::SHADOW;
        p.args_slot = args::SHADOW;
        p.total_counter = u32::MAX;
        p.clear_mask = 1 << counter::SHADOW;
        self.dispatch_args(p);
    }

    /// Mid-batch: sets queue 0's counter to `first_queue` and empties queue 1 and the shadow
    /// queue, leaving the running totals.
    fn set_queue_counters(&self, first_queue: u32) {
        const _: () = assert!(counter::RAYS_1 + 1 == counter::SHADOW);
        barrier(
            self.device,
            self.cmd,
            (
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
            ),
            (
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
        );
        self.fill_counters(first_queue, counter::RAYS_1, 2);
        self.transfers_to_kernels();
    }

    /// Sets queue 0's counter to `first_queue` and `count` counters from `from` to 0 (disjoint
    /// bytes: no barrier between the two fills).
    fn fill_counters(&self, first_queue: u32, from: u32, count: u32) {
        let buffer = self.counters.buffer;
        unsafe {
            self.device.cmd_fill_buffer(
                self.cmd,
                buffer,
                4 * counter::RAYS_0 as u64,
                4,
                first_queue,
            );
            self.device
                .cmd_fill_buffer(self.cmd, buffer, 4 * from as u64, 4 * count as u64, 0);
        }
    }

    /// Makes transfers recorded so far visible to the kernels and to indirect arguments.
    fn transfers_to_kernels(&self) {
        barrier(
            self.device,
            self.cmd,
            (
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
            (
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::DRAW_INDIRECT,
                vk::AccessFlags::SHADER_READ
                    | vk::AccessFlags::SHADER_WRITE
                    | vk::AccessFlags::UNIFORM_READ
                    | vk::AccessFlags::INDIRECT_COMMAND_READ,
            ),
        );
    }

    fn start_timing(&mut self, max_depth: u32) {
        if let Some(pool) = self.timestamps {
            unsafe {
                self.device
                    .cmd_reset_query_pool(self.cmd, pool, 0, query_count(max_depth));
                self.device.cmd_write_timestamp(
                    self.cmd,
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    pool,
                    0,
                );
            }
        }
    }

    /// Sets queue 0's counter to `first_queue` and zeroes every other counter.
    fn reset_counters(&self, first_queue: u32) {
        // Queue 0 starts full (generate writes every slot) or empty (generate_light appends);
        // every other counter starts at 0.
        self.reset_counters_to(counter::RAYS_0, first_queue);
    }

    /// Sets counter `queue` to `length` and zeroes every other counter (fills of disjoint
    /// bytes, no barrier between them), then makes them visible to the kernels.
    fn reset_counters_to(&self, queue: u32, length: u32) {
        let buffer = self.counters.buffer;
        let word = |k: u32| 4 * k as u64;
        unsafe {
            if queue > 0 {
                self.device
                    .cmd_fill_buffer(self.cmd, buffer, 0, word(queue), 0);
            }
            self.device
                .cmd_fill_buffer(self.cmd, buffer, word(queue), 4, length);
            self.device.cmd_fill_buffer(
                self.cmd,
                buffer,
                word(queue + 1),
                word(counter::COUNT - queue - 1),
                0,
            );
        }
        // Covers these fills and every earlier submission's transfers (scene upload, film
        // clear).
        self.transfers_to_kernels();
    }

    /// Camera rays and fresh path states for the whole batch.
    fn generate(&mut self, batch: Batch) {
        self.dispatch(
            "generate",
            params(batch, 0),
            batch.size.div_ceil(WORKGROUP_SIZE),
        );
    }

    /// Closest hits of the extension queue of `depth`.
    fn extend(&mut self, batch: Batch, depth: u32) {
        let queue = depth & 1;
        let mut p = params(batch, depth);
        p.counter = queue;
        p.args_slot = args::RAYS;
        p.total_counter = counter::TOTAL_EXTENSION_RAYS;
        // The next queue and the shadow queue are refilled by this bounce's shade.
        p.clear_mask = (1 << (queue ^ 1)) | (1 << counter::SHADOW);
        self.dispatch_args(p);
        self.dispatch_indirect("extend", params(batch, depth), args::RAYS);
    }

    /// Emission, emitter sampling, BSDF sampling and Russian roulette at every hit.
    fn shade(&mut self, batch: Batch, depth: u32) {
        self.dispatch_indirect("shade", params(batch, depth), args::RAYS);
    }

    /// Any-hit tests of the shadow queue.
    fn connect(&mut self, batch: Batch, depth: u32) {
        self.connect_kernel("connect", batch, depth);
    }

    /// The shadow queue's dispatch size, then `kernel` over it.
    fn connect_kernel(&mut self, kernel: &'static str, batch: Batch, depth: u32) {
        let mut p = params(batch, depth);
        p.counter = counter::SHADOW;
        p.args_slot = args::SHADOW;
        p.total_counter = counter::TOTAL_SHADOW_RAYS;
        p.clear_mask = 0;
        self.dispatch_args(p);
        self.dispatch_indirect(kernel, params(batch, depth), args::SHADOW);
    }

    /// A light subpath's scattering at every hit of the extension queue of `depth`: the vertex
    /// stored (BDPT), joined to the camera (light tracing), BSDF sampling and roulette.
    fn shade_light(&mut self, batch: Batch, depth: u32) {
        self.dispatch_indirect("shade_light", params(batch, depth), args::RAYS);
    }

    /// A camera subpath's vertex stored at every hit of the extension queue of `depth` (BDPT).
    fn shade_camera(&mut self, batch: Batch, depth: u32) {
        self.dispatch_indirect("shade_camera", params(batch, depth), args::RAYS);
    }

    /// Any-hit tests of the shadow queue's camera joins; `code` is the strategy's 64 s + t, its
    /// alpha key.
    fn connect_light(&mut self, batch: Batch, code: u32) {
        self.connect_kernel("connect_light", batch, code);
    }

    /// Strategy `j` of `bdpt_strategies` for every path of the batch: its weighted contribution,
    /// and a shadow ray where the connection needs one.
    fn connect_bdpt(&mut self, batch: Batch, j: u32) {
        self.dispatch(
            "connect_bdpt",
            params(batch, j),
            batch.size.div_ceil(WORKGROUP_SIZE),
        );
    }

    /// The next dispatch's size from a queue's counter (`p.counter` into `p.args_slot`), and the
    /// counters `p.clear_mask` names cleared.
    fn dispatch_args(&mut self, p: DispatchParams) {
        self.dispatch("dispatch_args", p, 1);
    }

    /// Path radiance into the film, one thread per pixel of the batch.
    fn accumulate(&mut self, batch: Batch) {
        let threads = batch.size.min(self.pixel_count);
        self.dispatch(
            "accumulate",
            params(batch, 0),
            threads.div_ceil(WORKGROUP_SIZE),
        );
    }

    fn dispatch(&mut self, name: &'static str, p: DispatchParams, groups: u32) {
        self.record(name, p, |d, cmd| unsafe {
            d.cmd_dispatch(cmd, groups, 1, 1)
        });
    }

    /// A dispatch whose size `dispatch_args` wrote into argument slot `slot`.
    fn dispatch_indirect(&mut self, name: &'static str, p: DispatchParams, slot: u32) {
        let buffer = self.args.buffer;
        self.record(name, p, |d, cmd| unsafe {
            d.cmd_dispatch_indirect(cmd, buffer, 16 * slot as u64)
        });
    }

    /// Binds, pushes, dispatches, then makes the results visible to the next kernel and to
    /// indirect argument reads.
    fn record(
        &mut self,
        name: &'static str,
        p: DispatchParams,
        dispatch: impl FnOnce(&ash::Device, vk::CommandBuffer),
    ) {
        let (device, cmd) = (self.device, self.cmd);
        let label = std::ffi::CString::new(name).unwrap_or_default();
        unsafe {
            if let Some(labels) = self.labels {
                labels.cmd_begin_debug_utils_label(
                    cmd,
                    &vk::DebugUtilsLabelEXT::default().label_name(&label),
                );
            }
            device.cmd_bind_pipeline(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.pipelines.get(name, self.features),
            );
            device.cmd_push_constants(
                cmd,
                self.pipelines.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                bytemuck::bytes_of(&p),
            );
            dispatch(device, cmd);
            barrier(
                device,
                cmd,
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::AccessFlags::SHADER_WRITE,
                ),
                (
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::DRAW_INDIRECT,
                    vk::AccessFlags::SHADER_READ
                        | vk::AccessFlags::SHADER_WRITE
                        | vk::AccessFlags::INDIRECT_COMMAND_READ,
                ),
            );
            if let Some(pool) = self.timestamps {
                self.timed.push(name);
                device.cmd_write_timestamp(
                    cmd,
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    pool,
                    self.timed.len() as u32,
                );
            }
            if let Some(labels) = self.labels {
                labels.cmd_end_debug_utils_label(cmd);
            }
        }
    }
}

fn params(batch: Batch, depth: u32) -> DispatchParams {
    DispatchParams {
        first_sample: batch.first_sample,
        first_pixel: batch.first_pixel,
        batch_size: batch.size,
        depth,
        counter: 0,
        args_slot: 0,
        total_counter: u32::MAX,
        clear_mask: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::path_pixel_sample;
    use crate::layout::FrameParams;

    /// The strategies of connect_bdpt: every (s, t) with t ≥ 1 and s + t − 2 ≤ max_depth once,
    /// but (1, 1), and (0, 1), which joins nothing.
    #[test]
    fn bdpt_strategies_cover_each_once() {
        for max_depth in 0..12 {
            let list: Vec<(u32, u32)> = bdpt_strategies(max_depth).collect();
            let mut expected = Vec::new();
            for k in 0..=max_depth {
                for s in 0..=k + 2 {
                    let t = k + 2 - s;
                    if t >= 1 && (s, t) != (1, 1) {
                        expected.push((s, t));
                    }
                }
            }
            assert_eq!(list, expected, "max depth {max_depth}");
            assert!(
                query_count(max_depth)
                    >= 1 + 1 + 3 * max_depth + 1 + 3 * (max_depth + 1) + 4 * list.len() as u32 + 1
            );
        }
    }

    #[test]
    fn batches_cover_every_path_once() {
        for (pixels, spp, cap) in [
            (16u32, 5u32, 64u32),
            (100, 3, 64),
            (64, 4, 64),
            (7, 1, 1000),
            (1000, 2, 999),
        ] {
            let frame = FrameParams {
                band_first_pixel: 0,
                band_pixel_count: pixels,
                ..Default::default()
            };
            let mut seen = vec![0u32; (pixels * spp) as usize];
            for b in batches(pixels, spp, cap) {
                assert!(b.size <= cap && b.size > 0);
                assert!(b.first_pixel == 0 || b.first_pixel + b.size <= pixels);
                for i in 0..b.size {
                    let (pixel, sample) =
                        path_pixel_sample(&frame, &[], b.first_sample, b.first_pixel, i);
                    seen[(sample * pixels + pixel) as usize] += 1;
                }
            }
            assert!(
                seen.iter().all(|&c| c == 1),
                "{pixels} px × {spp} spp, capacity {cap}"
            );
        }
    }

    #[test]
    fn batches_over_an_active_list_cover_each_listed_pixel_once_per_sample() {
        // A band of 40 pixels starting at pixel 100, of which every third is still active, in
        // a pass whose first sample is 48.
        let list: Vec<u32> = (0..40).step_by(3).collect();
        let n = list.len() as u32;
        for (spp, cap) in [(4u32, 1000u32), (4, 5), (7, 14), (3, 1)] {
            let frame = FrameParams {
                band_first_pixel: 100,
                band_pixel_count: 40,
                active_pixel_count: n,
                ..Default::default()
            };
            let mut seen = vec![0u32; (40 * spp) as usize];
            for b in batches(n, spp, cap) {
                for i in 0..b.size {
                    let (pixel, sample) =
                        path_pixel_sample(&frame, &list, 48 + b.first_sample, b.first_pixel, i);
                    assert!((48..48 + spp).contains(&sample));
                    seen[((sample - 48) * 40 + pixel - 100) as usize] += 1;
                }
            }
            for (k, &c) in seen.iter().enumerate() {
                let listed = list.contains(&(k as u32 % 40));
                assert_eq!(c, listed as u32, "slot {k}: {spp} spp, capacity {cap}");
            }
        }
    }
}
