//! The per-scene resources of a GPU bake: the host data derived from the scene ([`Host`]),
//! the buffers of a [`BakePlan`] (allocated through one helper that records what it made)
//! and the bind groups over them, built from the passes' named bindings. The pipelines they
//! bind to are the device's ([`BakePipelines`]).

use vlf_core::bake::BakeScene;
use vlf_core::bake::reference::{self, SpecularSetup, bin_triangles, project};
use vlf_core::directions::DirectionSet;
use vlf_core::lightfield::{BakeParams, tiles};
use wgpu::util::DeviceExt;

use super::cells::CellsBindings;
use super::chunks::ChunkBytes;
use super::gather::GatherBindings;
use super::interface::InterfaceBindings;
use super::pipelines::BakePipelines;
use super::plan::{self, BakeBuffer, BakePlan, DirSlot, PlannedBuffer, Setup};
use super::reflect::ReflectBindings;
use super::{DIR_STRIDE, GpuBakeError, UPLOAD_FLUSH_BYTES, binding_limit};
use crate::GpuContext;
use crate::layout::{BakeDirection, ReflectItem};

/// The non-diffuse data in GPU-ready form.
pub(super) struct TileData {
    /// face_slot ++ index_start ++ tile_ids ++ coverage.
    packed: Vec<u32>,
    offsets: [u32; 4],
    frames: Vec<[f32; 4]>,
    items: Vec<ReflectItem>,
    /// Per transport direction: (first item, count).
    item_ranges: Vec<(u32, u32)>,
}

