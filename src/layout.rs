//! (Over 900 lines: every GPU-visible struct and constant in one file, as in layout.glsl, so the checked pair reads side by side.)
//! Every struct the GPU reads or writes, as `#[repr(C)]` twins of `shaders/inc/layout.glsl`.
//!
//! The GLSL side uses std430 (storage buffers) and std140 (the frame uniform); each struct here is
//! laid out so that `repr(C)` gives the same offsets: a `vec3` is always followed by a 4-byte
//! scalar. `tests/twins/shaders.rs` reflects the compiled SPIR-V with naga and checks every offset and
//! size listed in [`STRUCT_LAYOUTS`].

use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};

/// Threads per workgroup of every 1-D kernel (`WORKGROUP_SIZE` in layout.glsl).
pub const WORKGROUP_SIZE: u32 = 64;

/// Random-number dimensions, a pure function of (seed, pixel, sample, dimension): see
/// `sampling::rng_uniform4`. Dimensions come in blocks of four; each bounce uses two blocks.
pub mod dim {
    /// Block 0: pixel jitter (x, y), point on the lens (x, y).
    pub const CAMERA_BLOCK: u32 = 0;
    /// Blocks per bounce: `bounce_block(d)` = light pick, light u, light v, roulette;
    /// `bounce_block(d) + 1` = BSDF u, BSDF v, two spare.
    pub const BLOCKS_PER_BOUNCE: u32 = 2;
    pub const fn bounce_block(depth: u32) -> u32 {
        1 + depth * BLOCKS_PER_BOUNCE
    }
    /// Light subpaths (`--integrator light|bdpt`) draw from blocks of their own, far above any
    /// camera bounce's: `light_block(0)` = emitter pick, point u, point v, side;
    /// `light_block(0) + 1` = emission direction u, v; `light_block(i)` for the i-th scattering
    /// vertex = BSDF u, BSDF v, lobe, roulette.
    pub const LIGHT_BLOCK_BASE: u32 = 1 << 24;
    /// The sample's wavelength (`spectrum::sample_wavelength` of its x), shared by both
    /// subpaths of a BDPT sample: the block just below the light subpaths'.
    pub const WAVELENGTH_BLOCK: u32 = LIGHT_BLOCK_BASE - 1;
    pub const fn light_block(vertex: u32) -> u32 {
        LIGHT_BLOCK_BASE + 2 * vertex
    }
}

/// A node of the flattened BVH, depth-first: an interior node's left child is the next node.
/// Total: 32 bytes, 16-byte aligned like the builder's primitive references, so the build
/// writes its nodes into their memory (`bvh::build`) instead of faulting in fresh pages.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub bounds_min: [f32; 3], // 12 bytes
    /// Leaf: index of the first triangle. Interior: index of the right child.
    pub offset: u32, // 4 bytes
    pub bounds_max: [f32; 3], // 12 bytes
    /// Leaf: number of triangles (> 0). Interior: 0.
    pub count: u32, // 4 bytes
}

impl BvhNode {
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
    /// Interior nodes only: the right child's index (the left child is `self + 1`).
    pub fn right_child(&self) -> u32 {
        self.offset
    }
    /// Leaf nodes only: the first triangle of the leaf.
    pub fn first_triangle(&self) -> u32 {
        self.offset
    }
}

/// A world-space triangle as the intersector wants it (Möller–Trumbore: p0 and two edges), in
/// BVH order. The geometric normal `cross(e1, e2)` points to the front face.
/// Total: 48 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub p0: [f32; 3],  // 12 bytes
    pub material: u32, // 4 bytes
    pub e1: [f32; 3],  // 12 bytes: p1 − p0
    /// Probability of choosing this triangle when sampling emitters (0 if it does not emit).
    pub light_pmf: f32, // 4 bytes
    pub e2: [f32; 3],  // 12 bytes: p2 − p0
    pub area: f32,     // 4 bytes
}

/// Material flags (`Material::flags`).
pub const MATERIAL_DOUBLE_SIDED: u32 = 1;
/// alphaMode MASK: the surface exists where base-colour alpha ≥ `alpha_cutoff`.
pub const MATERIAL_ALPHA_MASK: u32 = 2;
/// alphaMode BLEND: the surface exists with probability alpha (stochastic transparency).
pub const MATERIAL_ALPHA_BLEND: u32 = 4;
/// Some texture slot is set: hits need the texture level of detail (set when the scene is
/// prepared, so shading does not test five slots per hit).
pub const MATERIAL_TEXTURED: u32 = 8;
/// KHR_materials_unlit: the surface emits its base colour (`surface::surface_emission`) and
/// scatters nothing (`bsdf`).
pub const MATERIAL_UNLIT: u32 = 16;
/// Set only in the GPU's material image (`gpu::bindings::SceneImage::Materials`): the material
/// differs from `GpuMaterial::default()` past its first five texels (the extensions' parameters,
/// bytes 80 to 256). Other materials are read as five texels, the rest being the defaults
/// (`scene_arrays.glsl`, `material_image_at`).
pub const MATERIAL_EXTENDED: u32 = 32;
/// Energy compensation of the GGX lobes (`bsdf::energy`): multiple scattering and the albedo
/// coupling of the layers below the specular one. Set on every scene material unless
/// `--energy-compensation off` (`PreparedScene::set_energy_compensation`); a bare
/// `GpuMaterial` leaves it clear, the specification's single-scattering model.
pub const MATERIAL_ENERGY_COMPENSATION: u32 = 64;
/// Bytes of a `GpuMaterial` every read of the material image fetches.
pub const MATERIAL_CORE_BYTES: usize = 80;

impl GpuMaterial {
    /// The record of the GPU's material image: `self` with `MATERIAL_EXTENDED` set where its
    /// extension parameters are not the defaults.
    pub fn image_record(&self) -> GpuMaterial {
        let plain = GpuMaterial::default();
        let tail = |m: &GpuMaterial| bytemuck::bytes_of(m)[MATERIAL_CORE_BYTES..].to_vec();
        let mut record = *self;
        if tail(self) != tail(&plain) {
            record.flags |= MATERIAL_EXTENDED;
        }
        record
    }
}

/// No texture in a `GpuMaterial::*_texture` slot.
pub const NO_TEXTURE: u32 = u32::MAX;

