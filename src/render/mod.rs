//! What both integrators share: render settings, the scene prepared for tracing (BVH, triangles
//! in BVH order, materials, emitter table), the per-render constants and the render's output.

pub mod aov;
mod backend;
mod check;
mod prepared;
pub mod progressive;
mod settings;
mod stats;

pub use aov::Aov;
pub use backend::Backend;
pub use check::check;
pub use prepared::{gpu_material, GpuBvh, PreparedScene};
pub use settings::{Integrator, RenderSettings};
pub use stats::{
    statistics_line, DeviceMemory, KernelStatistic, RenderOutput, RenderStats, StatisticValue,
};
