//! Every embedded SPIR-V module parses and validates with naga, every GPU struct's reflected
//! offsets and size equal its `#[repr(C)]` twin in src/layout.rs, and every descriptor binding
//! a kernel declares has the kind the host's descriptor set layout gives it (DESIGN.md,
//! Verification 5).

use ash::vk;
use naga::{
    AddressSpace, ImageClass, ImageDimension, Module, ScalarKind, StorageAccess, StorageFormat,
    TypeInner,
};
use std::collections::BTreeSet;
use wavetrace::gpu::bindings::{Binding, STORAGE_BUFFERS_ONE_BINDING};
use wavetrace::gpu::pipelines::kernel_spirv;
use wavetrace::kernels::{KERNELS, KERNELS_ONE_BINDING, TEST_KERNELS};
use wavetrace::layout::STRUCT_LAYOUTS;

/// The module with its specialisation constants made plain constants of their default values,
/// as a pipeline made without specialisation runs it: naga reads a constant decorated with a
/// SpecId as an override, and sizes no array by one (the quantised walks' deferred array,
/// `QBVH_STACK_SIZE`, is one), so every `OpDecorate <id> SpecId <n>` becomes a decoration of
/// the same length that naga skips (Alignment <n>), and naga validates each kernel as
/// specialised to its defaults.
fn with_default_constants(mut words: Vec<u32>) -> Vec<u32> {
    const OP_DECORATE: u32 = 71;
    const SPEC_ID: u32 = 1;
    const ALIGNMENT: u32 = 44;
    let mut at = 5; // past the header
    while at < words.len() {
        let (count, opcode) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if opcode == OP_DECORATE && count == 4 && words[at + 2] == SPEC_ID {
            words[at + 2] = ALIGNMENT;
        }
        at += count.max(1);
    }
    words
}

fn parse(name: &str) -> Module {
    parse_of(name, false)
}

/// A test kernel, or a wavefront kernel of the set `one_binding` names (`kernels`).
fn parse_of(name: &str, one_binding: bool) -> Module {
    let words = match TEST_KERNELS.iter().find(|(n, _)| *n == name) {
        Some((_, bytes)) => ash::util::read_spv(&mut std::io::Cursor::new(bytes)).unwrap(),
        None => kernel_spirv(name, one_binding).unwrap(),
    };
    let words = with_default_constants(words);
    naga::front::spv::parse_u8_slice(
        bytemuck::cast_slice(&words),
        &naga::front::spv::Options::default(),
    )
    .unwrap_or_else(|e| panic!("naga cannot parse kernel {name}: {e:?}"))
}

#[test]
fn every_kernel_parses_and_validates() {
    assert!(
        KERNELS.len() >= 6,
        "expected the six wavefront kernels, found {}",
        KERNELS.len()
    );
    let names: Vec<(&str, bool)> = KERNELS
        .iter()
        .chain(TEST_KERNELS)
        .map(|(n, _)| (*n, false))
        .chain(KERNELS_ONE_BINDING.iter().map(|(n, _)| (*n, true)))
        .collect();
    for (name, one_binding) in names {
        let module = parse_of(name, one_binding);
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| {
            panic!("naga rejects kernel {name} (one binding: {one_binding}): {e:?}")
        });
    }
}