/// A glTF metallic-roughness material (`bsdf` reads it) and its emitted radiance, with the
/// texture references that modulate its factors at each surface point (`surface`).
/// Total: 256 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    pub base_color: [f32; 3], // 12 bytes: linear RGB, baseColorFactor
    pub flags: u32,           // 4 bytes: MATERIAL_* bits
    pub emission: [f32; 3],   // 12 bytes: radiance, W·sr⁻¹·m⁻²
    pub metallic: f32,        // 4 bytes: metallicFactor
    pub roughness: f32,       // 4 bytes: roughnessFactor (GGX α = roughness²)
    pub ior: f32,             // 4 bytes: KHR_materials_ior (1.5 by default)
    pub transmission: f32,    // 4 bytes: KHR_materials_transmission's factor
    pub specular: f32,        // 4 bytes: KHR_materials_specular's specularFactor (1 by default)
    pub alpha: f32,           // 4 bytes: baseColorFactor's alpha
    pub alpha_cutoff: f32,    // 4 bytes: alphaCutoff (MATERIAL_ALPHA_MASK)
    pub normal_scale: f32,    // 4 bytes: normalTexture.scale
    /// Indices into the texture references (`GpuTextureRef`), or `NO_TEXTURE`.
    pub base_color_texture: u32, // 4 bytes: sRGB; RGB × base_color, A × alpha
    pub metallic_roughness_texture: u32, // 4 bytes: B × metallic, G × roughness
    pub emissive_texture: u32, // 4 bytes: sRGB; RGB × emission
    pub normal_texture: u32,  // 4 bytes: tangent-space normal
    pub transmission_texture: u32, // 4 bytes: R × transmission
    /// KHR_materials_specular's specularColorFactor (linear RGB, may exceed 1).
    pub specular_color: [f32; 3], // 12 bytes
    pub specular_texture: u32, // 4 bytes: A × specular
    pub specular_color_texture: u32, // 4 bytes: sRGB; RGB × specular_color
    /// KHR_materials_clearcoat: clearcoatFactor, clearcoatRoughnessFactor (α = roughness²).
    pub clearcoat: f32, // 4 bytes
    pub clearcoat_roughness: f32, // 4 bytes
    pub clearcoat_texture: u32, // 4 bytes: R × clearcoat
    pub clearcoat_roughness_texture: u32, // 4 bytes: G × clearcoat_roughness
    pub clearcoat_normal_texture: u32, // 4 bytes: tangent-space normal of the coat
    pub clearcoat_normal_scale: f32, // 4 bytes: clearcoatNormalTexture.scale
    /// KHR_materials_sheen's sheenRoughnessFactor.
    pub sheen_roughness: f32, // 4 bytes
    /// The coat's world-space shading normal at a hit (`surface::surface_material` writes it);
    /// zero: the BSDF's shading normal. Always zero in the scene's material table.
    pub clearcoat_normal: [f32; 3], // 12 bytes
    pub sheen_color_texture: u32, // 4 bytes: sRGB; RGB × sheen_color
    /// KHR_materials_sheen's sheenColorFactor (linear RGB; 0: no sheen).
    pub sheen_color: [f32; 3], // 12 bytes
    pub sheen_roughness_texture: u32, // 4 bytes: A × sheen_roughness
    /// KHR_materials_anisotropy: the world-space direction of α_t at a hit
    /// (`surface::surface_material` writes it from the tangent frame, the texture's RG and the
    /// rotation); zero in the scene's material table and where the tangent frame is degenerate.
    pub anisotropy_direction: [f32; 3], // 12 bytes
    /// anisotropyStrength (× the texture's B at a hit; 0: isotropic).
    pub anisotropy: f32, // 4 bytes
    /// anisotropyRotation (radians, counter-clockwise from the tangent).
    pub anisotropy_rotation: f32, // 4 bytes
    pub anisotropy_texture: u32, // 4 bytes: RG direction, B × anisotropy
    /// KHR_materials_iridescence: iridescenceFactor (0: no film) and iridescenceIor.
    pub iridescence: f32, // 4 bytes
    pub iridescence_ior: f32, // 4 bytes
    /// iridescenceThicknessMinimum and the film's thickness (nm): iridescenceThicknessMaximum
    /// in the scene's table, mix(minimum, maximum, texture G) at a hit with a thickness texture.
    pub iridescence_thickness_min: f32, // 4 bytes
    pub iridescence_thickness: f32, // 4 bytes
    pub iridescence_texture: u32, // 4 bytes: R × iridescence
    pub iridescence_thickness_texture: u32, // 4 bytes: G
    /// KHR_materials_volume: the attenuation coefficient σ = −ln(attenuationColor) /
    /// attenuationDistance (per metre, per channel) of the medium behind the back faces; 0 for
    /// no volume (no extension, thicknessFactor 0: thin-walled, or an infinite distance).
    pub attenuation: [f32; 3], // 12 bytes
    /// thicknessFactor: 0 makes a transmissive surface thin-walled (light passes without bending
    /// and enters no medium), > 0 the boundary of a refracting volume; its value does not
    /// matter to a path tracer, which measures the distance through the mesh itself.
    pub thickness: f32, // 4 bytes
    /// KHR_materials_diffuse_transmission: diffuseTransmissionColorFactor (linear RGB) and
    /// diffuseTransmissionFactor (0: none).
    pub diffuse_transmission_color: [f32; 3], // 12 bytes
    pub diffuse_transmission: f32, // 4 bytes
    pub diffuse_transmission_texture: u32, // 4 bytes: A × diffuse_transmission
    pub diffuse_transmission_color_texture: u32, // 4 bytes: sRGB; RGB × the colour
    /// KHR_materials_dispersion: 20 / Abbe number (0: none; `spectrum::dispersive_ior`).
    pub dispersion: f32, // 4 bytes
    pub pad1: u32,            // 4 bytes
}

impl Default for GpuMaterial {
    /// glTF's default material (base colour 1, metallic 1, roughness 1), untextured.
    fn default() -> Self {
        GpuMaterial {
            base_color: [1.0; 3],
            flags: 0,
            emission: [0.0; 3],
            metallic: 1.0,
            roughness: 1.0,
            ior: 1.5,
            transmission: 0.0,
            specular: 1.0,
            alpha: 1.0,
            alpha_cutoff: 0.5,
            normal_scale: 1.0,
            base_color_texture: NO_TEXTURE,
            metallic_roughness_texture: NO_TEXTURE,
            emissive_texture: NO_TEXTURE,
            normal_texture: NO_TEXTURE,
            transmission_texture: NO_TEXTURE,
            specular_color: [1.0; 3],
            specular_texture: NO_TEXTURE,
            specular_color_texture: NO_TEXTURE,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            clearcoat_texture: NO_TEXTURE,
            clearcoat_roughness_texture: NO_TEXTURE,
            clearcoat_normal_texture: NO_TEXTURE,
            clearcoat_normal_scale: 1.0,
            sheen_roughness: 0.0,
            clearcoat_normal: [0.0; 3],
            sheen_color_texture: NO_TEXTURE,
            sheen_color: [0.0; 3],
            sheen_roughness_texture: NO_TEXTURE,
            anisotropy_direction: [0.0; 3],
            anisotropy: 0.0,
            anisotropy_rotation: 0.0,
            anisotropy_texture: NO_TEXTURE,
            iridescence: 0.0,
            iridescence_ior: 1.3,
            iridescence_thickness_min: 100.0,
            iridescence_thickness: 400.0,
            iridescence_texture: NO_TEXTURE,
            iridescence_thickness_texture: NO_TEXTURE,
            attenuation: [0.0; 3],
            thickness: 0.0,
            diffuse_transmission_color: [1.0; 3],
            diffuse_transmission: 0.0,
            diffuse_transmission_texture: NO_TEXTURE,
            diffuse_transmission_color_texture: NO_TEXTURE,
            dispersion: 0.0,
            pad1: 0,
        }
    }
}

