//! glTF accessors: positions and indices decoded with every offset, stride, count and index
//! checked (sparse substitutions included), quantized attributes (KHR_mesh_quantization) widened
//! to floats, elements a compression extension decoded (Draco) read in place of a buffer view,
//! and triangle lists, strips and fans turned into vertex triples.

use super::json::label;
use super::limits::Budget;
use anyhow::{bail, Context, Result};
use glam::Vec3;
use gltf::accessor::{sparse::IndexType, Accessor, DataType, Dimensions};
use gltf::buffer::View;
use gltf::mesh::Mode;

/// The most elements an accessor without a buffer view (all zeros) may claim.
const MAX_ZERO_ACCESSOR_COUNT: usize = 1 << 26;

/// Elements a compression extension decoded for an accessor without a buffer view
/// (KHR_draco_mesh_compression): tightly packed, in the accessor's component type.
pub(super) type Decoded<'a> = Option<&'a [u8]>;

/// Decoded elements of an accessor: dense data (the `decoded` elements, else its buffer view,
/// else zeros), then sparse substitutions. `size` is the element size in bytes, `decode` reads
/// one element.
fn read_accessor<T: Copy + Default>(
    accessor: &Accessor,
    buffers: &[Vec<u8>],
    decoded: Decoded,
    budget: &Budget,
    size: usize,
    decode: impl Fn(&[u8]) -> T,
) -> Result<Vec<T>> {
    let count = accessor.count();
    let mut out = match (decoded, accessor.view()) {
        (Some(bytes), _) => {
            if count.checked_mul(size) != Some(bytes.len()) {
                bail!(
                    "count: {count}, but the compressed stream decodes {} elements",
                    bytes.len() / size
                );
            }
            reserve::<T>(budget, "decompressed elements", count)?;
            bytes.chunks_exact(size).map(&decode).collect()
        }
        (None, Some(view)) => read_view(
            &view,
            accessor.offset(),
            count,
            size,
            buffers,
            budget,
            &decode,
        )?,
        (None, None) if count <= MAX_ZERO_ACCESSOR_COUNT => {
            reserve::<T>(budget, "an accessor without a bufferView", count)?;
            vec![T::default(); count]
        }
        (None, None) => {
            bail!("count: {count} without a bufferView, expected at most {MAX_ZERO_ACCESSOR_COUNT}")
        }
    };
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let indices = sparse.indices();
        let slots = read_view(
            &indices.view(),
            indices.offset(),
            n,
            indices.index_type().size(),
            buffers,
            budget,
            &|b| match indices.index_type() {
                IndexType::U8 => b[0] as usize,
                IndexType::U16 => u16::from_le_bytes([b[0], b[1]]) as usize,
                IndexType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
            },
        )
        .context("sparse indices")?;
        let values = sparse.values();
        let values = read_view(
            &values.view(),
            values.offset(),
            n,
            size,
            buffers,
            budget,
            &decode,
        )
        .context("sparse values")?;
        let temporary = slots.len() as u64 * std::mem::size_of::<usize>() as u64
            + values.len() as u64 * std::mem::size_of::<T>() as u64;
        for (k, (slot, value)) in slots.into_iter().zip(values).enumerate() {
            let Some(element) = out.get_mut(slot) else {
                bail!("sparse index {slot} (entry {k}) is out of range: the accessor has {count} elements");
            };
            *element = value;
        }
        budget.release(temporary);
    }
    Ok(out)
}

/// `count` elements of `size` bytes at `offset` within a buffer view, honouring its stride.
fn read_view<T>(
    view: &View,
    offset: usize,
    count: usize,
    size: usize,
    buffers: &[Vec<u8>],
    budget: &Budget,
    decode: &dyn Fn(&[u8]) -> T,
) -> Result<Vec<T>> {
    let what = label("bufferView", view.index(), view.name());
    let buffer = &buffers[view.buffer().index()];
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        bail!("{what}: byteStride {stride} is smaller than the {size}-byte elements it holds");
    }
    let (start, length) = (view.offset(), view.length());
    let Some(data) = start
        .checked_add(length)
        .and_then(|end| buffer.get(start..end))
    else {
        bail!(
            "{what} (bytes {start}..{}) lies outside {} of {} bytes",
            start.saturating_add(length),
            label("buffer", view.buffer().index(), view.buffer().name()),
            buffer.len()
        );
    };
    if count == 0 {
        return Ok(Vec::new());
    }
    let end = (count - 1)
        .checked_mul(stride)
        .and_then(|x| x.checked_add(offset))
        .and_then(|x| x.checked_add(size));
    if !matches!(end, Some(end) if end <= data.len()) {
        bail!(
            "{count} elements of {size} bytes (stride {stride}) from byte offset {offset} do not fit \
             in {what} of {length} bytes"
        );
    }
    reserve::<T>(
        budget,
        &format!("{count} elements read through {what}"),
        count,
    )?;
    Ok((0..count)
        .map(|i| decode(&data[offset + i * stride..][..size]))
        .collect())
}

