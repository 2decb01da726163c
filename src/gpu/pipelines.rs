//! The descriptor set every kernel shares, the pipeline layout with its push constants, and one
//! compute pipeline per embedded SPIR-V module.

use super::context::Context;
use crate::kernels::KERNELS;
use crate::layout::DispatchParams;
use anyhow::{anyhow, Context as _, Result};
use ash::vk;
use std::collections::HashMap;

/// The bindings of `shaders/inc/bindings.glsl`, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Binding {
    Frame = 0,
    BvhNodes = 1,
    Triangles = 2,
    Materials = 3,
    Lights = 4,
    Paths = 5,
    Rays = 6,
    Hits = 7,
    Shadows = 8,
    Film = 9,
    Counters = 10,
    Args = 11,
    TriangleVertices = 12,
    Vertices = 13,
    Textures = 14,
    TextureRefs = 15,
    Texels = 16,
    Instances = 17,
    Punctual = 18,
    EnvTexels = 19,
    EnvConditional = 20,
    EnvMarginal = 21,
    LightNodes = 22,
    LightTrails = 23,
    /// Band-local indices of the pixels a pass of an adaptive render samples
    /// (`FrameParams::active_pixel_count`).
    ActivePixels = 24,
    /// Light tracing's splat sums: per pixel and channel a 64-bit fixed-point integer as two
    /// words (`light_tracing.glsl`, `splat_add`).
    Splats = 25,
    /// The `--paths` automata (`PathExpr::gpu_table`).
    PathDfa = 26,
    /// `--integrator bdpt`: both subpaths of every path in flight (`bdpt.glsl`).
    BdptVertices = 27,
}

impl Binding {
    pub const ALL: [Binding; 28] = [
        Binding::Frame,
        Binding::BvhNodes,
        Binding::Triangles,
        Binding::Materials,
        Binding::Lights,
        Binding::Paths,
        Binding::Rays,
        Binding::Hits,
        Binding::Shadows,
        Binding::Film,
        Binding::Counters,
        Binding::Args,
        Binding::TriangleVertices,
        Binding::Vertices,
        Binding::Textures,
        Binding::TextureRefs,
        Binding::Texels,
        Binding::Instances,
        Binding::Punctual,
        Binding::EnvTexels,
        Binding::EnvConditional,
        Binding::EnvMarginal,
        Binding::LightNodes,
        Binding::LightTrails,
        Binding::ActivePixels,
        Binding::Splats,
        Binding::PathDfa,
        Binding::BdptVertices,
    ];
    pub fn descriptor_type(self) -> vk::DescriptorType {
        if self == Binding::Frame {
            vk::DescriptorType::UNIFORM_BUFFER
        } else {
            vk::DescriptorType::STORAGE_BUFFER
        }
    }
}

/// SPIR-V words of an embedded kernel.
pub fn kernel_spirv(name: &str) -> Result<Vec<u32>> {
    let (_, bytes) = KERNELS
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| anyhow!("no kernel named {name}"))?;
    ash::util::read_spv(&mut std::io::Cursor::new(bytes))
        .with_context(|| format!("reading SPIR-V of {name}"))
}

pub struct Pipelines {
    device: ash::Device,
    pub set_layout: vk::DescriptorSetLayout,
    pub layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
    pipelines: HashMap<&'static str, vk::Pipeline>,
}

impl Pipelines {
    pub fn new(ctx: &Context) -> Result<Pipelines> {
        let device = &ctx.device;
        let bindings: Vec<vk::DescriptorSetLayoutBinding> = Binding::ALL
            .iter()
            .map(|&b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b as u32)
                    .descriptor_type(b.descriptor_type())
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_layout = unsafe {
            device.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                None,
            )
        }
        .context("creating the descriptor set layout")?;
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .size(std::mem::size_of::<DispatchParams>() as u32)];
        let set_layouts = [set_layout];
        let layout = unsafe {
            device.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default()
                    .set_layouts(&set_layouts)
                    .push_constant_ranges(&push),
                None,
            )
        }
        .context("creating the pipeline layout")?;
        let sizes = [
            vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::UNIFORM_BUFFER)
                .descriptor_count(1),
            vk::DescriptorPoolSize::default()
                .ty(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(Binding::ALL.len() as u32 - 1),
        ];
        let pool = unsafe {
            device.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(1)
                    .pool_sizes(&sizes),
                None,
            )
        }
        .context("creating the descriptor pool")?;
        let set = unsafe {
            device.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(pool)
                    .set_layouts(&set_layouts),
            )
        }
        .context("allocating the descriptor set")?[0];

        let mut result = Pipelines {
            device: device.clone(),
            set_layout,
            layout,
            pool,
            set,
            pipelines: HashMap::new(),
        };
        for (name, _) in KERNELS {
            let words = kernel_spirv(name)?;
            let module = unsafe {
                device
                    .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)
            }
            .with_context(|| format!("creating the shader module of kernel {name}"))?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let info = [vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(layout)];
            let created =
                unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
            unsafe { device.destroy_shader_module(module, None) };
            let pipeline = created
                .map_err(|(_, e)| anyhow!("creating the pipeline of kernel {name}: {e}"))?[0];
            result.pipelines.insert(name, pipeline);
        }
        Ok(result)
    }

    pub fn get(&self, name: &str) -> vk::Pipeline {
        self.pipelines[name]
    }

    /// Points every binding at its buffer (whole range).
    pub fn bind_buffers(&self, buffers: &[(Binding, vk::Buffer)]) {
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
            .iter()
            .map(|(_, b)| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(*b)
                    .range(vk::WHOLE_SIZE)]
            })
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = buffers
            .iter()
            .zip(&infos)
            .map(|((binding, _), info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(*binding as u32)
                    .descriptor_type(binding.descriptor_type())
                    .buffer_info(info)
            })
            .collect();
        unsafe { self.device.update_descriptor_sets(&writes, &[]) };
    }
}

impl Drop for Pipelines {
    fn drop(&mut self) {
        unsafe {
            for (_, p) in self.pipelines.drain() {
                self.device.destroy_pipeline(p, None);
            }
            self.device.destroy_descriptor_pool(self.pool, None);
            self.device.destroy_pipeline_layout(self.layout, None);
            self.device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
