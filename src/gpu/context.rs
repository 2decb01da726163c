//! The Vulkan instance, the chosen physical device, its logical device and compute queue, and the
//! validation layer's messages when it is on.

use anyhow::{anyhow, bail, Context as _, Result};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use gpu_allocator::AllocationSizes;
use std::ffi::{c_void, CStr};
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex};

/// What to tell a user who has no Vulkan.
pub const INSTALL_HINT: &str = "install a Vulkan driver (on Debian/Ubuntu: `sudo tools/install-vulkan.sh` \
installs the Vulkan loader and Mesa's software driver, lavapipe) or render on the CPU with `--device cpu`";

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// A Vulkan device as `wavetrace devices` lists it.
#[derive(Clone, Debug)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    pub kind: String,
    pub api_version: String,
    pub driver: String,
    /// Vulkan 1.2+ with a compute queue and subgroup votes, ballots and arithmetic in compute
    /// shaders.
    pub usable: bool,
    /// Storage buffers a kernel may bind (`maxPerStageDescriptorStorageBuffers`).
    pub max_storage_buffers: u32,
    /// Storage images a kernel may bind (the least of `maxPerStageDescriptorStorageImages` and
    /// `maxDescriptorSetStorageImages`): the scene images are read as storage images.
    pub max_storage_images: u32,
}

/// What a usable device offers (`DeviceInfo::usable`), as the messages say it.
pub const REQUIREMENTS: &str =
    "Vulkan 1.2 with a compute queue and subgroup votes, ballots and arithmetic in compute shaders";

impl DeviceInfo {
    /// Whether the renderer runs on it: usable, and able to bind the storage buffers of the
    /// wavefront kernels that declare one binding per scene array (27; SwiftShader binds 30).
    pub fn renders(&self) -> bool {
        self.usable && self.storage_shortfall().is_none()
    }

    /// Whether it renders scenes whose arrays take more than one storage binding each: it
    /// binds all the kernels' storage buffers (42).
    pub fn splits_scene_arrays(&self) -> bool {
        self.renders() && self.max_storage_buffers >= super::bindings::STORAGE_BUFFERS
    }

    /// Why the wavefront kernels' storage buffers or images do not fit its limits, if they do
    /// not.
    pub fn storage_shortfall(&self) -> Option<String> {
        let needed = super::bindings::STORAGE_BUFFERS_ONE_BINDING;
        // The scene images and the wavefront's (the hit records').
        let images =
            super::bindings::SceneImage::ALL.len() as u32 + super::bindings::WAVEFRONT_IMAGES;
        if self.max_storage_buffers < needed {
            Some(format!(
                "binds at most {} storage buffers per kernel; wavetrace needs {needed}",
                self.max_storage_buffers
            ))
        } else if self.max_storage_images < images {
            Some(format!(
                "binds at most {} storage images per kernel; wavetrace needs {images}",
                self.max_storage_images
            ))
        } else {
            None
        }
    }
}

pub struct Context {
    _entry: ash::Entry,
    pub instance: ash::Instance,
    messenger: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pub labels: Option<ash::ext::debug_utils::Device>,
    pub physical: vk::PhysicalDevice,
    pub properties: vk::PhysicalDeviceProperties,
    pub memory_properties: vk::PhysicalDeviceMemoryProperties,
    pub device: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub timestamp_valid_bits: u32,
    pub info: DeviceInfo,
    /// Sub-allocates every buffer's memory from a few large blocks (`memory.rs`); dropped
    /// before the device.
    pub allocator: ManuallyDrop<Arc<Mutex<Allocator>>>,
    /// Error messages from the validation layer (boxed: the callback holds its address).
    validation_errors: Box<Mutex<Vec<String>>>,
    /// The driver's statistics of a compiled kernel (registers, spills, instructions: whatever
    /// it names), where the device offers `VK_KHR_pipeline_executable_properties`.
    pub executable_properties: Option<ash::khr::pipeline_executable_properties::Device>,
    /// Set once work has been submitted to the queue (`Commands::submit_and_wait`): only then
    /// does dropping the context wait for the device, which a device that cannot run work
    /// (Mesa RADV's null device, which `bench --kernels` compiles for) does not survive.
    pub submitted: std::sync::atomic::AtomicBool,
}

unsafe extern "system" fn on_validation_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) && !data.is_null() {
        let message = unsafe { (*data).message_as_c_str() }
            .map(|m| m.to_string_lossy().into_owned())
            .unwrap_or_default();
        let errors = unsafe { &*(user as *const Mutex<Vec<String>>) };
        if let Ok(mut errors) = errors.lock() {
            errors.push(message);
        }
    }
    vk::FALSE
}

