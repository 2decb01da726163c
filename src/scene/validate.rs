//! Checks on the untyped JSON before the `gltf` crate sees it, for what the crate would get
//! wrong: it narrows indices to 32 bits (2³² + 1 silently selects object 1), and some of its
//! accessors unwrap (a camera whose `type` names an absent projection object panics).
//! Every index is checked here as a 64-bit integer against the array it refers to.

use super::json::{kind, printable};
use anyhow::{bail, Result};
use serde_json::Value;
use std::f32::consts::PI;

/// Every place in a glTF document (core 2.0 and the KHR material extensions) that holds an
/// index, and the top-level array it refers to. `[]` is every element of an array, `*` every
/// property of an object.
const INDEX_FIELDS: &[(&str, &str)] = &[
    ("scene", "scenes"),
    ("scenes[].nodes[]", "nodes"),
    ("nodes[].children[]", "nodes"),
    ("nodes[].mesh", "meshes"),
    ("nodes[].camera", "cameras"),
    ("nodes[].skin", "skins"),
    ("meshes[].primitives[].attributes.*", "accessors"),
    ("meshes[].primitives[].indices", "accessors"),
    ("meshes[].primitives[].material", "materials"),
    ("meshes[].primitives[].targets[].*", "accessors"),
    ("accessors[].bufferView", "bufferViews"),
    ("accessors[].sparse.indices.bufferView", "bufferViews"),
    ("accessors[].sparse.values.bufferView", "bufferViews"),
    ("bufferViews[].buffer", "buffers"),
    ("images[].bufferView", "bufferViews"),
    ("textures[].source", "images"),
    ("textures[].sampler", "samplers"),
    (
        "materials[].pbrMetallicRoughness.baseColorTexture.index",
        "textures",
    ),
    (
        "materials[].pbrMetallicRoughness.metallicRoughnessTexture.index",
        "textures",
    ),
    ("materials[].normalTexture.index", "textures"),
    ("materials[].occlusionTexture.index", "textures"),
    ("materials[].emissiveTexture.index", "textures"),
    ("materials[].extensions.*.*.index", "textures"),
    ("skins[].joints[]", "nodes"),
    ("skins[].skeleton", "nodes"),
    ("skins[].inverseBindMatrices", "accessors"),
    ("animations[].channels[].target.node", "nodes"),
    ("animations[].samplers[].input", "accessors"),
    ("animations[].samplers[].output", "accessors"),
];

/// Index and camera checks over the whole document; the first problem is the error.
pub(super) fn check_document(root: &Value) -> Result<()> {
    for (pattern, target) in INDEX_FIELDS {
        let len = match root.get(target) {
            Some(Value::Array(a)) => a.len(),
            _ => 0,
        };
        let segments: Vec<&str> = pattern.split('.').collect();
        let mut result = Ok(());
        visit(root, &segments, String::new(), &mut |path, value| {
            if result.is_ok() {
                result = check_index(&path, value, target, len);
            }
        });
        result?;
    }
    check_animation_samplers(root)?;
    check_cameras(root)
}

/// Calls `f(path, value)` for every value that `segments` reaches from `value`.
fn visit(value: &Value, segments: &[&str], path: String, f: &mut dyn FnMut(String, &Value)) {
    let Some((first, rest)) = segments.split_first() else {
        f(path, value);
        return;
    };
    let join = |key: &str| {
        if path.is_empty() {
            printable(key)
        } else {
            format!("{path}.{}", printable(key))
        }
    };
    if let Some(key) = first.strip_suffix("[]") {
        if let Some(Value::Array(items)) = value.get(key) {
            for (i, item) in items.iter().enumerate() {
                visit(item, rest, format!("{}[{i}]", join(key)), f);
            }
        }
    } else if *first == "*" {
        if let Value::Object(map) = value {
            for (key, item) in map {
                visit(item, rest, join(key), f);
            }
        }
    } else if let Some(item) = value.get(first) {
        visit(item, rest, join(first), f);
    }
}

/// An index: a non-negative integer below the length of its target array, checked in 64 bits.
fn check_index(path: &str, value: &Value, target: &str, len: usize) -> Result<()> {
    let Some(index) = value.as_u64() else {
        bail!(
            "{path}: found {}, expected an index into \"{target}\" (a non-negative integer)",
            kind(value)
        );
    };
    if index >= len as u64 {
        bail!(
            "{path}: index {index} is out of range, expected an index into \"{target}\", which \
             has {len} elements"
        );
    }
    Ok(())
}