/// The kernels built with SCENE_ONE_BINDING are the same kernels, bound alike, less the split
/// arrays' further chunks: within the storage buffers a device of [`STORAGE_BUFFERS_ONE_BINDING`]
/// binds (SwiftShader's 30).
#[test]
fn one_binding_kernels_leave_out_the_further_chunks() {
    let names = |set: &[(&str, &[u8])]| set.iter().map(|(n, _)| n.to_string()).collect::<Vec<_>>();
    assert_eq!(names(KERNELS), names(KERNELS_ONE_BINDING));
    let bindings = |module: &Module| -> BTreeSet<u32> {
        module
            .global_variables
            .iter()
            .filter_map(|(_, var)| var.binding.as_ref().map(|rb| rb.binding))
            .collect()
    };
    let further: BTreeSet<u32> = Binding::ALL
        .iter()
        .filter(|b| b.is_further_chunk())
        .map(|&b| b as u32)
        .collect();
    for (name, _) in KERNELS {
        let (all, one) = (
            bindings(&parse_of(name, false)),
            bindings(&parse_of(name, true)),
        );
        assert!(
            one.is_disjoint(&further),
            "{name} declares a further chunk: {one:?}"
        );
        assert_eq!(
            all.difference(&further).copied().collect::<BTreeSet<u32>>(),
            one,
            "{name}: the one-binding build binds otherwise"
        );
        let storage = one
            .iter()
            .filter(|&&b| {
                Binding::ALL
                    .iter()
                    .find(|x| **x as u32 == b)
                    .unwrap()
                    .descriptor_type()
                    == vk::DescriptorType::STORAGE_BUFFER
            })
            .count() as u32;
        assert!(
            storage <= STORAGE_BUFFERS_ONE_BINDING,
            "{name} binds {storage} storage buffers"
        );
    }
}

#[test]
fn gpu_structs_match_their_rust_twins() {
    let modules: Vec<(&str, Module)> = KERNELS.iter().map(|(n, _)| (*n, parse(n))).collect();
    for layout in STRUCT_LAYOUTS {
        let mut found = false;
        for (kernel, module) in &modules {
            for (_, ty) in module.types.iter() {
                if ty.name.as_deref() != Some(layout.name) {
                    continue;
                }
                let TypeInner::Struct { members, span } = &ty.inner else {
                    continue;
                };
                found = true;
                assert_eq!(
                    *span as usize, layout.size,
                    "{kernel}: size of {} differs from Rust",
                    layout.name
                );
                let glsl: Vec<(String, usize)> = members
                    .iter()
                    .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
                    .collect();
                let rust: Vec<(String, usize)> = layout
                    .members
                    .iter()
                    .map(|(n, o)| (n.to_string(), *o))
                    .collect();
                assert_eq!(
                    glsl, rust,
                    "{kernel}: members (name, offset) of {} differ between GLSL and Rust",
                    layout.name
                );
            }
        }
        assert!(
            found,
            "struct {} of src/layout.rs is used by no kernel",
            layout.name
        );
    }
}

#[test]
fn descriptor_bindings_match_the_host_layout() {
    let mut used = BTreeSet::new();
    for (name, _) in KERNELS {
        let module = parse(name);
        for (_, var) in module.global_variables.iter() {
            let Some(rb) = &var.binding else { continue };
            assert_eq!(rb.group, 0, "{name}: {:?} is in set {}", var.name, rb.group);
            let binding = Binding::ALL
                .iter()
                .find(|b| **b as u32 == rb.binding)
                .unwrap_or_else(|| {
                    panic!("{name}: binding {} is not in the host's layout", rb.binding)
                });
            let expected = binding.descriptor_type();
            let found = match var.space {
                AddressSpace::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
                AddressSpace::Storage { .. } => vk::DescriptorType::STORAGE_BUFFER,
                // The scene images: read-only 2-D storage images of RGBA32UI texels (the
                // textures' R32UI), read by imageLoad; the hit records' image, which extend
                // writes, read-write.
                AddressSpace::Handle => match module.types[var.ty].inner {
                    TypeInner::Image {
                        dim: ImageDimension::D2,
                        arrayed: false,
                        class: ImageClass::Storage { format, access },
                    } => {
                        let want = if *binding == Binding::TexelImage {
                            StorageFormat::R32Uint
                        } else {
                            StorageFormat::Rgba32Uint
                        };
                        assert_eq!(format, want, "{name}: binding {}'s format", rb.binding);
                        let access_wanted = if *binding == Binding::HitImage {
                            StorageAccess::LOAD | StorageAccess::STORE
                        } else {
                            StorageAccess::LOAD
                        };
                        assert_eq!(
                            access, access_wanted,
                            "{name}: binding {}'s access",
                            rb.binding
                        );
                        vk::DescriptorType::STORAGE_IMAGE
                    }
                    // The same images as sampled images, read by texelFetch.
                    TypeInner::Image {
                        dim: ImageDimension::D2,
                        arrayed: false,
                        class:
                            ImageClass::Sampled {
                                kind: ScalarKind::Uint,
                                multi: false,
                            },
                    } => vk::DescriptorType::SAMPLED_IMAGE,
                    ref other => panic!("{name}: binding {} is a {other:?}", rb.binding),
                },
                other => panic!(
                    "{name}: binding {} has unexpected address space {other:?}",
                    rb.binding
                ),
            };
            assert_eq!(
                found, expected,
                "{name}: binding {} is a {found:?}, host says {binding:?} ({expected:?})",
                rb.binding
            );
            used.insert(rb.binding);
        }
    }
    assert_eq!(
        used.len(),
        Binding::ALL.len(),
        "some host bindings are used by no kernel: {used:?}"
    );
}