fn load_entry() -> Result<ash::Entry> {
    unsafe { ash::Entry::load() }
        .map_err(|e| anyhow!("no Vulkan loader could be loaded ({e}): {INSTALL_HINT}"))
}

fn create_instance(entry: &ash::Entry, validation: bool) -> Result<(ash::Instance, bool, bool)> {
    let layers = unsafe { entry.enumerate_instance_layer_properties() }.unwrap_or_default();
    let has_layer = layers
        .iter()
        .any(|l| l.layer_name_as_c_str() == Ok(VALIDATION_LAYER));
    let extensions =
        unsafe { entry.enumerate_instance_extension_properties(None) }.unwrap_or_default();
    let has_debug_utils = extensions
        .iter()
        .any(|e| e.extension_name_as_c_str() == Ok(ash::ext::debug_utils::NAME));
    let use_layer = validation && has_layer;
    let layer_ptrs: Vec<*const i8> = if use_layer {
        vec![VALIDATION_LAYER.as_ptr()]
    } else {
        vec![]
    };
    let ext_ptrs: Vec<*const i8> = if has_debug_utils {
        vec![ash::ext::debug_utils::NAME.as_ptr()]
    } else {
        vec![]
    };
    let app = vk::ApplicationInfo::default()
        .application_name(c"wavetrace")
        .engine_name(c"wavetrace")
        .api_version(vk::API_VERSION_1_2);
    // With the layer on, also check synchronization (hazards between commands and submissions).
    let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
    let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
    let mut info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layer_ptrs)
        .enabled_extension_names(&ext_ptrs);
    if use_layer {
        info = info.push_next(&mut features);
    }
    let instance = unsafe { entry.create_instance(&info, None) }
        .map_err(|e| anyhow!("vkCreateInstance failed ({e}): {INSTALL_HINT}"))?;
    Ok((instance, use_layer, has_debug_utils))
}

fn describe(instance: &ash::Instance, index: usize, physical: vk::PhysicalDevice) -> DeviceInfo {
    let mut driver = vk::PhysicalDeviceDriverProperties::default();
    let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default()
        .push_next(&mut driver)
        .push_next(&mut subgroup);
    unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    let p = props2.properties;
    let queues = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    let has_compute = queues
        .iter()
        .any(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE));
    let v = p.api_version;
    DeviceInfo {
        index,
        name: p
            .device_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        kind: format!("{:?}", p.device_type)
            .to_lowercase()
            .replace('_', " "),
        api_version: format!(
            "{}.{}.{}",
            vk::api_version_major(v),
            vk::api_version_minor(v),
            vk::api_version_patch(v)
        ),
        driver: format!(
            "{} {}",
            driver
                .driver_name_as_c_str()
                .map(|s| s.to_string_lossy())
                .unwrap_or_default(),
            driver
                .driver_info_as_c_str()
                .map(|s| s.to_string_lossy())
                .unwrap_or_default()
        )
        .trim()
        .to_owned(),
        // The kernels' BVH walks vote across a subgroup (subgroupAll, qbvh.glsl) and their queue
        // pushes and counts go one atomic per subgroup (ballot, arithmetic; bindings.glsl):
        // Vulkan 1.1 makes subgroups core, and every GPU driver and lavapipe offer these three
        // in compute.
        max_storage_buffers: p.limits.max_per_stage_descriptor_storage_buffers,
        max_storage_images: p
            .limits
            .max_per_stage_descriptor_storage_images
            .min(p.limits.max_descriptor_set_storage_images),
        usable: v >= vk::API_VERSION_1_2
            && has_compute
            && subgroup
                .supported_stages
                .contains(vk::ShaderStageFlags::COMPUTE)
            && subgroup.supported_operations.contains(
                vk::SubgroupFeatureFlags::VOTE
                    | vk::SubgroupFeatureFlags::BALLOT
                    | vk::SubgroupFeatureFlags::ARITHMETIC,
            ),
    }
}

/// Every Vulkan device the loader reports, usable or not.
pub fn list_devices() -> Result<Vec<DeviceInfo>> {
    let entry = load_entry()?;
    let (instance, _, _) = create_instance(&entry, false)?;
    let physicals = unsafe { instance.enumerate_physical_devices() }.unwrap_or_default();
    let list = physicals
        .iter()
        .enumerate()
        .map(|(i, &p)| describe(&instance, i, p))
        .collect();
    unsafe { instance.destroy_instance(None) };
    Ok(list)
}

