//! glTF 2.0 (`.gltf` / `.glb`) → [`Scene`]. The file is untrusted input (README, "Running on
//! untrusted files"):
//!
//! 1. the GLB container and the JSON are parsed here (`json.rs`), errors naming the chunk and
//!    byte offset or the JSON path;
//! 2. indices are checked in 64 bits and cameras' projections for presence (`validate.rs`),
//!    where the `gltf` crate would wrap or panic; then the crate builds its typed model and
//!    validates references, and a panic it still raises becomes an error;
//! 3. buffers are read without `gltf::import` (`buffers.rs`): base64 `data:` URIs, files inside
//!    the scene's folder (or `--allow-path` folders), the GLB binary chunk for `buffers[0]`
//!    only; images (`images.rs`) are read by the same rules and decoded only where a material
//!    uses them; accessors are read with every offset, stride and index checked (`accessors.rs`);
//! 4. every large allocation is reserved in the memory budget first (`limits.rs`).
//!
//! Supported: every node of the default scene (scene 0 if none is default), TRS or matrix
//! transforms, triangle lists, strips and fans, u8/u16/u32 or no indices, sparse accessors,
//! perspective and orthographic cameras (every instance, in `Scene::cameras`).
//! Point and line primitives are skipped (counted in `Scene::skipped_primitives`); skins,
//! morph targets and KHR_mesh_quantization are not supported (the first two are ignored,
//! quantized positions are an error).

use super::accessors::{
    element_bytes, read_attribute, read_indices, read_positions, triangle_corners,
};
use super::buffers::{check_image_uris, load_buffers, open_regular};
use super::images::{TextureBuilder, TextureInfo, TextureUse};
use super::json::{parse_value, split_container, typed_root, validation_message};
use super::limits::{
    format_bytes, Budget, LoadOptions, PREPARE_BYTES_PER_EMITTER, PREPARE_BYTES_PER_INSTANCE,
    PREPARE_BYTES_PER_TRIANGLE, PREPARE_BYTES_PER_TRIANGLE_WITH_EMITTERS,
};
use super::tangents::mikktspace_tangents;
use super::validate::check_document;
use super::{
    AlphaMode, Camera, Instance, Material, MaterialTextures, Mesh, Projection, Scene, SceneCamera,
    Triangle, NO_VERTEX,
};
use crate::layout::{
    GpuPunctualLight, GpuVertex, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT, TRIANGLE_ALPHA,
    TRIANGLE_FLAT, TRIANGLE_PLAIN,
};
use anyhow::{anyhow, bail, Context, Result};
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::{Mode, Primitive};
use gltf::Document;
use gltf::Semantic;
use rayon::prelude::*;
use std::io::Read;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// Extensions a file may list in `extensionsRequired`.
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_specular",
    "KHR_materials_unlit",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_materials_anisotropy",
    "KHR_materials_iridescence",
    "KHR_materials_volume",
    "KHR_materials_diffuse_transmission",
    "KHR_materials_dispersion",
    "KHR_texture_transform",
    "EXT_mesh_gpu_instancing",
    "KHR_lights_punctual",
];

/// Extensions wavetrace refuses on purpose, with the reason its messages give.
const REFUSED_EXTENSIONS: &[(&str, &str)] = &[
    (
        "KHR_materials_pbrSpecularGlossiness",
        "archived by Khronos; re-export the materials as metallic-roughness with \
         KHR_materials_specular and KHR_materials_ior",
    ),
    (
        "KHR_draco_mesh_compression",
        "compressed geometry is not decoded; re-export without Draco",
    ),
    (
        "EXT_meshopt_compression",
        "compressed buffers are not decoded; re-export without meshopt",
    ),
];

/// An unsupported extension's name, with the reason where wavetrace refuses it on purpose.
fn unsupported_extension(ext: &str) -> String {
    match REFUSED_EXTENSIONS.iter().find(|(name, _)| *name == ext) {
        Some((_, why)) => format!("{ext} ({why})"),
        None => ext.to_owned(),
    }
}

/// Memory a parsed JSON value may take per structural character (`,` `:` `[` `{`) of its text:
/// a `serde_json::Value` is 32 bytes, a map entry about twice that, and the `gltf` crate's
/// typed model is built from it while it lives.
const JSON_BYTES_PER_TOKEN: u64 = 96;

pub(super) fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    guarded(path, options, || {
        let bytes = read_scene_file(path, &options.budget)?;
        load_bytes(path, bytes, options)
    })
}

/// [`load`] of a file's bytes already in memory; `source` names it in messages and its folder is
/// where relative URIs resolve.
pub(super) fn load_from_bytes(
    source: &Path,
    bytes: Vec<u8>,
    options: &LoadOptions,
) -> Result<Scene> {
    guarded(source, options, || {
        let size = bytes.len() as u64;
        options
            .budget
            .reserve(&format!("the file ({})", format_bytes(size)), size)?;
        load_bytes(source, bytes, options)
    })
}

/// Runs a load, turning a panic into an error, giving back what a failed load reserved, and
/// naming the file in the error.
fn guarded(
    path: &Path,
    options: &LoadOptions,
    load: impl FnOnce() -> Result<Scene>,
) -> Result<Scene> {
    // The last guard: a panic inside the `gltf` crate that the checks below did not foresee
    // becomes an error (the release profile keeps panic = "unwind" for this).
    let reserved_before = options.budget.used();
    let result = catch_unwind(AssertUnwindSafe(load)).unwrap_or_else(|panic| {
        let message = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(anyhow!("the glTF library failed on this file: {message}"))
    });
    // Transient reservations of a failed load are given back; a loaded scene keeps its own.
    if result.is_err() {
        let now = options.budget.used();
        options.budget.release(now.saturating_sub(reserved_before));
    }
    result.with_context(|| format!("cannot load scene {}", path.display()))
}

/// The scene file's bytes: a regular file, no larger than the memory budget allows.
fn read_scene_file(path: &Path, budget: &Budget) -> Result<Vec<u8>> {
    let (file, size) = open_regular(path)?;
    budget.reserve(&format!("the file ({})", format_bytes(size)), size)?;
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(size)
        .read_to_end(&mut bytes)
        .context("cannot read the file")?;
    Ok(bytes)
}

