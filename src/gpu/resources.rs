//! The buffers of one render: the scene (uploaded once), the wavefront's queues sized for the
//! paths in flight, the film band, counters and indirect arguments, all bound to the one
//! descriptor set.

use super::bindings::SCENE_IMAGE_WIDTH;
use super::bindings::{Binding, SceneImage, SceneSplit, SplitArray};
use super::context::Context;
use super::memory::{Buffer, Commands, Image, Location};
use super::pipelines::Pipelines;
use crate::layout::{
    args, counter, BdptVertex, FilmPixel, FrameParams, PathState, QueuedRay, ShadowRay,
};
use crate::lights::environment::EnvironmentMap;
use crate::render::PreparedScene;
use anyhow::{bail, Result};
use ash::vk;
use std::mem::{size_of, size_of_val};

/// Largest staging buffer of the scene upload.
const STAGING_BYTES: usize = 64 << 20;

/// Longest a submission may run before the render is abandoned as hung.
pub const SUBMIT_TIMEOUT_S: u64 = 300;

pub struct RenderBuffers {
    pub frame: Buffer,
    pub film: Buffer,
    pub film_back: Buffer,
    pub counters: Buffer,
    pub counters_back: Buffer,
    pub args: Buffer,
    /// The active-pixel list of adaptive passes (`Binding::ActivePixels`) and its host upload.
    pub active_pixels: Buffer,
    pub active_upload: Buffer,
    /// Light tracing's splat sums over the whole image (`Binding::Splats`), 24 bytes a pixel.
    pub splats: Buffer,
    pub path_dfa: Buffer,
    /// The ray queues (`Binding::Rays`) and the hit records `extend` writes
    /// (`Binding::HitImage`), the shadow queue (`Binding::Shadows`) and the path states whose
    /// radiance `connect` adds to (`Binding::Paths`): [`super::GpuRenderer::trace_closest`] and
    /// [`super::GpuRenderer::trace_any`] fill the queues and read the results back.
    pub rays: Buffer,
    pub hit_image: Image,
    pub shadows: Buffer,
    pub paths: Buffer,
    /// Bindings each `SplitArray` uses (1 where it is not split).
    pub split_bindings: [u32; 5],
    /// Scene and queue buffers: only the descriptor set refers to them.
    _bound: Vec<Buffer>,
    /// BVH nodes and triangles as images (`Binding::BvhNodeImage`).
    _images: Vec<Image>,
}

/// Fills `image` with `data` (zeros after its end) through staging buffers of whole rows.
fn upload_rows(ctx: &Context, commands: &Commands, image: &Image, data: &[u8]) -> Result<()> {
    use vk::BufferUsageFlags as U;
    let row_bytes = image.row_bytes as usize;
    let rows_per_copy = (STAGING_BYTES / row_bytes).min(image.rows as usize);
    let staging = Buffer::new(
        ctx,
        "image_staging",
        (rows_per_copy * row_bytes) as u64,
        U::TRANSFER_SRC,
        Location::Host,
    )?;
    commands.begin()?;
    commands.image_layout(
        image,
        vk::ImageLayout::UNDEFINED,
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
    );
    let mut row = 0;
    while row < image.rows as usize {
        let rows = rows_per_copy.min(image.rows as usize - row);
        let from = (row * row_bytes).min(data.len());
        let to = ((row + rows) * row_bytes).min(data.len());
        staging.write(&data[from..to]);
        // Zeros after the data's end (the last row's rest, or a whole blank image).
        if to - from < rows * row_bytes {
            staging.write_at(to - from, &vec![0u8; rows * row_bytes - (to - from)]);
        }
        commands.copy_rows_to_image(&staging, 0, image, row as u32, rows as u32);
        row += rows;
        if row < image.rows as usize {
            commands.submit_and_wait(ctx, "the scene upload", SUBMIT_TIMEOUT_S)?;
            commands.begin()?;
        }
    }
    commands.image_layout(
        image,
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::ImageLayout::GENERAL,
    );
    commands.submit_and_wait(ctx, "the scene upload", SUBMIT_TIMEOUT_S)
}

