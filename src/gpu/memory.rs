//! Buffers with their own memory: device-local ones for the render, host-visible ones for
//! uploads and read-backs, and one-shot command submission to copy between them.

use super::bindings::SCENE_IMAGE_WIDTH;
use super::context::Context;
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme, Allocator};
use gpu_allocator::MemoryLocation;
use std::sync::{Arc, Mutex};

/// Where a buffer's memory lives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Location {
    /// Fastest for the GPU; filled and read through copies.
    Device,
    /// Mapped by the host (staging and read-back).
    Host,
}

/// Memory for a buffer or image from the allocator, where an injected fault (`fault.rs`) does
/// not refuse it first.
fn allocate(
    ctx: &Context,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> Result<Allocation> {
    super::fault::before_allocation(name).map_err(|e| anyhow!("{e}"))?;
    let desc = AllocationCreateDesc {
        name,
        requirements,
        location,
        linear,
        allocation_scheme: AllocationScheme::GpuAllocatorManaged,
    };
    let mut allocator = ctx
        .allocator
        .lock()
        .map_err(|_| anyhow!("allocator poisoned"))?;
    allocator.allocate(&desc).map_err(|e| anyhow!("{e}"))
}

/// A buffer and its memory, a range of a block that `gpu-allocator` sub-allocates (so that a
/// render holds a few device allocations however many buffers it has), freed on drop.
pub struct Buffer {
    device: ash::Device,
    allocator: Arc<Mutex<Allocator>>,
    pub buffer: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
    mapped: *mut u8,
}

impl Buffer {
    pub fn new(
        ctx: &Context,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: Location,
    ) -> Result<Buffer> {
        let size = size.max(16);
        let device = &ctx.device;
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let buffer = unsafe { device.create_buffer(&info, None) }
            .with_context(|| format!("creating buffer '{name}' ({} MiB)", size >> 20))?;
        let requirements = unsafe { device.get_buffer_memory_requirements(buffer) };
        let memory = match location {
            Location::Device => MemoryLocation::GpuOnly,
            // Staging, read-back and the frame constants: host-visible, coherent and, where
            // the device has such memory, cached for the host's reads.
            Location::Host => MemoryLocation::GpuToCpu,
        };
        let allocation = match allocate(ctx, name, requirements, memory, true) {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.destroy_buffer(buffer, None) };
                return Err(anyhow!(
                    "out of GPU memory allocating buffer '{name}' ({:.1} MiB): {e}; try a smaller --wavefront",
                    size as f64 / (1u64 << 20) as f64
                ));
            }
        };
        let mapped = allocation
            .mapped_ptr()
            .map_or(std::ptr::null_mut(), |p| p.as_ptr() as *mut u8);
        let bound =
            unsafe { device.bind_buffer_memory(buffer, allocation.memory(), allocation.offset()) };
        let result = Buffer {
            device: device.clone(),
            allocator: Arc::clone(&ctx.allocator),
            buffer,
            allocation: Some(allocation),
            size,
            mapped,
        };
        bound.context("binding buffer memory")?;
        if location == Location::Host && result.mapped.is_null() {
            bail!("buffer '{name}': its host-visible memory is not mapped");
        }
        if let Some(labels) = &ctx.labels {
            let cname = std::ffi::CString::new(name).unwrap_or_default();
            let info = vk::DebugUtilsObjectNameInfoEXT::default()
                .object_handle(buffer)
                .object_name(&cname);
            let _ = unsafe { labels.set_debug_utils_object_name(&info) };
        }
        Ok(result)
    }

    /// A host buffer holding `data`.
    pub fn with_data(
        ctx: &Context,
        name: &str,
        data: &[u8],
        usage: vk::BufferUsageFlags,
    ) -> Result<Buffer> {
        let b = Buffer::new(ctx, name, data.len() as u64, usage, Location::Host)?;
        b.write(data);
        Ok(b)
    }

    /// Host buffers only: copies `data` to the start of the buffer.
    pub fn write(&self, data: &[u8]) {
        assert!(!self.mapped.is_null() && data.len() as u64 <= self.size);
        unsafe { std::ptr::copy_nonoverlapping(data.as_ptr(), self.mapped, data.len()) };
    }

    /// Host buffers only: writes `items` from the start; returns how many bytes they took.
    pub fn write_pod<T: bytemuck::Pod>(&self, items: impl Iterator<Item = T>) -> usize {
        let items: Vec<T> = items.collect();
        self.write(bytemuck::cast_slice(&items));
        std::mem::size_of_val(items.as_slice())
    }

    /// Host buffers only: copies `data` to `offset` bytes into the buffer.
    pub fn write_at(&self, offset: usize, data: &[u8]) {
        assert!(!self.mapped.is_null() && (offset + data.len()) as u64 <= self.size);
        unsafe {
            std::ptr::copy_nonoverlapping(data.as_ptr(), self.mapped.add(offset), data.len())
        };
    }

    /// Host buffers only: the first `len` bytes.
    pub fn read(&self, len: usize) -> Vec<u8> {
        self.read_pod(len)
    }

    /// Host buffers only: the first `len` bytes as a vector of `T`, copied once (the film's
    /// read-back is tens of MiB: a byte vector cast after would copy it twice), on every core:
    /// a fresh vector faults its pages in as it is first written (about 2 µs a page on this VM,
    /// 16 ms for a 1024² film), which one thread would pay alone. Reads of one chunk or less
    /// stay on the calling thread.
    pub fn read_pod<T: bytemuck::Pod + Send + Sync>(&self, len: usize) -> Vec<T> {
        use rayon::prelude::*;
        /// Items per task: a 4 KiB page's worth of bytes 64 times over.
        const CHUNK_BYTES: usize = 256 << 10;
        assert!(!self.mapped.is_null() && len as u64 <= self.size);
        let bytes = unsafe { std::slice::from_raw_parts(self.mapped, len) };
        match bytemuck::try_cast_slice::<u8, T>(bytes) {
            // The counters after every batch: no work for other threads.
            Ok(items) if len <= CHUNK_BYTES => items.to_vec(),
            Ok(items) => {
                // Zeroed memory from the allocator (lazily mapped pages), not written here.
                let mut out: Vec<T> = bytemuck::zeroed_vec(items.len());
                let chunk = (CHUNK_BYTES / std::mem::size_of::<T>().max(1)).max(1);
                out.par_chunks_mut(chunk)
                    .zip(items.par_chunks(chunk))
                    .for_each(|(to, from)| to.copy_from_slice(from));
                out
            }
            Err(_) => bytemuck::pod_collect_to_vec(bytes),
        }
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        unsafe { self.device.destroy_buffer(self.buffer, None) };
        if let (Some(allocation), Ok(mut allocator)) =
            (self.allocation.take(), self.allocator.lock())
        {
            let _ = allocator.free(allocation);
        }
    }
}

