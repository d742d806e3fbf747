//! Pass 5: final radiance, one fragment per pixel of a viewport-covering triangle
//! (shader: `shaders/render_final_radiance.wgsl`).
//!
//! * Background (pass 3 found no face): the bake's sky radiance `params.sky`.
//! * Every face, on the side facing the camera: `L = Le(uv) [front side only] + ρ_d(uv)/π · E`
//!   ([`surface_radiance`]). E is the irradiance of the face's atlas chart, read bilinearly at
//!   the pass-4 position, texel indices clamped to the chart (never across faces or sides)
//!   ([`atlas_irradiance`]); ρ_d = diffuse weight × base colour × base-colour texture(uv) and
//!   Le = emission × emissive texture(uv), the textures looked up at pass 4's uv bilinearly with
//!   their wrap modes (`Shading::sample`), so they render at their own resolution, not the
//!   atlas's. Atlas and textures are textures read with `textureLoad` (see [`super::upload`]);
//!   the filters are done by hand in f32 so the CPU reproduces them exactly. Flags in the face
//!   record skip the atlas for faces without a diffuse part, the uv and texels for untextured
//!   faces and the emission for non-emitters.
//! * Mirror and mixed faces (`kind != FACE_DIFFUSE`) add the specular part from the sparse
//!   per-direction tiles: radiance towards
//!   the eye travels against the view ray, so the three sphere vertices of pass 1 are taken in
//!   the opposite sense with the pass-2 weights (paper §4's `Ls(ω,s,t,u,v,p) = Σ αᵢ Ls(ωᵢ,…)`);
//!   for each, the position maps into that direction's ray grid and the tile values of the
//!   covered cells around it are filtered bilinearly. That lookup lives in
//!   `shaders/common/mirror_tiles.wgsl` (bind group 2, [`super::upload::tiles_layout`]), shared
//!   with the GPU final gather; its CPU form is `vlf_core::gather::field::Tiles::radiance_towards`
//!   (the mirror accuracy tests compare whole images with the path-traced reference).
//! * With mirror tracing (the default where there are mirrors; [`FinalRadiancePass::set_tracing`]),
//!   mirror and mixed faces trace the reflected view ray through the scene's BVH instead of
//!   reading their tiles, and read the light field at the first diffuse face as this pass reads
//!   a visible point: [`super::mirror_trace`] (rules, BVH, CPU specification). The pipeline
//!   constant `TRACING` compiles the traversal out of the untraced pipelines.
//!
//! Output: this sample's radiance in an `Rgba32Float` render target (what the display, stills
//! and tests read; the window's final image writes its surface only, below). Stills with several jittered samples also accumulate into a storage buffer:
//! sample 0 overwrites it, later samples add with weight `1 / sample_count`, giving the mean
//! over the sub-pixel samples.
//!
//! Texture and mirror cost: llvmpipe runs both sides of a divergent branch under a mask at
//! every pixel, so skipping the texture code for untextured faces, or the mirror code (tiles,
//! tracing) for diffuse ones, takes more than a branch:
//!
//! * the shader's constants `BASE_TEXTURES` and `EMISSIVE_TEXTURES` compile out the code of the
//!   kinds of texture the light field does not use ([`TextureKinds`]), `SPECULAR` and
//!   `TRACING` the mirror code of light fields without mirrors;
//! * with textures or mirrors, in the window ([`FinalRadiancePass::encode_present`]) and where
//!   the device has a depth-stencil format for it ([`super::targets::DEPTH_STENCIL_FORMAT`]),
//!   pass 3 marks the pixels showing a textured face (`TEXTURED_STENCIL`) or a mirror or mixed
//!   face (`MIRROR_STENCIL`) in the stencil, and this pass draws once per kind of pixel the
//!   light field has, with stencil tests: a pipeline with neither texture nor mirror code on
//!   the unmarked pixels (plain diffuse faces and background), one with texture code on
//!   textured diffuse faces, one with everything (tracing when on) on mirror pixels. llvmpipe
//!   tests the stencil before running a shader that writes nothing but its targets, and skips a
//!   block of pixels that all fail, so only the pixels that show a mirror pay for tracing and
//!   diffuse-only scenes run no mirror code at all. Stills and debug views
//!   ([`FinalRadiancePass::encode`], `fs_main`) draw once with all the code: their shader
//!   writes the accumulation buffer, and a shader with such side effects runs (and writes)
//!   whatever the stencil says.
//!
//! Fused display (window): [`FinalRadiancePass::encode_present`] writes the exposed,
//! tonemapped colour straight onto the window's surface instead of a separate display pass
//! reading the radiance back: 37.5 → 30.2 ms per frame on lavapipe at 1024×768 (table in
//! [`super`]).
//!
//! Fused position (window): for the final image the window also skips pass 4
//! ([`super::Renderer::render_to_view`]) and [`FinalRadiancePass::encode_present`] draws the
//! scene's triangles instead of a viewport-covering one (`vs_surface`, `fs_surface`), against
//! pass 3's depth (greater or equal, no writes; the same corners and `@invariant` transform as
//! passes 3 and 4, so the same depths): each fragment gets pass 4's position and uv as its
//! interpolated inputs and its face record (texels 0–5, read once per vertex) as flat ones, so
//! a diffuse pixel reads 4 atlas texels and nothing else, where the full-screen shader reads
//! the face id, the position, 5 face-record texels and the 4 atlas texels (and llvmpipe pays
//! the emission texel, under a mask, at every pixel). The background is the viewport triangle
//! at depth 0 drawn first with the test "greater or equal" (`fs_sky`): the pixels no face
//! covers, whose depth pass 3 left at 0 (reverse-Z). Each
//! draw of the stencil split draws the triangles of its stencil group only (the triangles are
//! uploaded grouped, [`super::upload`]). Where two faces' triangles have equal depths at a
//! pixel, the last drawn is shaded, as pass 4 takes its position from it (the full-screen
//! shader took the face from pass 3, the first drawn). Measured in `docs/PERFORMANCE.md`.

