//! KHR_draco_mesh_compression: a primitive's Draco stream decoded (the pure-Rust `draco-core`)
//! into the elements of the accessors it stands for, which are then read like any other
//! (`accessors.rs`). The stream is untrusted: the decoder is held to the counts the accessors
//! declare and to what is left of the memory budget before it allocates, and the decoded counts
//! must equal the declared ones.

use super::json::label;
use super::limits::Budget;
use anyhow::{anyhow, bail, Result};
use draco_core::{DecodeLimits, DecoderBuffer, Mesh, MeshDecoder};
use gltf::accessor::DataType;
use gltf::mesh::Primitive;
use gltf::Document;
use std::collections::HashMap;

/// The accessors' elements a primitive's Draco stream decoded, tightly packed in each
/// accessor's component type, by accessor index; empty for a primitive without the extension.
#[derive(Default)]
pub(super) struct DracoPrimitive {
    elements: HashMap<usize, Vec<u8>>,
    /// Bytes reserved in the budget for `elements`, released with them.
    reserved: u64,
}

impl DracoPrimitive {
    /// The decoded elements of `accessor`, if the stream stands for it.
    pub(super) fn elements(&self, accessor: &gltf::Accessor) -> Option<&[u8]> {
        self.elements.get(&accessor.index()).map(Vec::as_slice)
    }

    /// Frees the decoded elements and gives their bytes back to the budget.
    pub(super) fn release(self, budget: &Budget) {
        budget.release(self.reserved);
    }
}

