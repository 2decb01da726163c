//! Skins at the file's static pose (glTF 2.0 §3.7.3 "Skins"): a skinned vertex is
//! Σₖ wₖ·Jⱼₖ·p with the joint matrices J = globalTransform(joint) · inverseBindMatrix, over every
//! JOINTS_n / WEIGHTS_n set; the skinned mesh node's own transform is ignored, as the
//! specification requires. Normals take the inverse transpose of the blended matrix, tangents
//! its linear part. Negative weights count as 0 and the rest are normalised to sum 1; a vertex
//! whose weights are not finite or all zero is left unskinned and counted in one note.

use super::accessors::{read_attribute, read_matrices};
use super::draco::DracoPrimitive;
use super::json::{json_path, label};
use super::limits::Budget;
use anyhow::{anyhow, bail, Context, Result};
use glam::{Mat4, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Primitive;
use gltf::{Document, Semantic};

/// The world transform of every node of the document from the nodes' `local` transforms (each
/// under its parents', from the nodes no node lists as a child); a node no root reaches (only
/// in a loop, which the walk refuses for the scene) keeps its local transform.
pub(super) fn world_transforms(document: &Document, local: &[Mat4]) -> Vec<Mat4> {
    let n = document.nodes().len();
    let mut is_child = vec![false; n];
    for node in document.nodes() {
        for c in node.children() {
            is_child[c.index()] = true;
        }
    }
    let mut world = local.to_vec();
    let mut done = vec![false; n];
    let mut stack: Vec<(usize, Mat4)> = (0..n)
        .filter(|&i| !is_child[i])
        .map(|i| (i, Mat4::IDENTITY))
        .collect();
    while let Some((i, parent)) = stack.pop() {
        if std::mem::replace(&mut done[i], true) {
            continue;
        }
        world[i] = parent * local[i];
        let node = document.nodes().nth(i).expect("index in range");
        stack.extend(node.children().map(|c| (c.index(), world[i])));
    }
    world
}

/// The joint matrices of `skin`: world(joint) · inverseBindMatrix (identity without them).
pub(super) fn joint_matrices(
    skin: &gltf::Skin,
    worlds: &[Mat4],
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<Vec<Mat4>> {
    let at = json_path("skin", skin.index());
    let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
    let inverse = match skin.inverse_bind_matrices() {
        Some(accessor) => {
            let what = format!(
                "{at}.inverseBindMatrices = {}",
                label("accessor", accessor.index(), accessor.name())
            );
            let m = read_matrices(&accessor, buffers, budget).context(what.clone())?;
            budget.release(std::mem::size_of_val(m.as_slice()) as u64);
            if m.len() != joints.len() {
                bail!("{what}: {} matrices for {} joints", m.len(), joints.len());
            }
            if let Some(k) = m.iter().position(|m| !m.is_finite()) {
                bail!("{what}: matrix {k} is not finite");
            }
            if let Some(k) = m.iter().position(|m| m.determinant().abs() < 1e-30) {
                bail!(
                    "{what}: matrix {k} (of {}) is singular: an inverse bind matrix must be \
                     invertible",
                    label(
                        "node",
                        joints[k],
                        skin.joints().nth(k).and_then(|j| j.name())
                    )
                );
            }
            m
        }
        None => vec![Mat4::IDENTITY; joints.len()],
    };
    let out: Vec<Mat4> = joints
        .iter()
        .zip(&inverse)
        .map(|(&j, m)| worlds[j] * *m)
        .collect();
    if let Some(k) = out.iter().position(|m| !m.is_finite()) {
        bail!("{at}.joints[{k}]: its joint matrix is not finite");
    }
    Ok(out)
}

/// The blended skinning matrix of each of `count` vertices, and how many vertices were left
/// unskinned for weights that are not finite or all zero.
pub(super) fn vertex_matrices(
    primitive: &Primitive,
    draco: &DracoPrimitive,
    joints: &[Mat4],
    count: usize,
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<(Vec<Mat4>, usize)> {
    budget.reserve(
        "the skinning matrices",
        count as u64 * std::mem::size_of::<Mat4>() as u64,
    )?;
    let mut blended = vec![Mat4::ZERO; count];
    let mut total = vec![0.0f32; count];
    let mut bad = vec![false; count];
    for set in 0.. {
        let (Some(j), Some(w)) = (
            primitive.get(&Semantic::Joints(set)),
            primitive.get(&Semantic::Weights(set)),
        ) else {
            break;
        };
        let jwhat = format!(
            "attributes.JOINTS_{set} = {}",
            label("accessor", j.index(), j.name())
        );
        let wwhat = format!(
            "attributes.WEIGHTS_{set} = {}",
            label("accessor", w.index(), w.name())
        );
        let ints = [DataType::U8, DataType::U16];
        let (jd, wd) = (draco.elements(&j), draco.elements(&w));
        let js = read_attribute(&j, buffers, jd, budget, &[Dimensions::Vec4], &[], &ints)
            .context(jwhat.clone())?;
        let ws = read_attribute(&w, buffers, wd, budget, &[Dimensions::Vec4], &ints, &[])
            .context(wwhat.clone())?;
        for (what, n) in [(&jwhat, js.len()), (&wwhat, ws.len())] {
            if n != count {
                bail!("{what}: {n} elements, but POSITION has {count}");
            }
        }
        for v in 0..count {
            for k in 0..4 {
                let weight = ws[v][k];
                if !weight.is_finite() {
                    bad[v] = true;
                    continue;
                }
                // Encoders' quantisation leaves weights a little below 0 (the Draco
                // RiggedSimple's reach −0.001): taken as 0, and the rest renormalised.
                if weight <= 0.0 {
                    continue;
                }
                let joint = js[v][k] as usize;
                let m = joints.get(joint).ok_or_else(|| {
                    anyhow!(
                        "{jwhat}: joint {joint} (vertex {v}) is out of range: the skin has {} joints",
                        joints.len()
                    )
                })?;
                blended[v] += *m * weight;
                total[v] += weight;
            }
        }
        budget.release(2 * std::mem::size_of_val(js.as_slice()) as u64);
    }
    let mut unskinned = 0;
    for v in 0..count {
        if bad[v] || total[v] <= 0.0 {
            blended[v] = Mat4::IDENTITY;
            unskinned += 1;
        } else {
            blended[v] *= 1.0 / total[v];
        }
    }
    Ok((blended, unskinned))
}

/// Whether `primitive` carries skinning attributes.
pub(super) fn is_skinned(primitive: &Primitive) -> bool {
    primitive.get(&Semantic::Joints(0)).is_some() && primitive.get(&Semantic::Weights(0)).is_some()
}

/// A skinned vertex: position, normal (inverse transpose) and tangent xyz (linear part).
pub(super) fn skin_vertex(
    m: &Mat4,
    p: &mut glam::Vec3,
    n: Option<&mut glam::Vec3>,
    t: Option<&mut Vec4>,
) {
    *p = m.transform_point3(*p);
    let linear = glam::Mat3::from_mat4(*m);
    if let Some(n) = n {
        *n = linear.inverse().transpose() * *n;
    }
    if let Some(t) = t {
        *t = (linear * t.truncate()).extend(t.w);
    }
}