/// `animations[i].channels[j].sampler` refers to the animation's own samplers.
fn check_animation_samplers(root: &Value) -> Result<()> {
    let Some(Value::Array(animations)) = root.get("animations") else {
        return Ok(());
    };
    for (i, animation) in animations.iter().enumerate() {
        let len = match animation.get("samplers") {
            Some(Value::Array(a)) => a.len(),
            _ => 0,
        };
        let Some(Value::Array(channels)) = animation.get("channels") else {
            continue;
        };
        for (j, channel) in channels.iter().enumerate() {
            if let Some(sampler) = channel.get("sampler") {
                let path = format!("animations[{i}].channels[{j}].sampler");
                check_index(&path, sampler, &format!("animations[{i}].samplers"), len)?;
            }
        }
    }
    Ok(())
}

/// A camera's `type` must name a projection object that is present (the `gltf` crate unwraps
/// it), and the projection's numbers must mean a camera (glTF 2.0 §5.12–5.14): a perspective
/// yfov in (0, π), positive aspectRatio and znear; an orthographic xmag and ymag that are
/// positive (wavetrace renders no mirrored views) and a non-negative znear; a zfar beyond znear.
fn check_cameras(root: &Value) -> Result<()> {
    let Some(Value::Array(cameras)) = root.get("cameras") else {
        return Ok(());
    };
    for (i, camera) in cameras.iter().enumerate() {
        let Some(Value::String(kind_name)) = camera.get("type") else {
            continue;
        };
        if !matches!(kind_name.as_str(), "perspective" | "orthographic") {
            bail!(
                "cameras[{i}].type: found {kind_name:?}, expected \"perspective\" or \"orthographic\""
            );
        }
        let projection = match camera.get(kind_name) {
            Some(p @ Value::Object(_)) => p,
            None => bail!(
                "cameras[{i}].{kind_name}: missing, expected an object since cameras[{i}].type is \
                 \"{kind_name}\""
            ),
            Some(other) => bail!(
                "cameras[{i}].{kind_name}: found {}, expected a JSON object",
                kind(other)
            ),
        };
        let path = format!("cameras[{i}].{kind_name}");
        let number = |key: &str, required: bool| camera_number(projection, &path, key, required);
        let positive = |key: &str, value: Option<f32>| -> Result<()> {
            match value {
                Some(v) if !(v.is_finite() && v > 0.0) => {
                    bail!("{path}.{key}: {v} must be positive and finite")
                }
                _ => Ok(()),
            }
        };
        let znear = if kind_name == "perspective" {
            let yfov = number("yfov", true)?;
            if let Some(yfov) = yfov.filter(|y| !(y.is_finite() && *y > 0.0 && *y < PI)) {
                bail!(
                    "{path}.yfov: {yfov} must lie in (0, π) (a vertical field of view in radians)"
                );
            }
            positive("aspectRatio", number("aspectRatio", false)?)?;
            let znear = number("znear", true)?;
            positive("znear", znear)?;
            znear
        } else {
            positive("xmag", number("xmag", true)?)?;
            positive("ymag", number("ymag", true)?)?;
            let znear = number("znear", true)?;
            if let Some(z) = znear.filter(|z| !(z.is_finite() && *z >= 0.0)) {
                bail!("{path}.znear: {z} must be non-negative and finite");
            }
            znear
        };
        let zfar = number("zfar", kind_name == "orthographic")?;
        if let (Some(zfar), Some(znear)) = (zfar, znear) {
            if !(zfar.is_finite() && zfar > znear) {
                bail!("{path}.zfar: {zfar} must be finite and greater than znear ({znear})");
            }
        }
    }
    Ok(())
}

