//! glTF 2.0 (`.gltf` / `.glb`) → [`Scene`].
//!
//! The `gltf` crate parses and validates the JSON (unresolved references, out-of-range enums);
//! everything after that is done here, without `gltf::import`: buffers are resolved relative to
//! the file (base64 `data:` URIs, relative paths, the GLB binary chunk), images are never
//! decoded (textures are ignored), and accessors are read with every offset, stride and index
//! checked, so that bad input becomes an error that names the file, the object and the
//! problem instead of a panic.
//!
//! Supported: every node of the default scene (scene 0 if none is default), TRS or matrix
//! transforms, triangle lists, strips and fans, u8/u16/u32 or no indices, sparse accessors.
//! Point and line primitives are skipped (counted in `Scene::skipped_primitives`); skins,
//! morph targets, textures and KHR_mesh_quantization are not supported (the first two are
//! ignored, quantized positions are an error).

use super::accessors::{read_indices, read_positions, triangle_corners};
use super::buffers::load_buffers;
use super::{bounds_of, Camera, Material, Scene, Triangle};
use anyhow::{anyhow, bail, Context, Result};
use glam::{Mat3, Mat4, Vec3};
use gltf::mesh::{Mode, Primitive};
use gltf::Document;
use std::path::Path;

/// Extensions a file may list in `extensionsRequired`.
const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_specular",
];

pub(super) fn load(path: &Path) -> Result<Scene> {
    load_file(path).with_context(|| format!("cannot load scene {}", path.display()))
}

