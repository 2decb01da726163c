//! Compiles every compute kernel in `shaders/wavefront/` (and the twin-test kernels in
//! `shaders/tests/`) to SPIR-V with glslang (built from
//! source by the `glslang` crate) for SPIR-V 1.3 (1.4 brings OpCopyLogical, which naga cannot
//! read yet), resolving `#include "x.glsl"` from `shaders/inc/`, and treats
//! any compiler warning as an error. The binary embeds the modules through `$OUT_DIR/kernels.rs`.

use glslang::include::{IncludeHandler, IncludeResult, IncludeType};
use glslang::{
    Compiler, CompilerOptions, ShaderInput, ShaderMessage, ShaderSource, ShaderStage,
    SourceLanguage, SpirvVersion, Target, VulkanVersion,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

struct IncludeDir(PathBuf);

impl IncludeHandler for IncludeDir {
    fn include(
        &mut self,
        _ty: IncludeType,
        header_name: &str,
        _includer_name: &str,
        _include_depth: usize,
    ) -> Option<IncludeResult> {
        let path = self.0.join(header_name);
        let data = std::fs::read_to_string(&path).ok()?;
        Some(IncludeResult {
            name: path.display().to_string(),
            data,
        })
    }
}

/// Compiles one kernel; `kernel_index` (a wavefront kernel's place in `KERNELS`) is defined as
/// `KERNEL_INDEX` after the `#version` line, with `SCENE_ONE_BINDING` where `one_binding`,
/// `#line 2` keeping the file's line numbers.
fn compile(
    compiler: &Compiler,
    path: &Path,
    include_dir: &Path,
    kernel_index: Option<usize>,
    one_binding: bool,
) -> Result<Vec<u32>, String> {
    let mut text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    if let Some(k) = kernel_index {
        let end = text.find('\n').map_or(text.len(), |i| i + 1);
        let one = if one_binding {
            "#define SCENE_ONE_BINDING\n"
        } else {
            ""
        };
        text.insert_str(end, &format!("#define KERNEL_INDEX {k}u\n{one}#line 2\n"));
    }
    let source = ShaderSource::from(text);
    let options = CompilerOptions {
        source_language: SourceLanguage::GLSL,
        target: Target::Vulkan {
            version: VulkanVersion::Vulkan1_2,
            spirv_version: SpirvVersion::SPIRV1_3,
        },
        version_profile: None,
        messages: ShaderMessage::DEFAULT,
    };
    let mut includes = IncludeDir(include_dir.to_path_buf());
    let input = ShaderInput::new(
        &source,
        ShaderStage::Compute,
        &options,
        None::<&[(&str, Option<&str>)]>,
        Some(&mut includes),
    )
    .map_err(|e| format!("{}: {e}", path.display()))?;
    let shader = compiler
        .create_shader(input)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let log = shader.get_log();
    if log.to_ascii_uppercase().contains("WARNING") {
        return Err(format!("{}: warnings are errors:\n{log}", path.display()));
    }
    shader
        .compile()
        .map_err(|e| format!("{}: {e}", path.display()))
}

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let kernel_dir = root.join("shaders/wavefront");
    let test_dir = root.join("shaders/tests");
    let include_dir = root.join("shaders/inc");
    println!("cargo:rerun-if-changed=shaders");
    commit(&root);

    for dir in [&kernel_dir, &test_dir, &include_dir] {
        for entry in std::fs::read_dir(dir).expect("shader folder exists") {
            println!("cargo:rerun-if-changed={}", entry.unwrap().path().display());
        }
    }
    let compiler = Compiler::acquire().expect("glslang initialises");
    let mut table = String::new();
    let mut failures = Vec::new();
    // (constant, folder, doc, wavefront kernels (KERNEL_INDEX defined), SCENE_ONE_BINDING)
    for (constant, dir, doc, wavefront, one_binding) in [
        ("KERNELS", &kernel_dir, "Every wavefront kernel", true, false),
        (
            "KERNELS_ONE_BINDING",
            &kernel_dir,
            "Every wavefront kernel without the scene arrays' further bindings (SCENE_ONE_BINDING), \
             for devices that bind fewer storage buffers",
            true,
            true,
        ),
        (
            "TEST_KERNELS",
            &test_dir,
            "Kernels that run GLSL twins of Rust functions for the tests",
            false,
            false,
        ),
    ] {
        writeln!(table, "/// {doc}: (name, SPIR-V bytes).").unwrap();
        writeln!(table, "pub const {constant}: &[(&str, &[u8])] = &[").unwrap();
        let suffix = if one_binding { ".one_binding" } else { "" };
        for (k, path) in comp_files(dir).into_iter().enumerate() {
            let name = path.file_stem().unwrap().to_str().unwrap().to_owned();
            let index = wavefront.then_some(k);
            match compile(compiler, &path, &include_dir, index, one_binding) {
                Ok(words) => {
                    let spv = out.join(format!("{name}{suffix}.spv"));
                    std::fs::write(&spv, words_to_bytes(&words)).unwrap();
                    writeln!(
                        table,
                        "    ({name:?}, include_bytes!({:?})),",
                        spv.display()
                    )
                    .unwrap();
                }
                Err(e) => failures.push(e),
            }
        }
        table.push_str("];\n");
    }
    if !failures.is_empty() {
        for f in &failures {
            println!("cargo:warning={}", f.lines().next().unwrap_or(""));
        }
        panic!("shader compilation failed:\n{}", failures.join("\n"));
    }
    std::fs::write(out.join("kernels.rs"), table).unwrap();
}

/// The `.comp` files of a folder, sorted.
fn comp_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("shader folder exists")
        .map(|e| e.expect("readable shader folder").path())
        .filter(|p| p.extension().is_some_and(|e| e == "comp"))
        .collect();
    files.sort();
    files
}

fn words_to_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// `wavetrace --version` names the commit it was built from (WAVETRACE_COMMIT): `git describe`
/// of the checkout, with "-dirty" for uncommitted changes; "unknown" outside a git checkout
/// (a source archive). The build script runs again when HEAD moves.
fn commit(root: &std::path::Path) {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .current_dir(root)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
    };
    let described = git(&["describe", "--always", "--dirty", "--abbrev=12"]);
    println!(
        "cargo:rustc-env=WAVETRACE_COMMIT={}",
        described.as_deref().unwrap_or("unknown")
    );
    if let Some(dir) = git(&["rev-parse", "--absolute-git-dir"]) {
        let dir = std::path::Path::new(&dir);
        println!("cargo:rerun-if-changed={}", dir.join("HEAD").display());
        if let Some(head) = git(&["symbolic-ref", "-q", "HEAD"]) {
            println!("cargo:rerun-if-changed={}", dir.join(head).display());
        }
        println!("cargo:rerun-if-changed={}", dir.join("index").display());
    }
}
