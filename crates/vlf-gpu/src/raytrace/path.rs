//! The GPU reference path tracer (`shaders/raytrace_path.wgsl`): the estimator of
//! `vlf_core::pathtrace` on the GPU, as a wavefront over the [`RayEngine`] or as a megakernel.
//!
//! Work is organised in *waves*: a wave traces `samples_per_wave` samples of every pixel of a
//! chunk of 8×8-pixel tiles (one path per slot, slots ordered tile by tile so primary rays are
//! coherent). A wave of the wavefront variant runs, per bounce, entirely with indirect
//! dispatches: engine closest hit → `shade` (emission with MIS, one NEE shadow ray, BSDF
//! sampling, Russian roulette; survivors are compacted into the other queue) → engine any hit
//! on the shadow rays → `resolve` → `queue_end` (next dispatch size). The host checks the queue
//! every few bounces and starts the next wave when it is empty. Path `(pixel, sample)` uses the
//! random stream of `vlf_core::pathtrace::Rng::for_path`, exactly like the CPU tracer.
//!
//! Thin glass panes are the CPU tracer's delta lobe (reflect with R(θ), pass with T(θ), tinted),
//! and a shadow ray towards a delta light that meets something is traced again through the
//! panes (`resolve`, or inline in the megakernel: `shaders/common/pane_trace.wgsl`,
//! `PreparedScene::shadow_transmittance`); an emitter's shadow ray stops at a pane, as on the
//! CPU. Translucent materials (the CPU tracer's `walk`) are not on the GPU: `vlf-bake reference`
//! traces such scenes on the CPU.
//!
//! Bind groups of the path kernels: 0 = [`RtGlobals`] + [`RtBatch`] (dynamic offset), 1 = scene
//! (nodes, triangles, blob, [`RtSceneInfo`]: `shaders/common/rt_scene.wgsl`), 2 = wave buffers
//! (rays, hits, paths, queues, accumulators), 3 = control (queues, indirect arguments, finished
//! image chunk).

use std::time::Instant;

use wgpu::util::DeviceExt;

use super::engine::{Query, RayEngine, WORKGROUP};
use super::{GpuScene, RaytraceError};
use crate::GpuContext;
use crate::layout::{RtBatch, RtGlobals, RtPath, RtQueue, RtSceneInfo};
use crate::readback::read_buffer;
use crate::shaders;
use crate::wgpu_util::{
    compute_pipeline, compute_storage, dispatch_2d, pipeline_layout, uniform_entry,
};
use vlf_core::image::Image;
use vlf_core::pathtrace::{Hit, PinholeCamera, PreparedScene, RR_DEPTH, Ray, RenderSettings};

/// Which GPU path-tracing organisation to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// Generate / intersect / shade / shadow / resolve kernels per bounce over compacted queues.
    Wavefront,
    /// One invocation traces a whole path.
    Megakernel,
}

/// How the GPU path tracer organises its work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuRenderOptions {
    /// Wavefront or megakernel.
    pub kernel: Kernel,
    /// Paths in flight per wave (memory ≈ 256 bytes per path for the wavefront).
    pub paths_per_wave: u32,
    /// Wavefront: bounces encoded per submission before the host checks the queue.
    pub bounces_per_check: u32,
}

impl Default for GpuRenderOptions {
    fn default() -> Self {
        Self {
            kernel: Kernel::Wavefront,
            paths_per_wave: 1 << 18,
            bounces_per_check: 8,
        }
    }
}

/// What a GPU render did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuRenderStats {
    /// Waves traced (over all chunks).
    pub waves: u32,
    /// Chunks of tiles the image was cut into.
    pub chunks: u32,
    /// Samples of each pixel per wave.
    pub samples_per_wave: u32,
    /// Camera and continuation rays traced (wavefront only; 0 for the megakernel).
    pub extension_rays: u64,
    /// Shadow rays traced (wavefront only).
    pub shadow_rays: u64,
    /// Wall time of the render, seconds.
    pub seconds: f64,
}

/// Pipelines of the GPU path tracer.
pub struct GpuPathTracer {
    engine: RayEngine,
    globals_layout: wgpu::BindGroupLayout,
    scene_layout: wgpu::BindGroupLayout,
    wave_layout: wgpu::BindGroupLayout,
    ctl_layout: wgpu::BindGroupLayout,
    wave_begin: wgpu::ComputePipeline,
    generate: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    queue_end: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    megakernel: wgpu::ComputePipeline,
}

