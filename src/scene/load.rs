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
//!    only; images are never decoded (textures are ignored), but their URIs obey the same
//!    rules; accessors are read with every offset, stride and index checked (`accessors.rs`);
//! 4. every large allocation is reserved in the memory budget first (`limits.rs`).
//!
//! Supported: every node of the default scene (scene 0 if none is default), TRS or matrix
//! transforms, triangle lists, strips and fans, u8/u16/u32 or no indices, sparse accessors,
//! perspective and orthographic cameras (every instance, in `Scene::cameras`).
//! Point and line primitives are skipped (counted in `Scene::skipped_primitives`); skins,
//! morph targets, textures and KHR_mesh_quantization are not supported (the first two are
//! ignored, quantized positions are an error).

use super::accessors::{element_bytes, read_indices, read_positions, triangle_corners};
use super::buffers::{check_image_uris, load_buffers, open_regular};
use super::json::{parse_value, split_container, typed_root, validation_message};
use super::limits::{format_bytes, Budget, LoadOptions, PREPARE_BYTES_PER_TRIANGLE};
use super::validate::check_document;
use super::{bounds_of, Camera, Material, Projection, Scene, SceneCamera, Triangle};
use anyhow::{anyhow, bail, Context, Result};
use glam::{Mat3, Mat4, Vec3};
use gltf::mesh::{Mode, Primitive};
use gltf::Document;
use std::io::Read;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// Extensions a file may list in `extensionsRequired`.
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_specular",
];

/// Memory a parsed JSON value may take per structural character (`,` `:` `[` `{`) of its text:
/// a `serde_json::Value` is 32 bytes, a map entry about twice that, and the `gltf` crate's
/// typed model is built from it while it lives.
const JSON_BYTES_PER_TOKEN: u64 = 96;

pub(super) fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    // The last guard: a panic inside the `gltf` crate that the checks below did not foresee
    // becomes an error (the release profile keeps panic = "unwind" for this).
    let reserved_before = options.budget.used();
    let result =
        catch_unwind(AssertUnwindSafe(|| load_file(path, options))).unwrap_or_else(|panic| {
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

fn load_file(path: &Path, options: &LoadOptions) -> Result<Scene> {
    let bytes = read_scene_file(path, &options.budget)?;
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
                "extensionsRequired: the file requires the glTF extension {ext:?}, which wavetrace \
                 does not support (supported: {})",
                SUPPORTED_EXTENSIONS.join(", ")
            );
        }
    }
    let document = Document::from_json(root).map_err(validation_message)?;

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
    let materials = document
        .materials()
        .enumerate()
        .map(|(i, m)| convert_material(i, &m))
        .collect::<Result<_>>()?;
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
        materials,
        default_material: None,
        cameras: Vec::new(),
        dropped_degenerate: 0,
        skipped_primitives: 0,
    };
    builder.walk(&document, &scene)?;
    if builder.triangles.is_empty() {
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
            builder.triangles.len()
        ),
        builder.triangles.len() as u64 * PREPARE_BYTES_PER_TRIANGLE,
    )?;
    let notes = notes(&document, &builder);
    let camera = builder.cameras.first().map_or_else(
        || Camera::framing(bounds_of(&builder.triangles)),
        |c| c.camera,
    );
    Ok(Scene {
        source: path.to_path_buf(),
        triangles: builder.triangles,
        materials: builder.materials,
        camera,
        cameras: builder.cameras,
        dropped_degenerate: builder.dropped_degenerate,
        skipped_primitives: builder.skipped_primitives,
        notes,
    })
}

/// What the file holds that the render will not show, said once each (`Scene::notes`).
fn notes(document: &Document, builder: &Builder) -> Vec<String> {
    let mut notes = Vec::new();
    let textured: Vec<String> = document
        .materials()
        .enumerate()
        .filter(|(_, m)| {
            let pbr = m.pbr_metallic_roughness();
            pbr.base_color_texture().is_some()
                || pbr.metallic_roughness_texture().is_some()
                || m.emissive_texture().is_some()
                || m.normal_texture().is_some()
                || m.transmission()
                    .is_some_and(|t| t.transmission_texture().is_some())
                || m.specular().is_some_and(|t| t.specular_texture().is_some())
        })
        .map(|(i, m)| label("material", i, m.name()))
        .collect();
    if !textured.is_empty() {
        let verb = if textured.len() == 1 {
            "uses its"
        } else {
            "use their"
        };
        notes.push(format!(
            "textures are not supported yet: {} {verb} colour factors only",
            textured.join(", ")
        ));
    }
    let ignored: Vec<&str> = document
        .extensions_used()
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
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

fn convert_material(index: usize, material: &gltf::Material) -> Result<Material> {
    // The JSON path of one property of this material, with the material's name after it.
    let at = |property: &str| {
        let path = format!("{}.{property}", json_path("material", index));
        match material.name() {
            Some(name) if !name.is_empty() => format!("{path} (material {name:?})"),
            _ => path,
        }
    };
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
    Ok(Material {
        name: material
            .name()
            .map_or_else(|| format!("material {index}"), str::to_owned),
        base_color: base_color.min(Vec3::ONE),
        metallic,
        roughness,
        ior,
        transmission,
        specular,
        emission,
        double_sided: material.double_sided(),
    })
}

// ---------------------------------------------------------------------------------------------
// Node traversal

struct Builder<'a> {
    buffers: &'a [Vec<u8>],
    budget: &'a Budget,
    triangles: Vec<Triangle>,
    materials: Vec<Material>,
    default_material: Option<u32>,
    cameras: Vec<SceneCamera>,
    dropped_degenerate: usize,
    skipped_primitives: usize,
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
            if let Some(mesh) = node.mesh() {
                for primitive in mesh.primitives() {
                    self.add_primitive(&primitive, &world).with_context(|| {
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
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world, Some(i))));
        }
        Ok(())
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
        // A mirroring transform turns counter-clockwise into clockwise: swap to keep the front.
        let mirrored = Mat3::from_mat4(*world).determinant() < 0.0;

        for (t, c) in corners.iter().enumerate() {
            let mut p = c.map(|v| world.transform_point3(positions[v as usize]));
            if let Some(k) = p.iter().position(|q| !q.is_finite()) {
                bail!(
                    "vertex {} (corner {k} of triangle {t}) has a non-finite world-space position {}",
                    c[k],
                    p[k]
                );
            }
            if mirrored {
                p.swap(1, 2);
            }
            let triangle = Triangle { p, material };
            if triangle.geometric_normal().try_normalize().is_none() {
                self.dropped_degenerate += 1;
                continue;
            }
            self.triangles.push(triangle);
        }
        // The decoded accessors and corners are freed on return.
        self.budget.release(
            element_bytes(&positions) + element_bytes(&vertices) + element_bytes(&corners),
        );
        Ok(())
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
