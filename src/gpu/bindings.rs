//! The descriptor bindings every kernel shares, the Rust twin of `shaders/inc/bindings.glsl`
//! (and of `scene_arrays.glsl` for the scene arrays read from images): each binding's number and
//! kind, how many storage buffers a kernel binds, and how a scene larger than one storage binding
//! is split across bindings.

use anyhow::{bail, Result};
use ash::vk;

/// The bindings of `shaders/inc/bindings.glsl`, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Binding {
    Frame = 0,
    BvhNodes = 1,
    Triangles = 2,
    Materials = 3,
    Lights = 4,
    Paths = 5,
    Rays = 6,
    /// The hit records' instances (their t, triangle, u and v are `HitImage`'s texels).
    HitInstances = 7,
    Shadows = 8,
    Film = 9,
    Counters = 10,
    Args = 11,
    TriangleVertices = 12,
    Vertices = 13,
    Textures = 14,
    TextureRefs = 15,
    Texels = 16,
    Instances = 17,
    Punctual = 18,
    EnvTexels = 19,
    EnvConditional = 20,
    EnvMarginal = 21,
    LightNodes = 22,
    LightTrails = 23,
    /// Band-local indices of the pixels a pass of an adaptive render samples
    /// (`FrameParams::active_pixel_count`).
    ActivePixels = 24,
    /// Light tracing's splat sums: per pixel and channel a 64-bit fixed-point integer as two
    /// words (`light_tracing.glsl`, `splat_add`).
    Splats = 25,
    /// The `--paths` automata (`PathExpr::gpu_table`).
    PathDfa = 26,
    /// `--integrator bdpt`: both subpaths of every path in flight (`bdpt.glsl`).
    BdptVertices = 27,
    /// Chunks 1 to 3 of the five large scene arrays (`SplitArray`), for scenes one binding
    /// does not hold (`scene_arrays.glsl`).
    BvhNodes1 = 28,
    BvhNodes2 = 29,
    BvhNodes3 = 30,
    Triangles1 = 31,
    Triangles2 = 32,
    Triangles3 = 33,
    TriangleVertices1 = 34,
    TriangleVertices2 = 35,
    TriangleVertices3 = 36,
    Vertices1 = 37,
    Vertices2 = 38,
    Vertices3 = 39,
    Texels1 = 40,
    Texels2 = 41,
    Texels3 = 42,
    /// The `SceneImage` arrays as RGBA32UI storage images (read-only), which the kernels read
    /// instead of their storage buffers where `SceneSplit::images` says so.
    BvhNodeImage = 43,
    TriangleImage = 44,
    TriangleVertexImage = 45,
    VertexImage = 46,
    MaterialImage = 47,
    LightNodeImage = 48,
    TexelImage = 49,
    InstanceImage = 50,
    TextureImage = 51,
    TextureRefImage = 52,
    LightImage = 53,
    /// The same images as sampled images, which the kernels read instead where
    /// `SceneImages::Sampled` says so.
    BvhNodeSampled = 54,
    TriangleSampled = 55,
    TriangleVertexSampled = 56,
    VertexSampled = 57,
    MaterialSampled = 58,
    LightNodeSampled = 59,
    TexelSampled = 60,
    InstanceSampled = 61,
    TextureSampled = 62,
    TextureRefSampled = 63,
    LightSampled = 64,
    /// The hit records' first 16 bytes (t, triangle, u, v) as an RGBA32UI storage image, one
    /// texel a record (`hit_store`, `hit_load`; bindings.glsl), which `extend` writes and the
    /// shade kernels read: on llvmpipe a texel costs a fraction of four words of a storage
    /// buffer (docs/perf-log/2026-12-03-lavapipe-instructions.md).
    HitImage = 65,
}

