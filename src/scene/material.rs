//! glTF materials → [`Material`]: the metallic-roughness core, its textures and their transforms,
//! and every KHR material extension, read from the typed model where the `gltf` crate has it and
//! from the raw JSON where it does not.

use super::images::{TextureBuilder, TextureInfo, TextureUse};
use super::json::json_path;
use super::model::{AlphaMode, Material, MaterialTextures};
use anyhow::{anyhow, bail, Result};
use glam::Vec3;
use gltf::Document;

/// What a material asks of the primitives that use it.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct MaterialNeeds {
    /// Texture coordinate sets its textures read.
    pub(super) tex_coords: [bool; 2],
    /// The set its normal map reads, if it has one (tangents are generated for it).
    pub(super) normal_map: Option<u32>,
}

/// A textureInfo's texture, set and KHR_texture_transform.
pub(super) fn texture_info<'a>(info: gltf::texture::Info<'a>) -> TextureInfo<'a> {
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
pub(super) fn untyped_transform(
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
pub(super) fn raw_extension<'a>(
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

pub(super) fn raw_unit_factor(
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
pub(super) fn raw_unit_color(
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
pub(super) fn raw_texture_info<'a>(
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

pub(super) fn convert_material(
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