/// Loads the scene held in `bytes` (the file `path`, already read and reserved in the budget).
fn load_bytes(path: &Path, bytes: Vec<u8>, options: &LoadOptions) -> Result<Scene> {
    if bytes.is_empty() {
        bail!("the top level: the file is empty, expected glTF JSON or binary glTF");
    }
    let container = split_container(&bytes)?;
    let text = &bytes[container.json.clone()];
    let tokens = text
        .iter()
        .filter(|b| matches!(b, b',' | b':' | b'[' | b'{'))
        .count() as u64;
    options.budget.reserve(
        "the parsed JSON",
        (tokens + 1) * JSON_BYTES_PER_TOKEN + 2 * text.len() as u64,
    )?;
    let value = parse_value(text, container.json.start)?;
    check_document(&value)?;
    let root = typed_root(value)?;
    // Checked before validation, which would reject them with a less helpful message.
    for ext in &root.extensions_required {
        if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) {
            bail!(
                "extensionsRequired: the file requires the glTF extension {}, which wavetrace \
                 does not support (supported: {})",
                unsupported_extension(ext),
                SUPPORTED_EXTENSIONS.join(", ")
            );
        }
    }
    let document = validated_document(root)?;

    let base = path.parent().unwrap_or(Path::new("."));
    let base = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    check_image_uris(&document, base, options)?;
    let bin = container.bin.clone().map(|range| {
        // The binary chunk is moved out of the file's bytes, not copied.
        let mut bytes = bytes;
        bytes.truncate(range.end);
        bytes.drain(..range.start);
        bytes
    });
    let buffers = load_buffers(&document, bin, container.is_glb(), base, options)?;
    let mut textures = TextureBuilder::new(&buffers, base, options);
    let (materials, needs): (Vec<Material>, Vec<MaterialNeeds>) = document
        .materials()
        .enumerate()
        .map(|(i, m)| convert_material(i, &m, &document, &mut textures))
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .unzip();
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| {
            anyhow!("scenes: the file contains no scene, so there is nothing to render")
        })?;

    let mut builder = Builder {
        buffers: &buffers,
        budget: &options.budget,
        triangles: Vec::new(),
        vertices: Vec::new(),
        materials,
        needs,
        repairs: Repairs::default(),
        default_material: None,
        cameras: Vec::new(),
        dropped_degenerate: 0,
        skipped_primitives: 0,
        mesh_uses: mesh_uses(&document),
        instancing: options.instancing,
        meshes: Vec::new(),
        mesh_ids: std::collections::HashMap::new(),
        instances: Vec::new(),
        punctual: Vec::new(),
    };
    builder.walk(&document, &scene)?;
    let instanced_triangles: usize = builder.meshes.iter().map(|m| m.triangles.len()).sum();
    if builder.triangles.is_empty() && builder.instances.is_empty() {
        bail!(
            "{} has no triangles to render ({} zero-area triangles dropped, {} point/line \
             primitives skipped)",
            label("scene", scene.index(), scene.name()),
            builder.dropped_degenerate,
            builder.skipped_primitives
        );
    }
    // Reserved here rather than by the renderer so that every caller of the loader is bounded.
    options.budget.reserve(
        &format!(
            "{}: the BVH and render data of {} triangles",
            label("scene", scene.index(), scene.name()),
            builder.triangles.len() + instanced_triangles
        ),
        (builder.triangles.len() + instanced_triangles) as u64 * PREPARE_BYTES_PER_TRIANGLE
            + builder.instances.len() as u64 * PREPARE_BYTES_PER_INSTANCE,
    )?;
    // The light BVH over the emitting triangles (emitting meshes are always baked: the
    // triangles above) and the punctual lights, which a scene whose every triangle emits makes
    // as large as its BVH.
    let emitters = builder
        .triangles
        .iter()
        .filter(|t| builder.materials[t.material as usize].is_emissive())
        .count()
        + builder.punctual.len();
    if emitters > 0 {
        options.budget.reserve(
            &format!(
                "{}: the light BVH of {emitters} emitters",
                label("scene", scene.index(), scene.name())
            ),
            emitters as u64 * PREPARE_BYTES_PER_EMITTER
                + (builder.triangles.len() + instanced_triangles) as u64
                    * PREPARE_BYTES_PER_TRIANGLE_WITH_EMITTERS,
        )?;
    }
    let notes = notes(&document, &builder);
    let bounds = super::scene_bounds(&builder.triangles, &builder.meshes, &builder.instances);
    let camera = builder
        .cameras
        .first()
        .map_or_else(|| Camera::framing(bounds), |c| c.camera);
    Ok(Scene {
        source: path.to_path_buf(),
        triangles: builder.triangles,
        materials: builder.materials,
        vertices: builder.vertices,
        textures: textures.set,
        meshes: builder.meshes,
        instances: builder.instances,
        punctual: builder.punctual,
        camera,
        cameras: builder.cameras,
        dropped_degenerate: builder.dropped_degenerate,
        skipped_primitives: builder.skipped_primitives,
        notes,
    })
}

/// The `gltf` crate's validation of the typed model, less its refusal of required extensions
/// it does not know itself (it lists only those it parses): every required extension was
/// checked against [`SUPPORTED_EXTENSIONS`] before, so an "unsupported extension" error here
/// names one that wavetrace reads from the raw JSON (KHR_materials_unlit, …).
fn validated_document(root: gltf::json::Root) -> Result<Document> {
    use gltf::json::validation::{Error, Validate};
    let mut errors = Vec::new();
    root.validate(&root, gltf::json::Path::new, &mut |path, error| {
        if error != Error::Unsupported {
            errors.push((path(), error));
        }
    });
    if !errors.is_empty() {
        return Err(validation_message(gltf::Error::Validation(errors)));
    }
    Ok(Document::from_json_without_validation(root))
}

/// What the file holds that the render will not show, said once each (`Scene::notes`).
fn notes(document: &Document, builder: &Builder) -> Vec<String> {
    let mut notes = Vec::new();
    notes.extend(builder.repairs.notes());
    let ignored: Vec<String> = document
        .extensions_used()
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
        .map(unsupported_extension)
        .collect();
    if !ignored.is_empty() {
        notes.push(format!("ignored glTF extensions: {}", ignored.join(", ")));
    }
    if builder.cameras.is_empty() && document.cameras().next().is_some() {
        notes.push(
            "no node of the scene carries one of the file's cameras: using a camera that frames \
             the scene"
                .into(),
        );
    }
    if builder.dropped_degenerate > 0 {
        notes.push(format!(
            "{} zero-area triangles dropped",
            builder.dropped_degenerate
        ));
    }
    if builder.skipped_primitives > 0 {
        notes.push(format!(
            "{} point and line primitives skipped",
            builder.skipped_primitives
        ));
    }
    notes
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

/// What a material asks of the primitives that use it.
#[derive(Clone, Copy, Debug, Default)]
struct MaterialNeeds {
    /// Texture coordinate sets its textures read.
    tex_coords: [bool; 2],
    /// The set its normal map reads, if it has one (tangents are generated for it).
    normal_map: Option<u32>,
}

/// A textureInfo's texture, set and KHR_texture_transform.
fn texture_info<'a>(info: gltf::texture::Info<'a>) -> TextureInfo<'a> {
    TextureInfo {
        texture: info.texture(),
        tex_coord: info.tex_coord(),
        transform: info
            .texture_transform()
            .map(|t| (t.offset(), t.rotation(), t.scale(), t.tex_coord())),
    }
}

/// KHR_texture_transform of a textureInfo the `gltf` crate does not type (normalTexture);
/// `what` is the textureInfo's JSON path, `owner` what follows a path in messages.
#[allow(clippy::type_complexity)]
fn untyped_transform(
    value: Option<&serde_json::Value>,
    what: &str,
    owner: &str,
) -> Result<Option<([f32; 2], f32, [f32; 2], Option<u32>)>> {
    let Some(value) = value else {
        return Ok(None);
    };
    let pair = |key: &str, default: [f32; 2]| -> Result<[f32; 2]> {
        match value.get(key) {
            None => Ok(default),
            Some(v) => match v
                .as_array()
                .map(|a| a.iter().map(|x| x.as_f64()).collect::<Vec<_>>())
            {
                Some(a) if a.len() == 2 && a.iter().all(Option::is_some) => {
                    Ok([a[0].unwrap() as f32, a[1].unwrap() as f32])
                }
                _ => bail!(
                    "{what}.extensions.KHR_texture_transform.{key}{owner}: expected two numbers"
                ),
            },
        }
    };
    let rotation = match value.get("rotation") {
        None => 0.0,
        Some(v) => v.as_f64().ok_or_else(|| {
            anyhow!("{what}.extensions.KHR_texture_transform.rotation{owner}: expected a number")
        })? as f32,
    };
    let tex_coord = match value.get("texCoord") {
        None => None,
        Some(v) => Some(v.as_u64().filter(|&c| c <= u32::MAX as u64).ok_or_else(|| {
            anyhow!("{what}.extensions.KHR_texture_transform.texCoord{owner}: expected a non-negative integer")
        })? as u32),
    };
    Ok(Some((
        pair("offset", [0.0, 0.0])?,
        rotation,
        pair("scale", [1.0, 1.0])?,
        tex_coord,
    )))
}

/// A number of a material extension's raw JSON object `ext` (`what` is the object's JSON path
/// and owner): `default` when absent, an error unless it is a number in [0, 1].
/// A material extension's raw JSON object (the `gltf` crate types only the extensions it knows)
/// and its JSON path, `path` giving the material's; None where the material does not use it.
fn raw_extension<'a>(
    material: &'a gltf::Material,
    name: &str,
    path: &dyn Fn(&str) -> String,
    owner: &str,
) -> Result<Option<(&'a serde_json::Value, String)>> {
    let Some(ext) = material.extension_value(name) else {
        return Ok(None);
    };
    let what = path(&format!("extensions.{name}"));
    if !ext.is_object() {
        bail!("{what}{owner}: expected an object");
    }
    Ok(Some((ext, what)))
}