/// Shading attributes of one vertex, in world space. Total: 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVertex {
    /// xyz: unit tangent; w: ±1, the bitangent is w · cross(normal, tangent) (glTF TANGENT).
    pub tangent: [f32; 4], // 16 bytes
    pub normal: [f32; 3], // 12 bytes: unit shading normal (NORMAL)
    pub pad: u32,         // 4 bytes
    pub uv: [f32; 4],     // 16 bytes: TEXCOORD_0 (xy), TEXCOORD_1 (zw)
    pub color: [f32; 4],  // 16 bytes: COLOR_0 (RGBA, 1 when absent)
}

/// `Triangle::flags` and `triangle_vertices[i].w` bit: the triangle has no vertex normals
/// (shade with its face normal).
pub const TRIANGLE_FLAT: u32 = 1;
/// `Triangle::flags` bit: the triangle's material is alpha-tested (MASK or BLEND).
pub const TRIANGLE_ALPHA: u32 = 2;
/// `Triangle::flags` and `triangle_vertices[i].w` bit: the triangle has no vertex attributes at
/// all (flat, texture coordinates 0, colour 1): shading reads no vertex.
pub const TRIANGLE_PLAIN: u32 = 4;

/// `GpuTriangle::material` holds the material index in its low 30 bits and the any-hit tests
/// traversal must run in its top two, so that a hit needs no other read to know it counts.
pub const TRIANGLE_MATERIAL_MASK: u32 = 0x3fff_ffff;
/// Alpha-tested: traversal consults the material's alpha (`surface::triangle_present`).
pub const TRIANGLE_TEST_ALPHA: u32 = 1 << 31;

/// The features of a scene a wavefront kernel can be compiled without (the specialisation
/// constant `SCENE_FEATURES`, bindings.glsl; `PreparedScene::gpu_features`): a pipeline made
/// for a scene that lacks one has that feature's code folded away by the driver, the same
/// results with less code, where a runtime test would leave it in.
/// The top level's walk: the scene is not one instance placed as it is.
pub const FEATURE_TOP_LEVEL: u32 = 1 << 0;
/// A level walked in its binary nodes (`NO_WIDE_ROOT`): no quantised walk for it.
pub const FEATURE_BINARY_WALK: u32 = 1 << 1;
/// A material that is not plain diffuse (`bsdf::material_is_plain`): the general BSDF.
pub const FEATURE_GENERAL_BSDF: u32 = 1 << 2;
/// An alpha-tested triangle (`TRIANGLE_TEST_ALPHA`): the any-hit test's alpha lookup.
pub const FEATURE_ALPHA: u32 = 1 << 3;
/// A texture (`PreparedScene::textures`): the materials' texture lookups.
pub const FEATURE_TEXTURES: u32 = 1 << 4;
/// An environment (`FrameParams::env_width` > 0): its lookups and sampling.
pub const FEATURE_ENVIRONMENT: u32 = 1 << 5;
/// A punctual light (`PreparedScene::punctual`): its emitter samples.
pub const FEATURE_PUNCTUAL: u32 = 1 << 6;
/// A dispersive material (`FrameParams::spectral`): the path's wavelength.
pub const FEATURE_DISPERSION: u32 = 1 << 7;
/// A material with attenuation (`GpuMaterial::attenuation` > 0): volume_sigma and transmittance
/// (otherwise 0 and 1 everywhere).
pub const FEATURE_VOLUME: u32 = 1 << 8;
/// A path expression (`--paths`): the automaton's steps.
pub const FEATURE_PATHS: u32 = 1 << 9;
/// The stratified sampler (`--sampler stratified`).
pub const FEATURE_STRATIFIED: u32 = 1 << 10;
/// The Sobol sampler (`--sampler sobol`, the default).
pub const FEATURE_SOBOL: u32 = 1 << 11;
/// The light BVH (`--light-sampler bvh`, the default): else emitters by power alone.
pub const FEATURE_LIGHT_BVH: u32 = 1 << 12;
/// A material with a thin film (`GpuMaterial::iridescence` > 0; its texture multiplies the
/// factor, so 0 stays 0): KHR_materials_iridescence's Fresnel term, about a fifth of a textured
/// `shade`'s first-dispatch compile on lavapipe (docs/perf-log/2026-12-02-kernels-made-for-the-scene.md).
pub const FEATURE_IRIDESCENCE: u32 = 1 << 13;
/// Every feature: a pipeline that serves any scene.
pub const FEATURES_ALL: u32 = u32::MAX;
/// The feature bits proper; above them the top level's deferred array ([`tlas_stack_size`])
/// and, in the top byte, the bottom levels' ([`qbvh_stack_size`]).
pub const FEATURE_FLAGS: u32 = (1 << FEATURE_TLAS_STACK_SHIFT) - 1;
/// Where `gpu_features` puts the entries of the top level's array of deferred slots
/// (`TLAS_STACK_SIZE`, the kernels' specialisation constant 8), six bits: the top level's walk
/// runs while an instance's walk holds its own array, and a top level over a few instances
/// defers far fewer slots than a bottom level over thousands of triangles.
pub const FEATURE_TLAS_STACK_SHIFT: u32 = 16;
/// Where `gpu_features` puts the entries of the quantised walks' per-lane array of deferred
/// slots made for the scene (`QBVH_STACK_SIZE`, the kernels' specialisation constant 7).
pub const FEATURE_STACK_SHIFT: u32 = 24;
/// The largest such array, and the one of kernels made with every feature: the GPU keeps at
/// most this many deferred slots beside its registers (`bvh::quantized::GPU_DEFERRED_MAX`).
pub const QBVH_STACK_MAX: u32 = 48;

/// The entries of the quantised walks' deferred array of kernels made for `features`: the top
/// byte where it is 1 to [`QBVH_STACK_MAX`], else (every feature) the largest.
pub fn qbvh_stack_size(features: u32) -> u32 {
    match features >> FEATURE_STACK_SHIFT {
        n @ 1..=QBVH_STACK_MAX => n,
        _ => QBVH_STACK_MAX,
    }
}

/// The entries of the top level's deferred array of kernels made for `features`: bits 16 to 21
/// where they are 1 to [`QBVH_STACK_MAX`], else (every feature) the largest.
pub fn tlas_stack_size(features: u32) -> u32 {
    match (features >> FEATURE_TLAS_STACK_SHIFT) & 63 {
        n @ 1..=QBVH_STACK_MAX => n,
        _ => QBVH_STACK_MAX,
    }
}