use std::collections::HashMap;

use glam::Vec3;
use vlf_core::lightfield::{BakeFace, LightField, Radiance};

pub use super::attributes::{PixelSurface, SurfaceLookup, shading_normal};
use super::targets::{
    DEPTH_STENCIL_FORMAT, MIRROR_STENCIL, RADIANCE_FORMAT, TEXTURED_STENCIL, Targets,
};
use super::upload::{
    FLAG_BASE_TEXTURE, FLAG_BASE_UV1, FLAG_COLORS, FLAG_EMISSIVE_TEXTURE, FLAG_EMISSIVE_UV1,
    FLAG_SMOOTH, GpuLightField, face_flags, rho_over_pi, tiles_layout,
};
use super::{storage_entry, texture_entry};
use crate::raytrace::GpuBvh;
use crate::shaders;

/// The kinds of texture a light field's faces read (faces with a diffuse part and a
/// base-colour texture, emitters with an emissive texture).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureKinds {
    pub base: bool,
    pub emissive: bool,
}

impl TextureKinds {
    pub fn of(lf: &LightField) -> Self {
        let mut k = TextureKinds::default();
        for f in &lf.faces {
            let flags = face_flags(&lf.shading.materials[f.material as usize]);
            k.base |= flags & FLAG_BASE_TEXTURE != 0;
            k.emissive |= flags & FLAG_EMISSIVE_TEXTURE != 0;
        }
        k
    }

    pub fn any(self) -> bool {
        self.base || self.emissive
    }
}

/// One draw of the pass: the shader's texture constants, whether it has the mirror code
/// (`specular`) and traces ([`super::mirror_trace`]), whether it reads per-corner attributes
/// and, with a stencil, the stencil value and read mask of the pixels it shades.
#[derive(Clone, Copy, Debug)]
struct Variant {
    textures: TextureKinds,
    specular: bool,
    tracing: bool,
    attributes: bool,
    stencil: Option<(u32, u32)>,
}

/// The draws of the window's final image (see the module docs): with a stencil, one per kind
/// of pixel the light field has (plain, textured, mirror), each with only the code it needs;
/// without, one with everything.
fn present_variants(
    textures: TextureKinds,
    mirrors: bool,
    tracing: bool,
    attributes: bool,
    stencil: bool,
) -> Vec<Variant> {
    let all = Variant {
        textures,
        specular: mirrors,
        tracing,
        attributes,
        stencil: None,
    };
    if !stencil {
        return vec![all];
    }
    let both = TEXTURED_STENCIL | MIRROR_STENCIL;
    let mut v = vec![Variant {
        textures: TextureKinds::default(),
        specular: false,
        tracing: false,
        // Vertex colours colour plain pixels too.
        attributes,
        stencil: Some((0, both)),
    }];
    if textures.any() {
        v.push(Variant {
            specular: false,
            tracing: false,
            stencil: Some((TEXTURED_STENCIL, both)),
            ..all
        });
    }
    if mirrors {
        v.push(Variant {
            stencil: Some((MIRROR_STENCIL, MIRROR_STENCIL)),
            ..all
        });
    }
    v
}

