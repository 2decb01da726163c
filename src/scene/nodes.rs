//! The node walk: every node of the default scene with its world transform, meshes turned into
//! triangles (attributes read and repaired, tangents made), cameras and punctual lights placed,
//! and meshes used more than once kept as instances where that saves memory.

use super::accessors::{
    element_bytes, read_attribute, read_indices, read_positions, triangle_corners,
};
use super::camera::{Camera, Projection};
use super::draco::{self, DracoPrimitive};
use super::json::{json_path, label};
use super::limits::Budget;
use super::material::MaterialNeeds;
use super::model::{AlphaMode, Instance, Material, Mesh, SceneCamera, Triangle, NO_VERTEX};
use super::morph;
use super::skin;
use super::tangents::mikktspace_tangents;
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

/// A primitive's vertex attributes, in its local space, one per glTF vertex.
pub(super) struct Attributes {
    pub(super) normals: Option<Vec<Vec3>>,
    /// Whether each NORMAL is finite and non-zero.
    pub(super) normal_valid: Vec<bool>,
    pub(super) tangents: Option<Vec<Vec4>>,
    pub(super) uv: [Vec<Vec2>; 2],
    pub(super) color: Vec<Vec4>,
    /// None of NORMAL, TANGENT, TEXCOORD_0/1 or COLOR_0 is present.
    pub(super) plain: bool,
}

/// Defects repaired while loading, counted for one note each.
#[derive(Default)]
pub(super) struct Repairs {
    /// Vertices whose NORMAL is not finite or zero (their triangles are shaded flat).
    pub(super) normals: usize,
    /// TEXCOORD, COLOR or TANGENT components that were not finite (set to their default).
    pub(super) attributes: usize,
    /// Primitives whose MikkTSpace tangents could not be generated (normal map ignored there).
    pub(super) tangents: usize,
    /// Skinned vertices left unskinned: their weights were not finite or all zero.
    pub(super) skin_weights: usize,
}