/// A 2-D image of RGBA32UI (or R32UI) texels that the kernels read as a storage image
/// (`imageLoad`) or as a sampled image (`texelFetch`; `SceneImages`): an array of records laid
/// row after row, `SCENE_IMAGE_WIDTH` texels a row, in the general layout both reads take. On
/// llvmpipe an image read gathers the lanes' 16 bytes with one unconditional load each, where a
/// storage-buffer read becomes a conditional load per lane and word; and a storage image's
/// load, unlike a sampled image's `texelFetch`, does not work out a mip level per lane
/// (docs/perf-log/2026-12-02-lavapipe-scene-reads.md).
pub struct Image {
    device: ash::Device,
    allocator: Arc<Mutex<Allocator>>,
    pub image: vk::Image,
    pub view: vk::ImageView,
    allocation: Option<Allocation>,
    pub rows: u32,
    /// Bytes of one row.
    pub row_bytes: u64,
}

impl Image {
    /// An image of `rows` rows (at least one) of RGBA32UI or R32UI texels, in device memory,
    /// undefined until uploaded.
    pub fn new(ctx: &Context, name: &str, format: vk::Format, rows: u32) -> Result<Image> {
        let device = &ctx.device;
        let rows = rows.max(1);
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: SCENE_IMAGE_WIDTH,
                height: rows,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(
                vk::ImageUsageFlags::STORAGE
                    | vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_DST
                    | vk::ImageUsageFlags::TRANSFER_SRC,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let image = unsafe { device.create_image(&info, None) }.with_context(|| {
            format!("creating image '{name}' ({SCENE_IMAGE_WIDTH}×{rows} texels)")
        })?;
        let requirements = unsafe { device.get_image_memory_requirements(image) };
        let allocation = match allocate(ctx, name, requirements, MemoryLocation::GpuOnly, false) {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.destroy_image(image, None) };
                return Err(anyhow!(
                    "out of GPU memory allocating image '{name}' ({:.1} MiB): {e}",
                    requirements.size as f64 / (1u64 << 20) as f64
                ));
            }
        };
        let mut result = Image {
            device: device.clone(),
            allocator: Arc::clone(&ctx.allocator),
            image,
            view: vk::ImageView::null(),
            allocation: None,
            rows,
            row_bytes: SCENE_IMAGE_WIDTH as u64
                * if format == vk::Format::R32_UINT {
                    4
                } else {
                    16
                },
        };
        let bound =
            unsafe { device.bind_image_memory(image, allocation.memory(), allocation.offset()) };
        result.allocation = Some(allocation);
        bound.context("binding image memory")?;
        let view_info = vk::ImageViewCreateInfo::default()
            .image(image)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(COLOR_RANGE);
        result.view = unsafe { device.create_image_view(&view_info, None) }
            .with_context(|| format!("creating the view of image '{name}'"))?;
        Ok(result)
    }
}

