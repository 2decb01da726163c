//! Morph targets at the file's static pose (glTF 2.0 §3.7.2.2 "Morph Targets"): an attribute is
//! its base value plus Σ wᵢ·Δᵢ over the primitive's targets, the weights the node's `weights`,
//! else the mesh's, else zeros. POSITION, NORMAL and TANGENT (its xyz) deltas are read, sparse
//! accessors and KHR_mesh_quantization's normalized deltas included, and TEXCOORD_n and COLOR_0
//! deltas (which the `gltf` crate's typed model drops: read from the JSON, [`ExtraTargets`]).

use super::accessors::read_attribute;
use super::json::label;
use super::limits::Budget;
use anyhow::{bail, Context, Result};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Primitive;
use gltf::Semantic;
use std::collections::HashMap;

/// The TEXCOORD_n and COLOR_0 accessors of every morph target, by (mesh, primitive): one map
/// per target from the attribute's name to its accessor index.
#[derive(Clone, Debug, Default)]
pub(super) struct ExtraTargets(HashMap<(usize, usize), Vec<HashMap<String, usize>>>);

/// Reads [`ExtraTargets`] from the file's JSON, each index checked against the accessors.
pub(super) fn extra_targets(value: &serde_json::Value) -> Result<ExtraTargets> {
    let accessors = value
        .get("accessors")
        .and_then(|a| a.as_array())
        .map_or(0, Vec::len);
    let mut out = HashMap::new();
    let list = |v: Option<&serde_json::Value>| v.and_then(|v| v.as_array()).cloned();
    for (m, mesh) in list(value.get("meshes"))
        .unwrap_or_default()
        .iter()
        .enumerate()
    {
        for (p, primitive) in list(mesh.get("primitives"))
            .unwrap_or_default()
            .iter()
            .enumerate()
        {
            let Some(targets) = list(primitive.get("targets")) else {
                continue;
            };
            let mut found = Vec::new();
            for (t, target) in targets.iter().enumerate() {
                let mut extra = HashMap::new();
                for (name, index) in target.as_object().into_iter().flatten() {
                    if !(name.starts_with("TEXCOORD_") || name == "COLOR_0") {
                        continue;
                    }
                    let at = format!("meshes[{m}].primitives[{p}].targets[{t}].{name}");
                    let index = index
                        .as_u64()
                        .filter(|&i| (i as usize) < accessors)
                        .ok_or_else(|| {
                            anyhow::anyhow!(
                                "{at}: {index} is not an accessor index (the file has {accessors})"
                            )
                        })?;
                    extra.insert(name.clone(), index as usize);
                }
                found.push(extra);
            }
            if found.iter().any(|e| !e.is_empty()) {
                out.insert((m, p), found);
            }
        }
    }
    Ok(ExtraTargets(out))
}

