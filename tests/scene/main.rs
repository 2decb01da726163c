//! Scenes: loading glTF (valid and real-world files), instancing and the figure scenes. (The
//! hostile files and the fuzz regressions have binaries of their own: see their files.)
//!
//! One test binary for what these files prove together (linking the crate once, not once per file).

#[path = "../common/mod.rs"]
mod common;

mod animation;
mod compressed;
mod figure_scenes;
mod instancing;
mod morph;
mod real_files;
mod scene_loading;
mod skin;
