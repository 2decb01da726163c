//! The scene's types: triangles (world space, or a mesh's own space for instances), meshes and
//! their placements, materials with their textures, cameras; and what a scene answers about
//! itself (bounds, the camera to render).

use super::camera::Camera;
use crate::layout::{
    GpuPunctualLight, GpuTexture, GpuTextureRef, GpuVertex, TRIANGLE_FLAT, TRIANGLE_PLAIN,
};
use glam::Vec3;
use std::path::PathBuf;

/// Everything the integrators need from a scene file.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file it came from, for messages.
    pub source: PathBuf,
    /// World-space triangles of every mesh primitive of the default scene, in node traversal
    /// order (depth-first, children in file order).
    pub triangles: Vec<Triangle>,
    /// Indexed by `Triangle::material`: the file's materials in file order, then
    /// [`Material::default_white`] if some primitive has no material.
    pub materials: Vec<Material>,
    /// Meshes that several nodes instance, in object space, stored once (`instances` place
    /// them); every other mesh is baked into `triangles` in world space.
    pub meshes: Vec<Mesh>,
    /// Placements of `meshes` in the world.
    pub instances: Vec<Instance>,
    /// KHR_lights_punctual lights of the default scene, in world space.
    pub punctual: Vec<GpuPunctualLight>,
    /// Shading attributes that `Triangle::vertices` index: world space for `triangles`, object
    /// space for `meshes`.
    pub vertices: Vec<GpuVertex>,
    /// Decoded textures (mip chains) and the materials' references to them.
    pub textures: TextureSet,
    /// The camera renders use: the first of `cameras` unless
    /// [`select_camera`](Scene::select_camera) picked another, or, for a file without cameras,
    /// [`Camera::framing`] of the scene's bounding box.
    pub camera: Camera,
    /// Every camera instance of the default scene (a node with a camera), in node traversal
    /// order.
    pub cameras: Vec<SceneCamera>,
    /// Zero-area triangles dropped while loading.
    pub dropped_degenerate: usize,
    /// Point and line primitives skipped while loading (they have no surface to hit).
    pub skipped_primitives: usize,
    /// What the file holds that the render will not show (textures, unsupported extensions,
    /// dropped geometry), one sentence each, for the user.
    pub notes: Vec<String>,
}

/// A camera instance: a glTF camera on a node, placed by the node's world transform.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneCamera {
    pub camera: Camera,
    /// Its index in the file's `cameras`.
    pub index: usize,
    /// The glTF camera's name and its node's name, where given.
    pub name: Option<String>,
    pub node_name: Option<String>,
    /// For messages, e.g. `cameras[1] ("Ortho") on nodes[4] ("Side")`.
    pub label: String,
}

/// A world-space triangle. Counter-clockwise (seen from the front) = front face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub p: [Vec3; 3],
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Indices into `Scene::vertices` of p0, p1, p2 ([`NO_VERTEX`]: untextured white, flat).
    pub vertices: [u32; 3],
    /// `layout::TRIANGLE_*` bits.
    pub flags: u32,
}

/// A glTF mesh stored once for all the nodes that use it (object space).
#[derive(Clone, Debug)]
pub struct Mesh {
    /// E.g. `meshes[2] ("Tree")`, for messages.
    pub label: String,
    pub triangles: Vec<Triangle>,
}

/// One placement of a [`Mesh`]: its object → world transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    pub mesh: u32,
    pub transform: glam::Mat4,
}

/// A triangle corner without attributes (texture coordinates 0, colour 1, face normal).
pub const NO_VERTEX: u32 = u32::MAX;

impl Triangle {
    /// A triangle without vertex attributes: flat-shaded, untextured.
    pub fn flat(p: [Vec3; 3], material: u32) -> Triangle {
        Triangle {
            p,
            material,
            vertices: [NO_VERTEX; 3],
            flags: TRIANGLE_FLAT | TRIANGLE_PLAIN,
        }
    }

    /// `cross(p1 − p0, p2 − p0)`: points to the front face, length = twice the area.
    pub fn geometric_normal(&self) -> Vec3 {
        (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0])
    }

    pub fn area(&self) -> f32 {
        0.5 * self.geometric_normal().length()
    }
}

/// The textures of a scene as both integrators sample them (`texture.rs`): mip chains of RGBA8
/// texels, one `GpuTexture` per (glTF texture, colour space) used, and one `GpuTextureRef` per
/// material slot that reads a texture.
#[derive(Clone, Debug, Default)]
pub struct TextureSet {
    pub textures: Vec<GpuTexture>,
    pub refs: Vec<GpuTextureRef>,
    /// Shared with the prepared scene, not copied.
    pub texels: std::sync::Arc<Vec<u32>>,
    /// Mean RGBA of each texture's level 0 (linear), for the emitters' power.
    pub means: Vec<[f32; 4]>,
}

