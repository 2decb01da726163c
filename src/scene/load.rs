//! glTF 2.0 (`.gltf` / `.glb`) → [`Scene`]. The file is untrusted input (docs/security.md, "Running on
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
//! Compressed files: Draco primitives (`draco.rs`), meshopt buffer views (`meshopt.rs`, decoded
//! right after the buffers are read), quantized attributes (`accessors.rs`), KTX2 and WebP
//! textures (`images.rs`).
//! Morph targets and skins (`morph.rs`, `skin.rs`) take the pose of a moment of the file's
//! animations (`animation.rs`), the static pose unless one is asked for: [`SceneFile`] holds
//! what every moment shares (the parsed file, buffers, materials, textures, keyframes) and
//! builds the scene of any one. Point and line primitives are skipped (counted in
//! `Scene::skipped_primitives`).

use super::animation::{self, infos, read_clips, AnimationInfo, Animations, Clip, Moment};
use super::buffers::{check_image_uris, load_buffers, open_regular_named};
use super::camera::Camera;
use super::extensions::{unsupported_extension, SUPPORTED_EXTENSIONS};
use super::images::TextureBuilder;
use super::json::label;
use super::json::{parse_value, split_container, typed_root, validation_message};
use super::limits::{
    format_bytes, Budget, LoadOptions, PREPARE_BYTES_PER_EMITTER, PREPARE_BYTES_PER_INSTANCE,
    PREPARE_BYTES_PER_TRIANGLE, PREPARE_BYTES_PER_TRIANGLE_WITH_EMITTERS,
};
use super::material::{convert_material, MaterialNeeds};
use super::model::{Material, Scene};
use super::nodes::{mesh_uses, Builder, Repairs};
use super::validate::check_document;
use anyhow::{anyhow, bail, Context, Result};
use gltf::Document;
use std::io::Read;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// Memory a parsed JSON value may take per structural character (`,` `:` `[` `{`) of its text:
/// a `serde_json::Value` is 32 bytes, a map entry about twice that, and the `gltf` crate's
/// typed model is built from it while it lives.
pub(super) const JSON_BYTES_PER_TOKEN: u64 = 96;

pub(super) fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    open(path, options)?.scene(&Moment::rest(), options)
}

/// Reads, parses and checks a scene file, its buffers, materials, textures and animations,
/// ready to be posed at any moment ([`SceneFile::scene`]).
pub(super) fn open(path: &Path, options: &LoadOptions) -> Result<SceneFile> {
    guarded(path, options, || {
        let bytes = read_scene_file(path, &options.budget)?;
        open_bytes(path, bytes, options)
    })
}

/// [`load`] of a file's bytes already in memory; `source` names it in messages and its folder is
/// where relative URIs resolve.
pub(super) fn load_from_bytes(
    source: &Path,
    bytes: Vec<u8>,
    options: &LoadOptions,
) -> Result<Scene> {
    open_from_bytes(source, bytes, options)?.scene(&Moment::rest(), options)
}

/// [`open`] of a file's bytes already in memory.
pub(super) fn open_from_bytes(
    source: &Path,
    bytes: Vec<u8>,
    options: &LoadOptions,
) -> Result<SceneFile> {
    guarded(source, options, || {
        let size = bytes.len() as u64;
        options
            .budget
            .reserve(&format!("the file ({})", format_bytes(size)), size)?;
        open_bytes(source, bytes, options)
    })
}

