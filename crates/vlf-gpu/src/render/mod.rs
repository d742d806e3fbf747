//! The viewer's renderer: five passes per frame (paper §4, "Rendering on the GPU").
//!
//! Pass order (the one place it is written down), per pixel of the view:
//!
//! 1. [`direction_ids`]: the direction set's sphere triangles drawn from the sphere centre with
//!    the camera's orientation → the three sphere-vertex ids of the view ray's triangle
//!    (`Rgba32Uint`: ids, triangle index).
//! 2. [`barycentrics`]: the same mesh with one-hot vertex colours → the view direction's
//!    barycentric weights (`Rgba32Float`), equal to `DirectionSet::lookup`'s.
//! 3. [`face_id`]: the scene, depth-tested → face id of the visible surface (`R32Uint`,
//!    [`NO_FACE`] for background); for light fields with textures or mirrors also a stencil
//!    marking the pixels whose visible face is textured or a mirror (so that pass 5 runs
//!    texture code and mirror code for those only).
//! 4. [`position`]: the scene again against pass 3's depth → VLF position of the visible point
//!    (`Rgba32Float`, w = 1 where a face is seen) and its `TEXCOORD_0` (`Rg32Float`); for
//!    light fields with per-corner attributes (shading normals, vertex colours, `TEXCOORD_1`)
//!    a second draw ([`position::attributes_pass`]) interpolates those into two `Rgba32Float`
//!    targets.
//! 5. [`final_radiance`]: per pixel (a viewport-covering triangle), the radiance leaving that
//!    point towards the camera: emission and base-colour texture at the pixel's uv applied to
//!    the atlas irradiance on the side facing the camera (`Le + ρ_d/π · E`), plus, for mirror
//!    and mixed faces, the reflection traced through the scene's BVH ([`mirror_trace`]) or read
//!    from the mirror tiles, or the sky (`Rgba32Float`); stills average several jittered
//!    samples into a storage buffer.
//!
//! Then [`display`] shows the selected [`Pass`]'s output (debug view) on a colour target. For
//! the final image in the window the display is fused into pass 5 (it writes the window's
//! surface), see below, and so is pass 4: pass 5 draws the scene's triangles against pass 3's
//! depth and interpolates the position and uv pass 4 would store, with each face's record as
//! flat inputs ([`final_radiance`]); passes 1–2 run only for light fields with mirror or mixed
//! faces, whose tiles read them ([`Renderer::render_to_view`]). Stills, debug views and
//! [`Renderer::render_frame_data`] run the five passes as listed.
//!
//! Pass structure, measured on lavapipe (2-core VM, Mesa 22.3.6), Cornell box, 1024×768,
//! wall-clock per frame (encode, submit, wait), median of 30 frames, variants run alternately:
//!
//! | variant | frame |
//! |---|---|
//! | five passes + separate display pass | 37.5 ms |
//! | passes 1+2 and 3+4 fused into two MRT passes, separate display | 36.8 ms |
//! | five passes, display fused into pass 5 (chosen) | 30.2 ms |
//!
//! Fusing 1+2 and 3+4 saved < 1 ms (2 %, within run-to-run noise), so those passes stay
//! separate: one pipeline and one WGSL file each. The fused display saves a full-screen pass
//! that only read the radiance back (~20 %). Also measured: per-pixel data read by pass 5
//! (atlas, face records) lives in textures, not storage buffers (see [`upload`]).
//!
//! Later, with per-pixel albedo in pass 5, CPU time per frame of the default
//! Cornell bake (llvmpipe on 2 cores, which runs the shaders; `docs/PERFORMANCE.md`): passes
//! 1–2 ~11 ms of 66, and each texel fetch of pass 5 3–4 ms (face id and position 8, the face
//! record's five texels 16, the atlas's four 8). Hence, for the window's final image, pass 4
//! fused into pass 5 (the face record read once per vertex instead of per pixel, no position or
//! face id read back, no pass 4 targets written) and passes 1–2 skipped without mirrors.
//!
//! Bindings: group 0 = [`RenderGlobals`] (camera matrices, eye, sky, sample index), group 1 =
//! the pass's own resources, group 2 = the mirror tiles (pass 5, `common/mirror_tiles.wgsl`).
//! Everything is labelled `"PassName::thing"`.

pub mod attributes;
pub mod barycentrics;
pub mod camera;
pub mod direction_ids;
pub mod display;
pub mod face_id;
pub mod final_radiance;
pub mod mirror_trace;
mod pipelines;
pub mod position;
pub mod targets;
pub mod timing;
pub mod upload;