/// The names of the features in `features`, in bit order (`render --stats`).
pub fn feature_names(features: u32) -> Vec<&'static str> {
    [
        (FEATURE_TOP_LEVEL, "top level"),
        (FEATURE_BINARY_WALK, "binary walk"),
        (FEATURE_GENERAL_BSDF, "general BSDF"),
        (FEATURE_ALPHA, "alpha"),
        (FEATURE_TEXTURES, "textures"),
        (FEATURE_ENVIRONMENT, "environment"),
        (FEATURE_PUNCTUAL, "punctual lights"),
        (FEATURE_DISPERSION, "dispersion"),
        (FEATURE_VOLUME, "volume"),
        (FEATURE_PATHS, "path expression"),
        (FEATURE_STRATIFIED, "stratified sampler"),
        (FEATURE_SOBOL, "Sobol sampler"),
        (FEATURE_LIGHT_BVH, "light BVH"),
        (FEATURE_IRIDESCENCE, "iridescence"),
    ]
    .into_iter()
    .filter(|&(f, _)| features & f != 0)
    .map(|(_, name)| name)
    .collect()
}
/// Single-sided and opaque (not transmissive): rays that reach its back face pass through
/// (glTF `doubleSided: false`, back-face culling).
pub const TRIANGLE_TEST_CULL: u32 = 1 << 30;

impl GpuTriangle {
    /// The material index, without the any-hit test bits.
    pub fn material_index(&self) -> u32 {
        self.material & TRIANGLE_MATERIAL_MASK
    }
}

/// A texture as a sampler sees it: a mip chain of RGBA8 texels in the texel buffer (level k
/// follows level k − 1; level k is max(1, ⌊w/2ᵏ⌋) × max(1, ⌊h/2ᵏ⌋), rows top to bottom) and
/// glTF's sampler settings. Total: 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTexture {
    pub texel_offset: u32, // 4 bytes: first texel of level 0
    pub width: u32,        // 4 bytes
    pub height: u32,       // 4 bytes
    pub levels: u32,       // 4 bytes
    pub wrap_s: u32,       // 4 bytes: WRAP_*
    pub wrap_t: u32,       // 4 bytes: WRAP_*
    /// Magnification filter (`FILTER_*`) in bits 0–3, minification (`MIN_*`) in bits 4–7.
    pub filters: u32, // 4 bytes
    /// 1: the texels are sRGB-encoded colour (decoded before filtering), 0: linear data.
    pub srgb: u32, // 4 bytes
}

pub const WRAP_REPEAT: u32 = 0;
pub const WRAP_CLAMP_TO_EDGE: u32 = 1;
pub const WRAP_MIRRORED_REPEAT: u32 = 2;
pub const FILTER_NEAREST: u32 = 0;
pub const FILTER_LINEAR: u32 = 1;
pub const MIN_NEAREST: u32 = 0;
pub const MIN_LINEAR: u32 = 1;
pub const MIN_NEAREST_MIPMAP_NEAREST: u32 = 2;
pub const MIN_LINEAR_MIPMAP_NEAREST: u32 = 3;
pub const MIN_NEAREST_MIPMAP_LINEAR: u32 = 4;
pub const MIN_LINEAR_MIPMAP_LINEAR: u32 = 5;

/// A material's use of a texture: which texture coordinate set, through which
/// `KHR_texture_transform` (uv' = (dot(row0, uv), dot(row1, uv)) + offset).
/// Total: 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTextureRef {
    /// (row0.x, row0.y, row1.x, row1.y) of the 2×2 part of the transform.
    pub transform: [f32; 4], // 16 bytes
    pub offset: [f32; 2], // 8 bytes
    pub texture: u32,     // 4 bytes: index into the textures
    pub texcoord: u32,    // 4 bytes: 0 or 1
}

/// One entry of the emitter table: triangles that emit, with the running CDF of their selection
/// probability (proportional to power). Total: 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightEntry {
    /// P(choose an entry ≤ this one); the last entry holds exactly 1.
    pub cdf: f32, // 4 bytes
    pub triangle: u32, // 4 bytes: index into the BVH-ordered triangles
    pub pmf: f32,      // 4 bytes
    pub pad: u32,      // 4 bytes
}

/// A `KHR_lights_punctual` light in world space (`LIGHT_*`): radiant intensity (point, spot;
/// W/sr) or irradiance (directional; W/m²) = color × intensity. Total: 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPunctualLight {
    pub position: [f32; 3], // 12 bytes
    pub kind: u32,          // 4 bytes: LIGHT_*
    /// The direction the light shines along (the node's −Z), unit.
    pub direction: [f32; 3], // 12 bytes
    /// `range`: beyond it the light is zero; 0 = no range.
    pub range: f32, // 4 bytes
    pub intensity: [f32; 3], // 12 bytes
    /// Spot cone falloff (KHR_lights_punctual): 1 / max(0.001, cos inner − cos outer) and
    /// −cos outer × that scale.
    pub spot_scale: f32, // 4 bytes
    pub spot_offset: f32,   // 4 bytes
    pub pad0: u32,          // 4 bytes
    pub pad1: u32,          // 4 bytes
    pub pad2: u32,          // 4 bytes
}

pub const LIGHT_POINT: u32 = 0;
pub const LIGHT_SPOT: u32 = 1;
pub const LIGHT_DIRECTIONAL: u32 = 2;
/// `LightEntry::triangle` bit: the entry is punctual light (index in the low bits).
pub const LIGHT_ENTRY_PUNCTUAL: u32 = 1 << 31;