/// Runs a load, turning a panic into an error, giving back what a failed load reserved, and
/// naming the file in the error.
pub(super) fn guarded<T>(
    path: &Path,
    options: &LoadOptions,
    load: impl FnOnce() -> Result<T>,
) -> Result<T> {
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
pub(super) fn read_scene_file(path: &Path, budget: &Budget) -> Result<Vec<u8>> {
    let (file, size) = open_regular_named(path, &"the file")?;
    budget.reserve(&format!("the file ({})", format_bytes(size)), size)?;
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(size)
        .read_to_end(&mut bytes)
        .context("cannot read the file")?;
    Ok(bytes)
}

/// Opens the scene file held in `bytes` (the file `path`, already read and reserved in the
/// budget).
pub(super) fn open_bytes(path: &Path, bytes: Vec<u8>, options: &LoadOptions) -> Result<SceneFile> {
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
    let extra_targets = super::morph::extra_targets(&value)?;
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
    let mut buffers = load_buffers(&document, bin, container.is_glb(), base, options)?;
    super::meshopt::decode_views(&document, &mut buffers, &options.budget)?;
    let buffers = buffers;
    let mut textures = TextureBuilder::new(Some(&document), &buffers, base, options);
    let (materials, needs): (Vec<Material>, Vec<MaterialNeeds>) = document
        .materials()
        .enumerate()
        .map(|(i, m)| convert_material(i, &m, &document, &mut textures))
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .unzip();
    if document.scenes().len() == 0 {
        bail!("scenes: the file contains no scene, so there is nothing to render");
    }
    let clips = read_clips(&document, &buffers, &options.budget)?;
    let textures = textures.set;
    Ok(SceneFile {
        source: path.to_path_buf(),
        document,
        buffers,
        materials,
        needs,
        textures,
        clips,
        extra_targets,
        framing: std::sync::Mutex::new(Vec::new()),
    })
}

/// Moments of an animation whose bounds the default camera of a file without cameras frames.
pub const FRAMING_MOMENTS: usize = 9;

/// A scene file read, parsed and checked, its materials and textures decoded and its
/// animations' keyframes read: what stays the same at every moment, from which
/// [`scene`](SceneFile::scene) builds the geometry, cameras and lights of any one.
pub struct SceneFile {
    source: std::path::PathBuf,
    document: Document,
    buffers: Vec<Vec<u8>>,
    materials: Vec<Material>,
    needs: Vec<MaterialNeeds>,
    textures: super::model::TextureSet,
    clips: Vec<Clip>,
    extra_targets: super::morph::ExtraTargets,
    /// [`framing_bounds`](SceneFile::framing_bounds) worked out so far.
    framing: std::sync::Mutex<Vec<(Animations, (glam::Vec3, glam::Vec3))>>,
}

impl SceneFile {
    /// Opens a `.gltf` or `.glb` file under `options`' limits (errors as for [`Scene::load`]).
    pub fn open(path: &Path, options: &LoadOptions) -> anyhow::Result<SceneFile> {
        open(path, options)
    }

    /// [`open`](SceneFile::open) of a file's bytes already in memory (as
    /// [`Scene::load_from_bytes`]).
    pub fn from_bytes(
        source: &Path,
        bytes: Vec<u8>,
        options: &LoadOptions,
    ) -> anyhow::Result<SceneFile> {
        open_from_bytes(source, bytes, options)
    }

    /// The file's animations, in file order.
    pub fn animations(&self) -> Vec<AnimationInfo> {
        infos(&self.clips)
    }

    /// The scene at `moment`: nodes posed by the chosen animations at its time (the static
    /// pose for [`Moment::rest`]), meshes morphed and skinned, cameras and lights placed.
    /// Its memory is reserved in `options`' budget, as for [`Scene::load_with`].
    ///
    /// A file without cameras is framed the same at every moment of an animation: the default
    /// camera frames the union of the scene's bounds at [`FRAMING_MOMENTS`] moments evenly
    /// spread over the animations playing, so a sequence's camera holds still and a frame is
    /// the same image as its `--time` rendered alone.
    pub fn scene(&self, moment: &Moment, options: &LoadOptions) -> anyhow::Result<Scene> {
        guarded(&self.source, options, || {
            let mut scene = self.build(moment, options)?;
            if scene.cameras.is_empty() {
                if let Some(bounds) = self.framing_bounds_of(&moment.animations, options)? {
                    scene.camera = Camera::framing(bounds);
                }
            }
            Ok(scene)
        })
    }

    /// The bounds a view of the animations `animations` frames (`--orbit`, and the default
    /// camera of a file without cameras): the union of the scene's bounds at
    /// [`FRAMING_MOMENTS`] moments evenly spread over them, worked out once per choice of
    /// animations; None at the static pose, where the scene's own bounds serve.
    pub fn framing_bounds(
        &self,
        animations: &Animations,
        options: &LoadOptions,
    ) -> anyhow::Result<Option<(glam::Vec3, glam::Vec3)>> {
        guarded(&self.source, options, || {
            self.framing_bounds_of(animations, options)
        })
    }

    fn framing_bounds_of(
        &self,
        animations: &Animations,
        options: &LoadOptions,
    ) -> Result<Option<(glam::Vec3, glam::Vec3)>> {
        if *animations == Animations::Static {
            return Ok(None);
        }
        let known = self.framing.lock().expect("not poisoned");
        if let Some((_, bounds)) = known.iter().find(|(a, _)| a == animations) {
            return Ok(Some(*bounds));
        }
        drop(known);
        let (start, end) = animation::span(&self.clips, animations)?;
        let mut bounds = None::<(glam::Vec3, glam::Vec3)>;
        for k in 0..FRAMING_MOMENTS {
            let time = start + (end - start) * k as f32 / (FRAMING_MOMENTS - 1) as f32;
            let before = options.budget.used();
            let moment = Moment {
                animations: animations.clone(),
                time,
            };
            let at = self.build(&moment, options)?;
            options
                .budget
                .release(options.budget.used().saturating_sub(before));
            let (lo, hi) = at.bounds();
            bounds = Some(bounds.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
        }
        let bounds = bounds.expect("FRAMING_MOMENTS > 0");
        self.framing
            .lock()
            .expect("not poisoned")
            .push((animations.clone(), bounds));
        Ok(Some(bounds))
    }

    fn build(&self, moment: &Moment, options: &LoadOptions) -> Result<Scene> {
        let path = &self.source;
        let document = &self.document;
        let pose = animation::pose(document, &self.clips, moment)?;
        let scene = document
            .default_scene()
            .or_else(|| document.scenes().next())
            .expect("a file with a scene");
        let mut builder = Builder {
            document,
            buffers: &self.buffers,
            budget: &options.budget,
            triangles: Vec::new(),
            vertices: Vec::new(),
            materials: self.materials.clone(),
            needs: self.needs.clone(),
            pose: &pose,
            extra_targets: &self.extra_targets,
            repairs: Repairs::default(),
            default_material: None,
            cameras: Vec::new(),
            dropped_degenerate: 0,
            skipped_primitives: 0,
            mesh_uses: mesh_uses(document),
            instancing: options.instancing,
            meshes: Vec::new(),
            mesh_ids: std::collections::HashMap::new(),
            instances: Vec::new(),
            punctual: Vec::new(),
        };
        builder.walk(document, &scene)?;
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
        let notes = notes(document, &builder);
        let bounds =
            super::model::scene_bounds(&builder.triangles, &builder.meshes, &builder.instances);
        let camera = builder
            .cameras
            .first()
            .map_or_else(|| Camera::framing(bounds), |c| c.camera);
        Ok(Scene {
            source: path.to_path_buf(),
            triangles: builder.triangles,
            materials: builder.materials,
            vertices: builder.vertices,
            textures: self.textures.clone(),
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
}

/// The `gltf` crate's validation of the typed model, less its refusal of required extensions
/// it does not know itself (it lists only those it parses): every required extension was
/// checked against [`SUPPORTED_EXTENSIONS`] before, so an "unsupported extension" error here
/// names one that wavetrace reads from the raw JSON (KHR_materials_unlit, …).
pub(super) fn validated_document(root: gltf::json::Root) -> Result<Document> {
    use gltf::json::validation::{Error, Validate};
    // KHR_draco_mesh_compression: the accessors a Draco stream stands for have no bufferView.
    let draco: std::collections::HashSet<String> = root
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .filter(|p| {
            p.extensions
                .as_ref()
                .is_some_and(|e| e.others.contains_key("KHR_draco_mesh_compression"))
        })
        .flat_map(|p| p.attributes.values().copied().chain(p.indices))
        .map(|a| format!("accessors[{}].bufferView", a.value()))
        .collect();
    let mut errors = Vec::new();
    root.validate(&root, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        let decoded = error == Error::Missing && draco.contains(path.as_str());
        if error != Error::Unsupported && !decoded {
            errors.push((path, error));
        }
    });
    if !errors.is_empty() {
        return Err(validation_message(gltf::Error::Validation(errors)));
    }
    Ok(Document::from_json_without_validation(root))
}

/// What the file holds that the render will not show, said once each (`Scene::notes`).
pub(super) fn notes(document: &Document, builder: &Builder) -> Vec<String> {
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

impl Scene {
    /// Loads the default scene (scene 0 if none is marked default) of a `.gltf` or `.glb` file.
    ///
    /// Errors name the file, the glTF object (node, mesh, primitive, accessor, buffer…) and the
    /// problem; print them with `{:#}` (or `{:?}`) to see the whole chain.
    pub fn load(path: &Path) -> anyhow::Result<Scene> {
        load(path, &LoadOptions::default())
    }

    /// [`load`](Scene::load) with explicit limits: the folders URIs may name and the memory
    /// budget, which the loader's allocations are reserved in (and stay reserved while the
    /// scene lives, so the render can keep accounting in the same budget).
    pub fn load_with(path: &Path, options: &LoadOptions) -> anyhow::Result<Scene> {
        load(path, options)
    }

    /// [`load_with`](Scene::load_with) of a scene file's bytes already in memory (`.gltf` JSON
    /// or `.glb`, told apart by the GLB magic). `source` names the file in messages, and its
    /// folder is where relative buffer and image URIs resolve, under the same rules as for a
    /// file read from disk; the bytes are accounted in the budget like a file's.
    pub fn load_from_bytes(
        source: &Path,
        bytes: Vec<u8>,
        options: &LoadOptions,
    ) -> anyhow::Result<Scene> {
        load_from_bytes(source, bytes, options)
    }
}