/// The number `key` of a camera's projection object at `path`, as the renderer's f32 (a value
/// beyond f32's range becomes infinite and fails the finiteness checks); `None` if it is absent
/// and optional.
fn camera_number(projection: &Value, path: &str, key: &str, required: bool) -> Result<Option<f32>> {
    match projection.get(key) {
        None if required => bail!("{path}.{key}: missing, expected a number"),
        None => Ok(None),
        Some(Value::Number(n)) => Ok(n.as_f64().map(|v| v as f32)),
        Some(other) => bail!("{path}.{key}: found {}, expected a number", kind(other)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn indices_are_checked_in_64_bits() {
        let doc = json!({"nodes": [{"mesh": 4294967296u64}], "meshes": [{}]});
        let e = check_document(&doc).unwrap_err().to_string();
        assert!(
            e.contains("nodes[0].mesh") && e.contains("4294967296"),
            "{e}"
        );
        let doc = json!({"meshes": [{"primitives": [{"attributes": {"POSITION": -1}}]}]});
        let e = check_document(&doc).unwrap_err().to_string();
        assert!(
            e.contains("meshes[0].primitives[0].attributes.POSITION"),
            "{e}"
        );
        let doc = json!({"nodes": [{"children": [0]}], "scenes": [{"nodes": [0]}], "scene": 0});
        check_document(&doc).unwrap();
    }

    #[test]
    fn camera_numbers_are_checked() {
        let error = |camera: Value| {
            check_document(&json!({"cameras": [{"type": "perspective", "perspective": {"yfov": 1, "znear": 0.1}}, camera]}))
                .unwrap_err()
                .to_string()
        };
        let ortho = |o: Value| json!({"type": "orthographic", "orthographic": o});
        let persp = |p: Value| json!({"type": "perspective", "perspective": p});
        for (camera, needle) in [
            (
                ortho(json!({"xmag": 0, "ymag": 1, "znear": 0, "zfar": 10})),
                "cameras[1].orthographic.xmag: 0 must be positive and finite",
            ),
            (
                ortho(json!({"xmag": 1, "ymag": -2, "znear": 0, "zfar": 10})),
                "cameras[1].orthographic.ymag: -2 must be positive and finite",
            ),
            (
                ortho(json!({"xmag": 1, "ymag": 1e39, "znear": 0, "zfar": 10})),
                "cameras[1].orthographic.ymag: inf must be positive and finite",
            ),
            (
                ortho(json!({"xmag": 1, "ymag": 1, "znear": -1, "zfar": 10})),
                "cameras[1].orthographic.znear: -1 must be non-negative",
            ),
            (
                ortho(json!({"xmag": 1, "ymag": 1, "znear": 0})),
                "cameras[1].orthographic.zfar: missing, expected a number",
            ),
            (
                ortho(json!({"xmag": "1", "ymag": 1, "znear": 0, "zfar": 1})),
                "cameras[1].orthographic.xmag: found the string \"1\", expected a number",
            ),
            (
                persp(json!({"yfov": 3.5, "znear": 0.1})),
                "cameras[1].perspective.yfov: 3.5 must lie in (0, π)",
            ),
            (
                persp(json!({"znear": 0.1})),
                "cameras[1].perspective.yfov: missing",
            ),
            (
                persp(json!({"yfov": 1, "znear": 0})),
                "cameras[1].perspective.znear: 0 must be positive and finite",
            ),
            (
                persp(json!({"yfov": 1, "znear": 0.1, "aspectRatio": 0})),
                "cameras[1].perspective.aspectRatio: 0 must be positive and finite",
            ),
            (
                persp(json!({"yfov": 1, "znear": 1, "zfar": 0.5})),
                "cameras[1].perspective.zfar: 0.5 must be finite and greater than znear (1)",
            ),
        ] {
            let e = error(camera);
            assert!(e.contains(needle), "expected {needle:?} in: {e}");
        }
        check_document(&json!({"cameras": [
            persp(json!({"yfov": 1, "znear": 0.1})),
            persp(json!({"yfov": 0.5, "znear": 0.01, "zfar": 100, "aspectRatio": 1.5})),
            ortho(json!({"xmag": 2, "ymag": 1, "znear": 0, "zfar": 100})),
        ]}))
        .unwrap();
    }

    #[test]
    fn camera_projection_must_be_present() {
        let doc = json!({"cameras": [{"type": "orthographic", "perspective": {"yfov": 1}}]});
        let e = check_document(&doc).unwrap_err().to_string();
        assert!(
            e.contains("cameras[0].orthographic") && e.contains("missing"),
            "{e}"
        );
    }
}
