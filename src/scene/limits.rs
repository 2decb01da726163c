//! What a scene file may make wavetrace do: the folders it may read from and the memory it may
//! take. A glTF file is untrusted input (docs/security.md, "Running on untrusted files").

use super::model::Triangle;
use crate::layout::{BvhNode, GpuTriangle, LightEntry};
use anyhow::{bail, Result};
use std::mem::size_of;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

/// The share of the machine's physical memory that the default budget allows.
pub const DEFAULT_MEMORY_FRACTION: f64 = 0.5;

/// Memory one triangle takes while the scene is prepared for rendering (`PreparedScene`): its
/// corners and material, the BVH builder's bounds reference (two corners and an id), up to
/// two BVH nodes, the intersector's triangle, a light-table entry and the BVH order.
pub const PREPARE_BYTES_PER_TRIANGLE: u64 = (size_of::<Triangle>()
    + 28
    + 2 * size_of::<BvhNode>()
    + size_of::<GpuTriangle>()
    + size_of::<LightEntry>()
    + 4) as u64;

/// Memory one emitter (emitting triangle or punctual light) takes in the light BVH besides
/// [`PREPARE_BYTES_PER_TRIANGLE`] (`light_bvh::BYTES_PER_LIGHT`).
pub const PREPARE_BYTES_PER_EMITTER: u64 = crate::lights::light_bvh::BYTES_PER_LIGHT as u64;

/// Memory every triangle takes once any emits: its trail to its light BVH leaf (a `u32`) and
/// its emitter-selection scale (an `f32`).
pub const PREPARE_BYTES_PER_TRIANGLE_WITH_EMITTERS: u64 = 8;

/// Memory one instance takes while prepared: its `GpuInstance`, its box in the top level's
/// build (bounds and id), up to two top-level nodes and the order entry.
pub const PREPARE_BYTES_PER_INSTANCE: u64 =
    (size_of::<crate::layout::GpuInstance>() + 28 + 2 * size_of::<BvhNode>() + 4) as u64;

/// The budget when the machine's memory cannot be determined.
const FALLBACK_MEMORY: u64 = 4 << 30;

/// How a scene is loaded: where its URIs may point and how much memory it may take.
#[derive(Debug)]
pub struct LoadOptions {
    /// Folders besides the scene file's own folder (and below) that buffer and image URIs may
    /// name (`--allow-path`).
    pub allow_paths: Vec<PathBuf>,
    /// Memory accounting for the load and everything the render derives from the scene.
    pub budget: Budget,
    /// Store meshes that several placements share once and instance them (`tlas.rs`); false
    /// bakes every placement into world space (for tests that compare the two).
    pub instancing: bool,
}

impl Default for LoadOptions {
    fn default() -> LoadOptions {
        LoadOptions {
            allow_paths: Vec::new(),
            budget: Budget::new(default_memory_budget()),
            instancing: true,
        }
    }
}

/// A memory budget checked before every large allocation: `reserve` before allocating,
/// `release` after freeing. Thread-safe, so the render can keep using the loader's budget.
#[derive(Debug)]
pub struct Budget {
    limit: u64,
    used: AtomicU64,
}

impl Budget {
    pub fn new(limit: u64) -> Budget {
        Budget {
            limit,
            used: AtomicU64::new(0),
        }
    }

    pub fn limit(&self) -> u64 {
        self.limit
    }

    /// Bytes reserved and not released.
    pub fn used(&self) -> u64 {
        self.used.load(Ordering::Relaxed)
    }

    /// Accounts `bytes` for `what`, or refuses, saying what would have been needed.
    pub fn reserve(&self, what: &str, bytes: u64) -> Result<()> {
        let mut used = self.used.load(Ordering::Relaxed);
        loop {
            let total = used.saturating_add(bytes);
            if total > self.limit {
                bail!(
                    "{what} would need {} more memory ({} in all), over the memory budget of {} \
                     (--max-memory)",
                    format_bytes(bytes),
                    format_bytes(total),
                    format_bytes(self.limit)
                );
            }
            match self
                .used
                .compare_exchange(used, total, Ordering::Relaxed, Ordering::Relaxed)
            {
                Ok(_) => return Ok(()),
                Err(now) => used = now,
            }
        }
    }

    /// Returns `bytes` reserved earlier.
    pub fn release(&self, bytes: u64) {
        let _ = self
            .used
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |u| {
                Some(u.saturating_sub(bytes))
            });
    }
}

/// `DEFAULT_MEMORY_FRACTION` of the machine's physical memory.
pub fn default_memory_budget() -> u64 {
    (physical_memory().unwrap_or(FALLBACK_MEMORY) as f64 * DEFAULT_MEMORY_FRACTION) as u64
}

/// Physical memory in bytes (POSIX sysconf).
fn physical_memory() -> Option<u64> {
    // SAFETY: sysconf only reads system configuration.
    let (pages, page) = unsafe {
        (
            libc::sysconf(libc::_SC_PHYS_PAGES),
            libc::sysconf(libc::_SC_PAGESIZE),
        )
    };
    (pages > 0 && page > 0).then(|| (pages as u64).saturating_mul(page as u64))
}

/// "512M", "4G", "1.5GiB", "100000" (bytes): binary units (K = 1024).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let number: f64 = number
        .parse()
        .map_err(|_| format!("'{text}': expected a size such as 512M or 4G"))?;
    let shift = match unit.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 0,
        "K" | "KB" | "KIB" => 10,
        "M" | "MB" | "MIB" => 20,
        "G" | "GB" | "GIB" => 30,
        "T" | "TB" | "TIB" => 40,
        _ => return Err(format!("'{text}': unknown unit (use K, M, G or T)")),
    };
    let bytes = number * (1u64 << shift) as f64;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!("'{text}': the size must be at least one byte"));
    }
    Ok(bytes as u64)
}

/// Bytes for messages: "1.50 GiB", "12.0 MiB", "512 bytes".
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [(&str, u32); 3] = [("GiB", 30), ("MiB", 20), ("KiB", 10)];
    for (unit, shift) in UNITS {
        if bytes >= 1 << shift {
            return format!("{:.2} {unit}", bytes as f64 / (1u64 << shift) as f64);
        }
    }
    format!("{bytes} bytes")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_in_binary_units() {
        assert_eq!(parse_size("100"), Ok(100));
        assert_eq!(parse_size("4K"), Ok(4096));
        assert_eq!(parse_size("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_size("512 m"), Ok(512 << 20));
        assert!(parse_size("0").is_err());
        assert!(parse_size("-1G").is_err());
        assert!(parse_size("3 parsecs").is_err());
    }

    #[test]
    fn budget_refuses_what_exceeds_it() {
        let budget = Budget::new(1000);
        budget.reserve("a", 600).unwrap();
        let e = budget
            .reserve("the triangles", 500)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("the triangles") && e.contains("500 bytes"),
            "{e}"
        );
        budget.release(600);
        budget.reserve("b", 1000).unwrap();
        assert_eq!(budget.used(), 1000);
        assert!(default_memory_budget() > 0);
    }
}
