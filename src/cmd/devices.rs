//! `wavetrace devices`: the Vulkan devices, their `--gpu-index` and what each can render.

use anyhow::{bail, Result};

pub(crate) fn devices() -> Result<()> {
    let list = wavetrace::gpu::list_devices()?;
    if list.is_empty() {
        bail!(
            "no Vulkan device was found: {}",
            wavetrace::gpu::INSTALL_HINT
        );
    }
    for d in list {
        println!(
            "{}: {} ({}, Vulkan {}, {}){}",
            d.index,
            d.name,
            d.kind,
            d.api_version,
            d.driver,
            if !d.usable {
                format!(
                    " — not usable: needs {}",
                    wavetrace::gpu::context::REQUIREMENTS
                )
            } else if let Some(shortfall) = d.storage_shortfall() {
                format!(" — cannot render: {shortfall} (it runs the twin tests' kernels)")
            } else if !d.splits_scene_arrays() {
                format!(
                    " — renders scenes whose arrays each fit one storage binding (it binds {} \
                     storage buffers per kernel, not {})",
                    d.max_storage_buffers,
                    wavetrace::gpu::bindings::STORAGE_BUFFERS
                )
            } else {
                String::new()
            }
        );
    }
    Ok(())
}