const COLOR_RANGE: vk::ImageSubresourceRange = vk::ImageSubresourceRange {
    aspect_mask: vk::ImageAspectFlags::COLOR,
    base_mip_level: 0,
    level_count: 1,
    base_array_layer: 0,
    layer_count: 1,
};

impl Drop for Image {
    fn drop(&mut self) {
        unsafe {
            self.device.destroy_image_view(self.view, None);
            self.device.destroy_image(self.image, None);
        }
        if let (Some(allocation), Ok(mut allocator)) =
            (self.allocation.take(), self.allocator.lock())
        {
            let _ = allocator.free(allocation);
        }
    }
}

/// A command pool with one reusable primary command buffer and a fence.
pub struct Commands {
    device: ash::Device,
    pool: vk::CommandPool,
    pub cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl Commands {
    pub fn new(ctx: &Context) -> Result<Commands> {
        let device = &ctx.device;
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let pool = unsafe { device.create_command_pool(&pool_info, None) }
            .context("creating a command pool")?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let cmd = unsafe { device.allocate_command_buffers(&alloc) }
            .context("allocating a command buffer")?[0];
        // A device that compiles kernels but cannot run them, such as Mesa RADV's null device
        // (RADV_FORCE_FAMILY, which `bench --kernels` compiles for), fails first here.
        let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .with_context(|| {
                format!(
                    "creating a fence on {} (a device that only compiles, such as Mesa RADV's null \
                     device under RADV_FORCE_FAMILY, cannot render: `wavetrace bench --kernels` \
                     reads its kernels' statistics)",
                    ctx.info.name
                )
            })?;
        Ok(Commands {
            device: device.clone(),
            pool,
            cmd,
            fence,
        })
    }

    pub fn begin(&self) -> Result<()> {
        unsafe {
            self.device
                .reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())?;
            let info = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            self.device.begin_command_buffer(self.cmd, &info)?;
        }
        Ok(())
    }

    /// Ends, submits and waits (at most `timeout_s`); device loss and time-outs become errors.
    pub fn submit_and_wait(&self, ctx: &Context, what: &str, timeout_s: u64) -> Result<()> {
        self.submit_and_wait_checked(ctx, what, timeout_s, || Ok(()))
    }

    /// [`Commands::submit_and_wait`] of one wavefront batch, where an injected device loss can
    /// strike (`fault.rs`).
    pub fn submit_batch(&self, ctx: &Context, what: &str, timeout_s: u64) -> Result<()> {
        self.submit_and_wait_checked(ctx, what, timeout_s, super::fault::before_batch)
    }

    fn submit_and_wait_checked(
        &self,
        ctx: &Context,
        what: &str,
        timeout_s: u64,
        before: impl FnOnce() -> std::result::Result<(), vk::Result>,
    ) -> Result<()> {
        // A CPU Vulkan device (lavapipe) compiles each kernel at its first dispatch, inside the
        // submission: minutes for the largest kernels on two cores. It has no watchdog to
        // outrun, so it gets an hour before a submission counts as hung.
        let timeout_s = if ctx.is_cpu() {
            timeout_s.max(3600)
        } else {
            timeout_s
        };
        let explain = |e: vk::Result| match e {
            vk::Result::ERROR_DEVICE_LOST => {
                anyhow!("the GPU was lost during {what} (VK_ERROR_DEVICE_LOST)")
            }
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
                anyhow!("out of memory during {what} ({e}); try a smaller --wavefront")
            }
            vk::Result::TIMEOUT => {
                anyhow!("{what} did not finish within {timeout_s} s; the GPU may be hung")
            }
            e => anyhow!("{what} failed: {e}"),
        };
        unsafe {
            self.device.end_command_buffer(self.cmd).map_err(explain)?;
            let cmds = [self.cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            before().map_err(explain)?;
            ctx.submitted
                .store(true, std::sync::atomic::Ordering::Release);
            self.device
                .queue_submit(ctx.queue, &submit, self.fence)
                .map_err(explain)?;
            let waited =
                self.device
                    .wait_for_fences(&[self.fence], true, timeout_s * 1_000_000_000);
            if let Err(e) = waited {
                return Err(explain(e));
            }
            self.device.reset_fences(&[self.fence]).map_err(explain)?;
        }
        Ok(())
    }

