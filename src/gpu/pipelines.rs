//! The descriptor set every kernel shares, the pipeline layout with its push constants, and one
//! compute pipeline per embedded SPIR-V module.

use super::bindings::{Binding, SceneSplit, SplitArray, STORAGE_BUFFERS};
use super::context::Context;
use crate::kernels::{KERNELS, KERNELS_ONE_BINDING};
use crate::layout::DispatchParams;
use crate::render::{KernelStatistic, StatisticValue};
use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Mutex;

/// The embedded wavefront kernels: all bindings, or without the split arrays' further chunks
/// (`SCENE_ONE_BINDING`).
pub fn kernels(one_binding: bool) -> &'static [(&'static str, &'static [u8])] {
    if one_binding {
        KERNELS_ONE_BINDING
    } else {
        KERNELS
    }
}

/// SPIR-V words of an embedded kernel, of the set [`kernels`] names.
pub fn kernel_spirv(name: &str, one_binding: bool) -> Result<Vec<u32>> {
    let (_, bytes) = kernels(one_binding)
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
    /// The split the kernels are specialised for.
    pub split: SceneSplit,
    /// The specialisation constants of every kernel: the split's shifts, then how the scene
    /// arrays are read (then the scene's features and the quantised walks' deferred arrays, the
    /// bottom levels' and the top level's, per pipeline: `layout::qbvh_stack_size`,
    /// `layout::tlas_stack_size`).
    constants: Vec<u32>,
    /// The pipelines created, by kernel and scene features (`layout::FEATURE_*`).
    pipelines: Mutex<HashMap<(&'static str, u32), vk::Pipeline>>,
    /// The kernels are built without the split arrays' further chunks
    /// (`KERNELS_ONE_BINDING`): the device binds fewer than [`STORAGE_BUFFERS`], and every
    /// scene array fits its first binding.
    pub one_binding: bool,
    /// Where the kernels' driver statistics are captured (`Pipelines::statistics`).
    executable_properties: Option<ash::khr::pipeline_executable_properties::Device>,
}

impl Pipelines {
    /// The descriptor set and the layout of kernels specialised for scenes laid over their
    /// bindings as `split` says; the kernels' pipelines are created by [`Pipelines::prepare`].
    /// With `one_binding`, the kernels that declare one binding per scene array
    /// (`KERNELS_ONE_BINDING`) also where the device binds them all. Where the device reports
    /// them, the driver keeps each kernel's statistics ([`Pipelines::statistics`]): keeping
    /// them changes none of its code.
    pub fn with_kernels(ctx: &Context, split: &SceneSplit, one_binding: bool) -> Result<Pipelines> {
        let device = &ctx.device;
        if let Some(shortfall) = ctx.info.storage_shortfall() {
            bail!("{} {shortfall}", ctx.info.name);
        }
        // A device that binds fewer than all the buffers renders with the kernels that
        // declare one binding per scene array, where the scene's arrays each fit one.
        let one_binding = one_binding || !ctx.info.splits_scene_arrays();
        if one_binding {
            if let Some(k) = split.shifts.iter().position(|&shift| shift < 32) {
                bail!(
                    "{}: this scene's {} take more than one storage binding, which takes kernels of \
                     {STORAGE_BUFFERS} storage buffers, and these kernels declare one binding per \
                     scene array (the device binds at most {} storage buffers per kernel); render \
                     it on another device (wavetrace devices) or with --device cpu",
                    ctx.info.name,
                    SplitArray::ALL[k].what(),
                    ctx.info.max_storage_buffers
                );
            }
        }
        let bindings: Vec<vk::DescriptorSetLayoutBinding> = Binding::ALL
            .iter()
            .filter(|b| b.declared(one_binding))
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
        // One descriptor of each type per binding of the layout.
        let sizes = [
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::STORAGE_BUFFER,
            vk::DescriptorType::STORAGE_IMAGE,
            vk::DescriptorType::SAMPLED_IMAGE,
        ]
        .map(|ty| {
            vk::DescriptorPoolSize::default().ty(ty).descriptor_count(
                    bindings.iter().filter(|b| b.descriptor_type == ty).count() as u32,
                )
        });
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

        let constants: Vec<u32> = split
            .shifts
            .iter()
            .copied()
            .chain([split.reads as u32])
            .collect();
        Ok(Pipelines {
            device: device.clone(),
            set_layout,
            layout,
            pool,
            set,
            split: *split,
            constants,
            pipelines: Mutex::new(HashMap::new()),
            one_binding,
            executable_properties: ctx.executable_properties.clone(),
        })
    }

    /// The features to make kernels `names` for where a scene needs `features`, for a renderer
    /// that reuses kernels across a sequence's frames (`set_reuse_deeper_kernels`): kernels already
    /// made for the same feature flags with deferred arrays at least as long serve as they are
    /// (a longer array holds the same entries in the same order; results do not depend on it,
    /// as they do not on specialising at all), the shortest such; else `features`. A sequence's
    /// frames, whose BVHs differ in depth, so compile their kernels once rather than per depth
    /// (lavapipe: about a second each time).
    pub fn reusable(&self, names: &[&'static str], features: u32) -> u32 {
        use crate::layout::{qbvh_stack_size, tlas_stack_size, FEATURE_FLAGS};
        let created = self.created();
        if names.iter().all(|&n| created.contains_key(&(n, features))) {
            return features;
        }
        let mut candidates: Vec<u32> = created
            .keys()
            .map(|&(_, f)| f)
            .filter(|&f| {
                f & FEATURE_FLAGS == features & FEATURE_FLAGS
                    && qbvh_stack_size(f) >= qbvh_stack_size(features)
                    && tlas_stack_size(f) >= tlas_stack_size(features)
                    && names.iter().all(|&n| created.contains_key(&(n, f)))
            })
            .collect();
        candidates.sort_by_key(|&f| (qbvh_stack_size(f), tlas_stack_size(f)));
        if let Some(&f) = candidates.first() {
            return f;
        }
        // Kernels of the same flags made for shallower trees: the scene changes from render to
        // render (a sequence), so the next kernels get the longest arrays and serve from now on.
        let flags = features & FEATURE_FLAGS;
        if created.keys().any(|&(_, f)| f & FEATURE_FLAGS == flags) {
            use crate::layout::{FEATURE_STACK_SHIFT, FEATURE_TLAS_STACK_SHIFT, QBVH_STACK_MAX};
            return flags
                | QBVH_STACK_MAX << FEATURE_TLAS_STACK_SHIFT
                | QBVH_STACK_MAX << FEATURE_STACK_SHIFT;
        }
        features
    }

    /// Creates the pipelines of kernels `names` specialised for scenes of `features`
    /// (`PreparedScene::gpu_features`) that are not created yet, side by side on as many
    /// threads as the machine has cores: a CPU Vulkan device compiles a kernel with LLVM, part
    /// as its pipeline is created (lavapipe, Cornell box: 0.3–0.9 s each for the large ones) and
    /// the rest at its first dispatch, so a render compiles only the kernels its integrator
    /// dispatches (`wavefront::kernels`), without the code of features its scene lacks.
    pub fn prepare(&self, names: &[&'static str], features: u32) -> Result<usize> {
        let missing: Vec<&'static str> = {
            let created = self.created();
            names
                .iter()
                .copied()
                .filter(|&n| !created.contains_key(&(n, features)))
                .collect()
        };
        // On rayon's threads, one per core, each taking the next kernel as it finishes one.
        let results: Vec<(&'static str, Result<vk::Pipeline>)> = missing
            .par_iter()
            .map(|&name| (name, self.create(name, features)))
            .collect();
        let mut created = self.created();
        let mut first_error = None;
        for (name, result) in results {
            match result {
                Ok(pipeline) => {
                    created.insert((name, features), pipeline);
                }
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        first_error.map_or(Ok(missing.len()), Err)
    }

    /// The pipeline of kernel `name`, specialised by `self.constants` and `features`.
    fn create(&self, name: &'static str, features: u32) -> Result<vk::Pipeline> {
        let device = &self.device;
        let stack = crate::layout::qbvh_stack_size(features);
        let tlas_stack = crate::layout::tlas_stack_size(features);
        let constants: Vec<u32> = self
            .constants
            .iter()
            .copied()
            .chain([features, stack, tlas_stack])
            .collect();
        let entries: Vec<vk::SpecializationMapEntry> = (0..constants.len() as u32)
            .map(|k| {
                vk::SpecializationMapEntry::default()
                    .constant_id(k)
                    .offset(4 * k)
                    .size(4)
            })
            .collect();
        let specialization = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(bytemuck::cast_slice(&constants));
        let words = kernel_spirv(name, self.one_binding)?;
        let module = unsafe {
            device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)
        }
        .with_context(|| format!("creating the shader module of kernel {name}"))?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main")
            .specialization_info(&specialization);
        let flags = match self.executable_properties {
            Some(_) => vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR,
            None => vk::PipelineCreateFlags::empty(),
        };
        let info = [vk::ComputePipelineCreateInfo::default()
            .flags(flags)
            .stage(stage)
            .layout(self.layout)];
        let mut created =
            unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
        if created.is_err() && !flags.is_empty() {
            // The statistics are a courtesy: a driver that cannot keep them still renders.
            let plain = [info[0].flags(vk::PipelineCreateFlags::empty())];
            created =
                unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &plain, None) };
        }
        unsafe { device.destroy_shader_module(module, None) };
        Ok(created.map_err(|(_, e)| anyhow!("creating the pipeline of kernel {name}: {e}"))?[0])
    }

    /// The driver's statistics of kernel `name` made for `features` (created by
    /// [`Pipelines::prepare`]), where they were captured: empty otherwise. A pipeline of more
    /// than one executable names each statistic after its executable.
    pub fn statistics(&self, name: &'static str, features: u32) -> Vec<KernelStatistic> {
        let Some(loader) = &self.executable_properties else {
            return Vec::new();
        };
        let Some(&pipeline) = self.created().get(&(name, features)) else {
            return Vec::new();
        };
        let text = |c: Result<&std::ffi::CStr, _>| {
            c.map(|c| c.to_string_lossy().trim().to_string())
                .unwrap_or_default()
        };
        let info = vk::PipelineInfoKHR::default().pipeline(pipeline);
        let executables =
            unsafe { loader.get_pipeline_executable_properties(&info) }.unwrap_or_default();
        let several = executables.len() > 1;
        let mut out = Vec::new();
        for (index, executable) in executables.iter().enumerate() {
            let info = vk::PipelineExecutableInfoKHR::default()
                .pipeline(pipeline)
                .executable_index(index as u32);
            let statistics =
                unsafe { loader.get_pipeline_executable_statistics(&info) }.unwrap_or_default();
            for s in statistics {
                // SAFETY: the format says which member of the union the driver wrote.
                let value = unsafe {
                    match s.format {
                        vk::PipelineExecutableStatisticFormatKHR::BOOL32 => {
                            StatisticValue::Bool(s.value.b32 == vk::TRUE)
                        }
                        vk::PipelineExecutableStatisticFormatKHR::INT64 => {
                            StatisticValue::Int(s.value.i64)
                        }
                        vk::PipelineExecutableStatisticFormatKHR::UINT64 => {
                            StatisticValue::Uint(s.value.u64)
                        }
                        vk::PipelineExecutableStatisticFormatKHR::FLOAT64 => {
                            StatisticValue::Float(s.value.f64)
                        }
                        _ => continue,
                    }
                };
                let name = match several {
                    true => format!(
                        "{}: {}",
                        text(executable.name_as_c_str()),
                        text(s.name_as_c_str())
                    ),
                    false => text(s.name_as_c_str()),
                };
                out.push(KernelStatistic {
                    name,
                    description: text(s.description_as_c_str()),
                    value,
                });
            }
        }
        out
    }

    fn created(&self) -> std::sync::MutexGuard<'_, HashMap<(&'static str, u32), vk::Pipeline>> {
        // A thread that panicked holding the lock left the map whole (inserts only).
        self.pipelines
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The pipeline of kernel `name` for scenes of `features`, which [`Pipelines::prepare`]
    /// created: every kernel a render records is in its integrator's list
    /// (`wavefront::kernels`), which the GPU tests of each integrator exercise.
    pub fn get(&self, name: &'static str, features: u32) -> vk::Pipeline {
        *self
            .created()
            .get(&(name, features))
            .unwrap_or_else(|| panic!("kernel {name} is not in its integrator's list"))
    }

    /// Points every binding at its buffer (whole range); with [`Pipelines::one_binding`], the
    /// further chunks, which its layout lacks, are passed by.
    pub fn bind_buffers(&self, buffers: &[(Binding, vk::Buffer)]) {
        let buffers: Vec<(Binding, vk::Buffer)> = buffers
            .iter()
            .copied()
            .filter(|(b, _)| b.declared(self.one_binding))
            .collect();
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
            .map(|((binding, _), info)| self.write(*binding).buffer_info(info))
            .collect();
        unsafe { self.device.update_descriptor_sets(&writes, &[]) };
    }

    /// Points each image binding at its image's view.
    pub fn bind_images(&self, images: &[(Binding, vk::ImageView)]) {
        let infos: Vec<[vk::DescriptorImageInfo; 1]> = images
            .iter()
            .map(|(_, view)| {
                [vk::DescriptorImageInfo::default()
                    .image_view(*view)
                    .image_layout(vk::ImageLayout::GENERAL)]
            })
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = images
            .iter()
            .zip(&infos)
            .map(|((binding, _), info)| self.write(*binding).image_info(info))
            .collect();
        unsafe { self.device.update_descriptor_sets(&writes, &[]) };
    }

    /// A descriptor write to `binding` of the set, its resource still to be given.
    fn write(&self, binding: Binding) -> vk::WriteDescriptorSet<'static> {
        vk::WriteDescriptorSet::default()
            .dst_set(self.set)
            .dst_binding(binding as u32)
            .descriptor_type(binding.descriptor_type())
    }
}

impl Drop for Pipelines {
    fn drop(&mut self) {
        unsafe {
            for (_, p) in self.created().drain() {
                self.device.destroy_pipeline(p, None);
            }
            self.device.destroy_descriptor_pool(self.pool, None);
            self.device.destroy_pipeline_layout(self.layout, None);
            self.device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