impl Binding {
    pub const ALL: [Binding; 66] = [
        Binding::Frame,
        Binding::BvhNodes,
        Binding::Triangles,
        Binding::Materials,
        Binding::Lights,
        Binding::Paths,
        Binding::Rays,
        Binding::HitInstances,
        Binding::Shadows,
        Binding::Film,
        Binding::Counters,
        Binding::Args,
        Binding::TriangleVertices,
        Binding::Vertices,
        Binding::Textures,
        Binding::TextureRefs,
        Binding::Texels,
        Binding::Instances,
        Binding::Punctual,
        Binding::EnvTexels,
        Binding::EnvConditional,
        Binding::EnvMarginal,
        Binding::LightNodes,
        Binding::LightTrails,
        Binding::ActivePixels,
        Binding::Splats,
        Binding::PathDfa,
        Binding::BdptVertices,
        Binding::BvhNodes1,
        Binding::BvhNodes2,
        Binding::BvhNodes3,
        Binding::Triangles1,
        Binding::Triangles2,
        Binding::Triangles3,
        Binding::TriangleVertices1,
        Binding::TriangleVertices2,
        Binding::TriangleVertices3,
        Binding::Vertices1,
        Binding::Vertices2,
        Binding::Vertices3,
        Binding::Texels1,
        Binding::Texels2,
        Binding::Texels3,
        Binding::BvhNodeImage,
        Binding::TriangleImage,
        Binding::TriangleVertexImage,
        Binding::VertexImage,
        Binding::MaterialImage,
        Binding::LightNodeImage,
        Binding::TexelImage,
        Binding::InstanceImage,
        Binding::TextureImage,
        Binding::TextureRefImage,
        Binding::LightImage,
        Binding::BvhNodeSampled,
        Binding::TriangleSampled,
        Binding::TriangleVertexSampled,
        Binding::VertexSampled,
        Binding::MaterialSampled,
        Binding::LightNodeSampled,
        Binding::TexelSampled,
        Binding::InstanceSampled,
        Binding::TextureSampled,
        Binding::TextureRefSampled,
        Binding::LightSampled,
        Binding::HitImage,
    ];
    /// Chunks 1 to 3 of a split scene array: bindings the kernels built with SCENE_ONE_BINDING
    /// (`KERNELS_ONE_BINDING`) do not declare.
    pub const fn is_further_chunk(self) -> bool {
        self as u32 >= Binding::BvhNodes1 as u32 && self as u32 <= Binding::Texels3 as u32
    }

    /// Whether the kernels of the set `one_binding` names declare it (the layout holds it).
    pub const fn declared(self, one_binding: bool) -> bool {
        !(one_binding && self.is_further_chunk())
    }

    pub fn descriptor_type(self) -> vk::DescriptorType {
        match self {
            Binding::Frame => vk::DescriptorType::UNIFORM_BUFFER,
            Binding::HitImage => vk::DescriptorType::STORAGE_IMAGE,
            b if b as u32 >= Binding::BvhNodeSampled as u32 => vk::DescriptorType::SAMPLED_IMAGE,
            b if b as u32 >= Binding::BvhNodeImage as u32 => vk::DescriptorType::STORAGE_IMAGE,
            _ => vk::DescriptorType::STORAGE_BUFFER,
        }
    }
}

/// How the kernels read the scene arrays of [`SceneImage`]: from storage buffers, or from
/// images as storage images (`imageLoad`) or as sampled images (`texelFetch`). The same texels
/// either way, so the same images bit for bit; only the speed differs. The discriminant is the
/// kernels' specialization constant 5 (`SCENE_IMAGES`, `scene_arrays.glsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum SceneImages {
    Buffers = 0,
    Storage = 1,
    Sampled = 2,
}

impl SceneImages {
    /// The kind a device reads by default: storage images on a CPU implementation, where
    /// llvmpipe's `imageLoad` costs about a quarter of its `texelFetch`
    /// (docs/perf-log/2026-12-02-lavapipe-scene-reads.md); sampled images on a GPU, which the one GPU measured (an NVIDIA H200,
    /// 4 December 2026) rendered with, until a session with one compares the two.
    /// `WAVETRACE_SCENE_IMAGES` = `buffers` (or `0`), `storage` or `sampled` overrides it.
    pub fn for_device(cpu: bool, env: Option<&str>) -> Result<SceneImages> {
        Ok(match env {
            None | Some("") | Some("1") if cpu => SceneImages::Storage,
            None | Some("") | Some("1") => SceneImages::Sampled,
            Some("0") | Some("buffers") => SceneImages::Buffers,
            Some("storage") => SceneImages::Storage,
            Some("sampled") => SceneImages::Sampled,
            Some(other) => {
                bail!("WAVETRACE_SCENE_IMAGES={other}: expected buffers (or 0), storage or sampled")
            }
        })
    }

    /// As `render --stats` names it.
    pub fn describe(self) -> &'static str {
        match self {
            SceneImages::Buffers => "storage buffers",
            SceneImages::Storage => "storage images",
            SceneImages::Sampled => "sampled images",
        }
    }
}

/// The read-only scene arrays that the kernels read from images (`scene_arrays.glsl`), laid row
/// after row: records of a whole number of RGBA32UI texels, or the textures' RGBA8 texels one
/// R32UI texel each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneImage {
    BvhNodes,
    Triangles,
    TriangleVertices,
    Vertices,
    Materials,
    LightNodes,
    Texels,
    Instances,
    Textures,
    TextureRefs,
    Lights,
}