fn tile_data(spec: &SpecularSetup, host_specular: &[[f32; 4]]) -> TileData {
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
    // Allocated at its final length (the plan's `reflect items`), not grown.
    let slots = |job: &reference::ReflectJob| {
        let k = ix.face_slot[job.face as usize] as usize * ix.directions as usize + job.j as usize;
        (ix.index_start[k + 1] - ix.index_start[k]) as usize
    };
    let mut items = Vec::with_capacity(spec.jobs.iter().flatten().map(slots).sum());
    let mut item_ranges = Vec::with_capacity(spec.jobs.len());
    for jobs in &spec.jobs {
        let first = items.len() as u32;
        for job in jobs {
            let mf = ix.face_slot[job.face as usize] as usize;
            let k = mf * ix.directions as usize + job.j as usize;
            for slot in ix.index_start[k]..ix.index_start[k + 1] {
                items.push(ReflectItem {
                    weight: job.rgb_weight(host_specular).extend(job.loss).to_array(),
                    slot,
                    face: job.face,
                    j: job.j,
                    senses: u32::from(job.incoming_sense) | (u32::from(job.sense) << 1),
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

/// The host side of one bake: the inputs, the directions and mirror setup, and what the
/// buffers and uniforms are filled from.
pub(super) struct Host<'a> {
    pub scene: &'a BakeScene,
    pub set: &'a DirectionSet,
    pub params: &'a BakeParams,
    pub plan: &'a BakePlan,
    pub setup: Setup,
    /// Face of every texel.
    pub tex_face: Vec<u32>,
    pub active: Vec<u32>,
    tiles: Option<TileData>,
    /// Where each direction lies in its chunk.
    pub slots: Vec<DirSlot>,
}

impl<'a> Host<'a> {
    /// The host side of the bake of `scene` with `plan`, which must have been made for this
    /// scene and these parameters (checked).
    pub fn new(
        scene: &'a BakeScene,
        set: &'a DirectionSet,
        params: &'a BakeParams,
        plan: &'a BakePlan,
        setup: Option<Setup>,
    ) -> Host<'a> {
        let mut setup = setup.unwrap_or_else(|| Setup::new(scene, set, params));
        let tiles = setup.spec.as_ref().map(|s| tile_data(s, &scene.specular));
        if let Some(s) = &mut setup.spec {
            // The jobs live on in the reflect items; only the index is needed from here on.
            s.jobs = Vec::new();
        }
        let tex_face = reference::texel_faces(scene);
        let active = plan::active_texels(scene, &tex_face);
        let host = Host {
            scene,
            set,
            params,
            plan,
            slots: plan.slots(),
            setup,
            tex_face,
            active,
            tiles,
        };
        host.check_plan();
        host
    }

    /// The plan was made for this scene and these parameters.
    fn check_plan(&self) {
        let p = self.plan;
        let items: Vec<u32> = match &self.tiles {
            Some(t) => t.item_ranges.iter().map(|r| r.1).collect(),
            None => vec![0; self.setup.dirs.len()],
        };
        let got = (
            (p.resolution, p.tile),
            p.transport_directions,
            (p.triangles, p.faces, p.texels, p.active_texels),
            p.mirror.tile_values,
            &p.mirror.items,
        );
        let want = (
            (self.params.resolution, self.params.tile),
            self.setup.dirs.len(),
            (
                self.scene.triangles.len() as u64,
                self.scene.faces.len() as u64,
                self.scene.texel_count() as u64,
                self.active.len() as u64,
            ),
            self.tile_len() as u64,
            &items,
        );
        assert_eq!(
            got, want,
            "the bake plan was made for another scene or other parameters"
        );
    }

    pub fn texels(&self) -> usize {
        self.scene.texel_count()
    }

    /// Mirror tile values in one copy (0 without mirror or mixed faces).
    pub fn tile_len(&self) -> usize {
        self.setup.spec.as_ref().map_or(0, |s| s.index.value_len())
    }

    /// Reflect items of transport direction `d`.
    pub fn items(&self, d: usize) -> u32 {
        self.plan.mirror.items[d]
    }

    /// The per-direction uniforms at a 256-byte stride, with `sky` entering open ends.
    pub fn direction_uniforms(&self, sky: glam::Vec3) -> Vec<u8> {
        let (set, params, plan) = (self.set, self.params, self.plan);
        let m = params.tile;
        let off = self.tiles.as_ref().map_or([0; 4], |t| t.offsets);
        let mut bytes = vec![0u8; self.setup.dirs.len() * DIR_STRIDE as usize];
        for (i, d) in self.setup.dirs.iter().enumerate() {
            let lk = |t: glam::Vec3| {
                let l = set.lookup(t);
                (
                    [l.vertices[0], l.vertices[1], l.vertices[2], 0],
                    [l.weights[0], l.weights[1], l.weights[2], 0.0],
                )
            };
            let (pv, pw) = lk(d.frame.w);
            let (mv, mw) = lk(-d.frame.w);
            let g = BakeDirection {
                u: d.frame.u.extend(0.0).into(),
                v: d.frame.v.extend(0.0).into(),
                w: d.frame.w.extend(0.0).into(),
                sun: d.sun.unwrap_or_default().extend(0.0).into(),
                weight: d.weight,
                n: params.resolution,
                tile: params.tile,
                k_max: plan.crossings_per_ray(),
                bin_base: self.slots[i].bin_base,
                tiles_per_side: self.setup.grid.tiles_per_side(),
                active_texels: self.active.len() as u32,
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
                tile_values_off: self.texels() as u32,
                items_base: self.slots[i].items_base,
                items_count: self.items(i),
                has_tiles: u32::from(self.tiles.is_some()),
                has_panes: u32::from(self.scene.panes.iter().any(|p| p.weight > 0.0)),
            };
            let at = i * DIR_STRIDE as usize;
            bytes[at..at + size_of::<BakeDirection>()].copy_from_slice(bytemuck::bytes_of(&g));
        }
        bytes
    }
}

/// A buffer the bake allocated, as wgpu reports it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AllocatedBuffer {
    pub label: String,
    pub size: u64,
    pub usage: wgpu::BufferUsages,
}

/// Creates the buffers of a plan, one [`PlannedBuffer`] at a time, and records each.
struct Allocator<'a> {
    ctx: &'a GpuContext,
    made: Vec<AllocatedBuffer>,
}

impl Allocator<'_> {
    /// The buffer `p`, filled with `contents` (which must be its planned size) or left to be
    /// written later.
    fn create(&mut self, p: &PlannedBuffer, contents: Option<&[u8]>) -> wgpu::Buffer {
        let label = p.label();
        let buffer = match contents {
            Some(bytes) => {
                assert_eq!(bytes.len() as u64, p.size, "{label}: contents off the plan");
                self.ctx
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some(&label),
                        contents: bytes,
                        usage: p.usage,
                    })
            }
            None => self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(&label),
                size: p.size,
                usage: p.usage,
                mapped_at_creation: false,
            }),
        };
        self.made.push(AllocatedBuffer {
            label,
            size: buffer.size(),
            usage: buffer.usage(),
        });
        buffer
    }

    /// The buffer `p` filled with `data`; an empty array is padded to one zero element (empty
    /// storage bindings are invalid).
    fn init<T: bytemuck::Pod>(&mut self, p: &PlannedBuffer, data: &[T]) -> wgpu::Buffer {
        let zero = [T::zeroed()];
        let data = if data.is_empty() { &zero[..] } else { data };
        self.create(p, Some(bytemuck::cast_slice(data)))
    }

    fn empty(&mut self, p: &PlannedBuffer) -> wgpu::Buffer {
        self.create(p, None)
    }
}