fn raw_unit_factor(
    ext: &serde_json::Value,
    key: &str,
    default: f32,
    what: &str,
    owner: &str,
) -> Result<f32> {
    let Some(v) = ext.get(key) else {
        return Ok(default);
    };
    match v.as_f64() {
        Some(x) if (0.0..=1.0 + 1e-4).contains(&x) => Ok((x as f32).min(1.0)),
        _ => bail!("{what}.{key}{owner}: {v} must be a number in [0, 1]"),
    }
}

/// A colour factor (three numbers in [0, 1], rounding just above 1 forgiven) of a material
/// extension's raw JSON, or `default` where absent.
fn raw_unit_color(
    ext: &serde_json::Value,
    key: &str,
    default: Vec3,
    what: &str,
    owner: &str,
) -> Result<Vec3> {
    let Some(v) = ext.get(key) else {
        return Ok(default);
    };
    let c: Option<Vec<f64>> = v
        .as_array()
        .filter(|a| a.len() == 3)
        .and_then(|a| a.iter().map(|x| x.as_f64()).collect());
    match c {
        Some(c) if c.iter().all(|x| (0.0..=1.0 + 1e-4).contains(x)) => {
            Ok(Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32).min(Vec3::ONE))
        }
        _ => bail!("{what}.{key}{owner}: {v} must be three numbers in [0, 1]"),
    }
}

/// A textureInfo or normalTextureInfo inside a material extension's raw JSON (the `gltf`
/// crate types only the extensions it knows): its texture, texCoord, KHR_texture_transform and
/// `scale` (1 when absent; a normalTextureInfo's). `what` is its JSON path.
fn raw_texture_info<'a>(
    document: &'a Document,
    value: &serde_json::Value,
    what: &str,
    owner: &str,
) -> Result<(TextureInfo<'a>, f32)> {
    let index = value
        .get("index")
        .and_then(|v| v.as_u64())
        .ok_or_else(|| anyhow!("{what}.index{owner}: expected a texture index"))?;
    let texture = usize::try_from(index)
        .ok()
        .and_then(|i| document.textures().nth(i))
        .ok_or_else(|| {
            anyhow!(
                "{what}.index{owner}: texture {index} does not exist (the file has {})",
                document.textures().len()
            )
        })?;
    let tex_coord = match value.get("texCoord") {
        None => 0,
        Some(v) => v
            .as_u64()
            .filter(|&c| c <= u32::MAX as u64)
            .ok_or_else(|| anyhow!("{what}.texCoord{owner}: expected a non-negative integer"))?
            as u32,
    };
    let scale = match value.get("scale") {
        None => 1.0,
        Some(v) => match v.as_f64() {
            Some(x) if x.is_finite() => x as f32,
            _ => bail!("{what}.scale{owner}: expected a finite number"),
        },
    };
    let transform = untyped_transform(
        value
            .get("extensions")
            .and_then(|e| e.get("KHR_texture_transform")),
        what,
        owner,
    )?;
    Ok((
        TextureInfo {
            texture,
            tex_coord,
            transform,
        },
        scale,
    ))
}