impl Repairs {
    pub(super) fn notes(&self) -> Vec<String> {
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
        if self.skin_weights > 0 {
            notes.push(format!(
                "skin weights not finite or all zero: those vertices are left unskinned (vertices: {})",
                self.skin_weights
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

pub(super) struct Builder<'a> {
    pub(super) document: &'a Document,
    pub(super) buffers: &'a [Vec<u8>],
    pub(super) budget: &'a Budget,
    pub(super) triangles: Vec<Triangle>,
    pub(super) vertices: Vec<GpuVertex>,
    pub(super) materials: Vec<Material>,
    pub(super) needs: Vec<MaterialNeeds>,
    pub(super) repairs: Repairs,
    pub(super) default_material: Option<u32>,
    pub(super) cameras: Vec<SceneCamera>,
    pub(super) dropped_degenerate: usize,
    pub(super) skipped_primitives: usize,
    /// LoadOptions::instancing.
    pub(super) instancing: bool,
    /// How many nodes of the document use each mesh.
    pub(super) mesh_uses: Vec<usize>,
    /// Meshes stored once for their instances, and which glTF mesh each is.
    pub(super) meshes: Vec<Mesh>,
    pub(super) mesh_ids: std::collections::HashMap<usize, u32>,
    pub(super) instances: Vec<Instance>,
    pub(super) punctual: Vec<GpuPunctualLight>,
    /// Every node's local transform and morph weights at the moment being loaded
    /// (`animation.rs`; the file's own values at the static pose).
    pub(super) pose: &'a super::animation::Pose,
    /// Morph targets' TEXCOORD_n and COLOR_0 accessors (`morph.rs`).
    pub(super) extra_targets: &'a morph::ExtraTargets,
}

/// Triangles a mesh must save by being instanced rather than baked (placements − 1 times
/// its triangles) for the loader to instance it.
pub const INSTANCING_MIN_SAVED: u64 = 4096;

/// The triangles a mesh's primitives declare (index or vertex counts), before any is read.
pub(super) fn mesh_triangle_estimate(mesh: &gltf::Mesh) -> u64 {
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
pub(super) fn punctual_light(
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

/// Where a primitive's error happened: "meshes[3].primitives[0] (mesh "Body", instanced by
/// nodes[5])".
fn primitive_label(mesh: &gltf::Mesh, primitive: &Primitive, what: &str) -> String {
    format!(
        "{}.primitives[{}] ({}instanced by {what})",
        json_path("mesh", mesh.index()),
        primitive.index(),
        mesh.name()
            .map_or_else(String::new, |n| format!("mesh {n:?}, "))
    )
}

/// How many nodes use each mesh.
pub(super) fn mesh_uses(document: &Document) -> Vec<usize> {
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
    pub(super) fn walk(&mut self, document: &Document, scene: &gltf::Scene) -> Result<()> {
        let node_count = document.nodes().len();
        let node_label =
            |i: usize| label("node", i, document.nodes().nth(i).and_then(|n| n.name()));
        let mut parent: Vec<Option<usize>> = vec![None; node_count];
        let mut visited = vec![false; node_count];
        let mut stack: Vec<(gltf::Node, Mat4, Option<usize>)> =
            scene.nodes().map(|n| (n, Mat4::IDENTITY, None)).collect();
        stack.reverse();
        // Skins' joints may lie anywhere in the node forest: every node's world transform.
        let worlds = if document.skins().len() > 0 {
            skin::world_transforms(document, &self.pose.locals)
        } else {
            Vec::new()
        };

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

            let local = self.pose.locals[i];
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
                // A skinned mesh: its joints place it, not its node (glTF 2.0 §3.7.3).
                let joints = match node.skin() {
                    Some(s) if mesh.primitives().any(|p| skin::is_skinned(&p)) => Some(
                        skin::joint_matrices(&s, &worlds, self.buffers, self.budget)
                            .with_context(|| format!("{what}.skin"))?,
                    ),
                    _ => None,
                };
                // (The node's children keep its world transform.)
                let mesh_world = if joints.is_some() {
                    Mat4::IDENTITY
                } else {
                    world
                };
                let gpu_instancing = node
                    .extension_value("EXT_mesh_gpu_instancing")
                    .map(|value| self.gpu_instances(document, value, &mesh_world, &what))
                    .transpose()?;
                let transforms = gpu_instancing.clone().unwrap_or_else(|| vec![mesh_world]);
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
                // A node's own morph weights give it geometry of its own: baked, not shared.
                let node_weights = self.pose.weights[i].as_deref();
                let own_weights = node_weights.is_some_and(|w| Some(w) != mesh.weights())
                    && mesh.primitives().any(|p| p.morph_targets().len() > 0);
                let shared = self.instancing
                    && placements > 1
                    && saved >= INSTANCING_MIN_SAVED
                    && !own_weights
                    && joints.is_none();
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
                let node_path = json_path("node", i);
                let mesh_path = json_path("mesh", mesh.index());
                let morph_weights = match (node_weights, mesh.weights()) {
                    (Some(w), _) => Some((w, node_path.as_str())),
                    (None, Some(w)) => Some((w, mesh_path.as_str())),
                    (None, None) => None,
                };
                for world in &transforms {
                    for primitive in mesh.primitives() {
                        self.add_primitive(
                            mesh.index(),
                            &primitive,
                            world,
                            morph_weights,
                            joints.as_deref(),
                        )
                        .with_context(|| primitive_label(&mesh, &primitive, &what))?;
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
    pub(super) fn instanced_mesh(&mut self, mesh: &gltf::Mesh, what: &str) -> Result<u32> {
        if let Some(&id) = self.mesh_ids.get(&mesh.index()) {
            return Ok(id);
        }
        let baked = std::mem::take(&mut self.triangles);
        let mut result = Ok(());
        for primitive in mesh.primitives() {
            let mesh_path = json_path("mesh", mesh.index());
            let morph_weights = mesh.weights().map(|w| (w, mesh_path.as_str()));
            result = self
                .add_primitive(
                    mesh.index(),
                    &primitive,
                    &Mat4::IDENTITY,
                    morph_weights,
                    None,
                )
                .with_context(|| primitive_label(&mesh, &primitive, what));
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
    pub(super) fn gpu_instances(
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
            let values = read_attribute(
                &accessor,
                self.buffers,
                None,
                self.budget,
                &[dims],
                normalized,
                &[],
            )
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
    pub(super) fn add_camera(
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
    pub(super) fn reserve_triangles(&mut self, more: usize) -> Result<()> {
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

    /// Bakes (or, with `world` the identity, stores for instancing) one primitive, its morph
    /// targets weighted by `morph_weights` (and the JSON path they come from).
    pub(super) fn add_primitive(
        &mut self,
        mesh: usize,
        primitive: &Primitive,
        world: &Mat4,
        morph_weights: Option<(&[f32], &str)>,
        joints: Option<&[Mat4]>,
    ) -> Result<()> {
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
        // KHR_draco_mesh_compression: the accessors' elements come from the stream.
        let draco = draco::decode(self.document, primitive, self.buffers, self.budget)?;
        let mut positions = read_positions(
            &accessor,
            self.buffers,
            draco.elements(&accessor),
            self.budget,
        )
        .context(position_what.clone())?;
        let weights = morph::weights(primitive, morph_weights)?;
        if let Some(deltas) = morph::weighted_deltas(
            primitive,
            &weights,
            Semantic::Positions,
            positions.len(),
            self.buffers,
            self.budget,
        )? {
            for (p, d) in positions.iter_mut().zip(&deltas) {
                *p += Vec3::new(d[0], d[1], d[2]);
            }
            self.budget.release(morph::sum_bytes(deltas.len()));
        }
        let vertices: Vec<u32> = match primitive.indices() {
            Some(accessor) => {
                let what = format!(
                    "indices = {}",
                    label("accessor", accessor.index(), accessor.name())
                );
                let indices = read_indices(
                    &accessor,
                    self.buffers,
                    draco.elements(&accessor),
                    self.budget,
                )
                .context(what.clone())?;
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
        let mut attributes =
            self.read_attributes((mesh, primitive), &draco, &weights, positions.len(), &needs)?;
        // Skinning, after the morph targets (glTF 2.0 §3.7.3), into world space.
        if let Some(joints) = joints.filter(|_| skin::is_skinned(primitive)) {
            let (matrices, unskinned) = skin::vertex_matrices(
                primitive,
                &draco,
                joints,
                positions.len(),
                self.buffers,
                self.budget,
            )?;
            self.repairs.skin_weights += unskinned;
            for (v, m) in matrices.iter().enumerate() {
                skin::skin_vertex(
                    m,
                    &mut positions[v],
                    attributes.normals.as_mut().map(|n| &mut n[v]),
                    attributes.tangents.as_mut().map(|t| &mut t[v]),
                );
            }
            self.budget
                .release(std::mem::size_of_val(matrices.as_slice()) as u64);
        }
        draco.release(self.budget);

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
    pub(super) fn read_attributes(
        &mut self,
        (mesh, primitive): (usize, &Primitive),
        draco: &DracoPrimitive,
        morph_weights: &[f32],
        count: usize,
        needs: &MaterialNeeds,
    ) -> Result<Attributes> {
        let read = |semantic: Semantic,
                    dims: &[Dimensions],
                    normalized: &[DataType],
                    integers: &[DataType]|
         -> Result<Option<Vec<[f32; 4]>>> {
            let Some(accessor) = primitive.get(&semantic) else {
                return Ok(None);
            };
            let what = format!(
                "attributes.{} = {}",
                semantic.to_string(),
                label("accessor", accessor.index(), accessor.name())
            );
            let values = read_attribute(
                &accessor,
                self.buffers,
                draco.elements(&accessor),
                self.budget,
                dims,
                normalized,
                integers,
            )
            .context(what.clone())?;
            if values.len() != count {
                bail!(
                    "{what}: {} elements, but POSITION has {count}",
                    values.len()
                );
            }
            Ok(Some(values))
        };
        // Core glTF, and what KHR_mesh_quantization adds: normalized BYTE/SHORT normals and
        // tangents, (normalized) BYTE/SHORT and plain integer texture coordinates.
        let signed = [DataType::I8, DataType::I16];
        let integers = [DataType::I8, DataType::U8, DataType::I16, DataType::U16];
        let mut normals = read(Semantic::Normals, &[Dimensions::Vec3], &signed, &[])?;
        let mut tangents = read(Semantic::Tangents, &[Dimensions::Vec4], &signed, &[])?;
        // Morph targets move normals and the tangents' xyz before they are normalised.
        for (semantic, values) in [
            (Semantic::Normals, &mut normals),
            (Semantic::Tangents, &mut tangents),
        ] {
            let Some(values) = values else { continue };
            if let Some(deltas) = morph::weighted_deltas(
                primitive,
                morph_weights,
                semantic,
                count,
                self.buffers,
                self.budget,
            )? {
                for (v, d) in values.iter_mut().zip(&deltas) {
                    for c in 0..3 {
                        v[c] += d[c];
                    }
                }
                self.budget.release(morph::sum_bytes(deltas.len()));
            }
        }
        let uv_types = [DataType::U8, DataType::U16];
        let uv0 = read(
            Semantic::TexCoords(0),
            &[Dimensions::Vec2],
            &integers,
            &integers,
        )?;
        let uv1 = read(
            Semantic::TexCoords(1),
            &[Dimensions::Vec2],
            &integers,
            &integers,
        )?;
        let mut uv0 = uv0;
        let mut uv1 = uv1;
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
            &[],
        )?;
        let mut color = color;
        // Morph targets move texture coordinates and colours too (before they are checked).
        for (name, values) in [
            ("TEXCOORD_0", &mut uv0),
            ("TEXCOORD_1", &mut uv1),
            ("COLOR_0", &mut color),
        ] {
            let Some(values) = values else { continue };
            if let Some(deltas) = morph::weighted_extra_deltas(
                self.document,
                self.extra_targets,
                (mesh, primitive.index()),
                morph_weights,
                name,
                count,
                self.buffers,
                self.budget,
            )? {
                for (v, d) in values.iter_mut().zip(&deltas) {
                    for c in 0..4 {
                        v[c] += d[c];
                    }
                }
                self.budget.release(morph::sum_bytes(count));
            }
        }
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
    pub(super) fn material_index(&mut self, index: Option<usize>) -> u32 {
        if let Some(i) = index {
            return i as u32;
        }
        *self.default_material.get_or_insert_with(|| {
            self.materials.push(Material::default_white());
            (self.materials.len() - 1) as u32
        })
    }
}
