//! The GPU propagator: the same algorithm as `vlf_core::bake::reference`, with steps 2–4 of
//! every transport direction (cell lists, interface, gather) as compute passes.
//!
//! Pass order per direction (the one place it is written down): [`cells`] → [`interface`] →
//! [`gather`] → [`reflect`] (scenes with mirror/mixed faces only). Per iteration: upload the unshot radiance, clear the accumulators, run every
//! direction, read the accumulators back and finish the iteration on the CPU with
//! `reference::finish_iteration` (a few flops per texel, shared code, f64 energy sums).
//! Triangle binning into tiles is done once on the CPU (`reference::bin_triangles`) and uploaded
//! in [`chunks`] of whole directions (one storage binding each, one `Cells`/`Reflect` bind group
//! per chunk); the host holds one direction's bins at a time.

mod cells;
pub mod chunks;
mod common;
mod gather;
mod interface;
mod reflect;

use glam::Vec4;
use vlf_core::bake::BakeScene;
use vlf_core::bake::reference::{
    self, EnergyStats, Propagated, SpecularSetup, TexelAccum, TransportDir, bin_triangles, project,
};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, tiles};
use vlf_core::psf::PsfGrid;
use wgpu::util::DeviceExt;

pub use chunks::{Chunk, ChunkBytes, Chunker, DEFAULT_MAX_CHUNK_BYTES, chunk_cap};

use crate::GpuContext;
use crate::layout::{self, BakeDirection, CellEntry, Crossing, ReflectItem};
use crate::passes::dispatch_2d;
use crate::readback::read_buffer;

/// Stride of the per-direction uniforms (≥ `min_uniform_buffer_offset_alignment`).
const DIR_STRIDE: u64 = 256;
/// Cap on crossings kept per ray.
pub const MAX_CROSSINGS: u32 = 256;
/// Directions encoded per submission (progress granularity).
const DIRS_PER_SUBMIT: usize = 32;

#[derive(Debug, thiserror::Error)]
pub enum GpuBakeError {
    #[error(
        "{what} needs {need} bytes in one GPU buffer but the adapter allows {limit}; lower --resolution or --directions"
    )]
    TooLarge {
        what: &'static str,
        need: u64,
        limit: u64,
    },
    #[error(
        "a ray crosses {crossings} faces, more than the {max} supported (depth complexity too high)"
    )]
    DepthComplexity { crossings: u32, max: u32 },
    #[error("reading back from the GPU failed (device lost?)")]
    Readback,
}

/// Progress of a GPU propagation, for the binary's progress bar.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub iteration: u32,
    pub max_iterations: u32,
    pub directions_done: usize,
    pub directions: usize,
}

/// Settings of the GPU propagator that do not change its result (the tests check that).
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuBakeOptions {
    /// Cap on one chunk buffer (tile bins, tile starts, reflect items) in bytes; `None`:
    /// [`DEFAULT_MAX_CHUNK_BYTES`]. Never above the adapter's binding limit (see [`chunk_cap`]).
    pub max_chunk_bytes: Option<u64>,
}

/// The largest storage buffer one binding may hold on `device`.
pub fn binding_limit(device: &wgpu::Device) -> u64 {
    let l = device.limits();
    l.max_storage_buffer_binding_size.min(l.max_buffer_size)
}

/// Where a direction's data lies in its chunk.
#[derive(Clone, Copy)]
struct DirSlot {
    chunk: usize,
    /// Offset of its tile starts in the chunk's `bin_start`.
    bin_base: u32,
    /// Offset of its first reflect item in the chunk's `reflect_items`.
    items_base: u32,
}

/// The chunked buffers of one chunk of directions.
struct ChunkBuffers {
    bin_start: wgpu::Buffer,
    bin_tris: wgpu::Buffer,
    items: wgpu::Buffer,
}

/// The bytes one direction adds to the chunked buffers.
fn direction_bytes(bins: &reference::Bins, items: u32) -> ChunkBytes {
    ChunkBytes {
        bin_start: bins.start.len() as u64 * 4,
        bin_tris: bins.tris.len() as u64 * 4,
        reflect_items: u64::from(items) * size_of::<ReflectItem>() as u64,
    }
}