/// Constants of one render (std140 uniform). Total: 4288 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct FrameParams {
    pub cam_position: [f32; 3], // 12 bytes
    /// Perspective cameras: tan(yfov / 2), the half-height of the image plane at unit distance;
    /// 0 for orthographic cameras (their half-height is `cam_ymag`).
    pub tan_half_fov_y: f32, // 4 bytes
    pub cam_right: [f32; 3],    // 12 bytes
    pub aspect: f32,            // 4 bytes: width / height
    pub cam_up: [f32; 3],       // 12 bytes
    pub width: u32,             // 4 bytes
    pub cam_forward: [f32; 3],  // 12 bytes
    pub height: u32,            // 4 bytes
    pub seed: u32,              // 4 bytes
    pub max_depth: u32,         // 4 bytes
    pub light_count: u32,       // 4 bytes
    pub rr_start_depth: u32,    // 4 bytes
    /// RGB factor on the environment map's radiance: `--environment`'s colour on the constant
    /// map, or `--env-scale` (`environment.rs`).
    pub env_scale: [f32; 3], // 12 bytes
    /// `DEBUG_*` bits; 0 in every real render.
    pub debug_flags: u32, // 4 bytes
    /// The GPU film holds a band of consecutive pixels (whole rows) at a time, so that no film
    /// exceeds the device's storage-buffer range: the band's first pixel and its pixel count.
    pub band_first_pixel: u32, // 4 bytes
    pub band_pixel_count: u32,  // 4 bytes
    /// How emitter and BSDF sampling are combined: `mis::MIS_*` and β of the power heuristic.
    pub mis_heuristic: u32, // 4 bytes
    pub mis_beta: f32,          // 4 bytes
    /// Samples per pixel of the whole render (the stratified sampler's strata).
    pub spp: u32, // 4 bytes
    /// `SAMPLER_*`: how the pairs of random numbers of a pixel's samples are placed.
    pub sampler_mode: u32, // 4 bytes
    /// `RR_*`: how Russian roulette picks survival probabilities.
    pub rr_mode: u32, // 4 bytes
    /// `CAMERA_*`: how camera rays leave the film (`scene::camera_ray`).
    pub cam_projection: u32, // 4 bytes
    /// Distance of the near plane along `cam_forward`: primary rays start on it.
    pub cam_znear: f32, // 4 bytes
    /// Thin lens: radius of the lens (half of `--aperture`), 0 for a pinhole.
    pub lens_radius: f32, // 4 bytes
    /// Thin lens: distance along `cam_forward` of the plane in focus.
    pub focus_distance: f32, // 4 bytes
    /// Orthographic cameras: ymag, the half-height of the view in scene units; 0 otherwise.
    pub cam_ymag: f32, // 4 bytes
    /// Ray cones (Akenine-Möller et al. 2021): the cone's width at the camera and its spread
    /// angle per unit distance, for texture level of detail.
    pub cone_width: f32, // 4 bytes
    pub cone_spread: f32,       // 4 bytes
    /// `AOV_*`: what the render records (radiance, or a surface property at the first hit).
    pub aov: u32, // 4 bytes
    /// Index in the BVH nodes of the top level's root (over `GpuInstance`s, `tlas.rs`).
    pub tlas_root: u32, // 4 bytes
    /// The environment map's size in texels (`environment.rs`); 0 = no environment.
    pub env_width: u32, // 4 bytes
    pub env_height: u32,        // 4 bytes
    /// cos and sin of `--env-rotate` (the map turned about +Y).
    pub env_rotation: [f32; 2], // 8 bytes
    /// Probability that next event estimation samples the environment rather than an emitter
    /// of the table (the emitters' pmfs are scaled by 1 − env_pmf).
    pub env_pmf: f32, // 4 bytes
    /// `LIGHT_SAMPLER_*`: how next event estimation picks an emitter of the table.
    pub light_sampler: u32, // 4 bytes
    /// The emitter table's CDF at its last bounded light (emissive triangles, point and spot
    /// lights come first, directional lights last): the light BVH's share of the table.
    pub light_bounded_cdf: f32, // 4 bytes
    /// Passes of a render that stops at a target error (`progressive.rs`): 0 = every path of
    /// a batch belongs to the band's pixels in order (`path_pixel_sample`); n > 0 = the paths
    /// go round the first n entries of the active-pixel list (band-local pixel indices, the
    /// `ActivePixels` binding), the pixels that have not yet reached the target.
    pub active_pixel_count: u32, // 4 bytes
    /// `INTEGRATOR_*`: which estimator the kernels run (`--integrator`).
    pub integrator: u32, // 4 bytes
    /// 1 when the scene has a dispersive material (`spectrum::is_dispersive`): light tracing
    /// and BDPT then carry one wavelength per sample (`spectrum`'s module docs).
    pub spectral: u32, // 4 bytes
    /// 1: every kernel adds the scene-image texels it fetched to `counter::FETCHES`
    /// (`GpuOptions::count_fetches`, `render --stats`).
    pub count_fetches: u32, // 4 bytes
    /// Index in the GPU's node array of the top level's quantised 4-wide root (`tlas.glsl`,
    /// `PreparedScene::gpu_bvh`), or `NO_WIDE_ROOT`: the top level is walked in its binary
    /// nodes from `tlas_root`.
    pub tlas_wide_root: u32, // 4 bytes
    /// KHR_materials_sheen's albedo table E(cos θ, roughness) (`bsdf::sheen::SHEEN_ALBEDO`,
    /// four entries per vec4): a uniform the shaders index, where a constant array of that size
    /// costs lavapipe minutes of shader compilation. Every `FrameParams::default()` holds it.
    pub sheen_albedo: [[f32; 4]; 256], // 4096 bytes
    /// The GGX albedo split (A, B) of energy compensation (`bsdf::energy_table::GGX_ALBEDO`, two
    /// entries per vec4, 512 vec4s) and its averages over μ (`GGX_ALBEDO_AVG`, 16 more):
    /// uniform like the sheen's. Every `FrameParams::default()` holds it.
    pub ggx_albedo: [[f32; 4]; 528], // 8448 bytes
}

impl Default for FrameParams {
    /// Every field 0 but the quantised top level's root (`NO_WIDE_ROOT`: none), and the sheen
    /// albedo table.
    fn default() -> Self {
        FrameParams {
            tlas_wide_root: NO_WIDE_ROOT,
            sheen_albedo: sheen_albedo_vec4s(),
            ggx_albedo: ggx_albedo_vec4s(),
            ..Zeroable::zeroed()
        }
    }
}

/// `FrameParams::integrator`: paths from the camera (the wavefront's `shade`).
pub const INTEGRATOR_PATH: u32 = 0;
/// `FrameParams::integrator`: light subpaths joined to the camera (`shade_light`).
pub const INTEGRATOR_LIGHT: u32 = 1;
/// `FrameParams::integrator`: both subpaths kept as `BdptVertex`es, joined by `connect_bdpt`.
pub const INTEGRATOR_BDPT: u32 = 2;

/// `FrameParams::light_sampler`: emitters chosen by power alone (the table's CDF).
pub const LIGHT_SAMPLER_POWER: u32 = 0;
/// `FrameParams::light_sampler`: bounded emitters chosen through the light BVH by their
/// importance to the shading point (`light_bvh.rs`), directional lights by power.
pub const LIGHT_SAMPLER_BVH: u32 = 1;

/// `FrameParams::aov`: radiance (a normal render).
pub const AOV_RADIANCE: u32 = 0;
/// The first hit's base colour (factor × texture × vertex colour, linear), black on a miss.
pub const AOV_BASE_COLOR: u32 = 1;
/// The first hit's shading normal (normal map applied), world space, raw in [-1, 1].
pub const AOV_NORMAL: u32 = 2;
/// The first hit's TEXCOORD_0 (u, v, 0).
pub const AOV_UV: u32 = 3;
/// The first hit's emitted radiance (emissive factor × texture), whatever the side.
pub const AOV_EMISSION: u32 = 4;
/// The first hit's distance along the camera ray, in scene units (0 on a miss).
pub const AOV_DEPTH: u32 = 5;
/// The first hit's world-space position (0 on a miss).
pub const AOV_POSITION: u32 = 6;
/// The first hit's material: its index in the scene's materials + 1 (0 on a miss).
pub const AOV_MATERIAL: u32 = 7;
/// The first hit's placement (TLAS instance) + 1 (0 on a miss).
pub const AOV_INSTANCE: u32 = 8;
/// Coverage: 1 where the camera ray hits a surface, 0 where it escapes.
pub const AOV_ALPHA: u32 = 9;

/// `FrameParams::cam_projection`: rays from one point (or a thin lens) through the film.
pub const CAMERA_PERSPECTIVE: u32 = 0;
/// `FrameParams::cam_projection`: parallel rays along `cam_forward` from the film.
pub const CAMERA_ORTHOGRAPHIC: u32 = 1;

