//! EXT_meshopt_compression: buffer views stored compressed in another buffer, decoded with
//! meshoptimizer's decoders (the `meshopt` crate) into their place in their own buffer — a
//! fallback buffer with no data of its own is zeros until then — before any accessor is read.
//! Every parameter the C decoders assert on is checked here first, so a malformed file is an
//! error naming the buffer view, never an abort.

use super::json::label;
use super::limits::Budget;
use anyhow::{anyhow, bail, Result};
use gltf::Document;
use meshopt::ffi;

/// Whether a buffer is a meshopt fallback: its bytes are what the compressed views decode to,
/// and it need not have data of its own.
pub(super) fn is_fallback(buffer: &gltf::Buffer) -> bool {
    buffer
        .extension_value("EXT_meshopt_compression")
        .and_then(|e| e.get("fallback"))
        .and_then(|f| f.as_bool())
        == Some(true)
}

/// Decodes every compressed buffer view into its bytes of its buffer. Errors name the view's
/// extension by JSON path.
pub(super) fn decode_views(
    document: &Document,
    buffers: &mut [Vec<u8>],
    budget: &Budget,
) -> Result<()> {
    for view in document.views() {
        let Some(extension) = view.extension_value("EXT_meshopt_compression") else {
            continue;
        };
        let at = format!(
            "{}.extensions.EXT_meshopt_compression",
            label("bufferView", view.index(), view.name())
        );
        let field = |name: &str| -> Result<Option<usize>> {
            match extension.get(name) {
                None => Ok(None),
                Some(v) => v
                    .as_u64()
                    .and_then(|v| usize::try_from(v).ok())
                    .map(Some)
                    .ok_or_else(|| anyhow!("{at}.{name}: expected a non-negative integer")),
            }
        };
        let required = |name: &str| -> Result<usize> {
            field(name)?.ok_or_else(|| anyhow!("{at}.{name}: missing, expected an integer"))
        };
        let source = required("buffer")?;
        let offset = field("byteOffset")?.unwrap_or(0);
        let length = required("byteLength")?;
        let stride = required("byteStride")?;
        let count = required("count")?;
        let text = |name: &str, default: &'static str| -> Result<String> {
            match extension.get(name) {
                None => Ok(default.to_owned()),
                Some(v) => v
                    .as_str()
                    .map(str::to_owned)
                    .ok_or_else(|| anyhow!("{at}.{name}: expected a string")),
            }
        };
        let mode = text("mode", "")?;
        let filter = text("filter", "NONE")?;

        let compressed = buffers
            .get(source)
            .ok_or_else(|| anyhow!("{at}.buffer: buffer {source} does not exist"))?
            .get(offset..offset.saturating_add(length))
            .ok_or_else(|| {
                anyhow!(
                    "{at}: bytes {offset}..{} lie outside buffer {source} of {} bytes",
                    offset.saturating_add(length),
                    buffers[source].len()
                )
            })?;
        let size = count
            .checked_mul(stride)
            .filter(|&size| size <= view.length())
            .ok_or_else(|| {
                anyhow!(
                    "{at}: count {count} × byteStride {stride} exceeds the view's byteLength {}",
                    view.length()
                )
            })?;
        budget.reserve(&format!("decoding {at}"), size as u64)?;
        let decoded = decode(compressed, &mode, &filter, count, stride, size)
            .map_err(|e| anyhow!("{at}: {e}"));
        budget.release(size as u64);
        let decoded = decoded?;
        let target = view.buffer();
        let into = buffers[target.index()]
            .get_mut(view.offset()..view.offset().saturating_add(size))
            .ok_or_else(|| {
                anyhow!(
                    "{}: bytes {}..{} lie outside {}",
                    label("bufferView", view.index(), view.name()),
                    view.offset(),
                    view.offset().saturating_add(size),
                    label("buffer", target.index(), target.name())
                )
            })?;
        into.copy_from_slice(&decoded);
    }
    Ok(())
}

/// `count` elements of `stride` bytes decoded from `compressed` by `mode`, then `filter`
/// (EXT_meshopt_compression, "Decoding": ATTRIBUTES, TRIANGLES, INDICES; NONE, OCTAHEDRAL,
/// QUATERNION, EXPONENTIAL, COLOR).
fn decode(
    compressed: &[u8],
    mode: &str,
    filter: &str,
    count: usize,
    stride: usize,
    size: usize,
) -> Result<Vec<u8>> {
    // Everything is checked before the decoders run.
    /// The filter NONE.
    unsafe extern "C" fn none(_: *mut std::ffi::c_void, _: usize, _: usize) {}
    type Filter = unsafe extern "C" fn(*mut std::ffi::c_void, usize, usize);
    let (apply, strides): (Filter, &[usize]) = match filter {
        "NONE" => (none, &[]),
        "OCTAHEDRAL" => (ffi::meshopt_decodeFilterOct, &[4, 8]),
        "QUATERNION" => (ffi::meshopt_decodeFilterQuat, &[8]),
        "COLOR" => (ffi::meshopt_decodeFilterColor, &[4, 8]),
        "EXPONENTIAL" => (ffi::meshopt_decodeFilterExp, &[]),
        other => bail!(
            "filter: {other:?}, expected \"NONE\", \"OCTAHEDRAL\", \"QUATERNION\", \
             \"EXPONENTIAL\" or \"COLOR\""
        ),
    };
    if !strides.is_empty() && !strides.contains(&stride) {
        bail!("byteStride {stride}: the {filter} filter needs {strides:?}");
    }
    if filter != "NONE" && mode != "ATTRIBUTES" {
        bail!("filter: {filter:?} on {mode}, but filters apply to ATTRIBUTES only");
    }
    let mut out = vec![0u8; size];
    let code = match mode {
        "ATTRIBUTES" => {
            if stride == 0 || stride > 256 || !stride.is_multiple_of(4) {
                bail!("byteStride {stride}: ATTRIBUTES need a multiple of 4 from 4 to 256");
            }
            // SAFETY: `out` holds count × stride bytes, the stride is one the decoder accepts,
            // and it reads at most `compressed.len()` bytes.
            unsafe {
                ffi::meshopt_decodeVertexBuffer(
                    out.as_mut_ptr().cast(),
                    count,
                    stride,
                    compressed.as_ptr(),
                    compressed.len(),
                )
            }
        }
        "TRIANGLES" | "INDICES" => {
            if stride != 2 && stride != 4 {
                bail!("byteStride {stride}: {mode} need 2 or 4");
            }
            if mode == "TRIANGLES" && !count.is_multiple_of(3) {
                bail!("count {count}: TRIANGLES need a multiple of 3");
            }
            let decode = if mode == "TRIANGLES" {
                ffi::meshopt_decodeIndexBuffer
            } else {
                ffi::meshopt_decodeIndexSequence
            };
            // SAFETY: as above, with an index size of 2 or 4 (and whole triangles).
            unsafe {
                decode(
                    out.as_mut_ptr().cast(),
                    count,
                    stride,
                    compressed.as_ptr(),
                    compressed.len(),
                )
            }
        }
        other => bail!("mode: {other:?}, expected \"ATTRIBUTES\", \"TRIANGLES\" or \"INDICES\""),
    };
    if code != 0 {
        bail!("the {mode} stream does not decode (meshoptimizer error {code})");
    }
    // SAFETY: `out` holds count × stride bytes and the stride is one the filter accepts
    // (EXPONENTIAL: any multiple of 4, checked for ATTRIBUTES above).
    unsafe { apply(out.as_mut_ptr().cast(), count, stride) };
    Ok(out)
}