/// The value of a constant as src/layout.rs or layout.glsl writes it (`64`, `0x3fffffffu`,
/// `(1u << 24)`, `1 << 20`, `u32::MAX`); None for anything else (an expression of other names).
fn constant_value(text: &str) -> Option<u64> {
    let t = text
        .trim()
        .trim_start_matches('(')
        .trim_end_matches(')')
        .trim();
    let number = |n: &str| -> Option<u64> {
        let n = n.trim().trim_end_matches('u').replace('_', "");
        match n.strip_prefix("0x") {
            Some(hex) => u64::from_str_radix(hex, 16).ok(),
            None if n == "u32::MAX" => Some(u32::MAX as u64),
            None => n.parse().ok(),
        }
    };
    match t.split_once("<<") {
        Some((a, b)) => Some(number(a)? << number(b)?),
        None => number(t),
    }
}

/// Every integer constant of layout.glsl has a twin of the same name and value in
/// src/layout.rs (the constants of its `counter` and `args` modules as COUNTER_* and ARGS_*):
/// the shared constants are defined once per language, in the checked layout.
#[test]
fn shared_constants_have_the_same_values_in_both_languages() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let rust = std::fs::read_to_string(root.join("src/layout.rs")).unwrap();
    let mut rust_constants = std::collections::BTreeMap::new();
    let mut module = String::new();
    for line in rust.lines() {
        if let Some(name) = line
            .strip_prefix("pub mod ")
            .and_then(|l| l.strip_suffix(" {"))
        {
            module = name.to_owned();
        } else if line == "}" {
            module.clear();
        }
        let Some(decl) = line.trim().strip_prefix("pub const ") else {
            continue;
        };
        let Some((name, rest)) = decl.split_once(": u32 = ") else {
            continue;
        };
        let prefix = match module.as_str() {
            "counter" => "COUNTER_",
            "args" => "ARGS_",
            _ => "",
        };
        if let Some(v) = constant_value(rest.trim_end_matches(';')) {
            rust_constants.insert(format!("{prefix}{name}"), v);
        }
    }
    let glsl = std::fs::read_to_string(root.join("shaders/inc/layout.glsl")).unwrap();
    let (mut compared, mut differ, mut alone) = (0, Vec::new(), Vec::new());
    for line in glsl.lines() {
        let Some(def) = line.strip_prefix("#define ") else {
            continue;
        };
        let def = def.split("//").next().unwrap().trim();
        let Some((name, value)) = def.split_once(char::is_whitespace) else {
            continue;
        };
        let Some(value) = constant_value(value) else {
            continue;
        };
        match rust_constants.get(name) {
            Some(&v) if v == value => compared += 1,
            Some(&v) => differ.push(format!("{name}: layout.glsl {value}, layout.rs {v}")),
            None => alone.push(name.to_owned()),
        }
    }
    assert!(differ.is_empty(), "constants that differ: {differ:?}");
    assert!(
        alone.is_empty(),
        "layout.glsl constants without a twin in src/layout.rs: {alone:?}"
    );
    assert!(compared >= 80, "only {compared} constants compared");
}