/// The buffers of one scene that are not split by direction.
pub(super) struct SceneBuffers {
    pub triangles: wgpu::Buffer,
    pub alpha_masks: wgpu::Buffer,
    pub faces: wgpu::Buffer,
    pub texel_center: wgpu::Buffer,
    pub active_texels: wgpu::Buffer,
    pub unshot: wgpu::Buffer,
    pub tile_index: wgpu::Buffer,
    pub frames: wgpu::Buffer,
    pub next_tiles: wgpu::Buffer,
    pub spec_escape: wgpu::Buffer,
    pub panes: wgpu::Buffer,
    pub pane_energy: wgpu::Buffer,
    pub cell_count: wgpu::Buffer,
    pub cells: wgpu::Buffer,
    pub crossings: wgpu::Buffer,
    pub accumulators: wgpu::Buffer,
    pub overflow: wgpu::Buffer,
    pub directions: wgpu::Buffer,
}

/// One chunk of directions: its buffers (tile starts, tile bins, reflect items) and the bind
/// groups of the passes that read them.
pub(super) struct ChunkResources {
    _buffers: [wgpu::Buffer; 3],
    pub cells: wgpu::BindGroup,
    pub reflect: wgpu::BindGroup,
}

/// Everything one scene's bake binds: the plan's buffers and the bind groups over them.
pub struct SceneResources {
    pub(super) buffers: SceneBuffers,
    pub(super) chunks: Vec<ChunkResources>,
    pub(super) globals: wgpu::BindGroup,
    pub(super) interface: wgpu::BindGroup,
    pub(super) gather: wgpu::BindGroup,
    allocated: Vec<AllocatedBuffer>,
}

impl SceneResources {
    /// The resources of the bake of `scene` with `plan` (made for this scene and these
    /// parameters), with the bins and reflect items uploaded: what
    /// [`super::propagate_planned`] builds before its first iteration.
    pub fn new(
        ctx: &GpuContext,
        pipelines: &BakePipelines,
        plan: &BakePlan,
        scene: &BakeScene,
        set: &DirectionSet,
        params: &BakeParams,
    ) -> Result<SceneResources, GpuBakeError> {
        let mut host = Host::new(scene, set, params, plan, None);
        SceneResources::build(ctx, pipelines, &mut host)
    }

    /// Every buffer allocated for the scene (label, and size and usage as wgpu reports
    /// them), in allocation order.
    pub fn allocated(&self) -> &[AllocatedBuffer] {
        &self.allocated
    }

