//! The integrators: the GPU against the CPU reference on every committed scene, light tracing and
//! BDPT, renders in passes, the lecture's estimators, the furnace, the samplers, emitter
//! sampling, dispersion.
//!
//! One test binary for what these files prove together (linking the crate once, not once per file).

#[path = "../common/mod.rs"]
mod common;

mod adaptive;
mod bidir;
mod dispersion;
mod estimators;
mod furnace;
mod gpu_vs_cpu;
mod light_sampling;
mod sampler;