/// `FrameParams::sampler_mode`: every number independent.
pub const SAMPLER_INDEPENDENT: u32 = 0;
/// `FrameParams::sampler_mode`: the 2-D pairs (pixel jitter, point on a light, BSDF direction) of a
/// pixel's samples are N-rooks stratified (`sampling::stratify2`).
pub const SAMPLER_STRATIFIED: u32 = 1;
/// `FrameParams::sampler_mode`: each 2-D pair of each pixel is an Owen-scrambled, shuffled Sobol
/// (0,2)-sequence over the pixel's samples (`sobol::sobol_pair`).
pub const SAMPLER_SOBOL: u32 = 2;

/// `FrameParams::rr_mode`: survival probability min(1, max throughput component) (the default).
pub const RR_THROUGHPUT: u32 = 0;
/// `FrameParams::rr_mode`: survival probability = the surface's estimated scattering albedo, the
/// lecture's subcritical set-up P = ∫K (`bsdf::bsdf_albedo_estimate`).
pub const RR_ALBEDO: u32 = 1;
/// `FrameParams::rr_mode`: no Russian roulette; paths end at `--max-depth` only.
pub const RR_OFF: u32 = 2;

/// `FrameParams::debug_flags` bit: drop the emitter-sampling (NEE) term while BSDF-sampled hits
/// on emitters keep their MIS weights. Biased on purpose: only for the test that proves the
/// CPU/GPU comparison can fail.
pub const DEBUG_NO_NEE: u32 = 1;
/// `FrameParams::debug_flags` bit (`--transparent`): camera rays that escape see nothing (the
/// environment still lights the scene and shows in reflections), Blender's "film transparent".
pub const FLAG_TRANSPARENT_BACKGROUND: u32 = 2;
/// `FrameParams::debug_flags` bit: camera rays through pixel centres and the lens centre, for
/// the AOV layers that must not be averaged (depth, position, IDs).
pub const FLAG_PIXEL_CENTRE: u32 = 4;

/// Per-dispatch push constants. Total: 32 bytes.
///
/// Path `i` of a batch has `local = first_pixel + i`, pixel
/// `band_first_pixel + local % band_pixel_count` and sample `first_sample + local /
/// band_pixel_count`: a batch is either whole sample passes over the band (`first_pixel` = 0) or
/// a run of pixels inside one pass, so no index overflows 32 bits.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DispatchParams {
    pub first_sample: u32, // 4 bytes
    pub first_pixel: u32,  // 4 bytes
    pub batch_size: u32,   // 4 bytes
    /// Scattering events so far for the rays being processed.
    pub depth: u32, // 4 bytes
    /// `dispatch_args` only: the queue counter to read, the argument slot to write, the total
    /// to add the count to (or `u32::MAX`), and a bit mask of counters to zero.
    pub counter: u32, // 4 bytes
    pub args_slot: u32,    // 4 bytes
    pub total_counter: u32, // 4 bytes
    pub clear_mask: u32,   // 4 bytes
}

/// What carries between bounces for one path. Total: 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PathState {
    pub throughput: [f32; 3], // 12 bytes
    /// Solid-angle pdf of the BSDF sample that produced the current ray.
    pub prev_bsdf_pdf: f32, // 4 bytes
    pub radiance: [f32; 3],   // 12 bytes
    /// 1 if the previous vertex was the camera or a specular bounce (no MIS on emission).
    pub prev_specular: u32, // 4 bytes
    /// The previous vertex (the current ray's origin, before its offset) and its geometric
    /// normal: where the light BVH's pmf of an emitter the ray hits is evaluated for MIS.
    pub prev_position: [f32; 3], // 12 bytes
    /// Width of the ray cone at the current ray's origin (texture level of detail).
    pub cone_width: f32, // 4 bytes
    pub prev_normal: [f32; 3], // 12 bytes
    pub pad0: u32,            // 4 bytes
    /// KHR_materials_volume: the attenuation coefficient of the medium the current ray enters
    /// at its origin (`volume::volume_sigma`; 0 outside every volume).
    pub medium: [f32; 3], // 12 bytes
    /// KHR_materials_dispersion: the wavelength (nm) the path carries since its first
    /// dispersive vertex, its throughput weighted by `spectrum::wavelength_weight`; 0 before.
    pub wavelength: f32, // 4 bytes
}

/// A ray in the extension queue. Total: 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct QueuedRay {
    pub origin: [f32; 3], // 12 bytes
    pub path: u32,        // 4 bytes: index of the path in the batch
    pub dir: [f32; 3],    // 12 bytes: unit length
    pub pad: u32,         // 4 bytes
}

/// Closest hit of a queued ray (`triangle` = `NO_HIT` on a miss). Total: 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HitRecord {
    pub t: f32,        // 4 bytes
    pub triangle: u32, // 4 bytes
    pub u: f32,        // 4 bytes: barycentric weight of p1
    pub v: f32,        // 4 bytes: barycentric weight of p2
    pub instance: u32, // 4 bytes: the `GpuInstance` whose bottom level holds the triangle
    pub pad0: u32,     // 4 bytes
    pub pad1: u32,     // 4 bytes
    pub pad2: u32,     // 4 bytes
}

/// One placement of a bottom-level BVH in the world: the top level's leaves (`tlas.rs`).
/// Total: 112 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInstance {
    /// Rows of the 3×4 affine object → world transform.
    pub object_to_world: [[f32; 4]; 3], // 48 bytes
    /// Rows of its inverse, world → object.
    pub world_to_object: [[f32; 4]; 3], // 48 bytes
    pub blas_root: u32, // 4 bytes: BVH node of the bottom level's root
    pub flags: u32,     // 4 bytes: INSTANCE_* bits
    /// 4 bytes: the GPU's node index of the bottom level's quantised 4-wide root
    /// (`PreparedScene::gpu_bvh`), which the GPU walks, or `NO_WIDE_ROOT` where it walks the
    /// binary nodes; the CPU leaves it unset and looks the root up itself.
    pub wide_root: u32,
    /// 4 bytes: which placement this is, before the top level reorders them: 0 the baked
    /// geometry, k + 1 the scene's instance k (`--aov instance` writes it + 1).
    pub placement: u32,
}

/// `GpuInstance::flags`: the transform is the identity (the baked world-space geometry).
pub const INSTANCE_IDENTITY: u32 = 1;
/// `GpuInstance::flags`: the transform mirrors (negative determinant): front faces flip.
pub const INSTANCE_MIRRORED: u32 = 2;

pub const NO_HIT: u32 = u32::MAX;
/// `GpuInstance::wide_root` and `FrameParams::tlas_wide_root` of a level the GPU walks in its
/// binary nodes (no primitives, or more deferred slots than its quantised walk keeps).
pub const NO_WIDE_ROOT: u32 = u32::MAX;

