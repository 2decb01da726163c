//! One-off compute dispatches over host-visible storage buffers, for kernels outside the
//! wavefront loop (the GLSL-twin tests): bind buffers 0..n, push a u32 invocation count,
//! dispatch, read every buffer back.

use super::context::{Context, DeviceInfo};
use super::memory::{barrier, Buffer, Commands, Location};
use super::resources::SUBMIT_TIMEOUT_S;
use crate::kernels::TEST_KERNELS;
use crate::layout::WORKGROUP_SIZE;
use anyhow::{anyhow, Context as _, Result};
use ash::vk;

/// A Vulkan device that runs the GLSL-twin test kernels: its context and one command buffer,
/// without the renderer's pipelines and their 42 storage-buffer bindings, so that a device
/// which cannot hold those (SwiftShader binds at most 30) still checks its arithmetic against
/// the Rust twins.
pub struct TestKernels {
    commands: Commands,
    ctx: Context,
}

impl TestKernels {
    /// The device `device_index` (else the preferred usable one), with the validation layer
    /// where asked and installed.
    pub fn new(device_index: Option<usize>, validation: bool) -> Result<TestKernels> {
        let ctx = Context::new(device_index, validation)?;
        let commands = Commands::new(&ctx)?;
        Ok(TestKernels { commands, ctx })
    }

    pub fn device(&self) -> &DeviceInfo {
        &self.ctx.info
    }

    pub fn validating(&self) -> bool {
        self.ctx.validating()
    }

    /// Runs test kernel `name` for `count` invocations with `buffers` bound as storage buffers
    /// 0, 1, ... and returns their contents afterwards.
    pub fn run(&self, name: &str, count: u32, buffers: &[Vec<u8>]) -> Result<Vec<Vec<u8>>> {
        let ctx = &self.ctx;
        let device = &ctx.device;
        let (_, bytes) = TEST_KERNELS
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| anyhow!("no test kernel named {name}"))?;
        let words = ash::util::read_spv(&mut std::io::Cursor::new(bytes))?;
        let gpu_buffers: Vec<Buffer> = buffers
            .iter()
            .map(|data| {
                let b = Buffer::new(
                    ctx,
                    name,
                    data.len() as u64,
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                    Location::Host,
                )?;
                b.write(data);
                Ok(b)
            })
            .collect::<Result<_>>()?;

        let bindings: Vec<vk::DescriptorSetLayoutBinding> = (0..buffers.len() as u32)
            .map(|i| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        unsafe {
            let set_layout = device.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                None,
            )?;
            let push = [vk::PushConstantRange::default()
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
                .size(4)];
            let set_layouts = [set_layout];
            let layout = device.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default()
                    .set_layouts(&set_layouts)
                    .push_constant_ranges(&push),
                None,
            )?;
            let module = device
                .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let pipeline = device
                .create_compute_pipelines(
                    vk::PipelineCache::null(),
                    &[vk::ComputePipelineCreateInfo::default()
                        .stage(stage)
                        .layout(layout)],
                    None,
                )
                .map_err(|(_, e)| anyhow!("creating the pipeline of test kernel {name}: {e}"))?[0];
            let sizes = [vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(buffers.len() as u32)];
            let pool = device.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(1)
                    .pool_sizes(&sizes),
                None,
            )?;
            let set = device.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(pool)
                    .set_layouts(&set_layouts),
            )?[0];
            let infos: Vec<[vk::DescriptorBufferInfo; 1]> = gpu_buffers
                .iter()
                .map(|b| {
                    [vk::DescriptorBufferInfo::default()
                        .buffer(b.buffer)
                        .range(vk::WHOLE_SIZE)]
                })
                .collect();
            let writes: Vec<vk::WriteDescriptorSet> = infos
                .iter()
                .enumerate()
                .map(|(i, info)| {
                    vk::WriteDescriptorSet::default()
                        .dst_set(set)
                        .dst_binding(i as u32)
                        .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                        .buffer_info(info)
                })
                .collect();
            device.update_descriptor_sets(&writes, &[]);

            let cmd = self.commands.cmd;
            let result = self.commands.begin().and_then(|()| {
                device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
                device.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    layout,
                    0,
                    &[set],
                    &[],
                );
                device.cmd_push_constants(
                    cmd,
                    layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    &count.to_le_bytes(),
                );
                device.cmd_dispatch(cmd, count.div_ceil(WORKGROUP_SIZE), 1, 1);
                barrier(
                    device,
                    cmd,
                    (
                        vk::PipelineStageFlags::COMPUTE_SHADER,
                        vk::AccessFlags::SHADER_WRITE,
                    ),
                    (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
                );
                self.commands.submit_and_wait(ctx, name, SUBMIT_TIMEOUT_S)
            });
            device.destroy_descriptor_pool(pool, None);
            device.destroy_pipeline(pipeline, None);
            device.destroy_shader_module(module, None);
            device.destroy_pipeline_layout(layout, None);
            device.destroy_descriptor_set_layout(set_layout, None);
            result.with_context(|| format!("running test kernel {name}"))?;
        }
        ctx.check_validation()?;
        Ok(gpu_buffers
            .iter()
            .zip(buffers)
            .map(|(b, d)| b.read(d.len()))
            .collect())
    }
}
