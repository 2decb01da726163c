//! The glTF container and its JSON: the GLB header and chunks (errors name the chunk and the
//! byte offset), then the JSON parsed twice, first to a `serde_json::Value` and then to the
//! `gltf` crate's typed model, with every error naming the JSON path of the offending value
//! (`serde_path_to_error`) and saying what was expected in glTF's words, not Rust's.

use anyhow::{anyhow, bail, Result};
use serde_json::Value;
use std::ops::Range;

/// GLB chunk types (glTF 2.0 §4.4.3).
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;
const GLB_HEADER: usize = 12;
const CHUNK_HEADER: usize = 8;

/// Where the JSON and the binary chunk lie within the file's bytes.
#[derive(Debug)]
pub(super) struct Container {
    pub json: Range<usize>,
    pub bin: Option<Range<usize>>,
}

impl Container {
    pub fn is_glb(&self) -> bool {
        self.json.start > 0
    }
}

/// A GLB's JSON and BIN chunks (glTF 2.0 §4.4), or the whole file when it is not a GLB.
pub(super) fn split_container(bytes: &[u8]) -> Result<Container> {
    if !bytes.starts_with(b"glTF") {
        return Ok(Container {
            json: 0..bytes.len(),
            bin: None,
        });
    }
    let u32_at = |offset: usize| {
        bytes
            .get(offset..offset + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (u32_at(4), u32_at(8)) else {
        bail!(
            "GLB header (bytes 0..12): the file ends at byte {}, inside the header",
            bytes.len()
        );
    };
    if version != 2 {
        bail!("GLB header, byte 4: version {version}, expected 2");
    }
    let length = length as usize;
    if length < GLB_HEADER || length > bytes.len() {
        bail!(
            "GLB header, byte 8: total length {length}, expected at least 12 and at most the \
             file's {} bytes",
            bytes.len()
        );
    }
    let mut chunks = Vec::new();
    let mut offset = GLB_HEADER;
    while offset < length {
        let (Some(chunk_length), Some(kind)) = (u32_at(offset), u32_at(offset + 4)) else {
            bail!(
                "GLB chunk {} header at byte {offset}: the file's declared length {length} ends \
                 inside it (a chunk header has 8 bytes)",
                chunks.len()
            );
        };
        let start = offset + CHUNK_HEADER;
        let end = start as u64 + chunk_length as u64;
        if end > length as u64 {
            bail!(
                "GLB chunk {} ({}) at byte {offset}: its length {chunk_length} runs past the end \
                 of the file's declared {length} bytes",
                chunks.len(),
                chunk_name(kind)
            );
        }
        let end = end as usize;
        chunks.push((kind, start..end, offset));
        // Chunks are padded to 4-byte boundaries (§4.4.3.1).
        offset = end.next_multiple_of(4);
    }
    let Some((kind, json, at)) = chunks.first().cloned() else {
        bail!("GLB: no chunk after the header, expected a JSON chunk at byte 12");
    };
    if kind != CHUNK_JSON {
        bail!(
            "GLB chunk 0 at byte {at}: type {}, expected JSON (the first chunk must hold the JSON)",
            chunk_name(kind)
        );
    }
    let bin = match chunks.get(1) {
        Some((CHUNK_BIN, range, _)) => Some(range.clone()),
        _ => None,
    };
    if let Some((i, (_, _, at))) = chunks
        .iter()
        .enumerate()
        .skip(1)
        .find(|(_, c)| c.0 == CHUNK_JSON)
    {
        bail!("GLB chunk {i} at byte {at}: a second JSON chunk (only chunk 0 may hold JSON)");
    }
    Ok(Container { json, bin })
}

/// A chunk type for messages: its four ASCII letters, or its number.
fn chunk_name(kind: u32) -> String {
    let b = kind.to_le_bytes();
    if b.iter().all(|c| c.is_ascii_alphanumeric() || *c == 0) {
        format!("\"{}\"", String::from_utf8_lossy(&b).trim_end_matches('\0'))
    } else {
        format!("0x{kind:08X}")
    }
}

/// Parses JSON text. `offset` is where the text starts in the file (a GLB's JSON chunk), so
/// that syntax errors in a GLB give a byte offset in the file rather than a line in the chunk.
pub(super) fn parse_value(text: &[u8], offset: usize) -> Result<Value> {
    let mut de = serde_json::Deserializer::from_slice(text);
    let value: Value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let position = position(text, offset, e.inner());
        anyhow!(
            "{}: {} ({position})",
            path_name(&e.path().to_string()),
            syntax_message(e.inner())
        )
    })?;
    de.end().map_err(|e| {
        anyhow!(
            "the top level: unexpected text after the end of the JSON document ({})",
            position(text, offset, &e)
        )
    })?;
    if !value.is_object() {
        bail!(
            "the top level: found {}, expected a JSON object (the glTF root)",
            kind(&value)
        );
    }
    Ok(value)
}

