//! glTF buffers: the GLB binary chunk, base64 `data:` URIs and files relative to the scene,
//! each checked against its declared byteLength, with file access confined to the scene's
//! folder (and `--allow-path` folders) and every allocation reserved in the memory budget.

use super::json::label;
use super::limits::LoadOptions;
use anyhow::{anyhow, bail, Context, Result};
use base64::alphabet;
use base64::engine::{DecodePaddingMode, Engine, GeneralPurpose, GeneralPurposeConfig};
use gltf::{buffer, Document};
use percent_encoding::percent_decode_str;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Standard base64 (RFC 4648), padding optional.
const BASE64: GeneralPurpose = GeneralPurpose::new(
    &alphabet::STANDARD,
    GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
);

/// The bytes of every buffer of the document, in order, each cut to its declared byteLength.
/// `bin` is a GLB's binary chunk: only `buffers[0]` may refer to it, and it is moved there,
/// not copied. Every buffer's bytes are reserved in the budget before they are allocated.
pub(super) fn load_buffers(
    document: &Document,
    mut bin: Option<Vec<u8>>,
    is_glb: bool,
    base: &Path,
    options: &LoadOptions,
) -> Result<Vec<Vec<u8>>> {
    let mut buffers = Vec::with_capacity(document.buffers().len());
    for buffer in document.buffers() {
        let what = label("buffer", buffer.index(), buffer.name());
        let length = buffer.length();
        let mut data = match buffer.source() {
            // EXT_meshopt_compression: the compressed views are decoded into it later.
            _ if super::meshopt::is_fallback(&buffer) => {
                options
                    .budget
                    .reserve(&format!("{what} ({length} bytes)"), length as u64)?;
                vec![0; length]
            }
            buffer::Source::Bin if buffer.index() > 0 => bail!(
                "{what}: has no \"uri\", expected one (only buffers[0] of a GLB may refer to the \
                 binary chunk)"
            ),
            buffer::Source::Bin if !is_glb => {
                bail!("{what}: has no \"uri\", expected one (the file is not a GLB)")
            }
            buffer::Source::Bin => bin.take().ok_or_else(|| {
                anyhow!("{what}: has no \"uri\" and the GLB has no BIN chunk, expected one of them")
            })?,
            buffer::Source::Uri(uri) => {
                options
                    .budget
                    .reserve(&format!("{what} ({length} bytes)"), length as u64)?;
                read_uri(uri, length, base, options)
                    .with_context(|| format!("{what}.uri: cannot load {}", describe_uri(uri)))?
            }
        };
        if data.len() < length {
            bail!(
                "{what}.byteLength: {length}, but its data has only {} bytes",
                data.len()
            );
        }
        data.truncate(length);
        buffers.push(data);
    }
    Ok(buffers)
}

/// The URI for a message: data URIs can be megabytes long.
/// Other URIs are quoted with control characters escaped and cut after 200 characters.
fn describe_uri(uri: &str) -> String {
    if uri.starts_with("data:") {
        format!("its data: URI ({} characters)", uri.len())
    } else if uri.chars().count() > 200 {
        let head: String = uri.chars().take(200).collect();
        format!("{head:?}… ({} characters)", uri.chars().count())
    } else {
        format!("{uri:?}")
    }
}

/// Every image URI obeys the same rules as buffers', checked before anything is read, so that a
/// file that names something outside its folder is refused even where no material uses it.
pub(super) fn check_image_uris(
    document: &Document,
    base: &Path,
    options: &LoadOptions,
) -> Result<()> {
    for (i, image) in document.as_json().images.iter().enumerate() {
        // The `gltf` crate unwraps these when the image is read: refuse them here, by name.
        match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => bail!("images[{i}]: has neither \"uri\" nor \"bufferView\", expected one"),
            (Some(_), Some(_), _) => {
                bail!("images[{i}]: has both \"uri\" and \"bufferView\", expected one")
            }
            (None, Some(_), None) => bail!(
                "images[{i}].mimeType: missing, expected \"image/png\", \"image/jpeg\", \"image/webp\" or \"image/ktx2\" (required with \"bufferView\")"
            ),
            _ => {}
        }
        let Some(uri) = image.uri.as_deref() else {
            continue;
        };
        if uri.starts_with("data:") {
            continue;
        }
        let refuse = |e: anyhow::Error| anyhow!("images[{i}].uri: {}: {e:#}", describe_uri(uri));
        let decoded = percent_encoding::percent_decode_str(uri).decode_utf8_lossy();
        // A missing file inside the folder is no error here: an image no material uses is never
        // read, and one that is used fails when it is read (images.rs).
        let relative = Path::new(decoded.as_ref());
        let has_scheme = uri.split_once(':').is_some_and(|(s, _)| !s.contains('/'));
        if !has_scheme
            && !relative.is_absolute()
            && !relative
                .components()
                .any(|c| c == std::path::Component::ParentDir)
            && !base.join(relative).exists()
        {
            continue;
        }
        let file = confined_path(uri, base, &options.allow_paths).map_err(refuse)?;
        if !file.is_file() {
            return Err(refuse(anyhow!("not a regular file, expected one")));
        }
    }
    Ok(())
}