/// How a material's alpha is read (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AlphaMode {
    #[default]
    Opaque,
    /// Present where alpha ≥ `Material::alpha_cutoff`.
    Mask,
    /// Present with probability alpha (stochastic transparency).
    Blend,
}

/// A material's texture slots: indices into `TextureSet::refs`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaterialTextures {
    pub base_color: Option<u32>,
    pub metallic_roughness: Option<u32>,
    pub emissive: Option<u32>,
    pub normal: Option<u32>,
    pub transmission: Option<u32>,
    /// KHR_materials_specular's specularTexture (A) and specularColorTexture (RGB, sRGB).
    pub specular: Option<u32>,
    pub specular_color: Option<u32>,
    /// KHR_materials_clearcoat's clearcoatTexture (R), clearcoatRoughnessTexture (G) and
    /// clearcoatNormalTexture.
    pub clearcoat: Option<u32>,
    pub clearcoat_roughness: Option<u32>,
    pub clearcoat_normal: Option<u32>,
    /// KHR_materials_sheen's sheenColorTexture (RGB, sRGB) and sheenRoughnessTexture (A).
    pub sheen_color: Option<u32>,
    pub sheen_roughness: Option<u32>,
    /// KHR_materials_anisotropy's anisotropyTexture (RG direction, B strength).
    pub anisotropy: Option<u32>,
    /// KHR_materials_iridescence's iridescenceTexture (R) and iridescenceThicknessTexture (G).
    pub iridescence: Option<u32>,
    pub iridescence_thickness: Option<u32>,
    /// KHR_materials_diffuse_transmission's diffuseTransmissionTexture (A) and
    /// diffuseTransmissionColorTexture (RGB, sRGB).
    pub diffuse_transmission: Option<u32>,
    pub diffuse_transmission_color: Option<u32>,
}

/// A glTF metallic-roughness material with emission: `pbrMetallicRoughness` factors,
/// `KHR_materials_ior`, `KHR_materials_transmission`, `KHR_materials_specular`,
/// `KHR_materials_unlit`, `KHR_materials_clearcoat`, `KHR_materials_sheen`,
/// `KHR_materials_anisotropy`, `KHR_materials_iridescence`, `KHR_materials_volume`,
/// `KHR_materials_diffuse_transmission` and `emissiveFactor × KHR_materials_emissive_strength`, alpha, and the
/// textures that modulate them.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGB base colour, each component in [0, 1].
    pub base_color: Vec3,
    /// metallicFactor, roughnessFactor in [0, 1] (GGX α = roughness²).
    pub metallic: f32,
    pub roughness: f32,
    /// Index of refraction (1.5 unless KHR_materials_ior says otherwise).
    pub ior: f32,
    /// KHR_materials_transmission's transmissionFactor in [0, 1].
    pub transmission: f32,
    /// KHR_materials_specular's specularFactor in [0, 1] (0: no dielectric specular lobe).
    pub specular: f32,
    /// KHR_materials_specular's specularColorFactor: linear RGB, non-negative, may exceed 1
    /// (F0 = min(((ior − 1)/(ior + 1))² · specularColor, 1) · specular).
    pub specular_color: Vec3,
    /// KHR_materials_unlit: the surface emits its base colour × texture × vertex colour and
    /// scatters nothing; `emission` and `textures.emissive` then hold the base colour's.
    pub unlit: bool,
    /// KHR_materials_clearcoat: clearcoatFactor and clearcoatRoughnessFactor in [0, 1] (0: no
    /// coat), clearcoatNormalTexture.scale.
    pub clearcoat: f32,
    pub clearcoat_roughness: f32,
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_sheen: sheenColorFactor (linear RGB in [0, 1]; 0: no sheen) and
    /// sheenRoughnessFactor in [0, 1].
    pub sheen_color: Vec3,
    pub sheen_roughness: f32,
    /// KHR_materials_anisotropy: anisotropyStrength in [0, 1] (0: isotropic) and
    /// anisotropyRotation (radians, counter-clockwise from the tangent).
    pub anisotropy: f32,
    pub anisotropy_rotation: f32,
    /// KHR_materials_iridescence: iridescenceFactor in [0, 1] (0: no film), iridescenceIor
    /// (≥ 1) and iridescenceThicknessMinimum/Maximum (nm, non-negative).
    pub iridescence: f32,
    pub iridescence_ior: f32,
    pub iridescence_thickness_min: f32,
    pub iridescence_thickness_max: f32,
    /// KHR_materials_volume: thicknessFactor (≥ 0; 0: thin-walled), attenuationColor (linear
    /// RGB in [0, 1]) and attenuationDistance (> 0; infinite: no attenuation).
    pub thickness: f32,
    pub attenuation_color: Vec3,
    pub attenuation_distance: f32,
    /// KHR_materials_diffuse_transmission: diffuseTransmissionFactor in [0, 1] (0: none) and
    /// diffuseTransmissionColorFactor (linear RGB in [0, 1]).
    pub diffuse_transmission: f32,
    pub diffuse_transmission_color: Vec3,
    /// KHR_materials_dispersion: 20 / Abbe number (≥ 0; 0: none).
    pub dispersion: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻², non-negative.
    pub emission: Vec3,
    /// Emits from both faces (the BSDF shades both sides either way).
    pub double_sided: bool,
    /// baseColorFactor's alpha and how alpha is used.
    pub alpha: f32,
    pub alpha_mode: AlphaMode,
    pub alpha_cutoff: f32,
    /// normalTexture.scale.
    pub normal_scale: f32,
    pub textures: MaterialTextures,
}