    pub(super) fn build(
        ctx: &GpuContext,
        pipelines: &BakePipelines,
        host: &mut Host,
    ) -> Result<SceneResources, GpuBakeError> {
        use BakeBuffer as B;
        let plan = host.plan;
        plan.check(binding_limit(&ctx.device))?;
        let mut alloc = Allocator {
            ctx,
            made: Vec::with_capacity(plan.buffers.len()),
        };
        let chunk_buffers: Vec<[wgpu::Buffer; 3]> = (0..plan.chunks.len())
            .map(|k| {
                [B::BinStart, B::BinTris, B::ReflectItems]
                    .map(|b| alloc.empty(plan.chunk_buffer(b, k)))
            })
            .collect();
        upload_bins(ctx, host, &chunk_buffers);
        if let Some(t) = &mut host.tiles {
            // Uploaded with their chunks.
            t.items = Vec::new();
        }
        let scene = host.scene;
        let centers: Vec<[f32; 4]> = scene
            .texel_center
            .iter()
            .zip(&host.tex_face)
            .map(|(c, &f)| [c[0], c[1], c[2], f32::from_bits(f)])
            .collect();
        let mut unshot = scene.emission.clone();
        unshot.resize(host.texels() + host.tile_len(), [0.0; 4]);
        let (packed, frames) = match &host.tiles {
            Some(t) => (&t.packed[..], &t.frames[..]),
            None => (&[][..], &[][..]),
        };
        let p = |b| plan.buffer(b);
        let b = SceneBuffers {
            triangles: alloc.init(p(B::Triangles), &scene.triangles),
            alpha_masks: alloc.init(p(B::AlphaMasks), &scene.masks.words()),
            faces: alloc.init(p(B::Faces), &scene.faces),
            texel_center: alloc.init(p(B::TexelCenter), &centers),
            active_texels: alloc.init(p(B::ActiveTexels), &host.active),
            unshot: alloc.init(p(B::Unshot), &unshot),
            tile_index: alloc.init(p(B::TileIndex), packed),
            frames: alloc.init(p(B::Frames), frames),
            next_tiles: alloc.empty(p(B::NextTiles)),
            spec_escape: alloc.empty(p(B::SpecEscape)),
            panes: alloc.init(p(B::Panes), &scene.panes),
            pane_energy: alloc.empty(p(B::PaneEnergy)),
            cell_count: alloc.empty(p(B::CellCount)),
            cells: alloc.empty(p(B::Cells)),
            crossings: alloc.empty(p(B::Crossings)),
            accumulators: alloc.empty(p(B::Accumulators)),
            overflow: alloc.init(p(B::Overflow), &[0u32; 4]),
            directions: alloc.create(
                p(B::Directions),
                Some(&host.direction_uniforms(host.params.sky)),
            ),
        };

        let device = &ctx.device;
        let chunks = chunk_buffers
            .into_iter()
            .map(|[bin_start, bin_tris, reflect_items]| ChunkResources {
                cells: pipelines.cells.bind_group(
                    device,
                    &CellsBindings {
                        triangles: &b.triangles,
                        bin_start: &bin_start,
                        bin_tris: &bin_tris,
                        cell_count: &b.cell_count,
                        cells: &b.cells,
                        overflow: &b.overflow,
                        alpha_masks: &b.alpha_masks,
                    },
                ),
                reflect: pipelines.reflect.bind_group(
                    device,
                    &ReflectBindings {
                        faces: &b.faces,
                        cell_count: &b.cell_count,
                        cells: &b.cells,
                        crossings: &b.crossings,
                        tile_index: &b.tile_index,
                        frames: &b.frames,
                        items: &reflect_items,
                        next_tiles: &b.next_tiles,
                    },
                ),
                _buffers: [bin_start, bin_tris, reflect_items],
            })
            .collect();
        let interface = pipelines.interface.bind_group(
            device,
            &InterfaceBindings {
                faces: &b.faces,
                unshot: &b.unshot,
                cell_count: &b.cell_count,
                cells: &b.cells,
                crossings: &b.crossings,
                tile_index: &b.tile_index,
                frames: &b.frames,
                spec_escape: &b.spec_escape,
                panes: &b.panes,
                pane_energy: &b.pane_energy,
            },
        );
        let gather = pipelines.gather.bind_group(
            device,
            &GatherBindings {
                faces: &b.faces,
                active_texels: &b.active_texels,
                texel_center: &b.texel_center,
                cell_count: &b.cell_count,
                cells: &b.cells,
                crossings: &b.crossings,
                acc: &b.accumulators,
            },
        );
        Ok(SceneResources {
            globals: pipelines.globals(device, &b.directions),
            buffers: b,
            chunks,
            interface,
            gather,
            allocated: alloc.made,
        })
    }
}

/// Bins every transport direction again (the plan binned it once to size the chunks) and
/// writes it, with its reflect items, straight into its chunk's buffers, so the host never
/// holds more than one direction's bins; staging is flushed every [`UPLOAD_FLUSH_BYTES`].
/// Checks that every direction bins to the bytes the plan counted.
fn upload_bins(ctx: &GpuContext, host: &Host, chunk_buffers: &[[wgpu::Buffer; 3]]) {
    let plan = host.plan;
    let items_of = |i: usize| host.tiles.as_ref().map_or((0, 0), |t| t.item_ranges[i]);
    let mut pending = 0u64;
    let mut start = Vec::new();
    for (chunk, [bin_start, bin_tris, reflect_items]) in plan.chunks.iter().zip(chunk_buffers) {
        let mut at = ChunkBytes::default();
        for i in chunk.directions.clone() {
            let bins = bin_triangles(
                &project(host.scene, &host.setup.dirs[i].frame),
                &host.setup.grid,
            );
            let (item_first, item_count) = items_of(i);
            let size = plan::direction_bytes(&bins, item_count);
            assert_eq!(
                size, plan.direction_bytes[i],
                "direction {i} bins differently from the plan"
            );
            let offset = (at.bin_tris / 4) as u32;
            start.clear();
            start.extend(bins.start.iter().map(|s| s + offset));
            let items: &[ReflectItem] = match &host.tiles {
                Some(t) => &t.items[item_first as usize..(item_first + item_count) as usize],
                None => &[],
            };
            for (buffer, offset, bytes) in [
                (bin_start, at.bin_start, bytemuck::cast_slice(&start)),
                (bin_tris, at.bin_tris, bytemuck::cast_slice(&bins.tris)),
                (reflect_items, at.reflect_items, bytemuck::cast_slice(items)),
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
        debug_assert_eq!(at, chunk.bytes);
    }
    ctx.queue.submit(None);
    log::debug!(
        "GPU bake: tile bins of {} directions in {} chunk(s) of ≤ {} bytes",
        host.setup.dirs.len(),
        plan.chunks.len(),
        plan.chunk_cap,
    );
}
