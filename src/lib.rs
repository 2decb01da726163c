//! wavetrace: a headless GPU wavefront path tracer (Vulkan) with a CPU reference integrator that
//! implements the same mathematics, so every GPU image can be checked against it.

pub mod bsdf;
pub mod bvh;
pub mod cpu;
pub mod denoise;
pub mod film;
pub mod flip;
pub mod gpu;
pub mod image_io;
pub mod kernels;
pub mod layout;
pub mod lights;
pub mod mc;
pub mod mis;
pub mod paths;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod shard;
pub mod sobol;
pub mod spectrum;
pub mod stats;
pub mod surface;
pub mod texture;
pub mod tlas;
pub mod verify;
pub mod view;
