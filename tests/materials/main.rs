//! Materials and lights: the glTF BSDF and its KHR extensions, textures as the specification
//! samples them, the environment map and punctual lights, CPU against GPU.
//!
//! One test binary for what these files prove together (linking the crate once, not once per file).

#[path = "../common/mod.rs"]
mod common;

mod environment;
mod material_extensions;
mod materials;
mod punctual;
mod texture_spec;
mod transmission_extensions;