/// How [`propagate_with`] splits the directions of `scene` into chunks with a cap of
/// `max_chunk_bytes` (`None`: the default) on an adapter whose binding limit is `limit`.
/// Bins every transport direction once (as the propagator does).
pub fn chunk_layout(
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    limit: u64,
    max_chunk_bytes: Option<u64>,
) -> Vec<Chunk> {
    let grid = PsfGrid::new(params.resolution, params.tile).expect("validated params");
    let (dirs, _) = reference::all_directions(scene, set, params);
    let spec = SpecularSetup::new(scene, set, &grid, &dirs);
    let items = spec.as_ref().map(|s| tile_data(s).item_ranges);
    let mut chunker = Chunker::new(chunk_cap(limit, max_chunk_bytes));
    for (i, d) in dirs.iter().enumerate() {
        let bins = bin_triangles(&project(scene, &d.frame), &grid);
        let count = items.as_ref().map_or(0, |r| r[i].1);
        chunker.push(direction_bytes(&bins, count));
    }
    chunker.chunks().to_vec()
}

fn check_size(ctx: &GpuContext, what: &'static str, bytes: u64) -> Result<(), GpuBakeError> {
    let limit = binding_limit(&ctx.device);
    if bytes > limit {
        return Err(GpuBakeError::TooLarge {
            what,
            need: bytes,
            limit,
        });
    }
    Ok(())
}

fn buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    label: &str,
    data: &[T],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    // Zero-length storage bindings are invalid: pad empty arrays to one element.
    let zero = [T::zeroed()];
    let data = if data.is_empty() { &zero[..] } else { data };
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(data),
            usage: wgpu::BufferUsages::STORAGE | usage,
        })
}

fn empty(ctx: &GpuContext, label: &str, bytes: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16),
        usage: wgpu::BufferUsages::STORAGE | usage,
        mapped_at_creation: false,
    })
}

/// The non-diffuse data in GPU-ready form.
struct TileData {
    /// face_slot ++ index_start ++ tile_ids ++ coverage.
    packed: Vec<u32>,
    offsets: [u32; 4],
    frames: Vec<[f32; 4]>,
    items: Vec<ReflectItem>,
    /// Per transport direction: (first item, count).
    item_ranges: Vec<(u32, u32)>,
}

fn tile_data(spec: &SpecularSetup) -> TileData {
    let ix = &spec.index;
    let mut packed = Vec::new();
    let mut offsets = [0u32; 4];
    for (k, part) in [&ix.face_slot, &ix.index_start, &ix.tile_ids, &ix.coverage]
        .into_iter()
        .enumerate()
    {
        offsets[k] = packed.len() as u32;
        packed.extend_from_slice(part);
    }
    let frames = spec
        .frames
        .iter()
        .flat_map(|f| [f.u, f.v, f.w].map(|a| a.extend(0.0).to_array()))
        .collect();
    let mut items = Vec::new();
    let mut item_ranges = Vec::with_capacity(spec.jobs.len());
    for jobs in &spec.jobs {
        let first = items.len() as u32;
        for job in jobs {
            let mf = ix.face_slot[job.face as usize] as usize;
            let k = mf * ix.directions as usize + job.j as usize;
            for slot in ix.index_start[k]..ix.index_start[k + 1] {
                items.push(ReflectItem {
                    weight: job.weight.extend(0.0).to_array(),
                    slot,
                    face: job.face,
                    j: job.j,
                    senses: job.incoming_sense | (job.sense << 1),
                });
            }
        }
        item_ranges.push((first, items.len() as u32 - first));
    }
    TileData {
        packed,
        offsets,
        frames,
        items,
        item_ranges,
    }
}

/// Runs the propagation on the GPU. Same inputs and outputs as `reference::propagate`.
pub fn propagate(
    ctx: &GpuContext,
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    progress: &mut dyn FnMut(Progress),
) -> Result<Propagated, GpuBakeError> {
    propagate_with(
        ctx,
        scene,
        set,
        params,
        &GpuBakeOptions::default(),
        progress,
    )
}