    pub fn copy(&self, src: &Buffer, dst: &Buffer, size: u64) {
        self.copy_region(src, 0, dst, 0, size);
    }

    /// Copies `size` bytes from `src_offset` in `src` to `dst_offset` in `dst`.
    pub fn copy_region(
        &self,
        src: &Buffer,
        src_offset: u64,
        dst: &Buffer,
        dst_offset: u64,
        size: u64,
    ) {
        let region = [vk::BufferCopy::default()
            .src_offset(src_offset)
            .dst_offset(dst_offset)
            .size(size)];
        unsafe {
            self.device
                .cmd_copy_buffer(self.cmd, src.buffer, dst.buffer, &region)
        };
    }
}

impl Commands {
    /// Moves `image` from layout `old` to `new`, after transfers (or nothing) and before
    /// transfers or kernel reads.
    pub fn image_layout(&self, image: &Image, old: vk::ImageLayout, new: vk::ImageLayout) {
        let (src_stage, src_access) = match old {
            vk::ImageLayout::UNDEFINED => (
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::AccessFlags::empty(),
            ),
            _ => (
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
        };
        let (dst_stage, dst_access) = match new {
            vk::ImageLayout::TRANSFER_DST_OPTIMAL => (
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
            _ => (
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::AccessFlags::SHADER_READ,
            ),
        };
        let barrier = [vk::ImageMemoryBarrier::default()
            .src_access_mask(src_access)
            .dst_access_mask(dst_access)
            .old_layout(old)
            .new_layout(new)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image.image)
            .subresource_range(COLOR_RANGE)];
        unsafe {
            self.device.cmd_pipeline_barrier(
                self.cmd,
                src_stage,
                dst_stage,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &barrier,
            )
        };
    }

    /// Copies `rows` whole rows from `src_offset` in `src` to rows `first_row..` of `dst`
    /// (in layout TRANSFER_DST_OPTIMAL).
    pub fn copy_rows_to_image(
        &self,
        src: &Buffer,
        src_offset: u64,
        dst: &Image,
        first_row: u32,
        rows: u32,
    ) {
        let region = [rows_region(src_offset, first_row, rows)];
        unsafe {
            self.device.cmd_copy_buffer_to_image(
                self.cmd,
                src.buffer,
                dst.image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &region,
            )
        };
    }

    /// Copies the first `rows` whole rows of `src` (in the general layout the kernels use) to
    /// the start of `dst`.
    pub fn copy_rows_from_image(&self, src: &Image, dst: &Buffer, rows: u32) {
        let region = [rows_region(0, 0, rows)];
        unsafe {
            self.device.cmd_copy_image_to_buffer(
                self.cmd,
                src.image,
                vk::ImageLayout::GENERAL,
                dst.buffer,
                &region,
            )
        };
    }
}

/// `rows` whole rows of a scene image from row `first_row`, and a buffer's bytes from
/// `buffer_offset`, tightly packed.
fn rows_region(buffer_offset: u64, first_row: u32, rows: u32) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .buffer_offset(buffer_offset)
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_offset(vk::Offset3D {
            x: 0,
            y: first_row as i32,
            z: 0,
        })
        .image_extent(vk::Extent3D {
            width: SCENE_IMAGE_WIDTH,
            height: rows,
            depth: 1,
        })
}

impl Drop for Commands {
    fn drop(&mut self) {
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_fence(self.fence, None);
            self.device.destroy_command_pool(self.pool, None);
        }
    }
}

/// A global memory barrier: accesses `src` (stage, access) of earlier commands, in this and
/// earlier submissions, happen before and are visible to accesses `dst` of later ones.
pub fn barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags, vk::AccessFlags),
    dst: (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let barrier = [vk::MemoryBarrier::default()
        .src_access_mask(src.1)
        .dst_access_mask(dst.1)];
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            src.0,
            dst.0,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        )
    };
}