use glam::Vec2;
use vlf_core::lightfield::LightField;

pub use camera::{CameraView, sample_offsets};

use crate::GpuContext;
use crate::layout::RenderGlobals;
use display::DisplayPass;
use face_id::FaceIdPass;
use final_radiance::FinalRadiancePass;
use mirror_trace::GpuMirrorScene;
use targets::Targets;
use timing::{FrameTimestamps, GpuTimer};
use upload::GpuLightField;

// Helpers of the pass modules, which reach them as `super::…`.
pub(crate) use crate::wgpu_util::{storage_entry, texture_entry};
pub(crate) use pipelines::color_attachment;
use pipelines::{geometry_pass_layout, geometry_pipeline};

/// Face id written where no surface is seen.
pub const NO_FACE: u32 = u32::MAX;

/// The five passes, in order; also the debug-view selector.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Pass {
    DirectionIds = 0,
    Barycentrics = 1,
    FaceId = 2,
    Position = 3,
    #[default]
    FinalRadiance = 4,
}

impl Pass {
    pub const ALL: [Pass; 5] = [
        Pass::DirectionIds,
        Pass::Barycentrics,
        Pass::FaceId,
        Pass::Position,
        Pass::FinalRadiance,
    ];

    /// Short kebab-case name (command-line values, labels).
    pub fn name(self) -> &'static str {
        match self {
            Pass::DirectionIds => "direction-ids",
            Pass::Barycentrics => "barycentrics",
            Pass::FaceId => "face-id",
            Pass::Position => "position",
            Pass::FinalRadiance => "final-radiance",
        }
    }

    pub fn from_name(name: &str) -> Option<Pass> {
        Pass::ALL.into_iter().find(|p| p.name() == name)
    }
}

/// Labels of the GPU-timed passes, in [`Renderer::pass_times`] order (a frame of the window's
/// final image skips some: see [`Renderer::render_to_view`]).
pub const TIMED_PASSES: [&str; 6] = [
    "direction-ids",
    "barycentrics",
    "face-id",
    "position",
    "final-radiance",
    "display",
];

/// How the display maps radiance to the screen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u32)]
pub enum Tonemap {
    /// Raw linear values (float targets only; unorm targets clamp).
    None = 0,
    /// Linear, clamped to [0, 1] (`vlf_core::image::Tonemap::Clamp`).
    #[default]
    Clamp = 1,
    /// Narkowicz's fitted ACES curve with 0.6 pre-exposure (`vlf_core::image::Tonemap::Aces`).
    Aces = 2,
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("light field is invalid: {0}")]
    InvalidLightField(String),
    #[error("{what} needs {bytes} bytes but the device allows at most {limit}")]
    TooLarge {
        what: String,
        bytes: u64,
        limit: u64,
    },
    #[error("image size {width}×{height} is not supported (1..={max} per side)")]
    Size { width: u32, height: u32, max: u32 },
    #[error("GPU readback failed: {0}")]
    Readback(#[from] wgpu::BufferAsyncError),
}

/// Every pass output of one frame (one sample at the pixel centres), row 0 at the top: for
/// tests and inspection.
#[derive(Clone, Debug)]
pub struct FrameData {
    pub width: u32,
    pub height: u32,
    pub direction_ids: Vec<[u32; 4]>,
    pub barycentrics: Vec<[f32; 4]>,
    pub face_id: Vec<u32>,
    pub position: Vec<[f32; 4]>,
    /// Pass 4's uv (meaningful only where a face is seen).
    pub uv: Vec<[f32; 2]>,
    /// Pass 4b's attribute targets, `[normal xyz, TEXCOORD_1 u]` and the packed words
    /// (`targets::ATTRIBUTE_WORDS_FORMAT`) (meaningful only where a face is seen; empty without
    /// attributes).
    pub attributes: (Vec<[f32; 4]>, Vec<[u32; 4]>),
    pub radiance: Vec<[f32; 4]>,
}

impl FrameData {
    /// What pass 5 read at pixel `i` besides its position: pass 4's uv and pass 4b's
    /// attributes, where there are ([`final_radiance::PixelSurface::from_targets`]).
    pub fn surface(&self, i: usize) -> final_radiance::PixelSurface {
        final_radiance::PixelSurface::from_targets(
            self.uv[i],
            self.attributes.0.get(i).copied(),
            self.attributes.1.get(i).copied(),
        )
    }
}

