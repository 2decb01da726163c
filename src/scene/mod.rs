//! The scene as the renderer sees it: world-space triangles, Lambertian materials with emission,
//! and cameras, loaded from glTF 2.0 (`.gltf` or `.glb`).
//!
//! Conventions are glTF's (DESIGN.md): metres, right-handed, +Y up, cameras look down −Z. A
//! triangle's front face is the one from which its vertices appear counter-clockwise, i.e. the
//! side its geometric normal `cross(p1 − p0, p2 − p0)` points to. Emission leaves the front face
//! only, unless the material is double-sided.
//!
//! - [`load`](Scene::load): glTF → [`Scene`] (`load.rs`), with errors that name the file, the
//!   object and the problem.
//! - [`Camera`] (`camera.rs`): every perspective and orthographic camera instance of the file
//!   ([`Scene::cameras`], the first the default), or a framing default; the thin lens and the
//!   primary rays ([`camera_ray`]).
//! - [`build_light_table`] (`lights.rs`): the emitter table sampled by next event estimation.

mod accessors;
mod animation;
mod buffers;
mod camera;
mod draco;
mod extensions;
mod images;
mod json;
mod limits;
mod load;
mod material;
mod meshopt;
mod model;
mod morph;
mod nodes;
mod skin;
mod tangents;
mod validate;

pub use animation::{AnimationInfo, Animations, Moment};
pub use camera::{camera_ray, Camera, Projection, ThinLens};
pub use limits::{default_memory_budget, format_bytes, parse_size, Budget, LoadOptions};
pub use load::SceneFile;
pub use model::{
    AlphaMode, Instance, Material, MaterialTextures, Mesh, Scene, SceneCamera, TextureSet,
    Triangle, NO_VERTEX,
};
