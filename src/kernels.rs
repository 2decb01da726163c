//! The SPIR-V of every wavefront kernel and twin-test kernel, compiled from `shaders/` by
//! build.rs at build time (`KERNELS`, `KERNELS_ONE_BINDING`, the twin tests' modules).

include!(concat!(env!("OUT_DIR"), "/kernels.rs"));