impl RenderBuffers {
    /// Creates every buffer for `capacity` paths in flight, a film of `band_pixels` and an
    /// active-pixel list of `active_pixels` entries (0 for renders that never use one), splat
    /// sums for `splat_pixels` and `bdpt_vertices` subpath vertices (0 for the path tracer),
    /// binds them and uploads the scene. The film's read-back buffer also uploads a band's
    /// accumulators between the passes of a render that stops at a target error.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &Context,
        pipelines: &Pipelines,
        split: &SceneSplit,
        commands: &Commands,
        scene: &PreparedScene,
        env: &EnvironmentMap,
        capacity: u64,
        band_pixels: u64,
        active_pixels: u64,
        splat_pixels: u64,
        bdpt_vertices: u64,
        path_expr: Option<&crate::paths::PathExpr>,
    ) -> Result<RenderBuffers> {
        use vk::BufferUsageFlags as U;
        let storage = U::STORAGE_BUFFER | U::TRANSFER_DST | U::TRANSFER_SRC;
        let device = |name: &str, bytes: usize| {
            Buffer::new(ctx, name, bytes as u64, storage, Location::Device)
        };
        let host =
            |name: &str, bytes: u64| Buffer::new(ctx, name, bytes, U::TRANSFER_DST, Location::Host);
        let cap = capacity as usize;
        let film_bytes = band_pixels * size_of::<FilmPixel>() as u64;
        let range = ctx.properties.limits.max_storage_buffer_range as usize;
        // (BVH nodes, triangles, vertices and texels may span several bindings: `split`.)
        for (what, bytes) in [
            ("emitters", size_of_val(scene.lights.as_slice())),
            ("light BVH nodes", size_of_val(scene.light_nodes.as_slice())),
            ("materials", size_of_val(scene.materials.as_slice())),
            ("textures", size_of_val(scene.textures.as_slice())),
            (
                "instances",
                size_of_val(scene.gpu_bvh().instances.as_slice()),
            ),
            (
                "emitting triangles' light trails",
                size_of_val(scene.light_trails.as_slice()),
            ),
            ("environment map", size_of_val(env.texels.as_slice())),
            ("environment CDFs", size_of_val(env.conditional.as_slice())),
        ] {
            if bytes > range {
                bail!(
                    "the scene's {what} take {} MiB, more than the {} MiB one storage buffer of {} may hold; \
                     render it with --device cpu",
                    bytes >> 20,
                    range >> 20,
                    ctx.info.name
                );
            }
        }

        let frame = Buffer::new(
            ctx,
            "frame",
            size_of::<FrameParams>() as u64,
            U::UNIFORM_BUFFER,
            Location::Host,
        )?;
        // The large arrays, each in up to SPLIT_BINDINGS chunks of `split`'s size.
        // (The arrays read from images have no buffer.)
        fn in_buffer(images: bool, data: &[u8]) -> &[u8] {
            if images {
                &[]
            } else {
                data
            }
        }
        let in_buffer = |data| in_buffer(split.images(), data);
        let split_data: [&[u8]; 5] = [
            in_buffer(bytemuck::cast_slice(&scene.gpu_bvh().nodes)),
            in_buffer(bytemuck::cast_slice(&scene.triangles)),
            in_buffer(bytemuck::cast_slice(&scene.triangle_vertices)),
            in_buffer(bytemuck::cast_slice(&scene.vertices)),
            in_buffer(bytemuck::cast_slice(scene.texels.as_slice())),
        ];
        let element_bytes = [
            size_of::<crate::layout::BvhNode>(),
            size_of::<crate::layout::GpuTriangle>(),
            size_of::<glam::UVec4>(),
            size_of::<crate::layout::GpuVertex>(),
            size_of::<u32>(),
        ];
        let mut chunks: Vec<(SplitArray, usize, Buffer, &[u8])> = Vec::new();
        for array in SplitArray::ALL {
            let k = array as usize;
            let data = split_data[k];
            let chunk_bytes = split
                .per_binding(k)
                .map_or(data.len().max(1), |n| n as usize * element_bytes[k]);
            for (c, piece) in data
                .chunks(chunk_bytes)
                .chain(data.is_empty().then_some(data))
                .enumerate()
            {
                let name = match c {
                    0 => array.buffer_name().to_string(),
                    c => format!("{}[{c}]", array.buffer_name()),
                };
                chunks.push((array, c, device(&name, piece.len())?, piece));
            }
        }
        let materials = device("materials", size_of_val(scene.materials.as_slice()))?;
        let lights = device("lights", size_of_val(scene.lights.as_slice()))?;
        let textures = device("textures", size_of_val(scene.textures.as_slice()))?;
        let texture_refs = device("texture_refs", size_of_val(scene.texture_refs.as_slice()))?;
        let instances = device(
            "instances",
            size_of_val(scene.gpu_bvh().instances.as_slice()),
        )?;
        let punctual = device("punctual_lights", size_of_val(scene.punctual.as_slice()))?;
        let env_texels = device("env_texels", size_of_val(env.texels.as_slice()))?;
        let env_conditional = device("env_conditional", size_of_val(env.conditional.as_slice()))?;
        let env_marginal = device("env_marginal", size_of_val(env.marginal.as_slice()))?;
        let light_nodes = device("light_nodes", size_of_val(scene.light_nodes.as_slice()))?;
        let light_trails = device("light_trails", size_of_val(scene.light_trails.as_slice()))?;
        let paths = device("paths", cap * size_of::<PathState>())?;
        let rays = device("rays", 2 * cap * size_of::<QueuedRay>())?;
        let hit_instances = device("hit_instances", cap * size_of::<u32>())?;
        let shadows = device("shadow_rays", cap * size_of::<ShadowRay>())?;
        let film = device("film", film_bytes as usize)?;
        let counters = device("counters", 4 * counter::COUNT as usize)?;
        let args = Buffer::new(
            ctx,
            "dispatch_args",
            16 * args::COUNT as u64,
            U::STORAGE_BUFFER | U::INDIRECT_BUFFER,
            Location::Device,
        )?;
        let counters_back = host("counters_readback", counters.size)?;
        let film_back = Buffer::new(
            ctx,
            "film_readback",
            film_bytes,
            U::TRANSFER_DST | U::TRANSFER_SRC,
            Location::Host,
        )?;
        let splats = device("splats", (splat_pixels * 24) as usize)?;
        let bdpt = device(
            "bdpt_vertices",
            bdpt_vertices as usize * size_of::<BdptVertex>(),
        )?;
        let dfa_table =
            path_expr.map_or_else(|| crate::paths::GPU_TABLE_NONE.to_vec(), |p| p.gpu_table());
        let path_dfa = device("path_dfa", 4 * dfa_table.len())?;
        let active_bytes = active_pixels * size_of::<u32>() as u64;
        let active = device("active_pixels", active_bytes as usize)?;
        let active_upload = Buffer::new(
            ctx,
            "active_pixels_upload",
            active_bytes,
            U::TRANSFER_SRC,
            Location::Host,
        )?;
        // Chunks a scene does not use are bound to its first (the kernels never read them).
        let mut split_bindings = Vec::new();
        for array in SplitArray::ALL {
            let mine: Vec<&(SplitArray, usize, Buffer, &[u8])> =
                chunks.iter().filter(|c| c.0 == array).collect();
            for (c, binding) in array.bindings().into_iter().enumerate() {
                split_bindings.push((binding, mine.get(c).unwrap_or(&mine[0]).2.buffer));
            }
        }
        pipelines.bind_buffers(&split_bindings);
        pipelines.bind_buffers(&[
            (Binding::Frame, frame.buffer),
            (Binding::Materials, materials.buffer),
            (Binding::Lights, lights.buffer),
            (Binding::Paths, paths.buffer),
            (Binding::Rays, rays.buffer),
            (Binding::HitInstances, hit_instances.buffer),
            (Binding::Shadows, shadows.buffer),
            (Binding::Film, film.buffer),
            (Binding::Counters, counters.buffer),
            (Binding::Args, args.buffer),
            (Binding::Textures, textures.buffer),
            (Binding::TextureRefs, texture_refs.buffer),
            (Binding::Instances, instances.buffer),
            (Binding::Punctual, punctual.buffer),
            (Binding::EnvTexels, env_texels.buffer),
            (Binding::EnvConditional, env_conditional.buffer),
            (Binding::EnvMarginal, env_marginal.buffer),
            (Binding::LightNodes, light_nodes.buffer),
            (Binding::LightTrails, light_trails.buffer),
            (Binding::ActivePixels, active.buffer),
            (Binding::Splats, splats.buffer),
            (Binding::PathDfa, path_dfa.buffer),
            (Binding::BdptVertices, bdpt.buffer),
        ]);

        // Upload the scene through one host-visible staging buffer of at most STAGING_BYTES,
        // refilled as often as it takes.
        let uploads: Vec<(&[u8], &Buffer)> = [
            (bytemuck::cast_slice::<_, u8>(&scene.materials), &materials),
            (bytemuck::cast_slice(&scene.lights), &lights),
            (bytemuck::cast_slice(&scene.textures), &textures),
            (bytemuck::cast_slice(&scene.texture_refs), &texture_refs),
            (bytemuck::cast_slice(&scene.gpu_bvh().instances), &instances),
            (bytemuck::cast_slice(&scene.punctual), &punctual),
            (bytemuck::cast_slice(&env.texels), &env_texels),
            (bytemuck::cast_slice(&env.conditional), &env_conditional),
            (bytemuck::cast_slice(&env.marginal), &env_marginal),
            (bytemuck::cast_slice(&scene.light_nodes), &light_nodes),
            (bytemuck::cast_slice(&scene.light_trails), &light_trails),
            (bytemuck::cast_slice(&dfa_table), &path_dfa),
        ]
        .into_iter()
        .chain(chunks.iter().map(|(_, _, buffer, data)| (*data, buffer)))
        .filter(|(data, _)| !data.is_empty())
        .collect();
        let total: usize = uploads.iter().map(|(data, _)| data.len()).sum();
        let staging = Buffer::new(
            ctx,
            "staging",
            total.min(STAGING_BYTES) as u64,
            U::TRANSFER_SRC,
            Location::Host,
        )?;
        let mut used = 0;
        commands.begin()?;
        for (data, dst) in uploads {
            let mut done = 0;
            while done < data.len() {
                if used as u64 == staging.size {
                    commands.submit_and_wait(ctx, "the scene upload", SUBMIT_TIMEOUT_S)?;
                    commands.begin()?;
                    used = 0;
                }
                let n = (data.len() - done).min(staging.size as usize - used);
                staging.write_at(used, &data[done..done + n]);
                commands.copy_region(&staging, used as u64, dst, done as u64, n as u64);
                used += n;
                done += n;
            }
        }
        commands.submit_and_wait(ctx, "the scene upload", SUBMIT_TIMEOUT_S)?;
        drop(staging);

        // The images (one row where the kernels read buffers instead).
        let mut images = Vec::new();
        for array in SceneImage::ALL {
            let records: Vec<crate::layout::GpuMaterial>;
            let (rows, data) = match (split.images(), array) {
                (true, SceneImage::Materials) => {
                    records = scene.materials.iter().map(|m| m.image_record()).collect();
                    (array.rows(scene), bytemuck::cast_slice(&records))
                }
                (true, _) => (array.rows(scene), array.data(scene)),
                (false, _) => (1, &[][..]),
            };
            let image = Image::new(ctx, array.name(), array.format(), rows as u32)?;
            upload_rows(ctx, commands, &image, data)?;
            images.push((array, image));
        }
        // Each image twice: as a storage image and as a sampled image (SceneImages).
        pipelines.bind_images(
            &images
                .iter()
                .flat_map(|(array, image)| {
                    [
                        (array.binding(), image.view),
                        (array.sampled_binding(), image.view),
                    ]
                })
                .collect::<Vec<_>>(),
        );
        // The hit records' texels (Binding::HitImage): written before they are read, so only
        // moved to the layout the kernels use.
        let hit_image = Image::new(
            ctx,
            "hit_records",
            vk::Format::R32G32B32A32_UINT,
            cap.div_ceil(SCENE_IMAGE_WIDTH as usize) as u32,
        )?;
        commands.begin()?;
        commands.image_layout(
            &hit_image,
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::GENERAL,
        );
        commands.submit_and_wait(ctx, "the hit image's layout", SUBMIT_TIMEOUT_S)?;
        pipelines.bind_images(&[(Binding::HitImage, hit_image.view)]);

        Ok(RenderBuffers {
            frame,
            film,
            film_back,
            counters,
            counters_back,
            args,
            active_pixels: active,
            active_upload,
            splats,
            path_dfa,
            split_bindings: SplitArray::ALL
                .map(|array| chunks.iter().filter(|c| c.0 == array).count() as u32),
            _bound: [
                materials,
                lights,
                hit_instances,
                textures,
                texture_refs,
                instances,
                punctual,
                env_texels,
                env_conditional,
                env_marginal,
                light_nodes,
                light_trails,
                bdpt,
            ]
            .into_iter()
            .chain(chunks.into_iter().map(|(_, _, buffer, _)| buffer))
            .collect(),
            _images: images.into_iter().map(|(_, image)| image).collect(),
            rays,
            hit_image,
            shadows,
            paths,
        })
    }
}