impl Material {
    /// The material of primitives that name none: glTF's default material, every property at
    /// its default (base colour 1, metallic 1, roughness 1: a rough white metal), no emission.
    pub fn default_white() -> Material {
        Material {
            name: "default".to_owned(),
            base_color: Vec3::ONE,
            metallic: 1.0,
            roughness: 1.0,
            ior: 1.5,
            transmission: 0.0,
            specular: 1.0,
            specular_color: Vec3::ONE,
            unlit: false,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            clearcoat_normal_scale: 1.0,
            sheen_color: Vec3::ZERO,
            sheen_roughness: 0.0,
            anisotropy: 0.0,
            anisotropy_rotation: 0.0,
            iridescence: 0.0,
            iridescence_ior: 1.3,
            iridescence_thickness_min: 100.0,
            iridescence_thickness_max: 400.0,
            thickness: 0.0,
            attenuation_color: Vec3::ONE,
            attenuation_distance: f32::INFINITY,
            diffuse_transmission: 0.0,
            diffuse_transmission_color: Vec3::ONE,
            dispersion: 0.0,
            emission: Vec3::ZERO,
            double_sided: false,
            alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            normal_scale: 1.0,
            textures: MaterialTextures::default(),
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

impl Scene {
    /// Makes the camera instance `which` the one renders use (`--camera`): a number N picks the
    /// first instance of glTF camera `cameras[N]`, anything else the first instance whose
    /// camera or node has that name. An unknown camera is an error that lists the file's.
    pub fn select_camera(&mut self, which: &str) -> anyhow::Result<()> {
        let by_index = which.trim().parse::<usize>().ok();
        let found = self.cameras.iter().find(|c| match by_index {
            Some(n) => c.index == n,
            None => c.name.as_deref() == Some(which) || c.node_name.as_deref() == Some(which),
        });
        match found {
            Some(c) => {
                self.camera = c.camera;
                Ok(())
            }
            None if self.cameras.is_empty() => anyhow::bail!(
                "--camera {which}: {} has no cameras (it is rendered with a camera that frames \
                 the scene)",
                self.source.display()
            ),
            None => anyhow::bail!(
                "--camera {which}: {} has no camera of that index or name; its cameras are: {}",
                self.source.display(),
                self.cameras
                    .iter()
                    .map(|c| c.label.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }

    /// Axis-aligned bounds (min, max) of all triangles, instances included; (0, 0) for a
    /// scene without triangles.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        scene_bounds(&self.triangles, &self.meshes, &self.instances)
    }

    /// Triangles as rendered: the baked ones plus every instance's.
    pub fn rendered_triangles(&self) -> u64 {
        self.triangles.len() as u64
            + self
                .instances
                .iter()
                .map(|i| self.meshes[i.mesh as usize].triangles.len() as u64)
                .sum::<u64>()
    }
}

pub(crate) fn bounds_of(triangles: &[Triangle]) -> (Vec3, Vec3) {
    if triangles.is_empty() {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    // On every core: min and max are exact, so any grouping gives the same bounds.
    use rayon::prelude::*;
    let empty = || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    triangles
        .par_iter()
        .fold(empty, |(lo, hi), t| {
            (
                lo.min(t.p[0]).min(t.p[1]).min(t.p[2]),
                hi.max(t.p[0]).max(t.p[1]).max(t.p[2]),
            )
        })
        .reduce(empty, |(a, b), (c, d)| (a.min(c), b.max(d)))
}

/// Bounds of the baked triangles and of every instance's transformed mesh bounds.
pub(crate) fn scene_bounds(
    triangles: &[Triangle],
    meshes: &[Mesh],
    instances: &[Instance],
) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = if triangles.is_empty() {
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY))
    } else {
        bounds_of(triangles)
    };
    let mesh_bounds: Vec<(Vec3, Vec3)> = meshes.iter().map(|m| bounds_of(&m.triangles)).collect();
    for instance in instances {
        let (a, b) = mesh_bounds[instance.mesh as usize];
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { a.x } else { b.x },
                if k & 2 == 0 { a.y } else { b.y },
                if k & 4 == 0 { a.z } else { b.z },
            );
            let w = instance.transform.transform_point3(c);
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    if lo.x > hi.x {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (lo, hi)
    }
}