fn convert_material(
    index: usize,
    material: &gltf::Material,
    document: &Document,
    builder: &mut TextureBuilder,
) -> Result<(Material, MaterialNeeds)> {
    // The JSON path of one property of this material, and the material's name to follow it.
    let path = |property: &str| format!("{}.{property}", json_path("material", index));
    let owner = match material.name() {
        Some(name) if !name.is_empty() => format!(" (material {name:?})"),
        _ => String::new(),
    };
    let at = |property: &str| format!("{}{owner}", path(property));
    let [r, g, b, _] = material.pbr_metallic_roughness().base_color_factor();
    let base_color = Vec3::new(r, g, b);
    // The spec bounds factors to [0, 1]; forgive rounding just above 1.
    if !(base_color.is_finite()
        && base_color.min_element() >= 0.0
        && base_color.max_element() <= 1.0 + 1e-4)
    {
        bail!(
            "{}: {base_color} is outside [0, 1] (an albedo above 1 creates energy)",
            at("pbrMetallicRoughness.baseColorFactor")
        );
    }
    let pbr = material.pbr_metallic_roughness();
    let unit = |property: &str, v: f32| -> Result<f32> {
        if (0.0..=1.0 + 1e-4).contains(&v) {
            Ok(v.min(1.0))
        } else {
            bail!("{}: {v} is outside [0, 1]", at(property))
        }
    };
    let metallic = unit("pbrMetallicRoughness.metallicFactor", pbr.metallic_factor())?;
    let roughness = unit(
        "pbrMetallicRoughness.roughnessFactor",
        pbr.roughness_factor(),
    )?;
    let transmission = material.transmission().map_or(Ok(0.0), |t| {
        unit(
            "extensions.KHR_materials_transmission.transmissionFactor",
            t.transmission_factor(),
        )
    })?;
    let specular = material.specular().map_or(Ok(1.0), |s| {
        unit(
            "extensions.KHR_materials_specular.specularFactor",
            s.specular_factor(),
        )
    })?;
    // specularColorFactor may exceed 1 (the spec clamps F0, not the factor).
    let specular_color = material
        .specular()
        .map_or(Vec3::ONE, |s| Vec3::from(s.specular_color_factor()));
    if !(specular_color.is_finite() && specular_color.min_element() >= 0.0) {
        bail!(
            "{}: {specular_color} must be finite and non-negative",
            at("extensions.KHR_materials_specular.specularColorFactor")
        );
    }
    let unlit = material.extension_value("KHR_materials_unlit").is_some();
    // KHR_materials_ior: ior ≥ 1, or exactly 0 (f0 = 1, a specular-glossiness conversion).
    let ior = material.ior().unwrap_or(1.5);
    if !(ior.is_finite() && (ior >= 1.0 || ior == 0.0)) {
        bail!(
            "{}: {ior} must be at least 1 (or exactly 0)",
            at("extensions.KHR_materials_ior.ior")
        );
    }
    let factor = Vec3::from(material.emissive_factor());
    let strength = material.emissive_strength().unwrap_or(1.0);
    let emission = factor * strength;
    if !(factor.is_finite()
        && factor.min_element() >= 0.0
        && strength >= 0.0
        && emission.is_finite())
    {
        bail!(
            "{}: emission (emissiveFactor {factor} × emissiveStrength {strength}) must be finite and non-negative",
            at("emissiveFactor")
        );
    }
    let alpha = material.pbr_metallic_roughness().base_color_factor()[3];
    if !(0.0..=1.0 + 1e-4).contains(&alpha) {
        bail!(
            "{}: alpha {alpha} is outside [0, 1]",
            at("pbrMetallicRoughness.baseColorFactor")
        );
    }
    let alpha_cutoff = material.alpha_cutoff().unwrap_or(0.5);
    if !(alpha_cutoff.is_finite() && alpha_cutoff >= 0.0) {
        bail!(
            "{}: {alpha_cutoff} must be a non-negative number",
            at("alphaCutoff")
        );
    }
    let alpha_mode = match material.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Mask => AlphaMode::Mask,
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
    };

    // Textures: each use becomes a reference (set, transform) to a decoded texture.
    let mut needs = MaterialNeeds::default();
    let mut reference = |property: &str, info: TextureInfo, srgb: bool| -> Result<u32> {
        let r = builder.reference(TextureUse {
            what: path(property),
            owner: owner.clone(),
            info,
            srgb,
        })?;
        let set = builder.set.refs[r as usize].texcoord as usize;
        needs.tex_coords[set] = true;
        Ok(r)
    };
    let mut textures = MaterialTextures::default();
    if let Some(info) = pbr.base_color_texture() {
        textures.base_color = Some(reference(
            "pbrMetallicRoughness.baseColorTexture",
            texture_info(info),
            true,
        )?);
    }
    if let Some(info) = pbr.metallic_roughness_texture() {
        textures.metallic_roughness = Some(reference(
            "pbrMetallicRoughness.metallicRoughnessTexture",
            texture_info(info),
            false,
        )?);
    }
    if let Some(info) = material.emissive_texture().filter(|_| !unlit) {
        textures.emissive = Some(reference("emissiveTexture", texture_info(info), true)?);
    }
    if let Some(info) = material
        .transmission()
        .and_then(|t| t.transmission_texture())
    {
        textures.transmission = Some(reference(
            "extensions.KHR_materials_transmission.transmissionTexture",
            texture_info(info),
            false,
        )?);
    }
    if let Some(specular) = material.specular() {
        if let Some(info) = specular.specular_texture() {
            textures.specular = Some(reference(
                "extensions.KHR_materials_specular.specularTexture",
                texture_info(info),
                false,
            )?);
        }
        if let Some(info) = specular.specular_color_texture() {
            textures.specular_color = Some(reference(
                "extensions.KHR_materials_specular.specularColorTexture",
                texture_info(info),
                true,
            )?);
        }
    }
    // KHR_materials_unlit: the base colour term is what the surface shows, so it is emitted
    // (factor × texture here, × vertex colour in `surface::surface_emission`); emissiveFactor
    // and emissiveTexture are the fallback of viewers without the extension.
    let emission = if unlit {
        textures.emissive = textures.base_color;
        base_color.min(Vec3::ONE)
    } else {
        emission
    };
    // A material extension's textures (key, slot, sRGB) from its raw JSON: each one present
    // becomes a reference; returns each one's `scale` (a normalTextureInfo's; 1 otherwise).
    let mut raw_textures = |ext: &serde_json::Value,
                            name: &str,
                            slots: &mut [(&str, &mut Option<u32>, bool)]|
     -> Result<Vec<f32>> {
        let mut scales = Vec::with_capacity(slots.len());
        for (key, slot, srgb) in slots.iter_mut() {
            let mut scale = 1.0;
            if let Some(value) = ext.get(*key) {
                let property = format!("extensions.{name}.{key}");
                let (info, s) = raw_texture_info(document, value, &path(&property), &owner)?;
                **slot = Some(reference(&property, info, *srgb)?);
                scale = s;
            }
            scales.push(scale);
        }
        Ok(scales)
    };
    // KHR_materials_clearcoat, read from the raw JSON.
    let (mut clearcoat, mut clearcoat_roughness, mut clearcoat_normal_scale) = (0.0, 0.0, 1.0);
    if let Some((ext, what)) = raw_extension(&material, "KHR_materials_clearcoat", &path, &owner)? {
        clearcoat = raw_unit_factor(ext, "clearcoatFactor", 0.0, &what, &owner)?;
        clearcoat_roughness = raw_unit_factor(ext, "clearcoatRoughnessFactor", 0.0, &what, &owner)?;
        clearcoat_normal_scale = raw_textures(
            ext,
            "KHR_materials_clearcoat",
            &mut [
                ("clearcoatTexture", &mut textures.clearcoat, false),
                (
                    "clearcoatRoughnessTexture",
                    &mut textures.clearcoat_roughness,
                    false,
                ),
                (
                    "clearcoatNormalTexture",
                    &mut textures.clearcoat_normal,
                    false,
                ),
            ],
        )?[2];
    }
    // KHR_materials_sheen, read from the raw JSON.
    let (mut sheen_color, mut sheen_roughness) = (Vec3::ZERO, 0.0);
    if let Some((ext, what)) = raw_extension(&material, "KHR_materials_sheen", &path, &owner)? {
        sheen_color = raw_unit_color(ext, "sheenColorFactor", Vec3::ZERO, &what, &owner)?;
        sheen_roughness = raw_unit_factor(ext, "sheenRoughnessFactor", 0.0, &what, &owner)?;
        raw_textures(
            ext,
            "KHR_materials_sheen",
            &mut [
                ("sheenColorTexture", &mut textures.sheen_color, true),
                (
                    "sheenRoughnessTexture",
                    &mut textures.sheen_roughness,
                    false,
                ),
            ],
        )?;
    }
    // KHR_materials_anisotropy, read from the raw JSON.
    let (mut anisotropy, mut anisotropy_rotation) = (0.0, 0.0);
    if let Some((ext, what)) = raw_extension(&material, "KHR_materials_anisotropy", &path, &owner)?
    {
        anisotropy = raw_unit_factor(ext, "anisotropyStrength", 0.0, &what, &owner)?;
        if let Some(v) = ext.get("anisotropyRotation") {
            match v.as_f64() {
                Some(x) if x.is_finite() => anisotropy_rotation = x as f32,
                _ => bail!("{what}.anisotropyRotation{owner}: {v} must be a finite number"),
            }
        }
        raw_textures(
            ext,
            "KHR_materials_anisotropy",
            &mut [("anisotropyTexture", &mut textures.anisotropy, false)],
        )?;
    }
    // KHR_materials_iridescence, read from the raw JSON.
    let (mut iridescence, mut iridescence_ior) = (0.0, 1.3);
    let (mut thickness_min, mut thickness_max) = (100.0, 400.0);
    if let Some((ext, what)) = raw_extension(&material, "KHR_materials_iridescence", &path, &owner)?
    {
        iridescence = raw_unit_factor(ext, "iridescenceFactor", 0.0, &what, &owner)?;
        for (key, slot, least) in [
            ("iridescenceIor", &mut iridescence_ior, 1.0),
            ("iridescenceThicknessMinimum", &mut thickness_min, 0.0),
            ("iridescenceThicknessMaximum", &mut thickness_max, 0.0),
        ] {
            if let Some(v) = ext.get(key) {
                match v.as_f64() {
                    Some(x) if x.is_finite() && x >= least && x <= 1e6 => *slot = x as f32,
                    _ => bail!(
                        "{what}.{key}{owner}: {v} must be a finite number of at least {least}"
                    ),
                }
            }
        }
        raw_textures(
            ext,
            "KHR_materials_iridescence",
            &mut [
                ("iridescenceTexture", &mut textures.iridescence, false),
                (
                    "iridescenceThicknessTexture",
                    &mut textures.iridescence_thickness,
                    false,
                ),
            ],
        )?;
    }
    // KHR_materials_volume, read from the raw JSON (thicknessTexture is a rasteriser's estimate
    // of the distance a path tracer measures: not read).
    let (mut thickness, mut attenuation_color, mut attenuation_distance) =
        (0.0, Vec3::ONE, f32::INFINITY);
    if let Some((ext, what)) = raw_extension(&material, "KHR_materials_volume", &path, &owner)? {
        if let Some(v) = ext.get("thicknessFactor") {
            match v.as_f64() {
                Some(x) if x.is_finite() && x >= 0.0 => thickness = x as f32,
                _ => bail!("{what}.thicknessFactor{owner}: {v} must be a non-negative number"),
            }
        }
        if let Some(v) = ext.get("attenuationDistance") {
            match v.as_f64() {
                Some(x) if x > 0.0 => attenuation_distance = x as f32,
                _ => bail!("{what}.attenuationDistance{owner}: {v} must be a positive number"),
            }
        }
        attenuation_color = raw_unit_color(ext, "attenuationColor", Vec3::ONE, &what, &owner)?;
    }
    // KHR_materials_diffuse_transmission, read from the raw JSON.
    let (mut diffuse_transmission, mut diffuse_transmission_color) = (0.0, Vec3::ONE);
    if let Some((ext, what)) = raw_extension(
        &material,
        "KHR_materials_diffuse_transmission",
        &path,
        &owner,
    )? {
        diffuse_transmission =
            raw_unit_factor(ext, "diffuseTransmissionFactor", 0.0, &what, &owner)?;
        diffuse_transmission_color = raw_unit_color(
            ext,
            "diffuseTransmissionColorFactor",
            Vec3::ONE,
            &what,
            &owner,
        )?;
        raw_textures(
            ext,
            "KHR_materials_diffuse_transmission",
            &mut [
                (
                    "diffuseTransmissionTexture",
                    &mut textures.diffuse_transmission,
                    false,
                ),
                (
                    "diffuseTransmissionColorTexture",
                    &mut textures.diffuse_transmission_color,
                    true,
                ),
            ],
        )?;
    }
    // KHR_materials_dispersion, read from the raw JSON: 20 / Abbe number, any non-negative
    // value (the extension calls [0, 1] realistic and allows more for effect).
    let mut dispersion = 0.0;
    if let Some((ext, what)) = raw_extension(&material, "KHR_materials_dispersion", &path, &owner)?
    {
        if let Some(v) = ext.get("dispersion") {
            match v.as_f64() {
                Some(x) if x.is_finite() && (0.0..=1e6).contains(&x) => dispersion = x as f32,
                _ => bail!("{what}.dispersion{owner}: {v} must be a non-negative number"),
            }
        }
    }
    let mut normal_scale = 1.0;
    if let Some(normal) = material.normal_texture() {
        normal_scale = normal.scale();
        if !normal_scale.is_finite() {
            bail!(
                "{}: {normal_scale} is not finite",
                at("normalTexture.scale")
            );
        }
        let info = TextureInfo {
            texture: normal.texture(),
            tex_coord: normal.tex_coord(),
            transform: untyped_transform(
                normal.extension_value("KHR_texture_transform"),
                &path("normalTexture"),
                &owner,
            )?,
        };
        let r = reference("normalTexture", info, false)?;
        textures.normal = Some(r);
        needs.normal_map = Some(builder.set.refs[r as usize].texcoord);
    }
    // A coat's normal map needs tangents too (the base's set wins where both are mapped).
    if let (None, Some(r)) = (needs.normal_map, textures.clearcoat_normal) {
        needs.normal_map = Some(builder.set.refs[r as usize].texcoord);
    }
    // So does anisotropy (its direction lies in the tangent frame): that of its texture's set,
    // else set 0.
    if needs.normal_map.is_none() && anisotropy > 0.0 {
        needs.normal_map = Some(
            textures
                .anisotropy
                .map_or(0, |r| builder.set.refs[r as usize].texcoord),
        );
    }
    Ok((
        Material {
            name: material
                .name()
                .map_or_else(|| format!("material {index}"), str::to_owned),
            base_color: base_color.min(Vec3::ONE),
            metallic,
            roughness,
            ior,
            transmission,
            specular,
            specular_color,
            unlit,
            clearcoat,
            clearcoat_roughness,
            clearcoat_normal_scale,
            sheen_color,
            sheen_roughness,
            anisotropy,
            anisotropy_rotation,
            iridescence,
            iridescence_ior,
            iridescence_thickness_min: thickness_min,
            iridescence_thickness_max: thickness_max,
            thickness,
            attenuation_color,
            attenuation_distance,
            diffuse_transmission,
            diffuse_transmission_color,
            dispersion,
            emission,
            double_sided: material.double_sided(),
            alpha: alpha.min(1.0),
            alpha_mode,
            alpha_cutoff,
            normal_scale,
            textures,
        },
        needs,
    ))
}