/// A shadow ray with the contribution its path gains if it is unoccluded. Total: 48 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ShadowRay {
    pub origin: [f32; 3],       // 12 bytes
    pub path: u32,              // 4 bytes
    pub dir: [f32; 3],          // 12 bytes: unit length
    pub t_max: f32,             // 4 bytes
    pub contribution: [f32; 3], // 12 bytes
    pub pad: u32,               // 4 bytes
}

/// One vertex of a BDPT subpath on the GPU (`src/cpu/bidir/bdpt.rs`, `Vertex`): where it is, what
/// MIS needs (the area densities of generating it from either side) and what rebuilds its
/// material (triangle, instance, barycentrics). Total: 96 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BdptVertex {
    pub p: [f32; 3], // 12 bytes
    /// `BDPT_VERTEX_*` kind, | `BDPT_VERTEX_DELTA` once the subpath left it along a delta lobe.
    pub kind: u32, // 4 bytes
    pub ng: [f32; 3], // 12 bytes: geometric normal (camera: view axis; spot: its axis)
    pub pdf_fwd: f32, // 4 bytes
    pub ns: [f32; 3], // 12 bytes: shading normal
    pub pdf_rev: f32, // 4 bytes
    pub wo: [f32; 3], // 12 bytes: towards the previous vertex of its subpath
    pub index: u32,  // 4 bytes: triangle (BVH order) or punctual light
    pub beta: [f32; 3], // 12 bytes: the subpath's throughput up to the vertex
    pub instance: u32, // 4 bytes: the hit's instance; NO_HIT at an emitter's own point
    pub bary: [f32; 2], // 8 bytes
    pub pad0: u32,   // 4 bytes
    pub pad1: u32,   // 4 bytes
}

/// Alpha-test keys of light subpaths' bounces (`ALPHA_LIGHT_WALK` + bounce) and of connections,
/// apart from the camera's bounces (cpu/bidir, light_tracing.glsl).
pub const ALPHA_LIGHT_WALK: u32 = 1 << 20;
pub const ALPHA_CONNECT: u32 = 1 << 21;

/// `BdptVertex::kind`, the twins of `bidir::Kind`.
pub const BDPT_VERTEX_CAMERA: u32 = 0;
pub const BDPT_VERTEX_AREA_LIGHT: u32 = 1;
pub const BDPT_VERTEX_POINT_LIGHT: u32 = 2;
pub const BDPT_VERTEX_SURFACE: u32 = 3;
/// `BdptVertex::kind` bit: the subpath left the vertex along a delta lobe.
pub const BDPT_VERTEX_DELTA: u32 = 16;

/// Per-pixel accumulator: sum, sum of squares and count of finite samples. Total: 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FilmPixel {
    pub sum: [f32; 3],    // 12 bytes
    pub count: u32,       // 4 bytes
    pub sum_sq: [f32; 3], // 12 bytes
    pub pad: u32,         // 4 bytes
}

/// Indices into the counter buffer (`uint counters[]`).
pub mod counter {
    /// Extension-ray queue lengths, ping-ponged by `depth & 1`.
    pub const RAYS_0: u32 = 0;
    pub const RAYS_1: u32 = 1;
    pub const SHADOW: u32 = 2;
    /// Totals over the render, read back once at the end.
    pub const TOTAL_EXTENSION_RAYS: u32 = 3;
    pub const TOTAL_SHADOW_RAYS: u32 = 4;
    pub const DROPPED_SAMPLES: u32 = 5;
    /// With `GpuOptions::count_fetches`: per kernel (its place in `KERNELS`), the scene-image
    /// texels its invocations fetched, a 64-bit count as two words, low then high
    /// (`scene_arrays.glsl`, `count_scene_fetches`).
    pub const FETCHES: u32 = 8;
    pub const COUNT: u32 = FETCHES + 2 * crate::kernels::KERNELS.len() as u32;
}

/// Indirect-dispatch argument slots (`uvec3 args[]`, padded to 16 bytes each).
pub mod args {
    pub const RAYS: u32 = 0;
    pub const SHADOW: u32 = 1;
    pub const COUNT: u32 = 2;
}

/// A struct's name, size and member offsets, as the GLSL side must have them.
pub struct StructLayout {
    pub name: &'static str,
    pub size: usize,
    pub members: &'static [(&'static str, usize)],
}

macro_rules! struct_layout {
    ($ty:ident { $($field:ident),* $(,)? }) => {
        StructLayout {
            name: stringify!($ty),
            size: size_of::<$ty>(),
            members: &[$((stringify!($field), offset_of!($ty, $field))),*],
        }
    };
}

/// Every GPU-visible struct with the offsets of its members (checked against SPIR-V).
pub const STRUCT_LAYOUTS: &[StructLayout] = &[
    struct_layout!(BvhNode {
        bounds_min,
        offset,
        bounds_max,
        count
    }),
    struct_layout!(GpuTriangle {
        p0,
        material,
        e1,
        light_pmf,
        e2,
        area
    }),
    struct_layout!(GpuMaterial {
        base_color,
        flags,
        emission,
        metallic,
        roughness,
        ior,
        transmission,
        specular,
        alpha,
        alpha_cutoff,
        normal_scale,
        base_color_texture,
        metallic_roughness_texture,
        emissive_texture,
        normal_texture,
        transmission_texture,
        specular_color,
        specular_texture,
        specular_color_texture,
        clearcoat,
        clearcoat_roughness,
        clearcoat_texture,
        clearcoat_roughness_texture,
        clearcoat_normal_texture,
        clearcoat_normal_scale,
        sheen_roughness,
        clearcoat_normal,
        sheen_color_texture,
        sheen_color,
        sheen_roughness_texture,
        anisotropy_direction,
        anisotropy,
        anisotropy_rotation,
        anisotropy_texture,
        iridescence,
        iridescence_ior,
        iridescence_thickness_min,
        iridescence_thickness,
        iridescence_texture,
        iridescence_thickness_texture,
        attenuation,
        thickness,
        diffuse_transmission_color,
        diffuse_transmission,
        diffuse_transmission_texture,
        diffuse_transmission_color_texture,
        dispersion,
        pad1
    }),
    struct_layout!(GpuVertex {
        tangent,
        normal,
        pad,
        uv,
        color
    }),
    struct_layout!(GpuTexture {
        texel_offset,
        width,
        height,
        levels,
        wrap_s,
        wrap_t,
        filters,
        srgb
    }),
    struct_layout!(GpuTextureRef {
        transform,
        offset,
        texture,
        texcoord
    }),
    struct_layout!(GpuPunctualLight {
        position,
        kind,
        direction,
        range,
        intensity,
        spot_scale,
        spot_offset,
        pad0,
        pad1,
        pad2
    }),
    struct_layout!(LightEntry {
        cdf,
        triangle,
        pmf,
        pad
    }),
    struct_layout!(FrameParams {
        cam_position,
        tan_half_fov_y,
        cam_right,
        aspect,
        cam_up,
        width,
        cam_forward,
        height,
        seed,
        max_depth,
        light_count,
        rr_start_depth,
        env_scale,
        debug_flags,
        band_first_pixel,
        band_pixel_count,
        mis_heuristic,
        mis_beta,
        spp,
        sampler_mode,
        rr_mode,
        cam_projection,
        cam_znear,
        lens_radius,
        focus_distance,
        cam_ymag,
        cone_width,
        cone_spread,
        aov,
        tlas_root,
        env_width,
        env_height,
        env_rotation,
        env_pmf,
        light_sampler,
        light_bounded_cdf,
        active_pixel_count,
        integrator,
        spectral,
        count_fetches,
        tlas_wide_root,
        sheen_albedo,
        ggx_albedo
    }),
    struct_layout!(DispatchParams {
        first_sample,
        first_pixel,
        batch_size,
        depth,
        counter,
        args_slot,
        total_counter,
        clear_mask
    }),
    struct_layout!(PathState {
        throughput,
        prev_bsdf_pdf,
        radiance,
        prev_specular,
        prev_position,
        cone_width,
        prev_normal,
        pad0,
        medium,
        wavelength
    }),
    struct_layout!(QueuedRay {
        origin,
        path,
        dir,
        pad
    }),
    struct_layout!(HitRecord {
        t,
        triangle,
        u,
        v,
        instance,
        pad0,
        pad1,
        pad2
    }),
    struct_layout!(GpuInstance {
        object_to_world,
        world_to_object,
        blas_root,
        flags,
        wide_root,
        placement
    }),
    struct_layout!(ShadowRay {
        origin,
        path,
        dir,
        t_max,
        contribution,
        pad
    }),
    struct_layout!(BdptVertex {
        p,
        kind,
        ng,
        pdf_fwd,
        ns,
        pdf_rev,
        wo,
        index,
        beta,
        instance,
        bary,
        pad0,
        pad1
    }),
    struct_layout!(FilmPixel {
        sum,
        count,
        sum_sq,
        pad
    }),
];