/// The per-render buffers and bind groups.
struct Resources {
    globals: wgpu::Buffer,
    queues: wgpu::Buffer,
    args: wgpu::Buffer,
    accum: wgpu::Buffer,
    image: wgpu::Buffer,
    globals_bg: wgpu::BindGroup,
    scene_bg: wgpu::BindGroup,
    wave_bg: wgpu::BindGroup,
    ctl_bg: wgpu::BindGroup,
    engine_batch_bg: wgpu::BindGroup,
    engine_scene_bg: wgpu::BindGroup,
    engine_rays_bg: wgpu::BindGroup,
    stride: u32,
}

impl GpuPathTracer {
    /// Compiles the kernels (the ray engine's included).
    pub fn new(device: &wgpu::Device) -> Self {
        let engine = RayEngine::new(device);
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("PathTracer::globals_layout"),
            entries: &[
                uniform_entry::<RtGlobals>(0, wgpu::ShaderStages::COMPUTE, false),
                uniform_entry::<RtBatch>(1, wgpu::ShaderStages::COMPUTE, true),
            ],
        });
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("PathTracer::scene_layout"),
            entries: &[
                compute_storage(0, true),
                compute_storage(1, true),
                compute_storage(2, true),
                uniform_entry::<RtSceneInfo>(3, wgpu::ShaderStages::COMPUTE, false),
                compute_storage(6, true),
            ],
        });
        let wave_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("PathTracer::wave_layout"),
            entries: &[
                compute_storage(0, false),
                compute_storage(1, true),
                compute_storage(2, false),
                compute_storage(3, false),
                compute_storage(4, false),
            ],
        });
        let ctl_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("PathTracer::ctl_layout"),
            entries: &[
                compute_storage(0, false),
                compute_storage(1, false),
                compute_storage(2, false),
            ],
        });
        let main_layout = pipeline_layout(
            device,
            "PathTracer::main_pipeline_layout",
            &[
                Some(&globals_layout),
                Some(&scene_layout),
                Some(&wave_layout),
            ],
        );
        let ctl_pipeline_layout = pipeline_layout(
            device,
            "PathTracer::ctl_pipeline_layout",
            &[Some(&globals_layout), None, None, Some(&ctl_layout)],
        );
        let finish_layout = pipeline_layout(
            device,
            "PathTracer::finish_pipeline_layout",
            &[
                Some(&globals_layout),
                None,
                Some(&wave_layout),
                Some(&ctl_layout),
            ],
        );
        let module = shaders::RAYTRACE_PATH.module(device);
        let pipeline = |entry: &str, layout: &wgpu::PipelineLayout| {
            compute_pipeline(device, "PathTracer", layout, &module, entry)
        };
        Self {
            wave_begin: pipeline("wave_begin", &ctl_pipeline_layout),
            generate: pipeline("generate", &main_layout),
            shade: pipeline("shade", &main_layout),
            resolve: pipeline("resolve", &main_layout),
            queue_end: pipeline("queue_end", &ctl_pipeline_layout),
            finish: pipeline("finish", &finish_layout),
            megakernel: pipeline("megakernel", &main_layout),
            engine,
            globals_layout,
            scene_layout,
            wave_layout,
            ctl_layout,
        }
    }

    /// The ray engine the wavefront drives.
    pub fn engine(&self) -> &RayEngine {
        &self.engine
    }

    /// Renders the mean radiance of every pixel with `settings.spp` samples (`settings.threads`
    /// is ignored). `progress(done, total)` counts samples. Same image conventions and the same
    /// estimator as `vlf_core::pathtrace::render`.
    pub fn render(
        &self,
        ctx: &GpuContext,
        prep: &PreparedScene,
        camera: &PinholeCamera,
        settings: &RenderSettings,
        options: &GpuRenderOptions,
        progress: &dyn Fn(u64, u64),
    ) -> Result<(Image, GpuRenderStats), RaytraceError> {
        settings.validate()?;
        let start = Instant::now();
        let device = &ctx.device;
        let scene = GpuScene::upload(device, prep)?;
        let (w, h) = (settings.width, settings.height);
        let tiles_x = w.div_ceil(8);
        let tiles_total = tiles_x * h.div_ceil(8);
        let target = options.paths_per_wave.max(64);
        // Samples per wave: the largest divisor of spp that keeps the wave within the target
        // (all tiles in one chunk); otherwise one sample per wave over chunks of tiles.
        let (k, tiles_per_chunk) = if u64::from(tiles_total) * 64 <= u64::from(target) {
            let max_k = (target / (tiles_total * 64)).clamp(1, settings.spp);
            let k = (1..=max_k)
                .rev()
                .find(|k| settings.spp.is_multiple_of(*k))
                .unwrap_or(1);
            (k, tiles_total)
        } else {
            (1, (target / 64).max(1))
        };
        let paths = tiles_per_chunk * 64 * k;
        let wavefront = options.kernel == Kernel::Wavefront;
        let res = self.resources(ctx, &scene, paths, tiles_per_chunk, wavefront)?;
        let waves_per_chunk = settings.spp / k;
        let chunks = tiles_total.div_ceil(tiles_per_chunk);
        let total = u64::from(w) * u64::from(h) * u64::from(settings.spp);
        let mut stats = GpuRenderStats {
            chunks,
            samples_per_wave: k,
            ..Default::default()
        };
        let mut image = Image::new(w, h, [0.0; 3]);
        let max_groups = device.limits().max_compute_workgroups_per_dimension;
        let mut done = 0u64;
        for chunk in 0..chunks {
            let tile_base = chunk * tiles_per_chunk;
            let tile_count = tiles_per_chunk.min(tiles_total - tile_base);
            let chunk_pixels = pixels_in_tiles(w, h, tiles_x, tile_base, tile_count);
            let path_count = tile_count * 64 * k;
            for wave in 0..waves_per_chunk {
                let globals = RtGlobals {
                    cam_pos: camera.position.extend(camera.tan_half_y).into(),
                    cam_forward: camera.forward.extend(camera.aspect).into(),
                    cam_right: camera.right.extend(0.0).into(),
                    cam_up: camera.up.extend(0.0).into(),
                    sky: settings.sky.extend(0.0).into(),
                    width: w,
                    height: h,
                    seed: settings.seed,
                    sample_base: wave * k,
                    samples_per_wave: k,
                    path_count,
                    tiles_x,
                    max_groups,
                    spp: settings.spp,
                    rr_depth: RR_DEPTH,
                    tile_base,
                    tile_count,
                };
                ctx.queue
                    .write_buffer(&res.globals, 0, bytemuck::bytes_of(&globals));
                if wavefront {
                    let (ext, shadow) =
                        self.wave(ctx, &res, path_count, options.bounces_per_check)?;
                    stats.extension_rays += ext;
                    stats.shadow_rays += shadow;
                } else {
                    self.mega_wave(ctx, &res, path_count);
                }
                stats.waves += 1;
                done += chunk_pixels * u64::from(k);
                progress(done, total);
            }
            // Mean per pixel of this chunk, then clear the accumulators for the next one.
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("PathTracer::finish_encoder"),
            });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("PathTracer::finish"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.finish);
                pass.set_bind_group(0, &res.globals_bg, &[0]);
                pass.set_bind_group(2, &res.wave_bg, &[]);
                pass.set_bind_group(3, &res.ctl_bg, &[]);
                let (x, y) = dispatch_2d(tile_count * 64, WORKGROUP, max_groups);
                pass.dispatch_workgroups(x, y, 1);
            }
            encoder.clear_buffer(&res.accum, 0, None);
            ctx.queue.submit(Some(encoder.finish()));
            let out: Vec<[f32; 4]> = read_buffer(device, &ctx.queue, &res.image)?;
            for i in 0..(tile_count * 64) as usize {
                let tile = tile_base + (i / 64) as u32;
                let local = (i % 64) as u32;
                let px = (tile % tiles_x) * 8 + local % 8;
                let py = (tile / tiles_x) * 8 + local / 8;
                if px < w && py < h {
                    let v = out[i];
                    image.pixels[(py * w + px) as usize] = [v[0], v[1], v[2]];
                }
            }
        }
        stats.seconds = start.elapsed().as_secs_f64();
        Ok((image, stats))
    }

    /// One wavefront wave: returns (extension rays, shadow rays).
    fn wave(
        &self,
        ctx: &GpuContext,
        res: &Resources,
        path_count: u32,
        bounces_per_check: u32,
    ) -> Result<(u64, u64), RaytraceError> {
        let device = &ctx.device;
        let max_groups = device.limits().max_compute_workgroups_per_dimension;
        let mut cur = 0u32;
        let mut first = true;
        loop {
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("PathTracer::wave_encoder"),
            });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("PathTracer::wave"),
                    timestamp_writes: None,
                });
                if first {
                    pass.set_pipeline(&self.wave_begin);
                    pass.set_bind_group(0, &res.globals_bg, &[0]);
                    pass.set_bind_group(3, &res.ctl_bg, &[]);
                    pass.dispatch_workgroups(1, 1, 1);
                    pass.set_pipeline(&self.generate);
                    pass.set_bind_group(0, &res.globals_bg, &[0]);
                    pass.set_bind_group(1, &res.scene_bg, &[]);
                    pass.set_bind_group(2, &res.wave_bg, &[]);
                    let (x, y) = dispatch_2d(path_count, WORKGROUP, max_groups);
                    pass.dispatch_workgroups(x, y, 1);
                    first = false;
                }
                for _ in 0..bounces_per_check.max(1) {
                    self.encode_bounce(&mut pass, res, cur);
                    cur = 1 - cur;
                }
            }
            ctx.queue.submit(Some(encoder.finish()));
            let q: Vec<RtQueue> = read_buffer(device, &ctx.queue, &res.queues)?;
            if q[cur as usize].count == 0 {
                return Ok((u64::from(q[2].count), u64::from(q[3].count)));
            }
        }
    }

    /// One bounce of the wavefront, with `cur` the queue holding this bounce's rays.
    fn encode_bounce(&self, pass: &mut wgpu::ComputePass, res: &Resources, cur: u32) {
        let args = u64::from(cur) * 16;
        let offset = |variant: u32| [variant * res.stride];
        // Intersect the queue.
        pass.set_pipeline(self.engine.pipeline(Query::Closest));
        pass.set_bind_group(0, &res.engine_batch_bg, &offset(cur));
        pass.set_bind_group(1, &res.engine_scene_bg, &[]);
        pass.set_bind_group(2, &res.engine_rays_bg, &[]);
        pass.dispatch_workgroups_indirect(&res.args, args);
        // Shade: emission, NEE shadow ray, continuation (compacted into the other queue).
        pass.set_pipeline(&self.shade);
        pass.set_bind_group(0, &res.globals_bg, &offset(cur));
        pass.set_bind_group(1, &res.scene_bg, &[]);
        pass.set_bind_group(2, &res.wave_bg, &[]);
        pass.dispatch_workgroups_indirect(&res.args, args);
        // Shadow rays (region S, one per path of this queue).
        pass.set_pipeline(self.engine.pipeline(Query::Any));
        pass.set_bind_group(0, &res.engine_batch_bg, &offset(2 + cur));
        pass.set_bind_group(1, &res.engine_scene_bg, &[]);
        pass.set_bind_group(2, &res.engine_rays_bg, &[]);
        pass.dispatch_workgroups_indirect(&res.args, args);
        // Add the unoccluded NEE contributions.
        pass.set_pipeline(&self.resolve);
        pass.set_bind_group(0, &res.globals_bg, &offset(cur));
        pass.set_bind_group(1, &res.scene_bg, &[]);
        pass.set_bind_group(2, &res.wave_bg, &[]);
        pass.dispatch_workgroups_indirect(&res.args, args);
        // Size the next queue's dispatches; empty this one.
        pass.set_pipeline(&self.queue_end);
        pass.set_bind_group(0, &res.globals_bg, &offset(cur));
        pass.set_bind_group(3, &res.ctl_bg, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }

    /// One megakernel wave (submitted and waited for).
    fn mega_wave(&self, ctx: &GpuContext, res: &Resources, path_count: u32) {
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("PathTracer::mega_encoder"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("PathTracer::megakernel"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.megakernel);
            pass.set_bind_group(0, &res.globals_bg, &[0]);
            pass.set_bind_group(1, &res.scene_bg, &[]);
            pass.set_bind_group(2, &res.wave_bg, &[]);
            let (x, y) = dispatch_2d(
                path_count,
                WORKGROUP,
                ctx.device.limits().max_compute_workgroups_per_dimension,
            );
            pass.dispatch_workgroups(x, y, 1);
        }
        ctx.queue.submit(Some(encoder.finish()));
        ctx.wait_idle();
    }

    fn resources(
        &self,
        ctx: &GpuContext,
        scene: &GpuScene,
        paths: u32,
        tiles_per_chunk: u32,
        wavefront: bool,
    ) -> Result<Resources, RaytraceError> {
        let device = &ctx.device;
        let limits = device.limits();
        let limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        // Wave buffers: three regions (A, B, S) of `paths` entries; the megakernel needs none.
        let regions = if wavefront { 3 * u64::from(paths) } else { 1 };
        let buffer = |what: &'static str, label: &str, bytes: u64, usage: wgpu::BufferUsages| {
            if bytes > limit {
                return Err(RaytraceError::TooLarge { what, bytes, limit });
            }
            Ok(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16),
                usage,
                mapped_at_creation: false,
            }))
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let rays = buffer(
            "ray queues",
            "PathTracer::rays",
            regions * size_of::<Ray>() as u64,
            storage,
        )?;
        let hits = buffer(
            "hit buffer",
            "PathTracer::hits",
            regions * size_of::<Hit>() as u64,
            storage,
        )?;
        let path_buf = buffer(
            "path states",
            "PathTracer::paths",
            regions * size_of::<RtPath>() as u64,
            storage,
        )?;
        let accum = buffer(
            "accumulators",
            "PathTracer::accum",
            u64::from(paths) * 16,
            storage | wgpu::BufferUsages::COPY_DST,
        )?;
        let image = buffer(
            "image chunk",
            "PathTracer::image",
            u64::from(tiles_per_chunk) * 64 * 16,
            storage | wgpu::BufferUsages::COPY_SRC,
        )?;
        let queues = buffer(
            "queues",
            "PathTracer::queues",
            4 * size_of::<RtQueue>() as u64,
            storage | wgpu::BufferUsages::COPY_SRC,
        )?;
        let args = buffer(
            "dispatch arguments",
            "PathTracer::args",
            2 * 16,
            storage | wgpu::BufferUsages::INDIRECT,
        )?;
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("PathTracer::globals"),
            size: size_of::<RtGlobals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Batch selectors: 0 = queue A → B, 1 = queue B → A, 2 / 3 = shadow rays of A / B.
        let stride = limits.min_uniform_buffer_offset_alignment.max(256);
        let (p, s) = (paths, 2 * paths);
        let variants = [
            RtBatch {
                queue: 0,
                base: 0,
                next_queue: 1,
                next_base: p,
                shadow_base: s,
                ..Default::default()
            },
            RtBatch {
                queue: 1,
                base: p,
                next_queue: 0,
                next_base: 0,
                shadow_base: s,
                ..Default::default()
            },
            RtBatch {
                queue: 0,
                base: s,
                ..Default::default()
            },
            RtBatch {
                queue: 1,
                base: s,
                ..Default::default()
            },
        ];
        let mut bytes = vec![0u8; stride as usize * variants.len()];
        for (i, v) in variants.iter().enumerate() {
            let at = i * stride as usize;
            bytes[at..at + size_of::<RtBatch>()].copy_from_slice(bytemuck::bytes_of(v));
        }
        let batches = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("PathTracer::batches"),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group =
            |label: &str, layout: &wgpu::BindGroupLayout, buffers: &[&wgpu::Buffer]| {
                crate::wgpu_util::buffer_bind_group(device, label, layout, buffers)
            };
        let globals_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("PathTracer::globals_bind_group"),
            layout: &self.globals_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: globals.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &batches,
                        offset: 0,
                        size: wgpu::BufferSize::new(size_of::<RtBatch>() as u64),
                    }),
                },
            ],
        });
        Ok(Resources {
            scene_bg: device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("PathTracer::scene_bind_group"),
                layout: &self.scene_layout,
                entries: &[
                    (0, &scene.nodes),
                    (1, &scene.triangles),
                    (2, &scene.blob),
                    (3, &scene.info),
                    (6, &scene.masks),
                ]
                .map(|(binding, b)| wgpu::BindGroupEntry {
                    binding,
                    resource: b.as_entire_binding(),
                }),
            }),
            wave_bg: bind_group(
                "PathTracer::wave_bind_group",
                &self.wave_layout,
                &[&rays, &hits, &path_buf, &queues, &accum],
            ),
            ctl_bg: bind_group(
                "PathTracer::ctl_bind_group",
                &self.ctl_layout,
                &[&queues, &args, &image],
            ),
            engine_batch_bg: self.engine.batch_bind_group(device, &batches),
            engine_scene_bg: self.engine.scene_bind_group(device, scene),
            engine_rays_bg: self.engine.rays_bind_group(
                device,
                "PathTracer::engine_rays_bind_group",
                &rays,
                &hits,
                &queues,
            ),
            globals_bg,
            globals,
            queues,
            args,
            accum,
            image,
            stride,
        })
    }
}

/// Pixels of the image covered by tiles `tile_base .. tile_base + tile_count`.
fn pixels_in_tiles(w: u32, h: u32, tiles_x: u32, tile_base: u32, tile_count: u32) -> u64 {
    (tile_base..tile_base + tile_count)
        .map(|t| {
            let (tx, ty) = (t % tiles_x, t / tiles_x);
            let cw = w.saturating_sub(tx * 8).min(8);
            let ch = h.saturating_sub(ty * 8).min(8);
            u64::from(cw * ch)
        })
        .sum()
}