impl SceneImage {
    pub const ALL: [SceneImage; 11] = [
        SceneImage::BvhNodes,
        SceneImage::Triangles,
        SceneImage::TriangleVertices,
        SceneImage::Vertices,
        SceneImage::Materials,
        SceneImage::LightNodes,
        SceneImage::Texels,
        SceneImage::Instances,
        SceneImage::Textures,
        SceneImage::TextureRefs,
        SceneImage::Lights,
    ];

    pub fn binding(self) -> Binding {
        match self {
            SceneImage::BvhNodes => Binding::BvhNodeImage,
            SceneImage::Triangles => Binding::TriangleImage,
            SceneImage::TriangleVertices => Binding::TriangleVertexImage,
            SceneImage::Vertices => Binding::VertexImage,
            SceneImage::Materials => Binding::MaterialImage,
            SceneImage::LightNodes => Binding::LightNodeImage,
            SceneImage::Texels => Binding::TexelImage,
            SceneImage::Instances => Binding::InstanceImage,
            SceneImage::Textures => Binding::TextureImage,
            SceneImage::TextureRefs => Binding::TextureRefImage,
            SceneImage::Lights => Binding::LightImage,
        }
    }

    /// The binding of the same image as a sampled image.
    pub fn sampled_binding(self) -> Binding {
        match self {
            SceneImage::BvhNodes => Binding::BvhNodeSampled,
            SceneImage::Triangles => Binding::TriangleSampled,
            SceneImage::TriangleVertices => Binding::TriangleVertexSampled,
            SceneImage::Vertices => Binding::VertexSampled,
            SceneImage::Materials => Binding::MaterialSampled,
            SceneImage::LightNodes => Binding::LightNodeSampled,
            SceneImage::Texels => Binding::TexelSampled,
            SceneImage::Instances => Binding::InstanceSampled,
            SceneImage::Textures => Binding::TextureSampled,
            SceneImage::TextureRefs => Binding::TextureRefSampled,
            SceneImage::Lights => Binding::LightSampled,
        }
    }

    /// Its image's name, as `WAVETRACE_FAULT=oom@NAME` names it.
    pub fn name(self) -> &'static str {
        match self {
            SceneImage::BvhNodes => "bvh_node_image",
            SceneImage::Triangles => "triangle_image",
            SceneImage::TriangleVertices => "triangle_vertex_image",
            SceneImage::Vertices => "vertex_image",
            SceneImage::Materials => "material_image",
            SceneImage::LightNodes => "light_node_image",
            SceneImage::Texels => "texel_image",
            SceneImage::Instances => "instance_image",
            SceneImage::Textures => "texture_image",
            SceneImage::TextureRefs => "texture_ref_image",
            SceneImage::Lights => "light_image",
        }
    }

    /// Its texels' format.
    pub fn format(self) -> vk::Format {
        match self {
            SceneImage::Texels => vk::Format::R32_UINT,
            _ => vk::Format::R32G32B32A32_UINT,
        }
    }

    /// Bytes of one texel.
    pub fn texel_bytes(self) -> u64 {
        match self {
            SceneImage::Texels => 4,
            _ => 16,
        }
    }

    /// The scene's records of this array, as bytes.
    pub fn data(self, scene: &crate::render::PreparedScene) -> &[u8] {
        match self {
            SceneImage::BvhNodes => bytemuck::cast_slice(&scene.gpu_bvh().nodes),
            SceneImage::Triangles => bytemuck::cast_slice(&scene.triangles),
            SceneImage::TriangleVertices => bytemuck::cast_slice(&scene.triangle_vertices),
            SceneImage::Vertices => bytemuck::cast_slice(&scene.vertices),
            SceneImage::Materials => bytemuck::cast_slice(&scene.materials),
            SceneImage::LightNodes => bytemuck::cast_slice(&scene.light_nodes),
            SceneImage::Texels => bytemuck::cast_slice(scene.texels.as_slice()),
            SceneImage::Instances => bytemuck::cast_slice(&scene.gpu_bvh().instances),
            SceneImage::Textures => bytemuck::cast_slice(&scene.textures),
            SceneImage::TextureRefs => bytemuck::cast_slice(&scene.texture_refs),
            SceneImage::Lights => bytemuck::cast_slice(&scene.lights),
        }
    }

    /// Rows of its image for `scene`.
    pub fn rows(self, scene: &crate::render::PreparedScene) -> u64 {
        let texels = self.data(scene).len() as u64 / self.texel_bytes();
        texels.div_ceil(SCENE_IMAGE_WIDTH as u64).max(1)
    }
}