/// Whether `physical` offers `VK_KHR_pipeline_executable_properties` with its
/// `pipelineExecutableInfo` feature.
fn offers_executable_info(instance: &ash::Instance, physical: vk::PhysicalDevice) -> bool {
    let extensions =
        unsafe { instance.enumerate_device_extension_properties(physical) }.unwrap_or_default();
    if !extensions
        .iter()
        .any(|e| e.extension_name_as_c_str() == Ok(ash::khr::pipeline_executable_properties::NAME))
    {
        return false;
    }
    let mut feature = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default();
    let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut feature);
    unsafe { instance.get_physical_device_features2(physical, &mut features) };
    feature.pipeline_executable_info == vk::TRUE
}

fn preference(kind: vk::PhysicalDeviceType) -> u32 {
    match kind {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

impl Context {
    /// Opens device `index` (as `wavetrace devices` numbers them), or the best usable one.
    pub fn new(index: Option<usize>, validation: bool) -> Result<Context> {
        let entry = load_entry()?;
        let (instance, use_layer, has_debug_utils) = create_instance(&entry, validation)?;
        let validation_errors = Box::new(Mutex::new(Vec::new()));
        let messenger = if use_layer && has_debug_utils {
            let loader = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                        | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL,
                )
                .pfn_user_callback(Some(on_validation_message))
                .user_data(&*validation_errors as *const Mutex<Vec<String>> as *mut c_void);
            let m = unsafe { loader.create_debug_utils_messenger(&info, None) }
                .context("creating the validation messenger")?;
            Some((loader, m))
        } else {
            None
        };

        let physicals = unsafe { instance.enumerate_physical_devices() }.unwrap_or_default();
        let infos: Vec<DeviceInfo> = physicals
            .iter()
            .enumerate()
            .map(|(i, &p)| describe(&instance, i, p))
            .collect();
        let chosen = match index {
            Some(i) => {
                let Some(info) = infos.get(i) else {
                    bail!(
                        "--gpu-index {i}: there are {} Vulkan device(s); `wavetrace devices` lists them",
                        infos.len()
                    );
                };
                if !info.usable {
                    bail!(
                        "Vulkan device {i} ({}) is not usable: wavetrace needs {REQUIREMENTS}",
                        info.name
                    );
                }
                i
            }
            None => {
                // A device that renders before one that runs test kernels only, one that renders
                // every scene before one that renders only scenes of one binding per array
                // (SwiftShader: lavapipe first where both are installed), then by kind.
                let best = (0..physicals.len())
                    .filter(|&i| infos[i].usable)
                    .min_by_key(|&i| {
                        (
                            !infos[i].renders(),
                            !infos[i].splits_scene_arrays(),
                            preference(
                                unsafe { instance.get_physical_device_properties(physicals[i]) }
                                    .device_type,
                            ),
                        )
                    });
                match best {
                    Some(i) => i,
                    None if physicals.is_empty() => {
                        bail!("no Vulkan device was found: {INSTALL_HINT}")
                    }
                    None => bail!("no Vulkan device offers {REQUIREMENTS}: {INSTALL_HINT}"),
                }
            }
        };
        let physical = physicals[chosen];
        let properties = unsafe { instance.get_physical_device_properties(physical) };
        let memory_properties = unsafe { instance.get_physical_device_memory_properties(physical) };
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let queue_family = families
            .iter()
            .position(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE))
            .expect("usable devices have a compute queue") as u32;
        let timestamp_valid_bits = families[queue_family as usize].timestamp_valid_bits;

        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        // VK_KHR_pipeline_executable_properties, where offered, so that `--stats` and `bench`
        // can show what the driver made of each kernel; it changes no kernel's code.
        let executable_info = offers_executable_info(&instance, physical);
        let extensions = [ash::khr::pipeline_executable_properties::NAME.as_ptr()];
        let mut executable_feature =
            vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default()
                .pipeline_executable_info(true);
        let mut device_info = vk::DeviceCreateInfo::default().queue_create_infos(&queue_info);
        if executable_info {
            device_info = device_info
                .enabled_extension_names(&extensions)
                .push_next(&mut executable_feature);
        }
        let device = unsafe { instance.create_device(physical, &device_info, None) }
            .with_context(|| format!("creating a Vulkan device on {}", infos[chosen].name))?;
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let labels =
            has_debug_utils.then(|| ash::ext::debug_utils::Device::new(&instance, &device));
        let executable_properties = executable_info
            .then(|| ash::khr::pipeline_executable_properties::Device::new(&instance, &device));
        // Blocks of 64 MiB (device) and 16 MiB (host) at first, growing to 256 MiB; a buffer
        // larger than a block gets a block of its own.
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: AllocationSizes::new(64 << 20, 16 << 20)
                .with_max_device_memblock_size(256 << 20)
                .with_max_host_memblock_size(256 << 20),
        });
        let allocator = match allocator {
            Ok(a) => ManuallyDrop::new(Arc::new(Mutex::new(a))),
            Err(e) => {
                unsafe { device.destroy_device(None) };
                bail!(
                    "creating the memory allocator on {}: {e}",
                    infos[chosen].name
                );
            }
        };
        Ok(Context {
            _entry: entry,
            instance,
            messenger,
            labels,
            physical,
            properties,
            memory_properties,
            device,
            queue,
            queue_family,
            timestamp_valid_bits,
            info: infos[chosen].clone(),
            allocator,
            validation_errors,
            executable_properties,
            submitted: std::sync::atomic::AtomicBool::new(false),
        })
    }

    /// True when the device is a CPU implementation such as lavapipe.
    pub fn is_cpu(&self) -> bool {
        self.properties.device_type == vk::PhysicalDeviceType::CPU
    }

    /// Whether the validation layer is running on this context.
    pub fn validating(&self) -> bool {
        self.messenger.is_some()
    }

    /// Sends an error-severity message through the validation messenger, as the layer would, so
    /// that a test can prove such errors fail the render. False when no messenger runs.
    #[doc(hidden)]
    pub fn report_validation_error_for_test(&self, message: &CStr) -> bool {
        let Some((loader, _)) = &self.messenger else {
            return false;
        };
        let data = vk::DebugUtilsMessengerCallbackDataEXT::default().message(message);
        unsafe {
            loader.submit_debug_utils_message(
                vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
                &data,
            )
        };
        true
    }

    /// Takes the validation errors reported so far (a test that expects one clears it this way).
    #[doc(hidden)]
    pub fn take_validation_errors(&self) -> Vec<String> {
        self.validation_errors
            .lock()
            .map(|mut e| std::mem::take(&mut *e))
            .unwrap_or_default()
    }

    /// Fails with every validation error reported so far.
    pub fn check_validation(&self) -> Result<()> {
        let errors = self
            .validation_errors
            .lock()
            .map(|e| e.clone())
            .unwrap_or_default();
        if errors.is_empty() {
            Ok(())
        } else {
            bail!(
                "the Vulkan validation layer reported {} error(s):\n{}",
                errors.len(),
                errors.join("\n")
            )
        }
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        unsafe {
            if self.submitted.load(std::sync::atomic::Ordering::Acquire) {
                let _ = self.device.device_wait_idle();
            }
            // Frees the allocator's blocks (every buffer is gone by now).
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((loader, m)) = self.messenger.take() {
                loader.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A device renders when it is usable and binds the wavefront kernels' storage buffers;
    /// SwiftShader (30) and an unusable device do not, and `devices` and `--device auto` say so.
    #[test]
    fn a_device_renders_only_with_room_for_the_kernels_buffers() {
        let device = |usable, max_storage_buffers| DeviceInfo {
            index: 0,
            name: "test".into(),
            kind: "cpu".into(),
            api_version: "1.3.0".into(),
            driver: String::new(),
            usable,
            max_storage_buffers,
            max_storage_images: 12,
        };
        let (all, one) = (
            crate::gpu::bindings::STORAGE_BUFFERS,
            crate::gpu::bindings::STORAGE_BUFFERS_ONE_BINDING,
        );
        assert_eq!((all, one), (42, 27));
        assert!(device(true, all).splits_scene_arrays());
        assert!(!device(true, all - 1).splits_scene_arrays());
        // SwiftShader's 30: scenes whose arrays fit one binding each.
        assert!(device(true, 30).renders() && !device(true, 30).splits_scene_arrays());
        assert!(device(true, one).renders());
        assert!(!device(true, one - 1).renders());
        assert!(!device(false, u32::MAX).renders());
        // The scene images are storage images, eleven of them, and the hit records' image.
        let few_images = DeviceInfo {
            max_storage_images: 11,
            ..device(true, all)
        };
        assert!(!few_images.renders());
        assert_eq!(
            few_images.storage_shortfall().as_deref(),
            Some("binds at most 11 storage images per kernel; wavetrace needs 12")
        );
    }
}