/// Σ wᵢ·Δᵢ of the TEXCOORD_n or COLOR_0 attribute `name` of primitive `index` of mesh `mesh`,
/// for `count` vertices; `None` where no target with a non-zero weight moves it. The sum's bytes
/// are reserved in the budget; the caller releases them (`sum_bytes`).
#[allow(clippy::too_many_arguments)]
pub(super) fn weighted_extra_deltas(
    document: &gltf::Document,
    extra: &ExtraTargets,
    (mesh, index): (usize, usize),
    weights: &[f32],
    name: &str,
    count: usize,
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<Option<Vec<[f32; 4]>>> {
    let Some(targets) = extra.0.get(&(mesh, index)) else {
        return Ok(None);
    };
    let dims: &[Dimensions] = if name == "COLOR_0" {
        &[Dimensions::Vec3, Dimensions::Vec4]
    } else {
        &[Dimensions::Vec2]
    };
    let accessors = targets.iter().enumerate().filter_map(|(k, target)| {
        let a = *target.get(name)?;
        Some((k, document.accessors().nth(a).expect("checked index")))
    });
    weighted_sum(accessors, name, weights, dims, &[], count, buffers, budget)
}

/// Σ wᵢ·Δᵢ over the targets' `accessors` (target index, accessor) of attribute `name` with a
/// non-zero weight: FLOAT, KHR_mesh_quantization's normalized BYTE and SHORT, and the plain
/// `integers` types.
#[allow(clippy::too_many_arguments)]
fn weighted_sum<'a>(
    accessors: impl Iterator<Item = (usize, gltf::Accessor<'a>)>,
    name: &str,
    weights: &[f32],
    dims: &[Dimensions],
    integers: &[DataType],
    count: usize,
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<Option<Vec<[f32; 4]>>> {
    let mut sum: Option<Vec<[f32; 4]>> = None;
    for (k, accessor) in accessors {
        let w = weights.get(k).copied().unwrap_or(0.0);
        if w == 0.0 {
            continue;
        }
        let what = format!(
            "targets[{k}].{name} = {}",
            label("accessor", accessor.index(), accessor.name())
        );
        let normalized = [DataType::I8, DataType::I16];
        let deltas = read_attribute(
            &accessor,
            buffers,
            None,
            budget,
            dims,
            &normalized,
            integers,
        )
        .context(what.clone())?;
        if deltas.len() != count {
            bail!(
                "{what}: {} elements, but POSITION has {count}",
                deltas.len()
            );
        }
        if deltas.iter().flatten().any(|v| !v.is_finite()) {
            bail!("{what}: non-finite deltas");
        }
        let sum = match &mut sum {
            Some(sum) => sum,
            None => {
                budget.reserve("the morph targets' weighted sum", sum_bytes(count))?;
                sum.insert(vec![[0.0; 4]; count])
            }
        };
        for (s, d) in sum.iter_mut().zip(&deltas) {
            for c in 0..4 {
                s[c] += w * d[c];
            }
        }
        budget.release(std::mem::size_of_val(deltas.as_slice()) as u64);
    }
    Ok(sum)
}

/// The morph weights of `primitive`: the node's, else the mesh's, else zeros, one per target.
/// `from` says where `weights` came from, for messages.
pub(super) fn weights(primitive: &Primitive, weights: Option<(&[f32], &str)>) -> Result<Vec<f32>> {
    let targets = primitive.morph_targets().len();
    let Some((weights, from)) = weights else {
        return Ok(vec![0.0; targets]);
    };
    if targets == 0 {
        return Ok(Vec::new());
    }
    if weights.len() != targets {
        bail!(
            "{from}.weights: {} values, but the primitive has {targets} morph targets",
            weights.len()
        );
    }
    if let Some(w) = weights.iter().find(|w| !w.is_finite()) {
        bail!("{from}.weights: {w} is not a finite number");
    }
    Ok(weights.to_vec())
}

/// Σ wᵢ·Δᵢ of one attribute (`Positions`, `Normals` or `Tangents`, xyz) over the targets with
/// a non-zero weight, for `count` vertices; `None` where no such target moves it. The sum's
/// bytes are reserved in the budget; the caller releases them (`sum_bytes`).
pub(super) fn weighted_deltas(
    primitive: &Primitive,
    weights: &[f32],
    semantic: Semantic,
    count: usize,
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<Option<Vec<[f32; 4]>>> {
    let accessors = primitive
        .morph_targets()
        .enumerate()
        .filter_map(|(k, target)| {
            let accessor = match semantic {
                Semantic::Positions => target.positions(),
                Semantic::Normals => target.normals(),
                Semantic::Tangents => target.tangents(),
                _ => None,
            }?;
            Some((k, accessor))
        });
    // Positions may also be plain integers (KHR_mesh_quantization).
    let integers: &[DataType] = if semantic == Semantic::Positions {
        &[DataType::I8, DataType::U8, DataType::I16, DataType::U16]
    } else {
        &[]
    };
    let name = semantic.to_string();
    weighted_sum(
        accessors,
        &name,
        weights,
        &[Dimensions::Vec3],
        integers,
        count,
        buffers,
        budget,
    )
}

/// The bytes [`weighted_deltas`] and [`weighted_extra_deltas`] reserved for a sum over `count`
/// vertices.
pub(super) fn sum_bytes(count: usize) -> u64 {
    count as u64 * std::mem::size_of::<[f32; 4]>() as u64
}
