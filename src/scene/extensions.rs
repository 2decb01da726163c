//! Which glTF extensions the loader reads, which it refuses by name (and why), and the one error
//! a file that requires an unsupported extension gets.

/// Extensions a file may list in `extensionsRequired`.
pub(super) const SUPPORTED_EXTENSIONS: &[&str] = &[
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
    "KHR_mesh_quantization",
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_texture_basisu",
    "EXT_texture_webp",
];

/// Extensions wavetrace refuses on purpose, with the reason its messages give.
pub(super) const REFUSED_EXTENSIONS: &[(&str, &str)] = &[(
    "KHR_materials_pbrSpecularGlossiness",
    "archived by Khronos; re-export the materials as metallic-roughness with \
         KHR_materials_specular and KHR_materials_ior",
)];

/// An unsupported extension's name, with the reason where wavetrace refuses it on purpose.
pub(super) fn unsupported_extension(ext: &str) -> String {
    match REFUSED_EXTENSIONS.iter().find(|(name, _)| *name == ext) {
        Some((_, why)) => format!("{ext} ({why})"),
        None => ext.to_owned(),
    }
}