/// Which of the optional passes before pass 5 a frame runs (pass 3 always runs).
#[derive(Clone, Copy, Debug)]
struct GeometryPasses {
    /// Passes 1 and 2 (direction ids and weights).
    directions: bool,
    /// Pass 4 (position and uv).
    position: bool,
}

impl GeometryPasses {
    const ALL: GeometryPasses = GeometryPasses {
        directions: true,
        position: true,
    };
}

/// How the display maps a frame to its target (written into the per-frame globals).
#[derive(Clone, Copy, Debug)]
struct Display {
    view: Pass,
    /// Linear factor.
    exposure: f32,
    tonemap: Tonemap,
    /// Format of the target (decides whether the shader encodes sRGB).
    format: wgpu::TextureFormat,
}

impl Display {
    /// Raw linear values (stills, tests).
    const RAW: Display = Display {
        view: Pass::FinalRadiance,
        exposure: 1.0,
        tonemap: Tonemap::None,
        format: wgpu::TextureFormat::Rgba32Float,
    };
}

/// Size-dependent state: targets and the bind groups that reference them.
struct Frame {
    targets: Targets,
    final_bind_group: final_radiance::FinalRadianceBindings,
    display_bind_group: wgpu::BindGroup,
}

/// Owns the passes and the uploaded light field. One renderer per device and light field; the
/// per-view targets are (re)created for each new image size.
pub struct Renderer {
    globals: wgpu::Buffer,
    globals_bind_group: wgpu::BindGroup,
    globals_layout: wgpu::BindGroupLayout,
    light_field: GpuLightField,
    /// The BVH pass 5 traces mirror reflections through.
    mirror_scene: GpuMirrorScene,
    direction_ids: pipelines::MeshPass,
    barycentrics: pipelines::MeshPass,
    face_id: FaceIdPass,
    position: pipelines::MeshPass,
    /// Pass 4b, for light fields with per-corner attributes.
    attributes: Option<pipelines::MeshPass>,
    final_radiance: FinalRadiancePass,
    display: DisplayPass,
    frame: Option<Frame>,
    timer: Option<GpuTimer>,
    debug_view: Pass,
    sky: glam::Vec3,
    /// Format of the depth buffer of passes 3–4 (with a stencil marking textured and mirror
    /// faces when the light field has them and the device the format; see [`final_radiance`]).
    depth_format: wgpu::TextureFormat,
}

