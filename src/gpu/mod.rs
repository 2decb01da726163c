//! The GPU integrator: Vulkan (ash) on any Vulkan 1.2 device, lavapipe included, running the
//! wavefront kernels of `shaders/wavefront/`.

pub mod bindings;
pub mod compute;
pub mod context;
pub mod fault;
pub mod memory;
mod passes;
pub mod pipelines;
mod renderer;
pub mod resources;
mod trace;
pub mod wavefront;

pub use bindings::SceneImages;
pub use context::{list_devices, DeviceInfo, INSTALL_HINT};
pub use passes::GpuBackend;
pub use renderer::{CompiledKernels, GpuOptions, GpuRenderer, KernelCompiler};
pub use trace::Traced;
