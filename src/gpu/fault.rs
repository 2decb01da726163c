//! Injected faults, for the tests that prove a render ends cleanly when the device is lost or
//! memory runs out (issue 14, item 5). `WAVETRACE_FAULT` names one fault:
//!
//! - `device-lost@N`: the N-th wavefront batch submitted by this process fails with
//!   `VK_ERROR_DEVICE_LOST` instead of running;
//! - `oom@NAME`: allocating the buffer named NAME (e.g. `film`, `bvh_nodes`) fails with
//!   `VK_ERROR_OUT_OF_DEVICE_MEMORY`.
//!
//! Without the variable nothing is injected. While a fault is injected, a render in progress
//! keeps a copy of its film after every whole sample pass (instead of every few seconds), so a
//! test knows exactly which samples survive.

use ash::vk;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::OnceLock;

#[derive(Clone, Debug, PartialEq, Eq)]
enum Fault {
    DeviceLost(u32),
    OutOfMemory(String),
}

fn fault() -> Option<&'static Fault> {
    static FAULT: OnceLock<Option<Fault>> = OnceLock::new();
    FAULT
        .get_or_init(|| {
            let v = std::env::var("WAVETRACE_FAULT").ok()?;
            let (kind, arg) = v.split_once('@')?;
            match kind {
                "device-lost" => arg.parse().ok().map(Fault::DeviceLost),
                "oom" => Some(Fault::OutOfMemory(arg.to_owned())),
                _ => None,
            }
        })
        .as_ref()
}

/// Whether any fault is injected (renders then checkpoint after every pass).
pub fn injected() -> bool {
    fault().is_some()
}

/// Called before each wavefront batch is submitted: the injected device loss, if this is its
/// batch.
pub fn before_batch() -> Result<(), vk::Result> {
    static BATCHES: AtomicU32 = AtomicU32::new(0);
    let n = BATCHES.fetch_add(1, Ordering::Relaxed) + 1;
    match fault() {
        Some(Fault::DeviceLost(at)) if n >= *at => Err(vk::Result::ERROR_DEVICE_LOST),
        _ => Ok(()),
    }
}

/// Called before memory for buffer `name` is allocated: the injected exhaustion, if it is this
/// buffer.
pub fn before_allocation(name: &str) -> Result<(), vk::Result> {
    match fault() {
        Some(Fault::OutOfMemory(n)) if n == name => Err(vk::Result::ERROR_OUT_OF_DEVICE_MEMORY),
        _ => Ok(()),
    }
}