#[cfg(test)]
mod tests {
    use super::*;

    /// The deferred array of kernels made for a scene is the features' top byte; kernels made
    /// with every feature (and a byte out of range) keep the largest, and the top byte never
    /// reads as a feature.
    #[test]
    fn deferred_array_comes_from_the_top_byte() {
        assert_eq!(qbvh_stack_size(FEATURES_ALL), QBVH_STACK_MAX);
        assert_eq!(qbvh_stack_size(FEATURE_SOBOL), QBVH_STACK_MAX);
        for n in 1..=QBVH_STACK_MAX {
            let features = FEATURE_SOBOL | FEATURE_LIGHT_BVH | n << FEATURE_STACK_SHIFT;
            assert_eq!(qbvh_stack_size(features), n);
            assert_eq!(features & FEATURE_FLAGS, FEATURE_SOBOL | FEATURE_LIGHT_BVH);
            assert_eq!(
                feature_names(features),
                feature_names(FEATURE_SOBOL | FEATURE_LIGHT_BVH)
            );
        }
        assert_eq!(qbvh_stack_size(49 << FEATURE_STACK_SHIFT), QBVH_STACK_MAX);
        assert!(FEATURE_LIGHT_BVH < 1 << FEATURE_STACK_SHIFT);
    }

    /// The top level's deferred array comes from bits 16 to 21, apart from the bottom levels'
    /// and from every feature; kernels made with every feature keep the largest.
    #[test]
    fn top_level_array_comes_from_its_own_bits() {
        assert_eq!(tlas_stack_size(FEATURES_ALL), QBVH_STACK_MAX);
        assert_eq!(tlas_stack_size(FEATURE_TOP_LEVEL), QBVH_STACK_MAX);
        for (top, bottom) in [(1, 48), (3, 19), (48, 1), (17, 17)] {
            let flags = FEATURE_TOP_LEVEL | FEATURE_IRIDESCENCE;
            let features = flags | top << FEATURE_TLAS_STACK_SHIFT | bottom << FEATURE_STACK_SHIFT;
            assert_eq!(tlas_stack_size(features), top);
            assert_eq!(qbvh_stack_size(features), bottom);
            assert_eq!(features & FEATURE_FLAGS, flags);
            assert_eq!(feature_names(features), feature_names(flags));
        }
        assert!(FEATURE_IRIDESCENCE < 1 << FEATURE_TLAS_STACK_SHIFT);
        assert!(QBVH_STACK_MAX < 64 && FEATURE_TLAS_STACK_SHIFT + 6 <= FEATURE_STACK_SHIFT);
    }

    /// The material image marks exactly the materials whose extension parameters (past the
    /// first five texels) are not the defaults the kernels substitute.
    #[test]
    fn only_materials_with_extension_parameters_are_marked_extended() {
        let plain = GpuMaterial {
            base_color: [0.2, 0.3, 0.4],
            emission: [5.0; 3],
            roughness: 0.1,
            transmission: 1.0,
            normal_texture: 3,
            ..GpuMaterial::default()
        };
        assert_eq!(plain.image_record(), plain);
        assert_eq!(GpuMaterial::default().image_record().flags, 0);
        for extended in [
            GpuMaterial {
                clearcoat: 0.5,
                ..plain
            },
            GpuMaterial {
                specular_color: [1.0, 0.9, 1.0],
                ..plain
            },
            GpuMaterial {
                dispersion: 0.1,
                ..plain
            },
        ] {
            let record = extended.image_record();
            assert_eq!(record.flags, extended.flags | MATERIAL_EXTENDED);
            assert_eq!(
                GpuMaterial {
                    flags: extended.flags,
                    ..record
                },
                extended
            );
        }
        // The core ends where the first extension parameter begins.
        assert_eq!(
            std::mem::offset_of!(GpuMaterial, specular_color),
            MATERIAL_CORE_BYTES
        );
    }
}

/// [`SHEEN_ALBEDO`](crate::bsdf::sheen_table::SHEEN_ALBEDO) four entries to a vec4, as `FrameParams::sheen_albedo` carries it to the
/// shaders.
pub fn sheen_albedo_vec4s() -> [[f32; 4]; 256] {
    let mut out = [[0.0; 4]; 256];
    for (k, v) in crate::bsdf::sheen_table::SHEEN_ALBEDO.iter().enumerate() {
        out[k / 4][k % 4] = *v;
    }
    out
}

/// [`GGX_ALBEDO`](crate::bsdf::energy_table::GGX_ALBEDO) two (A, B) pairs to a vec4, then
/// [`GGX_ALBEDO_AVG`](crate::bsdf::energy_table::GGX_ALBEDO_AVG) likewise, as
/// `FrameParams::ggx_albedo` carries them to the shaders (`energy.glsl`).
pub fn ggx_albedo_vec4s() -> [[f32; 4]; 528] {
    use crate::bsdf::energy_table::{GGX_ALBEDO, GGX_ALBEDO_AVG};
    let mut out = [[0.0; 4]; 528];
    for (k, [a, b]) in GGX_ALBEDO.iter().chain(GGX_ALBEDO_AVG.iter()).enumerate() {
        out[k / 2][(k % 2) * 2] = *a;
        out[k / 2][(k % 2) * 2 + 1] = *b;
    }
    out
}