/// The bind groups of pass 5 for one set of targets: group 1 (BVH, targets, faces, atlas,
/// textures) and group 2 (mirror tiles).
pub struct FinalRadianceBindings {
    pass: wgpu::BindGroup,
    tiles: wgpu::BindGroup,
}

pub struct FinalRadiancePass {
    pass_layout: wgpu::BindGroupLayout,
    /// Group 2: the mirror tiles (`shaders/common/mirror_tiles.wgsl`).
    tiles_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    /// Whether the light field has mirror or mixed faces (and so a traced branch).
    mirrors: bool,
    /// Whether mirror pixels trace (when `mirrors`), see [`FinalRadiancePass::set_tracing`].
    tracing: bool,
    /// The full-screen draw into the radiance target (stills, debug views; one variant,
    /// without stencil), untraced and, with mirrors, traced.
    pipelines: Vec<wgpu::RenderPipeline>,
    /// The draws of the window's final image, in order (see the module docs), untraced and
    /// traced.
    present_variants: [Vec<Variant>; 2],
    /// The window's surface, one per surface format and tracing: the background's pipeline,
    /// then one per present variant.
    present_pipelines: HashMap<(wgpu::TextureFormat, bool), Vec<wgpu::RenderPipeline>>,
    /// Format of pass 3's depth buffer, which the window's draws test against.
    depth_format: wgpu::TextureFormat,
    /// Whether the light field has alpha masks: the window's draws then discard the fragments
    /// they cut (as passes 3 and 4 do).
    masks: bool,
}