// ---------------------------------------------------------------------------------------------
// Node traversal

/// A primitive's vertex attributes, in its local space, one per glTF vertex.
struct Attributes {
    normals: Option<Vec<Vec3>>,
    /// Whether each NORMAL is finite and non-zero.
    normal_valid: Vec<bool>,
    tangents: Option<Vec<Vec4>>,
    uv: [Vec<Vec2>; 2],
    color: Vec<Vec4>,
    /// None of NORMAL, TANGENT, TEXCOORD_0/1 or COLOR_0 is present.
    plain: bool,
}

/// Defects repaired while loading, counted for one note each.
#[derive(Default)]
struct Repairs {
    /// Vertices whose NORMAL is not finite or zero (their triangles are shaded flat).
    normals: usize,
    /// TEXCOORD, COLOR or TANGENT components that were not finite (set to their default).
    attributes: usize,
    /// Primitives whose MikkTSpace tangents could not be generated (normal map ignored there).
    tangents: usize,
}

impl Repairs {
    fn notes(&self) -> Vec<String> {
        let mut notes = Vec::new();
        if self.normals > 0 {
            notes.push(format!(
                "non-finite or zero vertex normals: their triangles are shaded with face normals (vertices: {})",
                self.normals
            ));
        }
        if self.attributes > 0 {
            notes.push(format!(
                "non-finite TEXCOORD, COLOR_0 or TANGENT values replaced by their defaults (vertices repaired: {})",
                self.attributes
            ));
        }
        if self.tangents > 0 {
            notes.push(format!(
                "MikkTSpace could not build tangents for {} primitives: their normal maps are ignored",
                self.tangents
            ));
        }
        notes
    }
}

struct Builder<'a> {
    buffers: &'a [Vec<u8>],
    budget: &'a Budget,
    triangles: Vec<Triangle>,
    vertices: Vec<GpuVertex>,
    materials: Vec<Material>,
    needs: Vec<MaterialNeeds>,
    repairs: Repairs,
    default_material: Option<u32>,
    cameras: Vec<SceneCamera>,
    dropped_degenerate: usize,
    skipped_primitives: usize,
    /// LoadOptions::instancing.
    instancing: bool,
    /// How many nodes of the document use each mesh.
    mesh_uses: Vec<usize>,
    /// Meshes stored once for their instances, and which glTF mesh each is.
    meshes: Vec<Mesh>,
    mesh_ids: std::collections::HashMap<usize, u32>,
    instances: Vec<Instance>,
    punctual: Vec<GpuPunctualLight>,
}

/// Triangles a mesh must save by being instanced rather than baked (placements − 1 times
/// its triangles) for the loader to instance it.
pub const INSTANCING_MIN_SAVED: u64 = 4096;

/// The triangles a mesh's primitives declare (index or vertex counts), before any is read.
fn mesh_triangle_estimate(mesh: &gltf::Mesh) -> u64 {
    mesh.primitives()
        .map(|p| {
            let count = p
                .indices()
                .map(|a| a.count())
                .or_else(|| p.get(&Semantic::Positions).map(|a| a.count()))
                .unwrap_or(0) as u64;
            match p.mode() {
                Mode::Triangles => count / 3,
                Mode::TriangleStrip | Mode::TriangleFan => count.saturating_sub(2),
                _ => 0,
            }
        })
        .sum()
}

/// A KHR_lights_punctual light on a node with world transform `world`: at the node's origin,
/// shining along its −Z; intensity × color in the renderer's units (W/sr, or W/m² for a
/// directional light: no 683 lm/W factor, as the Khronos sample viewer and three.js do).
fn punctual_light(
    light: &gltf::khr_lights_punctual::Light,
    world: &Mat4,
    what: &str,
) -> Result<GpuPunctualLight> {
    use gltf::khr_lights_punctual::Kind;
    let at = |p: &str| {
        format!(
            "extensions.KHR_lights_punctual.lights[{}]{p} (on {what})",
            light.index()
        )
    };
    let color = Vec3::from(light.color());
    let intensity = light.intensity();
    if !(color.is_finite() && color.min_element() >= 0.0) {
        bail!("{}: {color} must be finite and non-negative", at(".color"));
    }
    if !(intensity.is_finite() && intensity >= 0.0) {
        bail!(
            "{}: {intensity} must be finite and non-negative",
            at(".intensity")
        );
    }
    let range = match light.range() {
        None => 0.0,
        Some(r) if r.is_finite() && r > 0.0 => r,
        Some(r) => bail!("{}: {r} must be positive", at(".range")),
    };
    let position = world.transform_point3(Vec3::ZERO);
    let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    if !position.is_finite() || direction == Vec3::ZERO {
        bail!(
            "{}: its node's transform gives no position or direction",
            at("")
        );
    }
    let (kind, spot_scale, spot_offset) = match light.kind() {
        Kind::Point => (LIGHT_POINT, 0.0, 0.0),
        Kind::Directional => (LIGHT_DIRECTIONAL, 0.0, 0.0),
        Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let half_pi = std::f32::consts::FRAC_PI_2;
            if !(0.0..=half_pi).contains(&outer_cone_angle) || !(outer_cone_angle > 0.0) {
                bail!(
                    "{}: {outer_cone_angle} must be in (0, π/2]",
                    at(".spot.outerConeAngle")
                );
            }
            if !(0.0..outer_cone_angle).contains(&inner_cone_angle) {
                bail!(
                    "{}: {inner_cone_angle} must be in [0, outerConeAngle = {outer_cone_angle})",
                    at(".spot.innerConeAngle")
                );
            }
            // KHR_lights_punctual, "Inner and Outer Cone Angles".
            let scale = 1.0 / (inner_cone_angle.cos() - outer_cone_angle.cos()).max(0.001);
            (LIGHT_SPOT, scale, -outer_cone_angle.cos() * scale)
        }
    };
    Ok(GpuPunctualLight {
        position: position.to_array(),
        kind,
        direction: direction.to_array(),
        range,
        intensity: (color * intensity).to_array(),
        spot_scale,
        spot_offset,
        ..Default::default()
    })
}