/// Reserves the memory of `count` elements of `T` for `what`.
fn reserve<T>(budget: &Budget, what: &str, count: usize) -> Result<()> {
    budget.reserve(what, count as u64 * std::mem::size_of::<T>() as u64)
}

/// The bytes `read_positions` or `read_indices` reserved for `count` elements, to release.
pub(super) fn element_bytes<T>(elements: &[T]) -> u64 {
    std::mem::size_of_val(elements) as u64
}

pub(super) fn read_positions(
    accessor: &Accessor,
    buffers: &[Vec<u8>],
    decoded: Decoded,
    budget: &Budget,
) -> Result<Vec<Vec3>> {
    // FLOAT, or (KHR_mesh_quantization) 8- and 16-bit integers, normalized or not.
    let ty = accessor.data_type();
    if accessor.dimensions() != Dimensions::Vec3
        || matches!(ty, DataType::U32)
        || (ty == DataType::F32 && accessor.normalized())
    {
        bail!(
            "positions must be VEC3 of FLOAT, or of (normalized) BYTE, UNSIGNED_BYTE, SHORT or \
             UNSIGNED_SHORT (KHR_mesh_quantization), found {:?} of {:?}{}",
            accessor.dimensions(),
            ty,
            if accessor.normalized() {
                " (normalized)"
            } else {
                ""
            }
        );
    }
    let component = component_decoder(ty, accessor.normalized());
    let k = ty.size();
    read_accessor(accessor, buffers, decoded, budget, 3 * k, |b| {
        Vec3::new(component(b), component(&b[k..]), component(&b[2 * k..]))
    })
}

/// One component of type `ty` as a float: FLOAT as it is, normalized integers as glTF 2.0 §3.11
/// says (c / (2ⁿ − 1) unsigned, max(c / (2ⁿ⁻¹ − 1), −1) signed), other integers as their value
/// (KHR_mesh_quantization's unnormalized positions and texture coordinates).
fn component_decoder(ty: DataType, normalized: bool) -> fn(&[u8]) -> f32 {
    match (ty, normalized) {
        (DataType::F32, _) => |c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
        (DataType::U8, true) => |c| c[0] as f32 / 255.0,
        (DataType::I8, true) => |c| (c[0] as i8 as f32 / 127.0).max(-1.0),
        (DataType::U16, true) => |c| u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0,
        (DataType::I16, true) => |c| (i16::from_le_bytes([c[0], c[1]]) as f32 / 32767.0).max(-1.0),
        (DataType::U8, false) => |c| c[0] as f32,
        (DataType::I8, false) => |c| c[0] as i8 as f32,
        (DataType::U16, false) => |c| u16::from_le_bytes([c[0], c[1]]) as f32,
        (DataType::I16, false) => |c| i16::from_le_bytes([c[0], c[1]]) as f32,
        (DataType::U32, _) => |c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f32,
    }
}

pub(super) fn read_indices(
    accessor: &Accessor,
    buffers: &[Vec<u8>],
    decoded: Decoded,
    budget: &Budget,
) -> Result<Vec<u32>> {
    if accessor.dimensions() != Dimensions::Scalar {
        bail!("indices must be SCALAR, found {:?}", accessor.dimensions());
    }
    match accessor.data_type() {
        DataType::U8 => read_accessor(accessor, buffers, decoded, budget, 1, |b| b[0] as u32),
        DataType::U16 => read_accessor(accessor, buffers, decoded, budget, 2, |b| {
            u16::from_le_bytes([b[0], b[1]]) as u32
        }),
        DataType::U32 => read_accessor(accessor, buffers, decoded, budget, 4, |b| {
            u32::from_le_bytes([b[0], b[1], b[2], b[3]])
        }),
        other => {
            bail!("indices must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT, found {other:?}")
        }
    }
}