/// Bytes written to the GPU between two submissions while uploading the bins: bounds the
/// staging memory `queue.write_buffer` holds until its submission completes.
pub const UPLOAD_FLUSH_BYTES: u64 = 32 << 20;

/// Bins every transport direction (CPU) and uploads the bins and reflect items into chunk
/// buffers. Two passes over the directions: the first bins to size the chunks (and find the
/// longest bin), the second bins again and writes each direction straight into its chunk, so
/// the host never holds more than one direction's bins (binning is cheap next to one
/// propagation iteration). Returns each direction's place, the chunks' buffers and the
/// longest tile bin.
fn upload_bins(
    ctx: &GpuContext,
    scene: &BakeScene,
    grid: &PsfGrid,
    dirs: &[TransportDir],
    tdata: Option<&TileData>,
    cap: u64,
) -> Result<(Vec<DirSlot>, Vec<ChunkBuffers>, u32), GpuBakeError> {
    let items_of = |i: usize| tdata.map_or((0, 0), |t| t.item_ranges[i]);
    let mut chunker = Chunker::new(cap);
    let mut k_max = 1;
    for (i, d) in dirs.iter().enumerate() {
        let bins = bin_triangles(&project(scene, &d.frame), grid);
        k_max = k_max.max(bins.max_len());
        chunker.push(direction_bytes(&bins, items_of(i).1));
    }
    let mut buffers = Vec::with_capacity(chunker.chunks().len());
    for (k, chunk) in chunker.chunks().iter().enumerate() {
        let one = chunk.directions.len() == 1;
        let b = &chunk.bytes;
        for (what, what_one, bytes) in [
            (
                "the tile bins of a chunk of directions",
                "the tile bins of one direction",
                b.bin_tris,
            ),
            (
                "the tile starts of a chunk of directions",
                "the tile starts of one direction",
                b.bin_start,
            ),
            (
                "the reflect items of a chunk of directions",
                "the reflect items of one direction",
                b.reflect_items,
            ),
        ] {
            check_size(ctx, if one { what_one } else { what }, bytes)?;
        }
        let dst = wgpu::BufferUsages::COPY_DST;
        buffers.push(ChunkBuffers {
            bin_start: empty(ctx, &format!("Bake::bin_start[{k}]"), b.bin_start, dst),
            bin_tris: empty(ctx, &format!("Bake::bin_tris[{k}]"), b.bin_tris, dst),
            items: empty(
                ctx,
                &format!("Bake::reflect_items[{k}]"),
                b.reflect_items,
                dst,
            ),
        });
    }
    let mut slots = Vec::with_capacity(dirs.len());
    let mut pending = 0u64;
    let mut start = Vec::new();
    for (k, chunk) in chunker.chunks().iter().enumerate() {
        let buf = &buffers[k];
        let (item_base, _) = items_of(chunk.directions.start);
        let mut at = ChunkBytes::default();
        for i in chunk.directions.clone() {
            let bins = bin_triangles(&project(scene, &dirs[i].frame), grid);
            let (item_first, item_count) = items_of(i);
            slots.push(DirSlot {
                chunk: k,
                bin_base: (at.bin_start / 4) as u32,
                items_base: item_first - item_base,
            });
            let offset = (at.bin_tris / 4) as u32;
            start.clear();
            start.extend(bins.start.iter().map(|s| s + offset));
            let items: &[ReflectItem] = match tdata {
                Some(t) => &t.items[item_first as usize..(item_first + item_count) as usize],
                None => &[],
            };
            let size = direction_bytes(&bins, item_count);
            for (buffer, offset, bytes) in [
                (&buf.bin_start, at.bin_start, bytemuck::cast_slice(&start)),
                (&buf.bin_tris, at.bin_tris, bytemuck::cast_slice(&bins.tris)),
                (&buf.items, at.reflect_items, bytemuck::cast_slice(items)),
            ] {
                if !bytes.is_empty() {
                    ctx.queue.write_buffer(buffer, offset, bytes);
                }
            }
            at = ChunkBytes {
                bin_start: at.bin_start + size.bin_start,
                bin_tris: at.bin_tris + size.bin_tris,
                reflect_items: at.reflect_items + size.reflect_items,
            };
            pending += size.sum();
            if pending >= UPLOAD_FLUSH_BYTES {
                ctx.queue.submit(None);
                let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
                pending = 0;
            }
        }
        // The second pass bins exactly as the first (same function, same input).
        debug_assert_eq!(at, chunk.bytes);
    }
    debug_assert_eq!(slots.len(), dirs.len());
    ctx.queue.submit(None);
    log::debug!(
        "GPU bake: tile bins of {} directions in {} chunk(s) of ≤ {} bytes (largest {:?})",
        dirs.len(),
        buffers.len(),
        chunker.cap(),
        chunker.largest()
    );
    Ok((slots, buffers, k_max))
}