/// An image's bytes from its URI (a data URI or a file inside the allowed folders), reserved
/// in the budget before they are read.
pub(super) fn read_image_uri(uri: &str, base: &Path, options: &LoadOptions) -> Result<Vec<u8>> {
    let describe = describe_uri(uri);
    let result = (|| {
        if uri.starts_with("data:") {
            options
                .budget
                .reserve("an image's data: URI", uri.len() as u64)?;
            return read_uri(uri, 0, base, options);
        }
        let file = confined_path(uri, base, &options.allow_paths)?;
        let (_, size) = open_regular(&file)?;
        options
            .budget
            .reserve(&format!("the image file {}", file.display()), size)?;
        read_regular_file(&file, size as usize)
    })();
    result.with_context(|| format!("cannot load {describe}"))
}

/// A buffer's bytes: at most `length` bytes from a file, or a decoded data URI.
fn read_uri(uri: &str, length: usize, base: &Path, options: &LoadOptions) -> Result<Vec<u8>> {
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
    let file = confined_path(uri, base, &options.allow_paths)?;
    read_regular_file(&file, length)
}

/// The file a relative URI names, refused unless it lies, after resolving `..` and symbolic
/// links, inside the scene's folder or an allowed folder. Schemes (`file:`, `http:`…) are refused.
pub(super) fn confined_path(uri: &str, base: &Path, allowed: &[PathBuf]) -> Result<PathBuf> {
    // A scheme is letters/digits/+/-/. before the first ':' (RFC 3986 §3.1).
    if let Some((scheme, _)) = uri.split_once(':') {
        if !scheme.contains('/') {
            bail!(
                "the URI scheme \"{scheme}:\" is refused (only data: URIs and paths relative to \
                 the scene's folder are read)"
            );
        }
    }
    let relative = percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| anyhow!("the URI's %-escapes do not decode to UTF-8"))?;
    let relative = Path::new(relative.as_ref());
    let base = base
        .canonicalize()
        .with_context(|| format!("cannot resolve the scene's folder {}", base.display()))?;
    let refused = |why: &str| {
        anyhow!(
            "{why}: wavetrace reads only files inside the scene's folder {} (pass --allow-path DIR \
             to allow another folder)",
            base.display()
        )
    };
    if relative.is_absolute() && allowed.is_empty() {
        return Err(refused("an absolute path is refused"));
    }
    if !relative.is_absolute() && escapes(relative) && allowed.is_empty() {
        return Err(refused("the path leaves the folder through `..`"));
    }
    let joined = base.join(relative);
    let file = joined
        .canonicalize()
        .with_context(|| format!("cannot read {}", joined.display()))?;
    let inside = std::iter::once(base.clone())
        .chain(allowed.iter().filter_map(|d| d.canonicalize().ok()))
        .any(|dir| file.starts_with(dir));
    if !inside {
        return Err(refused(&format!(
            "{} lies outside the allowed folders (through an absolute path, `..` or a symbolic link)",
            file.display()
        )));
    }
    Ok(file)
}

/// Whether a relative path climbs above its starting folder (`a/../../b`), judged on its text.
fn escapes(relative: &Path) -> bool {
    let mut depth = 0i64;
    for component in relative.components() {
        match component {
            std::path::Component::ParentDir => depth -= 1,
            std::path::Component::Normal(_) => depth += 1,
            _ => {}
        }
        if depth < 0 {
            return true;
        }
    }
    false
}

/// A file opened for reading if it is a regular file (devices, pipes and folders are refused,
/// and it is opened without blocking so that a pipe cannot stall the load), with its size.
pub(super) fn open_regular(path: &Path) -> Result<(std::fs::File, u64)> {
    open_regular_named(path, &path.display())
}

/// [`open_regular`], its errors naming the file as `name` (the scene file is "the file": the
/// message around it names its path once).
pub(super) fn open_regular_named(
    path: &Path,
    name: &dyn std::fmt::Display,
) -> Result<(std::fs::File, u64)> {
    let mut open = std::fs::OpenOptions::new();
    open.read(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::custom_flags(&mut open, libc::O_NONBLOCK);
    let file = open
        .open(path)
        .with_context(|| format!("cannot read {name}"))?;
    let metadata = file
        .metadata()
        .with_context(|| format!("cannot read {name}"))?;
    if !metadata.is_file() {
        bail!("{name} is not a regular file, expected one");
    }
    Ok((file, metadata.len()))
}

/// At most `length` bytes of a regular file.
fn read_regular_file(path: &Path, length: usize) -> Result<Vec<u8>> {
    let (file, size) = open_regular(path)?;
    if size < length as u64 {
        bail!(
            "{} has {size} bytes, fewer than the declared byteLength {length}",
            path.display()
        );
    }
    let mut data = Vec::with_capacity(length);
    file.take(length as u64)
        .read_to_end(&mut data)
        .with_context(|| format!("cannot read {}", path.display()))?;
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_decode() {
        let base = Path::new(".");
        let options = LoadOptions::default();
        let read_uri = |uri: &str, base: &Path| super::read_uri(uri, 100, base, &options);
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
        let options = LoadOptions::default();
        let read_uri = |uri: &str, base: &Path| super::read_uri(uri, 2, base, &options);
        let dir = std::env::temp_dir().join(format!("wavetrace-buffers-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a b.bin"), [7u8, 8]).unwrap();
        assert_eq!(read_uri("a%20b.bin", &dir).unwrap(), [7, 8]);
        assert!(read_uri("%FF.bin", &dir).is_err());
        let missing = read_uri("missing.bin", &dir).unwrap_err();
        assert!(format!("{missing:#}").contains("missing.bin"));
    }
}