impl FinalRadiancePass {
    /// `textures`: the kinds of texture the light field's faces read; `mirrors`: whether it has
    /// mirror or mixed faces (then mirror pixels trace, [`super::mirror_trace`]);
    /// `attributes`: whether it has per-corner attributes (shading normals, vertex colours,
    /// `TEXCOORD_1`; [`super::attributes::has_attributes`]); `depth_format`: that of passes 3–4,
    /// [`DEPTH_STENCIL_FORMAT`] when pass 3 marks textured faces in the stencil (see the module
    /// docs).
    pub fn new(
        device: &wgpu::Device,
        globals_layout: &wgpu::BindGroupLayout,
        textures: TextureKinds,
        mirrors: bool,
        attributes: bool,
        depth_format: wgpu::TextureFormat,
        masks: bool,
    ) -> Self {
        let vis = wgpu::ShaderStages::FRAGMENT;
        let vertex = wgpu::ShaderStages::VERTEX;
        let unfiltered = wgpu::TextureSampleType::Float { filterable: false };
        let pass_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("FinalRadiance::pass_layout"),
            entries: &[
                storage_entry(0, vis, true),
                storage_entry(1, vis, true),
                texture_entry(2, vis, wgpu::TextureSampleType::Uint),
                texture_entry(3, vis, unfiltered),
                texture_entry(4, vis | vertex, wgpu::TextureSampleType::Uint),
                texture_entry(5, vis, unfiltered),
                storage_entry(super::pipelines::MASK_BINDING, vis, true),
                storage_entry(7, vis, false),
                texture_entry(10, vis, unfiltered),
                texture_entry(11, vis, wgpu::TextureSampleType::Uint),
                texture_entry(12, vis, unfiltered),
                texture_entry(13, vis, wgpu::TextureSampleType::Uint),
                texture_entry(14, vis, unfiltered),
                storage_entry(15, vis, true),
                storage_entry(16, vertex, true),
                storage_entry(17, vertex, true),
                texture_entry(18, vis, unfiltered),
                texture_entry(19, vis, wgpu::TextureSampleType::Uint),
                storage_entry(20, vis | vertex, true),
            ],
        });
        let tiles_layout = tiles_layout(device, "FinalRadiance::tiles_layout", vis);
        let pipeline_layout = crate::wgpu_util::pipeline_layout(
            device,
            "FinalRadiance::pipeline_layout",
            &[
                Some(globals_layout),
                Some(&pass_layout),
                Some(&tiles_layout),
            ],
        );
        let module = shaders::RENDER_FINAL_RADIANCE.module(device);
        let variants = [false, true].map(|tracing| Variant {
            textures,
            specular: mirrors,
            tracing,
            attributes,
            stencil: None,
        });
        let stencil = depth_format == DEPTH_STENCIL_FORMAT;
        let present_variants = [false, true]
            .map(|tracing| present_variants(textures, mirrors, tracing, attributes, stencil));
        let pipelines = variants[..1 + usize::from(mirrors)]
            .iter()
            .map(|v| Self::create_pipeline(device, &pipeline_layout, &module, *v, None, masks))
            .collect();
        Self {
            pass_layout,
            tiles_layout,
            pipeline_layout,
            module,
            mirrors,
            tracing: mirrors,
            pipelines,
            present_variants,
            present_pipelines: HashMap::new(),
            depth_format,
            masks,
        }
    }

    /// Whether mirror pixels trace their reflection (on by default where the light field has
    /// mirrors); off, they read their tiles.
    pub fn set_tracing(&mut self, on: bool) {
        self.tracing = on && self.mirrors;
    }

    /// Whether mirror pixels trace their reflection.
    pub fn tracing(&self) -> bool {
        self.tracing
    }

    /// Whether the light field has mirror or mixed faces, whose tiles read passes 1 and 2.
    pub fn has_mirrors(&self) -> bool {
        self.mirrors
    }

    /// The pipeline of `variant`: with `present` (the window's surface format) a draw of the
    /// window's final image (`vs_surface`, `fs_surface`, depth-tested against pass 3's buffer
    /// of format `depth_format`), else the full-screen draw into the radiance target
    /// (`fs_main`).
    fn create_pipeline(
        device: &wgpu::Device,
        layout: &wgpu::PipelineLayout,
        module: &wgpu::ShaderModule,
        variant: Variant,
        present: Option<(wgpu::TextureFormat, wgpu::TextureFormat)>,
        masks: bool,
    ) -> wgpu::RenderPipeline {
        let flag = |b: bool| f64::from(u8::from(b));
        let constants = [
            ("BASE_TEXTURES", flag(variant.textures.base)),
            ("EMISSIVE_TEXTURES", flag(variant.textures.emissive)),
            ("SPECULAR", flag(variant.specular)),
            ("TRACING", flag(variant.tracing)),
            ("MASKS", flag(masks)),
            ("ATTRIBUTES", flag(variant.attributes)),
        ];
        // The vertex stage reads the attributes too (vs_surface).
        let vertex_constants = [("ATTRIBUTES", flag(variant.attributes))];
        let equal = wgpu::StencilFaceState {
            compare: wgpu::CompareFunction::Equal,
            fail_op: wgpu::StencilOperation::Keep,
            depth_fail_op: wgpu::StencilOperation::Keep,
            pass_op: wgpu::StencilOperation::Keep,
        };
        let stencil = |(_, read_mask): (u32, u32)| wgpu::StencilState {
            front: equal,
            back: equal,
            read_mask,
            write_mask: 0,
        };
        let (label, vertex, fragment, format, depth_stencil) = match present {
            None => (
                "FinalRadiance::pipeline",
                "vs_main",
                "fs_main",
                RADIANCE_FORMAT,
                None,
            ),
            Some((format, depth_format)) => (
                "FinalRadiance::present_pipeline",
                "vs_surface",
                "fs_surface",
                format,
                Some(super::pipelines::pass_three_depth(
                    depth_format,
                    variant.stencil.map(stencil).unwrap_or_default(),
                )),
            ),
        };
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some(vertex),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &vertex_constants,
                    ..Default::default()
                },
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some(fragment),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    ..Default::default()
                },
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// The window's background: the viewport triangle at depth 0 onto `format`, where pass 3's
    /// depth (format `depth_format`) is still 0 (`fs_sky`; test "greater or equal": a face's
    /// depth is above 0 with reverse-Z).
    fn create_sky_pipeline(
        device: &wgpu::Device,
        layout: &wgpu::PipelineLayout,
        module: &wgpu::ShaderModule,
        format: wgpu::TextureFormat,
        depth_format: wgpu::TextureFormat,
    ) -> wgpu::RenderPipeline {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("FinalRadiance::sky_pipeline"),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(super::pipelines::pass_three_depth(
                depth_format,
                Default::default(),
            )),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some("fs_sky"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// The pass's resources for one set of targets (rebuilt when the view is resized), with the
    /// mirror-tracing BVH and its leaf-order uvs (`super::mirror_trace::GpuMirrorScene`) and
    /// the triangles and corner uvs of `lf` (the window's draws).
    pub fn bind(
        &self,
        device: &wgpu::Device,
        targets: &Targets,
        lf: &GpuLightField,
        mirror_bvh: &GpuBvh,
        mirror_uvs: &wgpu::Buffer,
    ) -> FinalRadianceBindings {
        let tex = |binding, view| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::TextureView(view),
        };
        let pass = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("FinalRadiance::pass_bind_group"),
            layout: &self.pass_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: mirror_bvh.nodes.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: mirror_bvh.triangles.as_entire_binding(),
                },
                tex(2, &targets.face_id_view),
                tex(3, &targets.position_view),
                tex(4, &lf.faces_view),
                tex(5, &lf.atlas_view),
                wgpu::BindGroupEntry {
                    binding: super::pipelines::MASK_BINDING,
                    resource: lf.alpha_masks.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: targets.accum.as_entire_binding(),
                },
                tex(10, &targets.uv_view),
                tex(11, &lf.texture_records_view),
                tex(12, &lf.texels_view),
                tex(13, &targets.direction_ids_view),
                tex(14, &targets.barycentrics_view),
                wgpu::BindGroupEntry {
                    binding: 15,
                    resource: mirror_uvs.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 16,
                    resource: lf.triangles.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 17,
                    resource: lf.uvs.as_entire_binding(),
                },
                tex(18, &targets.attributes_view[0]),
                tex(19, &targets.attributes_view[1]),
                wgpu::BindGroupEntry {
                    binding: 20,
                    resource: lf.attributes.as_entire_binding(),
                },
            ],
        });
        FinalRadianceBindings {
            pass,
            tiles: lf.tiles_bind_group(
                device,
                &self.tiles_layout,
                "FinalRadiance::tiles_bind_group",
            ),
        }
    }

    /// Shades every pixel into the radiance target.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        bind_group: &FinalRadianceBindings,
        targets: &Targets,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("FinalRadiance::pass"),
            color_attachments: &[Some(super::color_attachment(
                &targets.radiance_view,
                wgpu::Color::TRANSPARENT,
            ))],
            depth_stencil_attachment: None,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, globals, &[]);
        pass.set_bind_group(1, &bind_group.pass, &[]);
        pass.set_bind_group(2, &bind_group.tiles, &[]);
        pass.set_pipeline(&self.pipelines[usize::from(self.tracing)]);
        pass.draw(0..3, 0..1);
    }

    /// Draws the window's final image onto `surface` (format `format`, the size of the
    /// targets; the globals' exposure, tonemap and encoding): the background, then the
    /// triangles of `lf` against pass 3's depth, each stencil group with its variant's pipeline
    /// (see the module docs). Passes 1–3 must have run; pass 4 need not.
    #[allow(clippy::too_many_arguments)]
    pub fn encode_present(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::BindGroup,
        bind_group: &FinalRadianceBindings,
        targets: &Targets,
        lf: &GpuLightField,
        surface: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let key = (format, self.tracing);
        let variants = &self.present_variants[usize::from(self.tracing)];
        if !self.present_pipelines.contains_key(&key) {
            let (layout, module, masks) = (&self.pipeline_layout, &self.module, self.masks);
            let sky = Self::create_sky_pipeline(device, layout, module, format, self.depth_format);
            let present = Some((format, self.depth_format));
            let pipelines = std::iter::once(sky)
                .chain(
                    (variants.iter())
                        .map(|v| Self::create_pipeline(device, layout, module, *v, present, masks)),
                )
                .collect();
            self.present_pipelines.insert(key, pipelines);
        }
        let pipelines = &self.present_pipelines[&key];
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("FinalRadiance::present_pass"),
            color_attachments: &[Some(super::color_attachment(surface, wgpu::Color::BLACK))],
            // Read only: the depth (and stencil) of pass 3.
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth_view,
                depth_ops: None,
                stencil_ops: None,
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, globals, &[]);
        pass.set_bind_group(1, &bind_group.pass, &[]);
        pass.set_bind_group(2, &bind_group.tiles, &[]);
        pass.set_pipeline(&pipelines[0]);
        pass.draw(0..3, 0..1);
        for (v, pipeline) in variants.iter().zip(&pipelines[1..]) {
            pass.set_pipeline(pipeline);
            if let Some((r, _)) = v.stencil {
                pass.set_stencil_reference(r);
            }
            for (s, w) in lf.stencil_starts.windows(2).enumerate() {
                let drawn = v.stencil.is_none_or(|(r, mask)| s as u32 & mask == r);
                if drawn && w[0] < w[1] {
                    pass.draw(w[0] * 3..w[1] * 3, 0..1);
                }
            }
        }
    }
}