fn load_file(path: &Path) -> Result<Scene> {
    let bytes = std::fs::read(path).context("cannot read the file")?;
    if bytes.is_empty() {
        bail!("the file is empty (expected glTF JSON or binary glTF)");
    }
    check_glb_header(&bytes)?;
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| anyhow!("not a glTF 2.0 document: {e}"))?;
    // Checked before validation, which would reject them with a less helpful message.
    for ext in document.extensions_required() {
        if !SUPPORTED_EXTENSIONS.contains(&ext) {
            bail!(
                "the file requires the glTF extension {ext}, which wavetrace does not support \
                 (supported: {})",
                SUPPORTED_EXTENSIONS.join(", ")
            );
        }
    }
    check_position_indices(document.as_json())?;
    let document = Document::from_json(document.into_json()).map_err(|e| anyhow!("{e}"))?;

    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(&document, blob.as_deref(), base)?;
    let materials = document
        .materials()
        .enumerate()
        .map(|(i, m)| convert_material(i, &m))
        .collect::<Result<_>>()?;
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| anyhow!("the file contains no scene, so there is nothing to render"))?;

    let mut builder = Builder {
        buffers: &buffers,
        triangles: Vec::new(),
        materials,
        default_material: None,
        camera: None,
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
    let notes = notes(&document, &builder);
    let camera = builder
        .camera
        .unwrap_or_else(|| Camera::framing(bounds_of(&builder.triangles)));
    Ok(Scene {
        source: path.to_path_buf(),
        triangles: builder.triangles,
        materials: builder.materials,
        camera,
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
    if builder.camera.is_none() && document.cameras().next().is_some() {
        notes.push("the file has no perspective camera (orthographic ones are not supported): using a camera that frames the scene".into());
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

/// `kind index "name"`, e.g. `mesh 3 "Chair"`, or `kind index` for unnamed objects.
pub(super) fn label(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(name) if !name.is_empty() => format!("{kind} {index} \"{name}\""),
        _ => format!("{kind} {index}"),
    }
}

/// gltf-json 1.4's validation indexes each primitive's POSITION accessor without a bounds check
/// (a panic on a dangling index), so check that first.
fn check_position_indices(root: &gltf::json::Root) -> Result<()> {
    use gltf::json::validation::Checked;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive
                .attributes
                .get(&Checked::Valid(gltf::Semantic::Positions));
            if let Some(index) = position.filter(|i| i.value() >= root.accessors.len()) {
                bail!(
                    "{}, primitive {p}: POSITION refers to accessor {}, but the file has {} accessors",
                    label("mesh", m, mesh.name.as_deref()),
                    index.value(),
                    root.accessors.len()
                );
            }
        }
    }
    Ok(())
}

/// The GLB header's total length must lie within the file (the `gltf` crate assumes ≥ 12).
fn check_glb_header(bytes: &[u8]) -> Result<()> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let Some(length) = bytes.get(8..12) else {
        bail!(
            "binary glTF: the file ends inside the 12-byte header ({} bytes)",
            bytes.len()
        );
    };
    let length = u32::from_le_bytes(length.try_into().unwrap()) as usize;
    if length < 12 || length > bytes.len() {
        bail!(
            "binary glTF: the header declares {length} bytes but the file has {}",
            bytes.len()
        );
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Materials

fn convert_material(index: usize, material: &gltf::Material) -> Result<Material> {
    let what = label("material", index, material.name());
    let [r, g, b, _] = material.pbr_metallic_roughness().base_color_factor();
    let base_color = Vec3::new(r, g, b);
    // The spec bounds factors to [0, 1]; forgive rounding just above 1.
    if !(base_color.is_finite()
        && base_color.min_element() >= 0.0
        && base_color.max_element() <= 1.0 + 1e-4)
    {
        bail!("{what}: baseColorFactor {base_color} is outside [0, 1] (an albedo above 1 creates energy)");
    }
    let pbr = material.pbr_metallic_roughness();
    let unit = |name: &str, v: f32| -> Result<f32> {
        if (0.0..=1.0 + 1e-4).contains(&v) {
            Ok(v.min(1.0))
        } else {
            bail!("{what}: {name} {v} is outside [0, 1]")
        }
    };
    let metallic = unit("pbrMetallicRoughness.metallicFactor", pbr.metallic_factor())?;
    let roughness = unit(
        "pbrMetallicRoughness.roughnessFactor",
        pbr.roughness_factor(),
    )?;
    let transmission = material.transmission().map_or(Ok(0.0), |t| {
        unit(
            "KHR_materials_transmission.transmissionFactor",
            t.transmission_factor(),
        )
    })?;
    let specular = material.specular().map_or(Ok(1.0), |s| {
        unit("KHR_materials_specular.specularFactor", s.specular_factor())
    })?;
    // KHR_materials_ior: ior ≥ 1, or exactly 0 (f0 = 1, a specular-glossiness conversion).
    let ior = material.ior().unwrap_or(1.5);
    if !(ior.is_finite() && (ior >= 1.0 || ior == 0.0)) {
        bail!("{what}: KHR_materials_ior.ior {ior} must be at least 1 (or exactly 0)");
    }
    let factor = Vec3::from(material.emissive_factor());
    let strength = material.emissive_strength().unwrap_or(1.0);
    let emission = factor * strength;
    if !(factor.is_finite()
        && factor.min_element() >= 0.0
        && strength >= 0.0
        && emission.is_finite())
    {
        bail!("{what}: emission (emissiveFactor {factor} × emissiveStrength {strength}) must be finite and non-negative");
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
    triangles: Vec<Triangle>,
    materials: Vec<Material>,
    default_material: Option<u32>,
    camera: Option<Camera>,
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
            if let (None, Some(camera)) = (&self.camera, node.camera()) {
                if let gltf::camera::Projection::Perspective(p) = camera.projection() {
                    let camera =
                        Camera::from_node(&world, p.yfov(), p.aspect_ratio()).map_err(|e| {
                            anyhow!(
                                "{} on {what}: {e}",
                                label("camera", camera.index(), camera.name())
                            )
                        })?;
                    self.camera = Some(camera);
                }
            }
            if let Some(mesh) = node.mesh() {
                for primitive in mesh.primitives() {
                    self.add_primitive(&primitive, &world).with_context(|| {
                        format!(
                            "{}, primitive {} (instanced by {what})",
                            label("mesh", mesh.index(), mesh.name()),
                            primitive.index()
                        )
                    })?;
                }
            }
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev().map(|c| (c, world, Some(i))));
        }
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
            bail!("it has no POSITION attribute");
        };
        let positions = read_positions(&accessor, self.buffers).with_context(|| {
            format!(
                "POSITION {}",
                label("accessor", accessor.index(), accessor.name())
            )
        })?;
        let vertices: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                let what = format!(
                    "indices {}",
                    label("accessor", accessor.index(), accessor.name())
                );
                let indices = read_indices(&accessor, self.buffers).context(what.clone())?;
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
            None => (0..positions.len() as u32).collect(),
        };
        let corners = triangle_corners(primitive.mode(), &vertices)?;
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
