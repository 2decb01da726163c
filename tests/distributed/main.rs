//! Past one machine: shards and merges, resume, the Slurm recipe on a real cluster and the
//! Kubernetes manifests.
//!
//! One test binary for what these files prove together (linking the crate once, not once per file).

#[path = "../common/mod.rs"]
mod common;

mod k8s;
mod shards;
mod slurm;