/// The `gltf` crate's typed model of a checked `Value`; errors name the JSON path.
pub(super) fn typed_root(value: Value) -> Result<gltf::json::Root> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        anyhow!(
            "{}: {}",
            path_name(&e.path().to_string()),
            printable(&plain_message(&e.inner().to_string()))
        )
    })
}

/// The `gltf` crate's validation errors, each with its JSON path, in plain words.
pub(super) fn validation_message(error: gltf::Error) -> anyhow::Error {
    use gltf::json::validation::Error as E;
    let gltf::Error::Validation(errors) = error else {
        return anyhow!("{error}");
    };
    let problems: Vec<String> = errors
        .iter()
        .map(|(path, e)| {
            let problem = match e {
                E::IndexOutOfBounds => "the index is out of range, expected an existing object",
                E::Invalid => "invalid value, expected one that glTF 2.0 allows here",
                E::Missing => "missing, expected a value here",
                E::Oversize => "the size exceeds what this machine can address",
                E::Unsupported => "an unsupported extension",
            };
            format!("{}: {problem}", printable(&path.to_string()))
        })
        .collect();
    let more = problems.len().saturating_sub(MAX_LISTED_PROBLEMS);
    let mut message = problems[..problems.len().min(MAX_LISTED_PROBLEMS)].join("; ");
    if more > 0 {
        message += &format!("; and {more} more problems");
    }
    anyhow!("{message}")
}

/// "the top level" for the root, the path otherwise.
/// Validation problems listed in one message; the rest are counted.
const MAX_LISTED_PROBLEMS: usize = 8;

/// Text from the file as it may appear in a message: control characters (terminal escapes
/// included) escaped.
pub(super) fn printable(text: &str) -> String {
    text.chars()
        .flat_map(|c| {
            let escaped: Vec<char> = if c.is_control() {
                c.escape_default().collect()
            } else {
                vec![c]
            };
            escaped
        })
        .collect()
}

/// Paths deeper than this many characters are cut in messages (a hostile file can nest 128
/// arrays).
const MAX_PATH_CHARS: usize = 160;

pub(super) fn path_name(path: &str) -> String {
    // serde_path_to_error writes `?` for a member whose key was not read yet.
    let path = printable(path.trim_end_matches(".?").trim_end_matches('?'));
    let path = path.as_str();
    if path.is_empty() || path == "." {
        "the top level".to_owned()
    } else if path.len() > MAX_PATH_CHARS {
        let cut = (0..=MAX_PATH_CHARS)
            .rev()
            .find(|&i| path.is_char_boundary(i))
            .unwrap_or(0);
        format!("{}… ({} characters)", &path[..cut], path.len())
    } else {
        path.to_owned()
    }
}

/// A JSON value's kind in words, for "found …" messages.
pub(super) fn kind(value: &Value) -> String {
    match value {
        Value::Null => "null".into(),
        Value::Bool(b) => format!("the boolean {b}"),
        Value::Number(n) => format!("the number {n}"),
        Value::String(s) if s.len() > 40 => format!("a string of {} characters", s.len()),
        Value::String(s) => format!("the string {s:?}"),
        Value::Array(a) => format!("an array of {} elements", a.len()),
        Value::Object(_) => "an object".into(),
    }
}

/// Where a JSON error lies: line and column, and for a GLB the byte offset in the file.
fn position(text: &[u8], offset: usize, e: &serde_json::Error) -> String {
    let (line, column) = (e.line(), e.column());
    if offset == 0 {
        return format!("line {line}, column {column}");
    }
    let line_start: usize = text
        .split(|&b| b == b'\n')
        .take(line.saturating_sub(1))
        .map(|l| l.len() + 1)
        .sum();
    let byte = offset + line_start + column.saturating_sub(1);
    format!("JSON chunk, byte {byte} of the file")
}

/// serde_json's syntax message without its position (given separately).
fn syntax_message(e: &serde_json::Error) -> String {
    let text = e.to_string();
    let text = match text.rfind(" at line ") {
        Some(i) => &text[..i],
        None => &text,
    };
    format!("invalid JSON: {text}")
}

