//! GLSL twins on the GPU against their Rust functions, and the SPIR-V of every kernel checked by naga
//! (struct layouts, bindings, validation).
//!
//! One test binary for what these files prove together (linking the crate once, not once per file).

#[path = "../common/mod.rs"]
mod common;

mod light_bvh_twins;
mod shaders;
mod surface_twins;
mod twins;