/// Decodes the primitive's KHR_draco_mesh_compression stream, if it has one. Errors name the
/// extension's JSON path (relative to the primitive) and the problem.
pub(super) fn decode(
    document: &Document,
    primitive: &Primitive,
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<DracoPrimitive> {
    let Some(extension) = primitive.extension_value("KHR_draco_mesh_compression") else {
        return Ok(DracoPrimitive::default());
    };
    let at = |s: &str| format!("extensions.KHR_draco_mesh_compression{s}");
    let view_index = extension
        .get("bufferView")
        .and_then(|v| v.as_u64())
        .ok_or_else(|| {
            anyhow!(
                "{}: missing, expected a bufferView index",
                at(".bufferView")
            )
        })?;
    let view = document.views().nth(view_index as usize).ok_or_else(|| {
        anyhow!(
            "{}: bufferView {view_index} does not exist",
            at(".bufferView")
        )
    })?;
    let what = label("bufferView", view.index(), view.name());
    let buffer = &buffers[view.buffer().index()];
    let stream = view
        .offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(|| {
            anyhow!(
                "{} = {what}: bytes {}..{} lie outside {} of {} bytes",
                at(".bufferView"),
                view.offset(),
                view.offset().saturating_add(view.length()),
                label("buffer", view.buffer().index(), view.buffer().name()),
                buffer.len()
            )
        })?;
    let attributes = extension
        .get("attributes")
        .and_then(|a| a.as_object())
        .ok_or_else(|| anyhow!("{}: missing, expected an object", at(".attributes")))?;
    let positions = primitive
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| anyhow!("attributes.POSITION: missing, expected an accessor index"))?;
    let indices = primitive.indices().ok_or_else(|| {
        anyhow!(
            "indices: missing, but a Draco-compressed primitive needs an indices accessor \
             (KHR_draco_mesh_compression)"
        )
    })?;
    if !indices.count().is_multiple_of(3) {
        bail!(
            "indices: count {} is not a multiple of 3, but a Draco stream holds triangles",
            indices.count()
        );
    }

    // The decoder may decode no more than the accessors declare, nor more bytes than the
    // budget has left (its `max_decoded_bytes` bounds the attribute values it allocates).
    let points = positions.count();
    let faces = indices.count() / 3;
    let left = budget.limit().saturating_sub(budget.used());
    let limits = DecodeLimits::default()
        .with_max_points(points as u64)
        .with_max_faces(faces as u64)
        .with_max_decoded_bytes(left);
    let mut mesh = Mesh::new();
    MeshDecoder::new()
        .decode(
            &mut DecoderBuffer::new(stream).with_limits(limits),
            &mut mesh,
        )
        .map_err(|e| {
            anyhow!(
                "{} = {what}: the Draco stream does not decode: {e}",
                at(".bufferView")
            )
        })?;
    if mesh.num_points() != points || mesh.num_faces() != faces {
        bail!(
            "{} = {what}: the Draco stream decodes {} points and {} triangles, but POSITION \
             declares {points} and indices {} ({faces} triangles)",
            at(".bufferView"),
            mesh.num_points(),
            mesh.num_faces(),
            indices.count()
        );
    }

    let mut out = DracoPrimitive::default();
    let reserve = |bytes: usize, out: &mut DracoPrimitive| -> Result<()> {
        budget.reserve("a decoded Draco attribute", bytes as u64)?;
        out.reserved += bytes as u64;
        Ok(())
    };
    // Indices, in the accessor's component type.
    let width = indices.data_type().size();
    reserve(3 * faces * width, &mut out)?;
    let mut bytes = Vec::with_capacity(3 * faces * width);
    for face in mesh.faces() {
        for corner in face.iter() {
            let v = corner.0;
            match indices.data_type() {
                DataType::U8 if v <= u8::MAX as u32 => bytes.push(v as u8),
                DataType::U16 if v <= u16::MAX as u32 => bytes.extend((v as u16).to_le_bytes()),
                DataType::U32 => bytes.extend(v.to_le_bytes()),
                ty => bail!(
                    "indices = {}: the Draco stream's vertex {v} does not fit its component type \
                     {ty:?}",
                    label("accessor", indices.index(), indices.name())
                ),
            }
        }
    }
    out.elements.insert(indices.index(), bytes);

    // Each attribute the stream holds, by its unique id, widened to floats and written in the
    // component type its accessor declares (integers stay integers: a normalized accessor's
    // elements are normalized when the accessor is read).
    for (semantic, accessor) in primitive.attributes() {
        let name = semantic.to_string();
        let Some(id) = attributes.get(&name) else {
            continue;
        };
        let path = at(&format!(".attributes.{name}"));
        let id = id
            .as_u64()
            .and_then(|id| u32::try_from(id).ok())
            .ok_or_else(|| anyhow!("{path}: expected an attribute id"))?;
        let attribute = mesh
            .attribute_by_unique_id(id)
            .ok_or_else(|| anyhow!("{path}: the Draco stream has no attribute with id {id}"))?;
        let n = accessor.dimensions().multiplicity();
        if attribute.num_components() as usize != n {
            bail!(
                "{path}: the Draco attribute has {} components, but {} is {:?}",
                attribute.num_components(),
                label("accessor", accessor.index(), accessor.name()),
                accessor.dimensions()
            );
        }
        let ty = accessor.data_type();
        reserve(points * n * (4 + ty.size()), &mut out)?;
        let values = attribute.read_f32s(points, n);
        let mut bytes = Vec::with_capacity(values.len() * ty.size());
        for v in values {
            match ty {
                DataType::F32 => bytes.extend(v.to_le_bytes()),
                DataType::U8 => bytes.push(v as u8),
                DataType::I8 => bytes.push(v as i8 as u8),
                DataType::U16 => bytes.extend((v as u16).to_le_bytes()),
                DataType::I16 => bytes.extend((v as i16).to_le_bytes()),
                DataType::U32 => bytes.extend((v as u32).to_le_bytes()),
            }
        }
        out.elements.insert(accessor.index(), bytes);
    }
    for (semantic, accessor) in primitive.attributes() {
        if accessor.view().is_none()
            && accessor.sparse().is_none()
            && out.elements(&accessor).is_none()
        {
            bail!(
                "attributes.{} = {}: has no bufferView, and {} does not name it",
                semantic.to_string(),
                label("accessor", accessor.index(), accessor.name()),
                at(".attributes")
            );
        }
    }
    if out.elements(&positions).is_none() {
        bail!(
            "{}: has no POSITION, but the primitive's positions are in the Draco stream",
            at(".attributes")
        );
    }
    Ok(out)
}