/// A vertex attribute as up to four floats per element (missing components 0): FLOAT,
/// normalized integers where `normalized_types` allows them and plain integers where
/// `integer_types` does (KHR_mesh_quantization), each component as [`component_decoder`] reads
/// it. `dimensions` lists the accepted element types. Non-finite values are reported as an
/// error by the caller, which knows what the attribute means.
pub(super) fn read_attribute(
    accessor: &Accessor,
    buffers: &[Vec<u8>],
    decoded: Decoded,
    budget: &Budget,
    dimensions: &[Dimensions],
    normalized_types: &[DataType],
    integer_types: &[DataType],
) -> Result<Vec<[f32; 4]>> {
    let dims = accessor.dimensions();
    if !dimensions.contains(&dims) {
        bail!("expected {dimensions:?} elements, found {dims:?}");
    }
    let n = dims.multiplicity();
    let ty = accessor.data_type();
    let normalized = accessor.normalized();
    let allowed = match (ty, normalized) {
        (DataType::F32, false) => true,
        (_, true) => normalized_types.contains(&ty),
        (_, false) => integer_types.contains(&ty),
    };
    if !allowed {
        let allowed: Vec<String> = normalized_types
            .iter()
            .map(|t| format!("normalized {t:?}"))
            .chain(integer_types.iter().map(|t| format!("{t:?}")))
            .collect();
        bail!(
            "component type {ty:?}{} is not allowed here (expected FLOAT{}{})",
            if normalized { " (normalized)" } else { "" },
            if allowed.is_empty() { "" } else { " or " },
            allowed.join(", ")
        );
    }
    let component = ty.size();
    let read = component_decoder(ty, normalized);
    let decode = move |b: &[u8]| {
        let mut out = [0.0f32; 4];
        for (k, value) in out.iter_mut().enumerate().take(n) {
            *value = read(&b[k * component..]);
        }
        out
    };
    // Vertex attributes are aligned to 4 bytes per element (glTF 2.0 §3.6.2.4), but the
    // element itself is n components.
    read_accessor(accessor, buffers, decoded, budget, n * component, decode)
}

/// MAT4 FLOAT elements (column-major, glTF 2.0 §3.6.2.4), e.g. a skin's inverse bind matrices.
pub(super) fn read_matrices(
    accessor: &Accessor,
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<Vec<glam::Mat4>> {
    if accessor.dimensions() != Dimensions::Mat4
        || accessor.data_type() != DataType::F32
        || accessor.normalized()
    {
        bail!(
            "expected MAT4 of FLOAT, found {:?} of {:?}",
            accessor.dimensions(),
            accessor.data_type()
        );
    }
    read_accessor(accessor, buffers, None, budget, 64, |b| {
        glam::Mat4::from_cols_array(&std::array::from_fn(|k| {
            f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]])
        }))
    })
}

/// Vertex triples of a triangle list, strip or fan (glTF 2.0 §3.7.2.1 topology rules).
pub(super) fn triangle_corners(mode: Mode, v: &[u32]) -> Result<Vec<[u32; 3]>> {
    let n = v.len();
    Ok(match mode {
        Mode::Triangles => {
            if !n.is_multiple_of(3) {
                bail!("a triangle list needs a multiple of 3 vertices/indices, found {n}");
            }
            v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        }
        Mode::TriangleStrip => (0..n.saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [v[i], v[i + 1], v[i + 2]]
                } else {
                    [v[i], v[i + 2], v[i + 1]]
                }
            })
            .collect(),
        Mode::TriangleFan => (0..n.saturating_sub(2))
            .map(|i| [v[i + 1], v[i + 2], v[0]])
            .collect(),
        _ => Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding() {
        let strip = triangle_corners(Mode::TriangleStrip, &[0, 1, 2, 3]).unwrap();
        assert_eq!(strip, [[0, 1, 2], [1, 3, 2]]);
        let fan = triangle_corners(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap();
        assert_eq!(fan, [[1, 2, 0], [2, 3, 0]]);
        assert!(triangle_corners(Mode::Triangles, &[0, 1]).is_err());
    }
}