/// [`propagate`] with [`GpuBakeOptions`]; the result does not depend on them.
pub fn propagate_with(
    ctx: &GpuContext,
    scene: &BakeScene,
    set: &DirectionSet,
    params: &BakeParams,
    options: &GpuBakeOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<Propagated, GpuBakeError> {
    let device = &ctx.device;
    let grid = PsfGrid::new(params.resolution, params.tile).expect("validated params");
    let n = params.resolution;
    let (dirs, quadrature) = reference::all_directions(scene, set, params);
    let mut spec = SpecularSetup::new(scene, set, &grid, &dirs);
    let mut tdata = spec.as_ref().map(tile_data);
    if let Some(s) = &mut spec {
        // The jobs live on in the reflect items; only the index is needed from here on.
        s.jobs = Vec::new();
    }
    let tile_len = spec.as_ref().map_or(0, |s| s.index.value_len());
    let cap = chunk_cap(binding_limit(device), options.max_chunk_bytes);
    let (slots, chunk_buffers, k_max) = upload_bins(ctx, scene, &grid, &dirs, tdata.as_ref(), cap)?;
    if let Some(t) = &mut tdata {
        // Uploaded with their chunks.
        t.items = Vec::new();
    }
    let k_max = k_max.min(MAX_CROSSINGS);
    let cells_n = u64::from(n) * u64::from(n);
    check_size(
        ctx,
        "the ray crossing lists",
        cells_n * u64::from(k_max) * size_of::<Crossing>() as u64,
    )?;
    let n_tex = scene.texel_count();
    check_size(
        ctx,
        "the texel accumulators",
        n_tex as u64 * size_of::<layout::TexelAccum>() as u64,
    )?;
    check_size(
        ctx,
        "the unshot radiance (texels and mirror tiles)",
        (n_tex + tile_len) as u64 * 16,
    )?;

    // Geometry and atlas (uploaded once).
    let triangles = buffer(
        ctx,
        "Bake::triangles",
        &scene.triangles,
        wgpu::BufferUsages::empty(),
    );
    let faces = buffer(
        ctx,
        "Bake::faces",
        &scene.faces,
        wgpu::BufferUsages::empty(),
    );
    let tex_face = reference::texel_faces(scene);
    let centers: Vec<[f32; 4]> = scene
        .texel_center
        .iter()
        .zip(&tex_face)
        .map(|(c, &f)| [c[0], c[1], c[2], f32::from_bits(f)])
        .collect();
    let texel_center = buffer(
        ctx,
        "Bake::texel_center",
        &centers,
        wgpu::BufferUsages::empty(),
    );
    let active_list: Vec<u32> = (0..n_tex)
        .filter(|&t| {
            let f = &scene.faces[tex_face[t] as usize];
            scene.texel_area[t] > 0.0 && (t as u32 - f.texel_base) < f.texels_per_side()
        })
        .map(|t| t as u32)
        .collect();
    let active = buffer(
        ctx,
        "Bake::active_texels",
        &active_list,
        wgpu::BufferUsages::empty(),
    );
    let mut unshot_init = scene.emission.clone();
    unshot_init.resize(n_tex + tile_len, [0.0; 4]);
    let unshot = buffer(
        ctx,
        "Bake::unshot",
        &unshot_init,
        wgpu::BufferUsages::COPY_DST,
    );
    let none_u32: Vec<u32> = Vec::new();
    let none_v4: Vec<[f32; 4]> = Vec::new();
    let tile_index = buffer(
        ctx,
        "Bake::tile_index",
        tdata.as_ref().map_or(&none_u32, |t| &t.packed),
        wgpu::BufferUsages::empty(),
    );
    let frames = buffer(
        ctx,
        "Bake::frames",
        tdata.as_ref().map_or(&none_v4, |t| &t.frames),
        wgpu::BufferUsages::empty(),
    );
    let next_tiles = empty(
        ctx,
        "Bake::next_tiles",
        tile_len as u64 * 16,
        wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    );
    let spec_escape = empty(
        ctx,
        "Bake::spec_escape",
        cells_n * 16,
        wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    );
    let cell_count = empty(
        ctx,
        "Bake::cell_count",
        cells_n * 4,
        wgpu::BufferUsages::empty(),
    );
    let cells = empty(
        ctx,
        "Bake::cells",
        cells_n * u64::from(k_max) * size_of::<CellEntry>() as u64,
        wgpu::BufferUsages::empty(),
    );
    let crossings = empty(
        ctx,
        "Bake::crossings",
        cells_n * u64::from(k_max) * size_of::<Crossing>() as u64,
        wgpu::BufferUsages::empty(),
    );
    let acc = empty(
        ctx,
        "Bake::accumulators",
        n_tex as u64 * size_of::<layout::TexelAccum>() as u64,
        wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    );
    let overflow = buffer(
        ctx,
        "Bake::overflow",
        &[0u32; 4],
        wgpu::BufferUsages::COPY_SRC,
    );

    // Per-direction globals at a 256-byte stride (rewritten per iteration: the sky enters in
    // the first one only).
    let m = params.tile;
    let uniforms = |sky: glam::Vec3| {
        let mut bytes = vec![0u8; dirs.len() * DIR_STRIDE as usize];
        for (i, d) in dirs.iter().enumerate() {
            let lk = |t: glam::Vec3| {
                let l = set.lookup(t);
                (
                    [l.vertices[0], l.vertices[1], l.vertices[2], 0],
                    [l.weights[0], l.weights[1], l.weights[2], 0.0],
                )
            };
            let (pv, pw) = lk(d.frame.w);
            let (mv, mw) = lk(-d.frame.w);
            let items_count = tdata.as_ref().map_or(0, |t| t.item_ranges[i].1);
            let off = tdata.as_ref().map_or([0; 4], |t| t.offsets);
            let g = BakeDirection {
                u: d.frame.u.extend(0.0).into(),
                v: d.frame.v.extend(0.0).into(),
                w: d.frame.w.extend(0.0).into(),
                sun: d.sun.unwrap_or_default().extend(0.0).into(),
                weight: d.weight,
                n,
                tile: params.tile,
                k_max,
                bin_base: slots[i].bin_base,
                tiles_per_side: grid.tiles_per_side(),
                active_texels: active_list.len() as u32,
                is_sun: u32::from(d.sun.is_some()),
                spec_plus_v: pv,
                spec_plus_w: pw,
                spec_minus_v: mv,
                spec_minus_w: mw,
                sky: sky.extend(0.0).into(),
                tiles_l: set.len() as u32,
                tile_m: m,
                words_per_slot: tiles::words_per_slot(m) as u32,
                face_slot_off: off[0],
                index_start_off: off[1],
                tile_ids_off: off[2],
                coverage_off: off[3],
                tile_values_off: n_tex as u32,
                items_base: slots[i].items_base,
                items_count,
                has_tiles: u32::from(tdata.is_some()),
                _pad: 0,
            };
            let at = i * DIR_STRIDE as usize;
            bytes[at..at + size_of::<BakeDirection>()].copy_from_slice(bytemuck::bytes_of(&g));
        }
        bytes
    };
    let uniform_bytes = uniforms(params.sky);
    let dir_uniforms = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("Bake::directions"),
        contents: &uniform_bytes,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    });
    let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("Bake::globals_layout"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: true,
                min_binding_size: wgpu::BufferSize::new(size_of::<BakeDirection>() as u64),
            },
            count: None,
        }],
    });
    let globals = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("Bake::globals"),
        layout: &globals_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &dir_uniforms,
                offset: 0,
                size: wgpu::BufferSize::new(size_of::<BakeDirection>() as u64),
            }),
        }],
    });
    let cells_pass = cells::CellsPass::new(device, &globals_layout);
    let interface_pass = interface::InterfacePass::new(device, &globals_layout);
    let gather_pass = gather::GatherPass::new(device, &globals_layout);
    let reflect_pass = reflect::ReflectPass::new(device, &globals_layout);
    // One Cells and one Reflect bind group per chunk of directions.
    let chunk_groups: Vec<(wgpu::BindGroup, wgpu::BindGroup)> = chunk_buffers
        .iter()
        .map(|c| {
            let cells_bg = cells_pass.bind_group(
                device,
                &[
                    &triangles,
                    &c.bin_start,
                    &c.bin_tris,
                    &cell_count,
                    &cells,
                    &overflow,
                ],
            );
            let reflect_bg = reflect_pass.bind_group(
                device,
                &[
                    &faces,
                    &cell_count,
                    &cells,
                    &crossings,
                    &tile_index,
                    &frames,
                    &c.items,
                    &next_tiles,
                ],
            );
            (cells_bg, reflect_bg)
        })
        .collect();
    let interface_bg = interface_pass.bind_group(
        device,
        &[
            &faces,
            &unshot,
            &cell_count,
            &cells,
            &crossings,
            &tile_index,
            &frames,
            &spec_escape,
        ],
    );
    let gather_bg = gather_pass.bind_group(
        device,
        &[
            &faces,
            &active,
            &texel_center,
            &cell_count,
            &cells,
            &crossings,
            &acc,
        ],
    );

    let max_dim = device.limits().max_compute_workgroups_per_dimension;
    let cell_groups = dispatch_2d(n * n, 64, max_dim);
    let texel_groups = dispatch_2d(active_list.len() as u32, 64, max_dim);

    let mut unshot_host = scene.emission.clone();
    let mut unshot_tiles = vec![[0f32; 4]; tile_len];
    let mut total_tiles = vec![[0f32; 4]; tile_len];
    let mut total = scene.emission.clone();
    let mut next = vec![[0f32; 4]; n_tex];
    let mut irradiance = vec![[0f32; 4]; n_tex];
    let mut energy = EnergyStats {
        emitted: scene
            .emitted_power()
            .to_array()
            .iter()
            .map(|&x| f64::from(x))
            .sum(),
        ..Default::default()
    };
    let (max_iter, threshold) = reference::stopping(params.iterations);
    let mut iterations = 0;
    for it in 0..max_iter {
        let first = it == 0;
        ctx.queue
            .write_buffer(&unshot, 0, bytemuck::cast_slice(&unshot_host));
        if tile_len > 0 {
            ctx.queue.write_buffer(
                &unshot,
                n_tex as u64 * 16,
                bytemuck::cast_slice(&unshot_tiles),
            );
        }
        if it == 1 {
            ctx.queue
                .write_buffer(&dir_uniforms, 0, &uniforms(glam::Vec3::ZERO));
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("Bake::clear"),
        });
        encoder.clear_buffer(&acc, 0, None);
        encoder.clear_buffer(&next_tiles, 0, None);
        encoder.clear_buffer(&spec_escape, 0, None);
        ctx.queue.submit(Some(encoder.finish()));
        let active_dirs: Vec<usize> = (0..dirs.len())
            .filter(|&i| i < quadrature || first)
            .collect();
        for (chunk_i, chunk) in active_dirs.chunks(DIRS_PER_SUBMIT).enumerate() {
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("Bake::directions"),
            });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("Bake::pass"),
                    timestamp_writes: None,
                });
                for &d in chunk {
                    let offset = [(d as u64 * DIR_STRIDE) as u32];
                    let (cells_bg, reflect_bg) = &chunk_groups[slots[d].chunk];
                    pass.set_bind_group(0, &globals, &offset);
                    pass.set_pipeline(&cells_pass.pipeline);
                    pass.set_bind_group(1, cells_bg, &[]);
                    pass.dispatch_workgroups(cell_groups.0, cell_groups.1, 1);
                    pass.set_pipeline(&interface_pass.pipeline);
                    pass.set_bind_group(1, &interface_bg, &[]);
                    pass.dispatch_workgroups(cell_groups.0, cell_groups.1, 1);
                    if !active_list.is_empty() {
                        pass.set_pipeline(&gather_pass.pipeline);
                        pass.set_bind_group(1, &gather_bg, &[]);
                        pass.dispatch_workgroups(texel_groups.0, texel_groups.1, 1);
                    }
                    let count = tdata.as_ref().map_or(0, |t| t.item_ranges[d].1);
                    if count > 0 {
                        let g = dispatch_2d(count * m * m, 64, max_dim);
                        pass.set_pipeline(&reflect_pass.pipeline);
                        pass.set_bind_group(1, reflect_bg, &[]);
                        pass.dispatch_workgroups(g.0, g.1, 1);
                    }
                }
            }
            ctx.queue.submit(Some(encoder.finish()));
            let _ = device.poll(wgpu::PollType::wait_indefinitely());
            progress(Progress {
                iteration: it,
                max_iterations: max_iter,
                directions_done: (chunk_i * DIRS_PER_SUBMIT + chunk.len()).min(active_dirs.len()),
                directions: active_dirs.len(),
            });
        }
        let over: Vec<u32> =
            read_buffer(device, &ctx.queue, &overflow).map_err(|_| GpuBakeError::Readback)?;
        if over[0] > 0 {
            return Err(GpuBakeError::DepthComplexity {
                crossings: over[0],
                max: k_max,
            });
        }
        let gpu_acc: Vec<layout::TexelAccum> =
            read_buffer(device, &ctx.queue, &acc).map_err(|_| GpuBakeError::Readback)?;
        let acc_host: Vec<TexelAccum> = gpu_acc
            .iter()
            .take(n_tex)
            .map(|a| TexelAccum {
                irradiance: Vec4::from(a.irradiance),
                open: Vec4::from(a.open),
            })
            .collect();
        let sky = if first { params.sky } else { glam::Vec3::ZERO };
        let mut e = reference::finish_iteration(
            scene,
            &tex_face,
            &acc_host,
            &unshot_host,
            sky,
            &mut next,
            &mut irradiance,
        );
        if let Some(sp) = &spec {
            let mut next_tiles_host: Vec<[f32; 4]> =
                read_buffer(device, &ctx.queue, &next_tiles).map_err(|_| GpuBakeError::Readback)?;
            next_tiles_host.truncate(tile_len);
            let esc: Vec<[f32; 4]> = read_buffer(device, &ctx.queue, &spec_escape)
                .map_err(|_| GpuBakeError::Readback)?;
            e.escaped += esc
                .iter()
                .map(|v| f64::from(v[0]) + f64::from(v[1]) + f64::from(v[2]))
                .sum::<f64>();
            e.sent += reference::tile_power(&sp.index, &unshot_tiles, set, &grid);
            e.next += reference::tile_power(&sp.index, &next_tiles_host, set, &grid);
            reference::accumulate(&mut total_tiles, &next_tiles_host);
            unshot_tiles = next_tiles_host;
        }
        log::debug!(
            "GPU iteration {it}: sent {:.5} received {:.5} escaped {:.5} next {:.5}",
            e.sent,
            e.received,
            e.escaped,
            e.next
        );
        energy.record(&e);
        reference::accumulate(&mut total, &next);
        std::mem::swap(&mut unshot_host, &mut next);
        iterations = it + 1;
        if energy.converged(threshold) {
            break;
        }
    }
    Ok(Propagated {
        radiance: total,
        irradiance,
        tiles: spec.map(|s| (s.index, total_tiles)),
        iterations,
        energy,
    })
}