/// Bindings each large scene array may span.
pub const SPLIT_BINDINGS: usize = 4;

/// The scene arrays that may span several bindings (`shaders/inc/scene_arrays.glsl`), in the
/// order of their specialization constants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SplitArray {
    BvhNodes = 0,
    Triangles = 1,
    TriangleVertices = 2,
    Vertices = 3,
    Texels = 4,
}

impl SplitArray {
    pub const ALL: [SplitArray; 5] = [
        SplitArray::BvhNodes,
        SplitArray::Triangles,
        SplitArray::TriangleVertices,
        SplitArray::Vertices,
        SplitArray::Texels,
    ];

    /// The array's bindings, chunk 0 first.
    pub fn bindings(self) -> [Binding; SPLIT_BINDINGS] {
        use Binding as B;
        match self {
            SplitArray::BvhNodes => [B::BvhNodes, B::BvhNodes1, B::BvhNodes2, B::BvhNodes3],
            SplitArray::Triangles => [B::Triangles, B::Triangles1, B::Triangles2, B::Triangles3],
            SplitArray::TriangleVertices => [
                B::TriangleVertices,
                B::TriangleVertices1,
                B::TriangleVertices2,
                B::TriangleVertices3,
            ],
            SplitArray::Vertices => [B::Vertices, B::Vertices1, B::Vertices2, B::Vertices3],
            SplitArray::Texels => [B::Texels, B::Texels1, B::Texels2, B::Texels3],
        }
    }

    /// Its buffer's name (chunk 0; chunk c adds `[c]`), as `WAVETRACE_FAULT=oom@NAME` names it.
    pub fn buffer_name(self) -> &'static str {
        match self {
            SplitArray::BvhNodes => "bvh_nodes",
            SplitArray::Triangles => "triangles",
            SplitArray::TriangleVertices => "triangle_vertices",
            SplitArray::Vertices => "vertices",
            SplitArray::Texels => "texels",
        }
    }

    /// What the array holds, for messages.
    pub fn what(self) -> &'static str {
        match self {
            SplitArray::BvhNodes => "BVH nodes",
            SplitArray::Triangles => "triangles",
            SplitArray::TriangleVertices => "triangle vertex indices",
            SplitArray::Vertices => "vertices",
            SplitArray::Texels => "texels",
        }
    }
}

/// How a scene's large arrays are laid over their bindings: per `SplitArray`, log2 of the
/// elements one binding holds, or 32 where the first binding holds the whole array, and how the
/// scene images are read (storage buffers, storage images `Binding::BvhNodeImage` or sampled
/// images `Binding::BvhNodeSampled`). The shifts are the kernels' specialization constants 0 to
/// 4, `reads` constant 5 (`scene_arrays.glsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneSplit {
    pub shifts: [u32; 5],
    pub reads: SceneImages,
}

impl SceneSplit {
    /// Every array in one binding, read from storage images (`plan`'s split before the renderer
    /// sets `reads`).
    pub const NONE: SceneSplit = SceneSplit::whole(SceneImages::Storage);

    /// The split of arrays of `lengths` elements of `sizes` bytes into bindings of at most
    /// `binding_bytes` each: one binding where it holds the array, else the largest power of two
    /// of elements that fits, or an error naming the array where four bindings are too few.
    pub fn plan(lengths: [u64; 5], sizes: [u64; 5], binding_bytes: [u64; 5]) -> Result<SceneSplit> {
        let mut shifts = [32; 5];
        for (k, array) in SplitArray::ALL.into_iter().enumerate() {
            let bytes = lengths[k] * sizes[k];
            if bytes <= binding_bytes[k] {
                continue;
            }
            let per_binding = binding_bytes[k] / sizes[k];
            if per_binding == 0 {
                bail!(
                    "one of the scene's {} is larger than a storage binding",
                    array.what()
                );
            }
            let shift = 63 - per_binding.leading_zeros();
            let capacity = (SPLIT_BINDINGS as u64) << shift;
            if lengths[k] > capacity {
                bail!(
                    "the scene's {} take {} MiB, more than the {} MiB that {SPLIT_BINDINGS} storage \
                     bindings of this device hold ({} of them); render it with --device cpu",
                    array.what(),
                    bytes >> 20,
                    (capacity * sizes[k]) >> 20,
                    capacity
                );
            }
            shifts[k] = shift;
        }
        Ok(SceneSplit {
            shifts,
            ..SceneSplit::NONE
        })
    }