impl Renderer {
    /// Uploads `lf` and builds the pipelines.
    pub fn new(ctx: &GpuContext, lf: &LightField) -> Result<Self, RenderError> {
        let device = &ctx.device;
        let light_field = GpuLightField::new(device, &ctx.queue, lf)?;
        let mirror_scene = GpuMirrorScene::new(device, lf)?;
        let mirrors = mirror_trace::has_mirrors(lf);
        let textures = final_radiance::TextureKinds::of(lf);
        let attributes = light_field.has_attributes;
        let depth_format = if (textures.any() || mirrors)
            && device
                .features()
                .contains(wgpu::Features::DEPTH32FLOAT_STENCIL8)
        {
            targets::DEPTH_STENCIL_FORMAT
        } else {
            targets::DEPTH_FORMAT
        };
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Renderer::globals_layout"),
            entries: &[crate::wgpu_util::uniform_entry::<RenderGlobals>(
                0,
                wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
                false,
            )],
        });
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Renderer::globals"),
            size: std::mem::size_of::<RenderGlobals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let globals_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("Renderer::globals_bind_group"),
            layout: &globals_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            }],
        });
        Ok(Self {
            direction_ids: direction_ids::pass(device, &globals_layout, &light_field),
            barycentrics: barycentrics::pass(device, &globals_layout, &light_field),
            face_id: FaceIdPass::new(device, &globals_layout, &light_field, depth_format),
            position: position::position_pass(device, &globals_layout, &light_field, depth_format),
            attributes: attributes.then(|| {
                position::attributes_pass(device, &globals_layout, &light_field, depth_format)
            }),
            final_radiance: FinalRadiancePass::new(
                device,
                &globals_layout,
                textures,
                mirrors,
                attributes,
                depth_format,
                light_field.has_masks,
            ),
            display: DisplayPass::new(device, &globals_layout),
            timer: GpuTimer::new(device, &ctx.queue, TIMED_PASSES.len() as u32),
            globals,
            globals_bind_group,
            globals_layout,
            light_field,
            mirror_scene,
            frame: None,
            debug_view: Pass::FinalRadiance,
            sky: lf.params.sky,
            depth_format,
        })
    }

    /// The pass output the display shows ([`Pass::FinalRadiance`] = the image itself).
    pub fn debug_view(&self) -> Pass {
        self.debug_view
    }

    /// Selects the pass output [`Renderer::render_to_view`] displays.
    pub fn set_debug_view(&mut self, pass: Pass) {
        self.debug_view = pass;
    }

    /// Bytes of light-field data on the GPU (geometry, uvs, faces, atlas, textures, direction
    /// mesh, the mirror-tracing BVH).
    pub fn light_field_bytes(&self) -> u64 {
        self.light_field.bytes + self.mirror_scene.bytes
    }

    /// Whether pass 5 traces the reflections of mirror pixels (default: on where the light
    /// field has mirror or mixed faces; see [`mirror_trace`]). Off, they read the mirror tiles.
    pub fn set_mirror_tracing(&mut self, on: bool) {
        self.final_radiance.set_tracing(on);
    }

    /// Whether pass 5 traces mirror reflections (false without mirrors).
    pub fn mirror_tracing(&self) -> bool {
        self.final_radiance.tracing()
    }

    /// Bytes of the light textures on the GPU (atlas irradiance and mirror tile values, in the
    /// stored encoding: 4 bytes per value for RGB9E5, 8 for f16; see [`upload`]).
    pub fn radiance_bytes(&self) -> u64 {
        self.light_field.radiance_bytes
    }

    /// Bytes of the surface textures on the GPU (texels as `Rgba16Float` and their records).
    pub fn texture_bytes(&self) -> u64 {
        self.light_field.texture_bytes
    }

    /// Bytes of the per-view targets (0 before the first frame).
    pub fn target_bytes(&self) -> u64 {
        let attributes = if self.attributes.is_some() { 2 * 16 } else { 0 };
        self.frame.as_ref().map_or(0, |f| {
            u64::from(f.targets.width)
                * u64::from(f.targets.height)
                * (16 * 5 + 4 + 4 + 8 + attributes)
        })
    }

    /// Whether GPU pass times are available (device has `TIMESTAMP_QUERY`).
    pub fn has_pass_times(&self) -> bool {
        self.timer.is_some()
    }

    /// Milliseconds per pass ([`TIMED_PASSES`] order) of a recent frame rendered with
    /// [`Renderer::render_to_view`], once available; `None` for the passes that frame did not
    /// run (the display with the final image, fused into pass 5, and the passes
    /// [`Renderer::render_to_view`] skips for it).
    pub fn pass_times(&self) -> Option<&[Option<f64>]> {
        self.timer.as_ref().and_then(|t| t.latest())
    }

    /// Makes sure the targets have the given size.
    fn ensure_frame(
        &mut self,
        device: &wgpu::Device,
        width: u32,
        height: u32,
    ) -> Result<(), RenderError> {
        if self
            .frame
            .as_ref()
            .is_some_and(|f| f.targets.width == width && f.targets.height == height)
        {
            return Ok(());
        }
        let targets = Targets::new(
            device,
            width,
            height,
            self.depth_format,
            self.attributes.is_some(),
        )?;
        let final_bind_group = self.final_radiance.bind(
            device,
            &targets,
            &self.light_field,
            &self.mirror_scene.bvh,
            &self.mirror_scene.uvs,
        );
        let display_bind_group = self.display.bind(device, &targets);
        self.frame = Some(Frame {
            targets,
            final_bind_group,
            display_bind_group,
        });
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn write_globals(
        &self,
        queue: &wgpu::Queue,
        camera: &CameraView,
        width: u32,
        height: u32,
        sample: u32,
        samples: u32,
        jitter: Vec2,
        display: &Display,
    ) {
        let g = RenderGlobals {
            view_proj: camera.view_proj(width, height, jitter).to_cols_array_2d(),
            dir_view_proj: camera
                .direction_view_proj(width, height, jitter)
                .to_cols_array_2d(),
            eye: camera.position.extend(1.0).into(),
            sky: self.sky.extend(0.0).into(),
            width,
            height,
            sample_index: sample,
            sample_count: samples,
            sample_weight: 1.0 / samples as f32,
            face_count: self.light_field.face_count,
            view: display.view as u32,
            tonemap: display.tonemap as u32,
            exposure: display.exposure,
            encode_srgb: u32::from(display::needs_srgb_encoding(display.format)),
            _pad0: 0,
            _pad1: 0,
        };
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&g));
    }

    /// Encodes pass 3 and, as `passes` says, passes 1–2 and 4 (targets must exist), with the
    /// timestamps of `stamps`.
    fn encode_geometry_passes(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        passes: GeometryPasses,
        stamps: &mut FrameTimestamps<'_>,
    ) {
        let frame = self.frame.as_ref().expect("ensure_frame before encoding");
        let (g, lf, tg) = (&self.globals_bind_group, &self.light_field, &frame.targets);
        if passes.directions {
            self.direction_ids
                .encode(encoder, g, tg, lf, stamps.writes(0));
            self.barycentrics
                .encode(encoder, g, tg, lf, stamps.writes(1));
        }
        self.face_id.encode(encoder, g, tg, lf, stamps.writes(2));
        if passes.position {
            self.position.encode(encoder, g, tg, lf, stamps.writes(3));
            if let Some(a) = &self.attributes {
                a.encode(encoder, g, tg, lf, None);
            }
        }
    }

    /// Encodes the five passes, pass 5 into the radiance target only (no timestamps).
    fn encode_passes(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut none = FrameTimestamps::new(None);
        self.encode_geometry_passes(encoder, GeometryPasses::ALL, &mut none);
        let frame = self.frame.as_ref().expect("ensure_frame before encoding");
        self.final_radiance.encode(
            encoder,
            &self.globals_bind_group,
            &frame.final_bind_group,
            &frame.targets,
            None,
        );
    }

    /// Renders `spp` jittered samples (see [`sample_offsets`]) of `camera` and leaves their mean
    /// in the radiance target. One submission per sample.
    fn render_samples(
        &mut self,
        ctx: &GpuContext,
        camera: &CameraView,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<(), RenderError> {
        self.ensure_frame(&ctx.device, width, height)?;
        let offsets = sample_offsets(spp);
        for (i, jitter) in offsets.iter().enumerate() {
            self.write_globals(
                &ctx.queue,
                camera,
                width,
                height,
                i as u32,
                offsets.len() as u32,
                *jitter,
                &Display::RAW,
            );
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("Renderer::still_encoder"),
                });
            self.encode_passes(&mut encoder);
            ctx.queue.submit(Some(encoder.finish()));
        }
        Ok(())
    }

    /// Renders a still: each pixel is the mean radiance of `spp` stratified sub-pixel samples
    /// (box filter), linear RGB, row-major with row 0 at the top.
    pub fn render_still(
        &mut self,
        ctx: &GpuContext,
        camera: &CameraView,
        width: u32,
        height: u32,
        spp: u32,
    ) -> Result<Vec<[f32; 3]>, RenderError> {
        self.render_samples(ctx, camera, width, height, spp)?;
        let t = &self.frame.as_ref().expect("frame exists").targets;
        let px: Vec<[f32; 4]> = if spp > 1 {
            crate::readback::read_buffer(&ctx.device, &ctx.queue, &t.accum)?
        } else {
            targets::read_texture(&ctx.device, &ctx.queue, &t.radiance, 16)?
        };
        Ok(px.into_iter().map(|p| [p[0], p[1], p[2]]).collect())
    }

    /// Renders one centred sample and reads every pass output back.
    pub fn render_frame_data(
        &mut self,
        ctx: &GpuContext,
        camera: &CameraView,
        width: u32,
        height: u32,
    ) -> Result<FrameData, RenderError> {
        self.render_samples(ctx, camera, width, height, 1)?;
        let (d, q) = (&ctx.device, &ctx.queue);
        let t = &self.frame.as_ref().expect("frame exists").targets;
        Ok(FrameData {
            width,
            height,
            direction_ids: targets::read_texture(d, q, &t.direction_ids, 16)?,
            barycentrics: targets::read_texture(d, q, &t.barycentrics, 16)?,
            face_id: targets::read_texture(d, q, &t.face_id, 4)?,
            position: targets::read_texture(d, q, &t.position, 16)?,
            uv: targets::read_texture(d, q, &t.uv, 8)?,
            attributes: if self.attributes.is_some() {
                (
                    targets::read_texture(d, q, &t.attributes[0], 16)?,
                    targets::read_texture(d, q, &t.attributes[1], 16)?,
                )
            } else {
                (Vec::new(), Vec::new())
            },
            radiance: targets::read_texture(d, q, &t.radiance, 16)?,
        })
    }

    /// A still of `pass`'s debug view as shown on screen (exposure 1, no tonemap for the final
    /// radiance, which then equals [`Renderer::render_still`]). Linear RGB, row 0 at the top.
    pub fn render_debug_still(
        &mut self,
        ctx: &GpuContext,
        camera: &CameraView,
        width: u32,
        height: u32,
        spp: u32,
        pass: Pass,
    ) -> Result<Vec<[f32; 3]>, RenderError> {
        if pass == Pass::FinalRadiance {
            return self.render_still(ctx, camera, width, height, spp);
        }
        // Debug outputs (ids, weights, positions) are not averaged: one centred sample.
        self.render_samples(ctx, camera, width, height, 1)?;
        let format = wgpu::TextureFormat::Rgba32Float;
        let display = Display {
            view: pass,
            ..Display::RAW
        };
        self.write_globals(
            &ctx.queue,
            camera,
            width,
            height,
            0,
            1,
            Vec2::splat(0.5),
            &display,
        );
        let texture =
            targets::readback_target(&ctx.device, "Display::still_target", width, height, format);
        let view = texture.create_view(&Default::default());
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("Display::still_encoder"),
            });
        let frame = self.frame.as_ref().expect("frame exists");
        self.display.encode(
            &ctx.device,
            &mut encoder,
            &self.globals_bind_group,
            &frame.display_bind_group,
            &view,
            format,
            None,
        );
        ctx.queue.submit(Some(encoder.finish()));
        let px: Vec<[f32; 4]> = targets::read_texture(&ctx.device, &ctx.queue, &texture, 16)?;
        Ok(px.into_iter().map(|p| [p[0], p[1], p[2]]).collect())
    }

    /// Encodes one interactive frame into `encoder`: the passes it needs (one sample at the pixel
    /// centres, see below) and the selected debug view on `target` (`width × height`, format `format`),
    /// with `exposure` (a linear factor) and `tonemap` for the final image. For the final image
    /// pass 5 writes `target` itself (fused display) and interpolates pass 4's outputs itself
    /// (fused position, [`final_radiance`]), so pass 4 does not run, nor do passes 1–2 when
    /// the light field has no mirror or mixed faces (only their tiles read them); debug views
    /// run every pass and add the display pass. The caller submits `encoder` (it may add e.g. a
    /// UI pass first) and then calls [`Renderer::frame_submitted`].
    #[allow(clippy::too_many_arguments)]
    pub fn render_to_view(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        camera: &CameraView,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        width: u32,
        height: u32,
        exposure: f32,
        tonemap: Tonemap,
    ) -> Result<(), RenderError> {
        self.ensure_frame(&ctx.device, width, height)?;
        let display = Display {
            view: self.debug_view,
            exposure,
            tonemap,
            format,
        };
        self.write_globals(
            &ctx.queue,
            camera,
            width,
            height,
            0,
            1,
            Vec2::splat(0.5),
            &display,
        );
        let final_image = self.debug_view == Pass::FinalRadiance;
        let passes = if final_image {
            GeometryPasses {
                directions: self.final_radiance.has_mirrors(),
                position: false,
            }
        } else {
            GeometryPasses::ALL
        };
        let mut stamps = FrameTimestamps::new(self.timer.as_ref());
        self.encode_geometry_passes(encoder, passes, &mut stamps);
        let frame = self.frame.as_ref().expect("frame exists");
        let g = &self.globals_bind_group;
        if final_image {
            self.final_radiance.encode_present(
                &ctx.device,
                encoder,
                g,
                &frame.final_bind_group,
                &frame.targets,
                &self.light_field,
                target,
                format,
                stamps.writes(4),
            );
        } else {
            self.final_radiance.encode(
                encoder,
                g,
                &frame.final_bind_group,
                &frame.targets,
                stamps.writes(4),
            );
            self.display.encode(
                &ctx.device,
                encoder,
                g,
                &frame.display_bind_group,
                target,
                format,
                stamps.writes(5),
            );
        }
        let timed = stamps.into_passes();
        if let Some(t) = self.timer.as_mut() {
            t.resolve(encoder, &timed);
        }
        Ok(())
    }

    /// Call once after submitting a frame from [`Renderer::render_to_view`] (collects GPU timings).
    pub fn frame_submitted(&mut self, ctx: &GpuContext) {
        if let Some(t) = self.timer.as_mut() {
            t.after_submit(&ctx.device);
        }
    }

    /// Bind-group layout of group 0 (for callers adding their own passes).
    pub fn globals_layout(&self) -> &wgpu::BindGroupLayout {
        &self.globals_layout
    }
}

#[cfg(test)]
mod tests;