/// CPU counterpart of the shader's atlas lookup: the irradiance of `face` at plane point `p` on
/// `side` (0 = front), bilinear in chart coordinates with clamp-to-chart, in f32 like the GPU
/// (texels decoded exactly, as the GPU's texel fetch decodes them).
pub fn atlas_irradiance(face: &BakeFace, irradiance: &Radiance, side: u32, p: Vec3) -> Vec3 {
    let d = p - Vec3::from(face.origin);
    let x = d.dot(Vec3::from(face.u)) / face.texel_size - 0.5;
    let y = d.dot(Vec3::from(face.v)) / face.texel_size - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (w, h) = (face.width as i64, face.height as i64);
    let i0 = (x0 as i64).clamp(0, w - 1);
    let i1 = (x0 as i64 + 1).clamp(0, w - 1);
    let j0 = (y0 as i64).clamp(0, h - 1);
    let j1 = (y0 as i64 + 1).clamp(0, h - 1);
    let base = face.texel_base as i64 + i64::from(side) * w * h;
    let at = |i: i64, j: i64| Vec3::from(irradiance.get((base + j * w + i) as usize));
    let top = at(i0, j0).lerp(at(i1, j0), fx);
    let bottom = at(i0, j1).lerp(at(i1, j1), fx);
    top.lerp(bottom, fy)
}

