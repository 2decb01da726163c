//! glTF buffers: the GLB binary chunk, base64 `data:` URIs and files relative to the scene,
//! each checked against its declared byteLength.

use super::load::label;
use anyhow::{anyhow, bail, Context, Result};
use base64::alphabet;
use base64::engine::{DecodePaddingMode, Engine, GeneralPurpose, GeneralPurposeConfig};
use gltf::{buffer, Document};
use percent_encoding::percent_decode_str;
use std::path::Path;

/// Standard base64 (RFC 4648), padding optional.
const BASE64: GeneralPurpose = GeneralPurpose::new(
    &alphabet::STANDARD,
    GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

/// The bytes of every buffer of the document, in order, each cut to its declared byteLength.
pub(super) fn load_buffers(
    document: &Document,
    blob: Option<&[u8]>,
    base: &Path,
) -> Result<Vec<Vec<u8>>> {
    document
        .buffers()
        .map(|buffer| {
            let what = label("buffer", buffer.index(), buffer.name());
            let mut data = match buffer.source() {
                buffer::Source::Bin => blob
                    .ok_or_else(|| {
                        anyhow!("{what} has no uri, and the file is not a GLB with a binary chunk")
                    })?
                    .to_vec(),
                buffer::Source::Uri(uri) => read_uri(uri, base)
                    .with_context(|| format!("{what}: cannot load {}", describe_uri(uri)))?,
            };
            if data.len() < buffer.length() {
                bail!(
                    "{what} declares byteLength {} but its data has only {} bytes",
                    buffer.length(),
                    data.len()
                );
            }
            data.truncate(buffer.length());
            Ok(data)
        })
        .collect()
}

/// The URI for a message: data URIs can be megabytes long.
fn describe_uri(uri: &str) -> String {
    if uri.starts_with("data:") {
        format!("its data: URI ({} characters)", uri.len())
    } else {
        format!("\"{uri}\"")
    }
}

fn read_uri(uri: &str, base: &Path) -> Result<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((header, payload)) = rest.split_once(',') else {
            bail!("malformed data URI (no ',' before the data)");
        };
        if !header.ends_with(";base64") {
            bail!("the data URI is not base64-encoded (its header is \"data:{header}\")");
        }
        return BASE64
            .decode(payload)
            .map_err(|e| anyhow!("invalid base64 data in the data URI: {e}"));
    }
    // A scheme is letters/digits/+/-/. before the first ':' (RFC 3986 §3.1).
    if let Some((scheme, _)) = uri.split_once(':') {
        if !scheme.contains('/') {
            bail!("unsupported URI scheme \"{scheme}:\" (only data: URIs and relative paths are supported)");
        }
    }
    let relative = percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| anyhow!("the URI's %-escapes do not decode to UTF-8"))?;
    let file = base.join(relative.as_ref());
    std::fs::read(&file).with_context(|| format!("cannot read {}", file.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_decode() {
        let base = Path::new(".");
        let uri = |payload: &str| format!("data:application/octet-stream;base64,{payload}");
        assert_eq!(read_uri(&uri("AAECAw=="), base).unwrap(), [0, 1, 2, 3]);
        assert_eq!(read_uri(&uri("AAECAw"), base).unwrap(), [0, 1, 2, 3]);
        assert_eq!(read_uri(&uri("/+8="), base).unwrap(), [0xff, 0xef]);
        assert!(read_uri(&uri("AA*A"), base).is_err());
        assert!(read_uri("data:text/plain,abc", base).is_err());
        assert!(read_uri("https://example.com/a.bin", base).is_err());
    }

    #[test]
    fn relative_paths_decode_percent_escapes() {
        let dir = std::env::temp_dir().join(format!("wavetrace-buffers-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a b.bin"), [7u8, 8]).unwrap();
        assert_eq!(read_uri("a%20b.bin", &dir).unwrap(), [7, 8]);
        assert!(read_uri("%FF.bin", &dir).is_err());
        let missing = read_uri("missing.bin", &dir).unwrap_err();
        assert!(format!("{missing:#}").contains("missing.bin"));
    }
}
