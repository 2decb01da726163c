//! The commands of the `wavetrace` binary, one per file, each a thin layer over the library:
//! `render`, `devices`, `bench` (with `bench_bvh` and `bench_kernels`), `compare`, `verify`,
//! `merge` and `estimators` (and `sequence`, render's frames of an animation); below them what
//! several share (`options`, `prepare`, `report`, `shards`, `bench_args`, `version`).

pub(crate) mod bench;
pub(crate) mod bench_args;
pub(crate) mod bench_bvh;
pub(crate) mod bench_kernels;
pub(crate) mod compare;
pub(crate) mod devices;
pub(crate) mod estimators;
pub(crate) mod merge;
pub(crate) mod options;
pub(crate) mod prepare;
pub(crate) mod render;
pub(crate) mod report;
pub(crate) mod sequence;
pub(crate) mod shards;
pub(crate) mod verify;
pub(crate) mod version;