/// CPU counterpart of pass 5 without the specular tiles: `Le(uv) [side 0] + ρ_d(uv)/π · E` of
/// face `face` at plane point `p` with the interpolated attributes `s` on `side`, in f32 in the
/// shader's order of operations: the base-colour texture (read with the set its material
/// names) and then the vertex colour (on faces with [`FLAG_COLORS`]) multiply ρ_d; on faces
/// with smooth triangles the interpolated irradiance correction is added to the atlas's
/// ([`super::attributes`]).
pub fn surface_radiance(
    lf: &LightField,
    lookup: &SurfaceLookup,
    face: u32,
    side: u32,
    p: Vec3,
    s: &PixelSurface,
) -> Vec3 {
    let f = &lf.faces[face as usize];
    let sh = &lf.shading;
    let flags = lookup.flags[face as usize];
    let m = &sh.materials[f.material as usize];
    let mut l = Vec3::ZERO;
    let rho = rho_over_pi(m);
    if rho.max_element() > 0.0 {
        let uv = s.tex_uv(flags & FLAG_BASE_UV1 != 0);
        let mut rho = rho * sh.sample(m.base_color_texture, uv, &lookup.offsets);
        if flags & FLAG_COLORS != 0 {
            rho *= s.color;
        }
        let mut e = atlas_irradiance(f, &lf.irradiance, side, p);
        if flags & FLAG_SMOOTH != 0 {
            // The correction interpolates between corners, the atlas varies inside the face:
            // their sum can dip below zero next to a dark texel, irradiance cannot.
            e = (e + s.irradiance).max(Vec3::ZERO);
        }
        l = rho * e;
    }
    let le = Vec3::from(m.emission);
    if side == 0 && le.max_element() > 0.0 {
        let uv = s.tex_uv(flags & FLAG_EMISSIVE_UV1 != 0);
        l += le * sh.sample(m.emissive_texture, uv, &lookup.offsets);
    }
    l
}

/// The side of `face` that an eye at `eye` sees at `p`: 0 (front) when the eye is on the
/// normal's side, else 1.
pub fn visible_side(face: &BakeFace, eye: Vec3, p: Vec3) -> u32 {
    if Vec3::from(face.normal).dot(eye - p) >= 0.0 {
        0
    } else {
        1
    }
}