/// How many nodes use each mesh.
fn mesh_uses(document: &Document) -> Vec<usize> {
    let mut uses = vec![0; document.meshes().len()];
    for node in document.nodes() {
        if let Some(mesh) = node.mesh() {
            uses[mesh.index()] += 1;
        }
    }
    uses
}

impl Builder<'_> {
    /// Depth-first, pre-order (children in file order), accumulating world transforms. A node
    /// reached twice is an error: either a loop or a node with two parents (glTF requires a
    /// forest), which also bounds the work by the number of nodes.
    fn walk(&mut self, document: &Document, scene: &gltf::Scene) -> Result<()> {
        let node_count = document.nodes().len();
        let node_label =
            |i: usize| label("node", i, document.nodes().nth(i).and_then(|n| n.name()));
        let mut parent: Vec<Option<usize>> = vec![None; node_count];
        let mut visited = vec![false; node_count];
        let mut stack: Vec<(gltf::Node, Mat4, Option<usize>)> =
            scene.nodes().map(|n| (n, Mat4::IDENTITY, None)).collect();
        stack.reverse();

        while let Some((node, parent_world, from)) = stack.pop() {
            let i = node.index();
            let what = label("node", i, node.name());
            if visited[i] {
                let mut ancestor = from;
                while let Some(a) = ancestor {
                    if a == i {
                        bail!(
                            "node loop: {what} is its own ancestor (reached again from {})",
                            node_label(from.unwrap())
                        );
                    }
                    ancestor = parent[a];
                }
                match from {
                    Some(p) => bail!("{what} is reached twice (again as a child of {}); a glTF node may have only one parent", node_label(p)),
                    None => bail!("{what} is a root of {} but is also reached elsewhere", label("scene", scene.index(), scene.name())),
                }
            }
            visited[i] = true;
            parent[i] = from;

            let local = Mat4::from_cols_array_2d(&node.transform().matrix());
            if !local.is_finite() {
                bail!("{what} has a non-finite transform: {local}");
            }
            let world = parent_world * local;
            if !world.is_finite() {
                bail!("{what}: its world transform overflows to non-finite values: {world}");
            }
            if let Some(camera) = node.camera() {
                self.add_camera(&camera, &node, &world, &what)?;
            }
            if let Some(light) = node.light() {
                self.punctual.push(punctual_light(&light, &world, &what)?);
            }
            if let Some(mesh) = node.mesh() {
                let gpu_instancing = node
                    .extension_value("EXT_mesh_gpu_instancing")
                    .map(|value| self.gpu_instances(document, value, &world, &what))
                    .transpose()?;
                let transforms = gpu_instancing.clone().unwrap_or_else(|| vec![world]);
                // Meshes several placements share are stored once and instanced when that saves
                // at least INSTANCING_MIN_SAVED triangles (smaller ones are cheaper to trace
                // baked, in the one-level fast path), unless they emit (the emitter table
                // needs world-space triangles) or a placement is singular.
                let placements = if gpu_instancing.is_some() {
                    transforms.len()
                } else {
                    self.mesh_uses[mesh.index()]
                };
                let saved = (placements.saturating_sub(1) as u64)
                    .saturating_mul(mesh_triangle_estimate(&mesh));
                let shared = self.instancing && placements > 1 && saved >= INSTANCING_MIN_SAVED;
                let emits = mesh.primitives().any(|p| {
                    p.material()
                        .index()
                        .is_some_and(|m| self.materials[m].is_emissive())
                });
                let singular = transforms
                    .iter()
                    .any(|t| Mat3::from_mat4(*t).determinant().abs() < 1e-30);
                if shared && !emits && !singular {
                    let id = self.instanced_mesh(&mesh, &what)?;
                    self.budget.reserve(
                        &format!(
                            "{} instances of {}",
                            transforms.len(),
                            json_path("mesh", mesh.index())
                        ),
                        transforms.len() as u64 * std::mem::size_of::<Instance>() as u64,
                    )?;
                    self.instances
                        .extend(transforms.iter().map(|&transform| Instance {
                            mesh: id,
                            transform,
                        }));
                    let children: Vec<_> = node.children().collect();
                    stack.extend(children.into_iter().rev().map(|c| (c, world, Some(i))));
                    continue;
                }
                for world in &transforms {
                    for primitive in mesh.primitives() {
                        self.add_primitive(&primitive, world).with_context(|| {
                            format!(
                                "{}.primitives[{}] ({}instanced by {what})",
                                json_path("mesh", mesh.index()),
                                primitive.index(),
                                mesh.name()
                                    .map_or_else(String::new, |n| format!("mesh {n:?}, "))
                            )
                        })?;
                    }
                }
            }
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world, Some(i))));
        }
        Ok(())
    }

    /// The index in `meshes` of glTF mesh `mesh` stored once in object space, built on first
    /// use (`what` names the node that first uses it).
    fn instanced_mesh(&mut self, mesh: &gltf::Mesh, what: &str) -> Result<u32> {
        if let Some(&id) = self.mesh_ids.get(&mesh.index()) {
            return Ok(id);
        }
        let baked = std::mem::take(&mut self.triangles);
        let mut result = Ok(());
        for primitive in mesh.primitives() {
            result = self
                .add_primitive(&primitive, &Mat4::IDENTITY)
                .with_context(|| {
                    format!(
                        "{}.primitives[{}] ({}instanced by {what})",
                        json_path("mesh", mesh.index()),
                        primitive.index(),
                        mesh.name()
                            .map_or_else(String::new, |n| format!("mesh {n:?}, "))
                    )
                });
            if result.is_err() {
                break;
            }
        }
        let triangles = std::mem::replace(&mut self.triangles, baked);
        result?;
        self.meshes.push(Mesh {
            label: label("mesh", mesh.index(), mesh.name()),
            triangles,
        });
        let id = self.meshes.len() as u32 - 1;
        self.mesh_ids.insert(mesh.index(), id);
        Ok(id)
    }

    /// The world transforms of EXT_mesh_gpu_instancing's instances on a node with world
    /// transform `world`: world · T · R · S per instance (the extension's attributes
    /// TRANSLATION, ROTATION and SCALE, each optional).
    fn gpu_instances(
        &self,
        document: &Document,
        value: &serde_json::Value,
        world: &Mat4,
        what: &str,
    ) -> Result<Vec<Mat4>> {
        let at = |s: &str| format!("{what}.extensions.EXT_mesh_gpu_instancing{s}");
        let attributes = value
            .get("attributes")
            .and_then(|a| a.as_object())
            .ok_or_else(|| anyhow!("{}: missing, expected an object", at(".attributes")))?;
        let read = |name: &str,
                    dims: Dimensions,
                    normalized: &[DataType]|
         -> Result<Option<Vec<[f32; 4]>>> {
            let Some(index) = attributes.get(name) else {
                return Ok(None);
            };
            let path = at(&format!(".attributes.{name}"));
            let index = index
                .as_u64()
                .ok_or_else(|| anyhow!("{path}: expected an accessor index"))?;
            let accessor = document
                .accessors()
                .nth(index as usize)
                .ok_or_else(|| anyhow!("{path}: accessor {index} does not exist"))?;
            let values = read_attribute(&accessor, self.buffers, self.budget, &[dims], normalized)
                .with_context(|| {
                    format!(
                        "{path} = {}",
                        label("accessor", accessor.index(), accessor.name())
                    )
                })?;
            if values.iter().flatten().any(|v| !v.is_finite()) {
                bail!("{path}: non-finite values");
            }
            Ok(Some(values))
        };
        let translation = read("TRANSLATION", Dimensions::Vec3, &[])?;
        let rotation = read("ROTATION", Dimensions::Vec4, &[DataType::I8, DataType::I16])?;
        let scale = read("SCALE", Dimensions::Vec3, &[])?;
        let counts: Vec<usize> = [&translation, &rotation, &scale]
            .iter()
            .filter_map(|a| a.as_ref().map(Vec::len))
            .collect();
        let Some(&count) = counts.first() else {
            bail!(
                "{}: none of TRANSLATION, ROTATION, SCALE",
                at(".attributes")
            );
        };
        if counts.iter().any(|&c| c != count) {
            bail!(
                "{}: the attributes have different counts {counts:?}",
                at(".attributes")
            );
        }
        Ok((0..count)
            .map(|k| {
                let t = translation
                    .as_ref()
                    .map_or(Vec3::ZERO, |v| Vec3::from_slice(&v[k]));
                let r = rotation.as_ref().map_or(glam::Quat::IDENTITY, |v| {
                    glam::Quat::from_array(v[k]).normalize()
                });
                let s = scale
                    .as_ref()
                    .map_or(Vec3::ONE, |v| Vec3::from_slice(&v[k]));
                *world * Mat4::from_scale_rotation_translation(s, r, t)
            })
            .collect())
    }

    /// A camera instance: glTF camera `camera` on `node` (labelled `what`) with world transform
    /// `world`. Its numbers were checked with the document (`validate.rs`).
    fn add_camera(
        &mut self,
        camera: &gltf::Camera,
        node: &gltf::Node,
        world: &Mat4,
        what: &str,
    ) -> Result<()> {
        let (projection, znear) = match camera.projection() {
            gltf::camera::Projection::Perspective(p) => (
                Projection::Perspective {
                    yfov: p.yfov(),
                    aspect_ratio: p.aspect_ratio(),
                },
                p.znear(),
            ),
            gltf::camera::Projection::Orthographic(o) => (
                Projection::Orthographic {
                    xmag: o.xmag(),
                    ymag: o.ymag(),
                },
                o.znear(),
            ),
        };
        let label = format!(
            "{} on {what}",
            label("camera", camera.index(), camera.name())
        );
        let placed =
            Camera::from_node(world, projection, znear).map_err(|e| anyhow!("{label}: {e}"))?;
        self.cameras.push(SceneCamera {
            camera: placed,
            index: camera.index(),
            name: camera.name().map(str::to_owned),
            node_name: node.name().map(str::to_owned),
            label,
        });
        Ok(())
    }

    /// Reserves (in the budget and the vector) room for `more` triangles, growing the vector
    /// geometrically as `Vec` would.
    fn reserve_triangles(&mut self, more: usize) -> Result<()> {
        let size = std::mem::size_of::<Triangle>() as u64;
        let needed = self.triangles.len().saturating_add(more);
        let capacity = self.triangles.capacity();
        if needed <= capacity {
            return Ok(());
        }
        let grown = needed.max(capacity.saturating_mul(2));
        self.budget.reserve(
            &format!("{needed} world-space triangles"),
            (grown - capacity) as u64 * size,
        )?;
        self.triangles.reserve_exact(grown - self.triangles.len());
        Ok(())
    }

    fn add_primitive(&mut self, primitive: &Primitive, world: &Mat4) -> Result<()> {
        if !matches!(
            primitive.mode(),
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.skipped_primitives += 1;
            return Ok(());
        }
        let Some(accessor) = primitive.get(&gltf::Semantic::Positions) else {
            bail!("attributes.POSITION: missing, expected an accessor index");
        };
        let position_what = format!(
            "attributes.POSITION = {}",
            label("accessor", accessor.index(), accessor.name())
        );
        let positions =
            read_positions(&accessor, self.buffers, self.budget).context(position_what.clone())?;
        let vertices: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                let what = format!(
                    "indices = {}",
                    label("accessor", accessor.index(), accessor.name())
                );
                let indices =
                    read_indices(&accessor, self.buffers, self.budget).context(what.clone())?;
                if let Some((k, v)) = indices
                    .iter()
                    .enumerate()
                    .find(|(_, &v)| v as usize >= positions.len())
                {
                    bail!(
                        "{what}: index {v} (element {k}) is out of range, POSITION has {} vertices",
                        positions.len()
                    );
                }
                indices
            }
            None => {
                if positions.len() > u32::MAX as usize {
                    bail!(
                        "{position_what}: {} vertices without indices, expected at most 2³²",
                        positions.len()
                    );
                }
                self.budget
                    .reserve("the implicit indices", element_bytes(&positions) / 3)?;
                (0..positions.len() as u32).collect()
            }
        };
        let corner_count = match primitive.mode() {
            Mode::Triangles => vertices.len() / 3,
            _ => vertices.len().saturating_sub(2),
        };
        let corner_bytes = corner_count as u64 * 12;
        self.budget.reserve("the triangle corners", corner_bytes)?;
        let corners = triangle_corners(primitive.mode(), &vertices)?;
        self.reserve_triangles(corners.len())?;
        let material = self.material_index(primitive.material().index());
        let needs = primitive
            .material()
            .index()
            .map_or_else(MaterialNeeds::default, |i| self.needs[i]);
        let alpha_tested = self.materials[material as usize].alpha_mode != AlphaMode::Opaque;
        let attributes = self.read_attributes(primitive, positions.len(), &needs)?;

        // Shading vertices: one per glTF vertex, or one per triangle corner where MikkTSpace
        // tangents are generated (a corner keeps the tangent MikkTSpace gives it).
        let first_vertex = self.vertices.len() as u64;
        let unweld = needs.normal_map.is_some() && attributes.tangents.is_none();
        // No attributes at all: no vertices, and shading reads none (TRIANGLE_PLAIN).
        let plain = attributes.plain && !unweld;
        let local: Vec<(Vec3, Vec3, Vec4, [Vec2; 2], Vec4, bool)> = if plain {
            Vec::new()
        } else if unweld {
            let set = needs.normal_map.unwrap_or(0) as usize;
            let mut p = Vec::with_capacity(3 * corners.len());
            let mut n = Vec::with_capacity(3 * corners.len());
            let mut uv = Vec::with_capacity(3 * corners.len());
            let mut flat = Vec::with_capacity(3 * corners.len());
            for c in &corners {
                let q = c.map(|v| positions[v as usize]);
                let face = (q[1] - q[0]).cross(q[2] - q[0]).normalize_or_zero();
                for &v in c {
                    p.push(positions[v as usize]);
                    let (normal, valid) = match &attributes.normals {
                        Some(normals) if attributes.normal_valid[v as usize] => {
                            (normals[v as usize], true)
                        }
                        _ => (face, attributes.normals.is_none()),
                    };
                    n.push(normal);
                    flat.push(!valid);
                    uv.push(attributes.uv[set][v as usize]);
                }
            }
            let tangents = mikktspace_tangents(&p, &n, &uv);
            if tangents.is_none() {
                self.repairs.tangents += 1;
            }
            let tangents = tangents.unwrap_or_else(|| vec![[0.0, 0.0, 0.0, 1.0]; p.len()]);
            corners
                .iter()
                .flatten()
                .enumerate()
                .map(|(k, &v)| {
                    let v = v as usize;
                    (
                        p[k],
                        n[k],
                        Vec4::from(tangents[k]),
                        [attributes.uv[0][v], attributes.uv[1][v]],
                        attributes.color[v],
                        flat[k],
                    )
                })
                .collect()
        } else {
            // Per vertex on every core (a collect keeps the order).
            (0..positions.len())
                .into_par_iter()
                .map(|v| {
                    (
                        positions[v],
                        attributes.normals.as_ref().map_or(Vec3::ZERO, |n| n[v]),
                        attributes
                            .tangents
                            .as_ref()
                            .map_or(Vec4::new(0.0, 0.0, 0.0, 1.0), |t| t[v]),
                        [attributes.uv[0][v], attributes.uv[1][v]],
                        attributes.color[v],
                        attributes.normals.is_none() || !attributes.normal_valid[v],
                    )
                })
                .collect()
        };
        self.budget.reserve(
            &format!("{} shading vertices", local.len()),
            local.len() as u64 * std::mem::size_of::<GpuVertex>() as u64,
        )?;
        if first_vertex + local.len() as u64 > u32::MAX as u64 - 1 {
            bail!("the scene has more than 2³² − 2 shading vertices");
        }
        // Normals transform by the inverse transpose; tangents like positions, their
        // handedness flipping with a mirroring transform.
        let linear = Mat3::from_mat4(*world);
        let determinant = linear.determinant();
        let mirrored = determinant < 0.0;
        let normal_matrix = linear.inverse().transpose();
        // Per vertex on every core, written in place in order; a vertex shades flat where its
        // normal is missing, invalid or vanishes in world space.
        self.vertices
            .par_extend(local.par_iter().map(|&(_, n, t, uv, color, _)| {
                let normal = (normal_matrix * n).normalize_or_zero();
                let tangent = (linear * t.truncate()).normalize_or_zero();
                let sign = if (t.w < 0.0) != mirrored { -1.0 } else { 1.0 };
                GpuVertex {
                    tangent: tangent.extend(sign).to_array(),
                    normal: normal.to_array(),
                    pad: 0,
                    uv: [uv[0].x, uv[0].y, uv[1].x, uv[1].y],
                    color: color.to_array(),
                }
            }));
        let vertex_flat: Vec<bool> = local
            .par_iter()
            .zip(&self.vertices[first_vertex as usize..])
            .map(|(l, v)| {
                let normal = Vec3::from(v.normal);
                l.5 || normal == Vec3::ZERO || !normal.is_finite()
            })
            .collect();

        // Triangle t in world space: the index and position of its first non-finite corner,
        // or the triangle, or `None` where it is degenerate (dropped).
        let make =
            |t: usize, c: &[u32; 3]| -> std::result::Result<Option<Triangle>, (usize, Vec3)> {
                let mut p = c.map(|v| world.transform_point3(positions[v as usize]));
                if let Some(k) = p.iter().position(|q| !q.is_finite()) {
                    return Err((k, p[k]));
                }
                let local_index = |k: usize| if unweld { 3 * t + k } else { c[k] as usize };
                let mut corner_vertices = if plain {
                    [NO_VERTEX; 3]
                } else {
                    [0, 1, 2].map(|k| (first_vertex + local_index(k) as u64) as u32)
                };
                let flat = plain || (0..3).any(|k| vertex_flat[local_index(k)]);
                if mirrored {
                    p.swap(1, 2);
                    corner_vertices.swap(1, 2);
                }
                let mut flags = if flat { TRIANGLE_FLAT } else { 0 };
                if plain {
                    flags |= TRIANGLE_PLAIN;
                }
                if alpha_tested {
                    flags |= TRIANGLE_ALPHA;
                }
                let triangle = Triangle {
                    p,
                    material,
                    vertices: corner_vertices,
                    flags,
                };
                Ok(triangle
                    .geometric_normal()
                    .try_normalize()
                    .is_some()
                    .then_some(triangle))
            };
        // Checked on every core first (nothing stored); where every triangle is finite and
        // kept, as in most files, they are made again and written in place on every core
        // (the capacity is reserved above) — a million triangles' 56 MiB of fresh memory is
        // faulted in by the threads that write it, and no copy of them is collected first.
        // Otherwise one pass in triangle order: the first non-finite corner is the error
        // reported and degenerate triangles are dropped.
        let all_kept = corners
            .par_iter()
            .enumerate()
            .all(|(t, c)| matches!(make(t, c), Ok(Some(_))));
        if all_kept {
            self.triangles.par_extend(
                corners
                    .par_iter()
                    .enumerate()
                    .map(|(t, c)| make(t, c).ok().flatten().expect("checked above")),
            );
        } else {
            for (t, c) in corners.iter().enumerate() {
                match make(t, c) {
                    Ok(Some(triangle)) => self.triangles.push(triangle),
                    Ok(None) => self.dropped_degenerate += 1,
                    Err((k, p)) => bail!(
                        "vertex {} (corner {k} of triangle {t}) has a non-finite world-space \
                         position {p}",
                        c[k]
                    ),
                }
            }
        }
        // The decoded accessors and corners are freed on return.
        self.budget.release(
            element_bytes(&positions) + element_bytes(&vertices) + element_bytes(&corners),
        );
        Ok(())
    }

    /// NORMAL, TANGENT, TEXCOORD_0/1 and COLOR_0 of a primitive of `count` vertices, checked
    /// against what its material needs; non-finite values repaired and counted.
    fn read_attributes(
        &mut self,
        primitive: &Primitive,
        count: usize,
        needs: &MaterialNeeds,
    ) -> Result<Attributes> {
        let read = |semantic: Semantic,
                    dims: &[Dimensions],
                    normalized: &[DataType]|
         -> Result<Option<Vec<[f32; 4]>>> {
            let Some(accessor) = primitive.get(&semantic) else {
                return Ok(None);
            };
            let what = format!(
                "attributes.{} = {}",
                semantic.to_string(),
                label("accessor", accessor.index(), accessor.name())
            );
            let values = read_attribute(&accessor, self.buffers, self.budget, dims, normalized)
                .context(what.clone())?;
            if values.len() != count {
                bail!(
                    "{what}: {} elements, but POSITION has {count}",
                    values.len()
                );
            }
            Ok(Some(values))
        };
        let normals = read(Semantic::Normals, &[Dimensions::Vec3], &[])?;
        let tangents = read(Semantic::Tangents, &[Dimensions::Vec4], &[])?;
        let uv_types = [DataType::U8, DataType::U16];
        let uv0 = read(Semantic::TexCoords(0), &[Dimensions::Vec2], &uv_types)?;
        let uv1 = read(Semantic::TexCoords(1), &[Dimensions::Vec2], &uv_types)?;
        let colors = primitive.get(&Semantic::Colors(0)).map(|a| a.dimensions());
        let plain = normals.is_none()
            && tangents.is_none()
            && uv0.is_none()
            && uv1.is_none()
            && colors.is_none();
        let color = read(
            Semantic::Colors(0),
            &[Dimensions::Vec3, Dimensions::Vec4],
            &uv_types,
        )?;
        for (set, present) in [(0, uv0.is_some()), (1, uv1.is_some())] {
            if needs.tex_coords[set] && !present {
                bail!(
                    "attributes.TEXCOORD_{set}: missing, but the primitive's material reads texture \
                     coordinate set {set}"
                );
            }
        }
        let mut repaired = 0;
        let mut finite_or = |v: [f32; 4], default: [f32; 4]| {
            if v.iter().all(|x| x.is_finite()) {
                v
            } else {
                repaired += 1;
                default
            }
        };
        let uv = [uv0, uv1].map(|set| match set {
            Some(values) => values
                .into_iter()
                .map(|v| Vec2::from_slice(&finite_or(v, [0.0; 4])))
                .collect(),
            None => vec![Vec2::ZERO; count],
        });
        let color = match color {
            Some(values) => values
                .into_iter()
                .map(|mut v| {
                    if colors == Some(Dimensions::Vec3) {
                        v[3] = 1.0;
                    }
                    Vec4::from(finite_or(v, [1.0; 4])).clamp(Vec4::ZERO, Vec4::ONE)
                })
                .collect(),
            None => vec![Vec4::ONE; count],
        };
        let tangents = tangents.map(|values| {
            values
                .into_iter()
                .map(|v| Vec4::from(finite_or(v, [0.0, 0.0, 0.0, 1.0])))
                .collect()
        });
        self.repairs.attributes += repaired;
        let mut normal_valid = vec![true; count];
        let normals = normals.map(|values| {
            values
                .into_iter()
                .enumerate()
                .map(|(k, v)| {
                    let n = Vec3::new(v[0], v[1], v[2]);
                    if !(n.is_finite() && n.length_squared() > 0.0) {
                        normal_valid[k] = false;
                        self.repairs.normals += 1;
                    }
                    n
                })
                .collect()
        });
        Ok(Attributes {
            plain,
            normals,
            normal_valid,
            tangents,
            uv,
            color,
        })
    }

    /// The file's material index, or the default material, appended on first use.
    fn material_index(&mut self, index: Option<usize>) -> u32 {
        if let Some(i) = index {
            return i as u32;
        }
        *self.default_material.get_or_insert_with(|| {
            self.materials.push(Material::default_white());
            (self.materials.len() - 1) as u32
        })
    }
}