/// serde's type-level messages in glTF's words: "invalid type: null, expected struct
/// PbrMetallicRoughness" → "found null, expected a JSON object".
pub(super) fn plain_message(text: &str) -> String {
    let text = match text.rfind(" at line ") {
        Some(i) => &text[..i],
        None => text,
    };
    if let Some(field) = text
        .strip_prefix("missing field `")
        .and_then(|t| t.strip_suffix('`'))
    {
        return format!("the required property \"{field}\" is missing");
    }
    for prefix in ["invalid type: ", "invalid value: "] {
        if let Some((found, expected)) = text
            .strip_prefix(prefix)
            .and_then(|t| t.split_once(", expected "))
        {
            return format!(
                "found {}, expected {}",
                found_words(found),
                expected_words(expected)
            );
        }
    }
    if let Some((found, expected)) = text
        .strip_prefix("invalid length ")
        .and_then(|t| t.split_once(", expected "))
    {
        return format!(
            "found {found} elements, expected {}",
            expected_words(expected)
        );
    }
    if let Some(rest) = text.strip_prefix("unknown variant ") {
        return format!("unknown value {}", rest.replace('`', "\""));
    }
    text.replace('`', "\"")
}

fn found_words(found: &str) -> String {
    let inner = |s: &str| s.split('`').nth(1).unwrap_or(s).to_owned();
    match found {
        "map" => "an object".into(),
        "sequence" => "an array".into(),
        "null" | "unit value" => "null".into(),
        f if f.starts_with("floating point") || f.starts_with("integer") => {
            format!("the number {}", inner(f))
        }
        f if f.starts_with("boolean") => format!("the boolean {}", inner(f)),
        f if f.starts_with("string ") => format!("the {f}"),
        f => f.replace('`', "\""),
    }
}

fn expected_words(expected: &str) -> String {
    if expected.starts_with("struct ") || expected == "a map" || expected == "map" {
        return "a JSON object".into();
    }
    match expected {
        "u8" | "u16" | "u32" | "u64" | "usize" | "index into child of root" => {
            "a non-negative integer".into()
        }
        "i8" | "i16" | "i32" | "i64" => "an integer".into(),
        "f32" | "f64" => "a number".into(),
        "a sequence" => "an array".into(),
        "fewer elements in array" => "fewer (the array is too long)".into(),
        "a boolean" | "a string" => expected.into(),
        e => e.replace('`', "\"").replace("sequence", "array"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_messages_become_gltf_words() {
        assert_eq!(
            plain_message("invalid type: null, expected struct PbrMetallicRoughness"),
            "found null, expected a JSON object"
        );
        assert_eq!(
            plain_message("invalid type: floating point `1.5`, expected u32"),
            "found the number 1.5, expected a non-negative integer"
        );
        assert_eq!(
            plain_message("missing field `buffer`"),
            "the required property \"buffer\" is missing"
        );
    }

    #[test]
    fn glb_chunks_are_checked() {
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend(24u32.to_le_bytes());
        glb.extend(4u32.to_le_bytes());
        glb.extend(CHUNK_JSON.to_le_bytes());
        glb.extend(b"{}  ");
        let c = split_container(&glb[..20]).unwrap_err().to_string();
        assert!(c.contains("byte 8"), "{c}");
        let ok = split_container(&glb).unwrap();
        assert_eq!(ok.json, 20..24);
        glb[12] = 9;
        let e = split_container(&glb).unwrap_err().to_string();
        assert!(e.contains("chunk 0") && e.contains("byte 12"), "{e}");
        let syntax = parse_value(b"{\"a\": [1, }", 20).unwrap_err().to_string();
        assert!(
            syntax.contains("a[1]") && syntax.contains("byte 30"),
            "{syntax}"
        );
    }
}

/// The JSON path of a top-level object, e.g. `meshes[3]`.
pub(super) fn json_path(kind: &str, index: usize) -> String {
    let array = match kind {
        "mesh" => "meshes".to_owned(),
        "accessor" | "buffer" | "bufferView" | "camera" | "image" | "material" | "node"
        | "scene" | "skin" | "texture" => format!("{kind}s"),
        other => other.to_owned(),
    };
    format!("{array}[{index}]")
}

/// The JSON path of a top-level object and its name, e.g. `meshes[3] ("Chair")`.
pub(super) fn label(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(name) if !name.is_empty() => format!("{} ({name:?})", json_path(kind, index)),
        _ => json_path(kind, index),
    }
}

// ---------------------------------------------------------------------------------------------
// Materials