    /// Every array in one binding, read as `reads` says.
    pub const fn whole(reads: SceneImages) -> SceneSplit {
        SceneSplit {
            shifts: [32; 5],
            reads,
        }
    }

    /// Whether the scene arrays are read from images (of either kind), not storage buffers.
    pub fn images(&self) -> bool {
        self.reads != SceneImages::Buffers
    }

    /// Elements of array `k` in one binding (all of them where it is not split).
    pub fn per_binding(&self, k: usize) -> Option<u64> {
        (self.shifts[k] < 32).then(|| 1u64 << self.shifts[k])
    }
}

/// Storage buffers every wavefront kernel binds: all bindings but the frame's uniform buffer,
/// the scene images and the wavefront's images.
pub const STORAGE_BUFFERS: u32 =
    (Binding::ALL.len() - 1 - WAVEFRONT_IMAGES as usize - 2 * SceneImage::ALL.len()) as u32;

/// The wavefront's own storage images: the hit records' (`Binding::HitImage`).
pub const WAVEFRONT_IMAGES: u32 = 1;

/// Storage buffers the kernels built with SCENE_ONE_BINDING bind: all but the further chunks.
pub const STORAGE_BUFFERS_ONE_BINDING: u32 = STORAGE_BUFFERS - further_chunks();

const fn further_chunks() -> u32 {
    let (mut n, mut i) = (0, 0);
    while i < Binding::ALL.len() {
        n += Binding::ALL[i].is_further_chunk() as u32;
        i += 1;
    }
    n
}

/// Texels per row of a scene image (`scene_arrays.glsl`, `SCENE_IMAGE_SHIFT`).
pub const SCENE_IMAGE_WIDTH: u32 = 1 << 12;

#[cfg(test)]
mod tests {
    use super::*;

    const SIZES: [u64; 5] = [32, 48, 16, 64, 4];

    /// A CPU device reads the scene images as storage images, a GPU as sampled images, unless
    /// WAVETRACE_SCENE_IMAGES names a kind; an unknown name is an error that says the choices;
    /// the kind is specialization constant 5.
    #[test]
    fn scene_images_by_device_and_environment() {
        use SceneImages::*;
        for (cpu, env, want) in [
            (true, None, Storage),
            (false, None, Sampled),
            (true, Some("1"), Storage),
            (false, Some(""), Sampled),
            (true, Some("0"), Buffers),
            (false, Some("buffers"), Buffers),
            (false, Some("storage"), Storage),
            (true, Some("sampled"), Sampled),
        ] {
            assert_eq!(
                SceneImages::for_device(cpu, env).unwrap(),
                want,
                "{cpu} {env:?}"
            );
        }
        let err = SceneImages::for_device(true, Some("texels")).unwrap_err();
        assert!(
            err.to_string()
                .contains("buffers (or 0), storage or sampled"),
            "{err}"
        );
        assert_eq!([Buffers, Storage, Sampled].map(|r| r as u32), [0, 1, 2]);
    }

    #[test]
    fn a_scene_that_fits_is_not_split() {
        let split = SceneSplit::plan([10, 10, 10, 10, 10], SIZES, [1 << 27; 5]).unwrap();
        assert_eq!(split, SceneSplit::NONE);
    }

    #[test]
    fn five_million_triangles_take_three_bindings_of_lavapipe() {
        // 128 MiB bindings hold 2^21 triangles of 48 bytes (2^21 · 48 = 96 MiB; 2^22 would be
        // 192 MiB): 5 M triangles need three.
        let n = 5_000_000;
        let split = SceneSplit::plan([n, n, n, n / 2, 0], SIZES, [1 << 27; 5]).unwrap();
        assert_eq!(split.per_binding(1), Some(1 << 21));
        assert_eq!(
            split.per_binding(2),
            None,
            "80 MB of vertex indices fit one binding"
        );
        assert_eq!(split.per_binding(3), Some(1 << 21));
        assert_eq!(split.per_binding(4), None);
    }

    #[test]
    fn an_array_too_large_for_four_bindings_is_refused_by_name() {
        let n = 9_000_000; // 4 · 2^21 = 8.4 M triangles fit
        let err = SceneSplit::plan([1, n, 1, 1, 1], SIZES, [1 << 27; 5]).unwrap_err();
        let msg = format!("{err:#}");
        assert!(msg.contains("the scene's triangles take 411 MiB"), "{msg}");
        assert!(msg.contains("--device cpu"), "{msg}");
    }
}
