//! Export of a baked light field as a glTF 2.0 binary (GLB) with lightmaps, for other engines
//! (`vlf-bake export`, docs/ENGINES.md).
//!
//! The scene's triangles (world space, both sides of every face as separate one-sided
//! triangles, the back side wound the other way) carry their chart position in `TEXCOORD_1`;
//! the diffuse atlas, as **irradiance E** per texel (what the light field stores), is packed into
//! one or a few lightmap pages ([`pack`]: a clamp-to-edge gutter, so bilinear filtering never
//! mixes charts). Materials keep their base colour (and texture, re-encoded as PNG), emission
//! (front side only), metallic weight, and carry the lightmap as `MOZ_lightmap`
//! `{index, texCoord: 1, intensity}` and under `extras.vlf_lightmap`. An engine shading
//! `outgoing = baseColor·(1 − metallic)/π · E + emission` (three.js's lightMap with
//! `MeshStandardMaterial`) reproduces the viewer's diffuse radiance. View-dependent light
//! (mirror and mixed faces' specular part) is not exported: it stays the light field's.
//!
//! Lightmap encodings: OpenEXR (linear half float, a buffer view named by the texture
//! extension `VLF_texture_exr` `{bufferView, mimeType}`, since core glTF admits only PNG and
//! JPEG images; the
//! texture's core `source` is then the same page as RGBM PNG, a fallback that keeps the file
//! loadable by strict readers), RGBM in a PNG (range in `extras`), KTX2 refused as not
//! implemented.

mod encode;
mod glb;
pub mod pack;

use std::collections::HashMap;

use glam::{Vec2, Vec3};
use serde_json::{Value, json};

use crate::bake::BakeScene;
use crate::lightfield::LightField;
use crate::scene::{FilterMode, Scene, Texture, WrapMode};

pub use encode::{rgbm_decode, rgbm_range};

/// Default largest lightmap page edge (texels).
pub const DEFAULT_MAX_SIZE: u32 = 4096;
/// Gutter round every chart side (texels): one is enough for bilinear filtering without
/// mipmaps; two leave a margin for texture-coordinate rounding.
pub const GUTTER: u32 = 2;
/// The vendor texture extension naming an OpenEXR image source.
pub const EXR_EXTENSION: &str = "VLF_texture_exr";
/// The MIME type written for OpenEXR images.
pub const EXR_MIME: &str = "image/x-exr";
/// What is not in the exported file, as written into its `extras`.
pub const NOT_EXPORTED: &str = "Only diffuse light is exported (the lightmaps hold irradiance \
    E of the diffuse atlas). Mirror and glossy (view-dependent) light stays in the vlf light \
    field: mirror faces and the mirror part of mixed faces show only what the engine renders \
    for them.";

/// The source texture coordinate sets a material's exported primitives carry: the set exported
/// as `TEXCOORD_0` (the base-colour texture's, else the emissive texture's, else 0) and, where
/// the emissive texture reads another set than the base colour's, the set exported as
/// `TEXCOORD_2` (`TEXCOORD_1` holds the lightmap's coordinates).
fn export_sets(m: &crate::scene::Material) -> (u32, Option<u32>) {
    match (m.base_color_texture, m.emissive_texture) {
        (Some(b), Some(e)) if b.texcoord != e.texcoord => (b.texcoord, Some(e.texcoord)),
        (Some(b), _) => (b.texcoord, None),
        (None, Some(e)) => (e.texcoord, None),
        (None, None) => (0, None),
    }
}

/// How the lightmap pages are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightmapEncoding {
    /// OpenEXR, linear half float.
    Exr,
    /// RGBM in an 8-bit PNG: `rgb · a · range` (range a power of two, in `extras`).
    PngRgbm,
    /// KTX2: not implemented, refused with [`ExportError::NotImplemented`].
    Ktx2,
}

impl LightmapEncoding {
    pub fn name(self) -> &'static str {
        match self {
            LightmapEncoding::Exr => "exr",
            LightmapEncoding::PngRgbm => "png-rgbm",
            LightmapEncoding::Ktx2 => "ktx2",
        }
    }
}

/// What to export.
#[derive(Clone, Copy, Debug)]
pub struct ExportOptions {
    pub encoding: LightmapEncoding,
    /// Largest lightmap page edge in texels.
    pub max_size: u32,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            encoding: LightmapEncoding::Exr,
            max_size: DEFAULT_MAX_SIZE,
        }
    }
}

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error(
        "the {0} lightmap encoding is not implemented (use --texture exr or --texture png-rgbm)"
    )]
    NotImplemented(&'static str),
    #[error(
        "the scene does not match the light field ({0}): pass the scene it was baked from, or bake \
         it again"
    )]
    SceneMismatch(String),
    #[error(
        "face {face}'s chart ({width}×{height} texels and a {GUTTER}-texel gutter) does not fit a \
         {max_size}×{max_size} lightmap page: raise --max-size"
    )]
    ChartTooLarge {
        face: usize,
        width: u32,
        height: u32,
        max_size: u32,
    },
    #[error("--max-size {0} is out of range (16..=16384)")]
    MaxSize(u32),
    #[error("cannot encode the {what}: {reason}")]
    Encode { what: String, reason: String },
    #[error("the exported file would exceed the 4 GiB a GLB can hold")]
    TooLarge,
}

/// An exported GLB and what it holds.
#[derive(Clone, Debug)]
pub struct Exported {
    pub glb: Vec<u8>,
    pub summary: ExportSummary,
}

/// What an export wrote (for the command's report and tests).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ExportSummary {
    pub encoding: &'static str,
    /// (width, height) of each lightmap page.
    pub pages: Vec<(u32, u32)>,
    pub triangles: usize,
    pub vertices: usize,
    pub materials: usize,
    pub cameras: usize,
    /// RGBM range (png-rgbm only).
    pub rgbm_range: Option<f32>,
    pub bytes: usize,
}

/// The atlas of `lf` as lightmap values: the irradiance E the light field stores per texel
/// (uncovered texels already dilated from their neighbours by the bake), emission excluded
/// (the exported materials carry it, as the renderer applies it per pixel).
fn atlas_irradiance(lf: &LightField) -> Vec<[f32; 4]> {
    (0..lf.irradiance.len())
        .map(|k| {
            let v = lf.irradiance.get(k);
            [v[0], v[1], v[2], 0.0]
        })
        .collect()
}

/// Checks that `scene` is the scene `lf` was baked from and prepares its atlas (albedo and
/// emission per texel) at the light field's texel size.
fn prepare(lf: &LightField, scene: &Scene) -> Result<BakeScene, ExportError> {
    let mismatch = |what: String| Err(ExportError::SceneMismatch(what));
    if scene.triangles.len() != lf.triangles.len() || scene.faces.len() != lf.faces.len() {
        return mismatch(format!(
            "{} triangles and {} faces, the light field has {} and {}",
            scene.triangles.len(),
            scene.faces.len(),
            lf.triangles.len(),
            lf.faces.len()
        ));
    }
    if scene.materials.len() != lf.shading.materials.len() {
        return mismatch(format!(
            "{} materials, the light field has {}",
            scene.materials.len(),
            lf.shading.materials.len()
        ));
    }
    let Some(texel_size) = lf.faces.first().map(|f| f.texel_size) else {
        return mismatch("the light field has no face".into());
    };
    let prep = BakeScene::with_texel_size(scene, texel_size)
        .map_err(|e| ExportError::SceneMismatch(e.to_string()))?;
    for (i, (a, b)) in prep.faces.iter().zip(&lf.faces).enumerate() {
        if (a.width, a.height, a.texel_base, a.kind) != (b.width, b.height, b.texel_base, b.kind) {
            return mismatch(format!("face {i}'s chart differs"));
        }
    }
    if prep.texel_count() != lf.irradiance.len() {
        return mismatch(format!(
            "{} atlas texels, the light field has {}",
            prep.texel_count(),
            lf.irradiance.len()
        ));
    }
    Ok(prep)
}

/// Exports `lf`, baked from `scene`, as a GLB.
pub fn export_glb(
    lf: &LightField,
    scene: &Scene,
    options: &ExportOptions,
) -> Result<Exported, ExportError> {
    if options.encoding == LightmapEncoding::Ktx2 {
        return Err(ExportError::NotImplemented("ktx2"));
    }
    if !(16..=16384).contains(&options.max_size) {
        return Err(ExportError::MaxSize(options.max_size));
    }
    prepare(lf, scene)?;
    let irradiance = atlas_irradiance(lf);
    let layout = pack::pack(&lf.faces, options.max_size, GUTTER).map_err(|e| {
        ExportError::ChartTooLarge {
            face: e.face,
            width: e.width,
            height: e.height,
            max_size: options.max_size,
        }
    })?;
    let pages = pack::fill_pages(&lf.faces, &layout, |fi, side, i, j| {
        let f = &lf.faces[fi];
        let k = f.texel_base + side * f.texels_per_side() + j * f.width + i;
        let e = irradiance[k as usize];
        [e[0], e[1], e[2]]
    });

    let mut w = Writer::new(scene, lf, options.encoding);
    w.lightmaps(&layout, &pages)?;
    w.geometry(lf, scene, &layout)?;
    w.cameras(lf);
    w.finish(lf, &layout)
}

/// The glTF being written.
struct Writer<'a> {
    scene: &'a Scene,
    /// Per scene material, the weight of its diffuse part as baked (the light field's
    /// shading materials: a rough metal folded into the diffuse part has its own).
    diffuse_weights: Vec<f32>,
    encoding: LightmapEncoding,
    buf: glb::Buffer,
    images: Vec<Value>,
    samplers: Vec<Value>,
    textures: Vec<Value>,
    materials: Vec<Value>,
    primitives: Vec<Value>,
    nodes: Vec<Value>,
    cameras: Vec<Value>,
    extensions: Vec<&'static str>,
    /// glTF texture index of each lightmap page.
    lightmap_textures: Vec<usize>,
    /// glTF texture of each scene texture, once encoded.
    scene_textures: HashMap<u32, usize>,
    rgbm_range: Option<f32>,
    triangles: usize,
    vertices: usize,
}

impl<'a> Writer<'a> {
    fn new(scene: &'a Scene, lf: &LightField, encoding: LightmapEncoding) -> Self {
        Self {
            scene,
            diffuse_weights: lf
                .shading
                .materials
                .iter()
                .map(|m| m.diffuse_weight)
                .collect(),
            encoding,
            buf: glb::Buffer::default(),
            images: Vec::new(),
            samplers: Vec::new(),
            textures: Vec::new(),
            materials: Vec::new(),
            primitives: Vec::new(),
            nodes: Vec::new(),
            cameras: Vec::new(),
            extensions: Vec::new(),
            lightmap_textures: Vec::new(),
            scene_textures: HashMap::new(),
            rgbm_range: None,
            triangles: 0,
            vertices: 0,
        }
    }

    fn use_extension(&mut self, name: &'static str) {
        if !self.extensions.contains(&name) {
            self.extensions.push(name);
        }
    }

    fn image(&mut self, bytes: &[u8], mime: &str, name: String) -> usize {
        let view = self.buf.view(bytes, None);
        self.images
            .push(json!({ "bufferView": view, "mimeType": mime, "name": name }));
        self.images.len() - 1
    }

    /// Encodes the lightmap pages; one texture each, linear filtering, clamped, no mipmaps.
    fn lightmaps(
        &mut self,
        layout: &pack::Layout,
        pages: &[Vec<[f32; 3]>],
    ) -> Result<(), ExportError> {
        let encode_err = |page: usize| {
            move |reason: String| ExportError::Encode {
                what: format!("lightmap page {page}"),
                reason,
            }
        };
        self.samplers.push(json!({
            "magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071,
            "name": "lightmap",
        }));
        let sampler = self.samplers.len() - 1;
        // Both encodings carry an RGBM PNG: png-rgbm as the texture's source, exr as the
        // source's fallback (core glTF and loaders built on it, such as the `gltf` crate,
        // require a PNG or JPEG source), the EXR through VLF_texture_exr.
        let all: Vec<[f32; 3]> = pages.iter().flatten().copied().collect();
        let range = rgbm_range(&all);
        self.rgbm_range = Some(range);
        for (i, (&(w, h), pixels)) in layout.pages.iter().zip(pages).enumerate() {
            let name = format!("vlf lightmap {i}");
            let mut texture = match self.encoding {
                LightmapEncoding::Exr | LightmapEncoding::PngRgbm => {
                    let rgba = encode::rgbm(pixels, range);
                    let bytes = encode::png_rgba8(w, h, &rgba).map_err(encode_err(i))?;
                    let image = self.image(&bytes, "image/png", format!("{name} (RGBM)"));
                    json!({ "sampler": sampler, "source": image, "name": name })
                }
                LightmapEncoding::Ktx2 => return Err(ExportError::NotImplemented("ktx2")),
            };
            if self.encoding == LightmapEncoding::Exr {
                // The EXR is a buffer view named by the extension, not an entry of `images`:
                // core glTF admits only PNG and JPEG there, and loaders that decode every image
                // up front would fail on it.
                let bytes = encode::exr_rgb_half(w, h, pixels).map_err(encode_err(i))?;
                let view = self.buf.view(&bytes, None);
                self.use_extension(EXR_EXTENSION);
                texture["extensions"] =
                    json!({ EXR_EXTENSION: { "bufferView": view, "mimeType": EXR_MIME } });
            }
            self.textures.push(texture);
            self.lightmap_textures.push(self.textures.len() - 1);
        }
        Ok(())
    }

    /// The glTF texture of scene texture `index` (sRGB PNG, its sampler's modes).
    fn scene_texture(&mut self, index: u32) -> Result<usize, ExportError> {
        if let Some(&t) = self.scene_textures.get(&index) {
            return Ok(t);
        }
        let tex: &Texture = &self.scene.textures[index as usize];
        let rgba: Vec<u8> = tex
            .pixels
            .iter()
            .flat_map(|p| {
                let srgb = |v: f32| (crate::image::linear_to_srgb(v) * 255.0 + 0.5) as u8;
                [
                    srgb(p.x),
                    srgb(p.y),
                    srgb(p.z),
                    (p.w.clamp(0.0, 1.0) * 255.0 + 0.5) as u8,
                ]
            })
            .collect();
        let name = tex
            .name
            .clone()
            .unwrap_or_else(|| format!("texture {index}"));
        let bytes = encode::png_rgba8(tex.width, tex.height, &rgba).map_err(|reason| {
            ExportError::Encode {
                what: format!("texture {name}"),
                reason,
            }
        })?;
        let image = self.image(&bytes, "image/png", name.clone());
        let wrap = |m: WrapMode| match m {
            WrapMode::Repeat => 10497,
            WrapMode::ClampToEdge => 33071,
            WrapMode::MirroredRepeat => 33648,
        };
        let mag = match tex.filter {
            FilterMode::Linear => 9729,
            FilterMode::Nearest => 9728,
        };
        self.samplers.push(json!({
            "magFilter": mag, "minFilter": 9987,
            "wrapS": wrap(tex.wrap_s), "wrapT": wrap(tex.wrap_t),
        }));
        self.textures.push(json!({
            "sampler": self.samplers.len() - 1, "source": image, "name": name,
        }));
        let t = self.textures.len() - 1;
        self.scene_textures.insert(index, t);
        Ok(t)
    }

    /// The material of scene material `m` on one side with lightmap page `page`: the front side
    /// emits, the back side does not (emission is one-sided in vlf).
    fn material(&mut self, m: u32, back: bool, page: u32) -> Result<usize, ExportError> {
        let mat = &self.scene.materials[m as usize];
        // The engine's diffuse part is baseColor × (1 − metallic): the bake's diffuse weight.
        let metallic = 1.0 - self.diffuse_weights[m as usize];
        let roughness = if metallic > 0.0 { 0.0 } else { 1.0 };
        let b = mat.base_color;
        // Alpha masks cut the same holes in the engine (a blend as the mask at ½ vlf bakes).
        let masks = mat.transparency.masks();
        let alpha = if masks { mat.transparency.alpha } else { 1.0 };
        let mut pbr = json!({
            "baseColorFactor": [b.x, b.y, b.z, alpha],
            "metallicFactor": metallic,
            "roughnessFactor": roughness,
        });
        let (base_tex, emissive_tex, emission) =
            (mat.base_color_texture, mat.emissive_texture, mat.emission);
        let name = format!("{}{}", mat.name, if back { " (back)" } else { "" });
        let (_, second) = export_sets(mat);
        if let Some(t) = base_tex {
            pbr["baseColorTexture"] =
                json!({ "index": self.scene_texture(t.index)?, "texCoord": 0 });
        }
        let lightmap = self.lightmap_textures[page as usize];
        let mut extensions = serde_json::Map::new();
        extensions.insert(
            "MOZ_lightmap".into(),
            json!({ "index": lightmap, "texCoord": 1, "intensity": 1.0 }),
        );
        // No specular lobe on the diffuse part: the engine's Fresnel term would add light the
        // bake does not have.
        extensions.insert(
            "KHR_materials_specular".into(),
            json!({ "specularFactor": 0.0 }),
        );
        self.use_extension("MOZ_lightmap");
        self.use_extension("KHR_materials_specular");
        let mut material = json!({
            "name": name,
            "pbrMetallicRoughness": pbr,
            "extras": { "vlf_lightmap": self.lightmap_extras(lightmap) },
        });
        if masks {
            material["alphaMode"] = json!("MASK");
            material["alphaCutoff"] = json!(mat.transparency.cutoff());
            material["doubleSided"] = json!(true);
        }
        let strength = emission.max_element();
        if !back && strength > 0.0 {
            let factor = if strength > 1.0 {
                emission / strength
            } else {
                emission
            };
            material["emissiveFactor"] = json!([factor.x, factor.y, factor.z]);
            if strength > 1.0 {
                extensions.insert(
                    "KHR_materials_emissive_strength".into(),
                    json!({ "emissiveStrength": strength }),
                );
                self.use_extension("KHR_materials_emissive_strength");
            }
            if let Some(t) = emissive_tex {
                // TEXCOORD_2 where it reads another set than the base colour (`export_sets`).
                let set = if second.is_some() { 2 } else { 0 };
                material["emissiveTexture"] =
                    json!({ "index": self.scene_texture(t.index)?, "texCoord": set });
            }
        }
        material["extensions"] = Value::Object(extensions);
        self.materials.push(material);
        Ok(self.materials.len() - 1)
    }

    /// What `extras.vlf_lightmap` of a material says about its lightmap texture.
    fn lightmap_extras(&self, texture: usize) -> Value {
        let mut v = json!({
            "texture": texture,
            "texCoord": 1,
            "encoding": self.encoding.name(),
            "quantity": "irradiance",
            "intensity": 1.0,
        });
        if let Some(r) = self.rgbm_range {
            v["rgbmRange"] = json!(r);
        }
        v
    }

    /// One primitive per (material, side, page); vertices shared within a primitive only where
    /// position, normal, colour and every uv set agree. A smooth triangle's corners carry its
    /// shading normals (the face's normal otherwise), a coloured material's its vertex
    /// colours (`COLOR_0`), and `TEXCOORD_0` (and `TEXCOORD_2`) the sets its textures read
    /// (`export_sets`): `TEXCOORD_1` is the lightmap's.
    fn geometry(
        &mut self,
        lf: &LightField,
        scene: &Scene,
        layout: &pack::Layout,
    ) -> Result<(), ExportError> {
        struct Prim {
            positions: Vec<[f32; 3]>,
            normals: Vec<[f32; 3]>,
            colors: Vec<[f32; 3]>,
            uv0: Vec<[f32; 2]>,
            uv1: Vec<[f32; 2]>,
            uv2: Vec<[f32; 2]>,
            indices: Vec<u32>,
            dedup: HashMap<[u32; 15], u32>,
        }
        // Normals and colours as the light field holds them (a bake with `--flat-normals` has
        // none); materials some of whose triangles have vertex colours carry COLOR_0.
        let (normals, colors) = (&lf.shading.normals, &lf.shading.colors);
        let mut colored = vec![false; scene.materials.len()];
        for (i, t) in scene.triangles.iter().enumerate() {
            colored[t.material as usize] |= colors.as_ref().is_some_and(|c| c[i] != [[1.0; 3]; 3]);
        }
        let mut prims: Vec<((u32, bool, u32), Prim)> = Vec::new();
        let mut slot: HashMap<(u32, bool, u32), usize> = HashMap::new();
        let xf = lf.to_vlf;
        for (fi, face) in scene.faces.iter().enumerate() {
            let bf = &lf.faces[fi];
            let (o, u, v) = (Vec3::from(bf.origin), Vec3::from(bf.u), Vec3::from(bf.v));
            for side in 0..2u32 {
                let back = side == 1;
                let p = layout.placements[2 * fi + side as usize];
                let (pw, ph) = layout.pages[p.page as usize];
                let key = (face.material, back, p.page);
                let k = *slot.entry(key).or_insert_with(|| {
                    prims.push((
                        key,
                        Prim {
                            positions: Vec::new(),
                            normals: Vec::new(),
                            colors: Vec::new(),
                            uv0: Vec::new(),
                            uv1: Vec::new(),
                            uv2: Vec::new(),
                            indices: Vec::new(),
                            dedup: HashMap::new(),
                        },
                    ));
                    prims.len() - 1
                });
                let prim = &mut prims[k].1;
                let (first, second) = export_sets(&scene.materials[face.material as usize]);
                for ti in face.triangles.clone() {
                    let tri = &scene.triangles[ti as usize];
                    let order: [usize; 3] = if back { [0, 2, 1] } else { [0, 1, 2] };
                    for c in order {
                        let n = match normals.as_ref().map(|n| Vec3::from(n[ti as usize][c])) {
                            Some(n) if n != Vec3::ZERO => n,
                            _ => face.normal,
                        };
                        let n = if back { -n } else { n }.to_array();
                        let color = colors.as_ref().map_or([1.0; 3], |col| col[ti as usize][c]);
                        let uv2 = second.map_or([0.0; 2], |set| tri.uv_set(set)[c].to_array());
                        let pos = tri.p[c];
                        let d = xf.apply(pos) - o;
                        let chart = Vec2::new(d.dot(u), d.dot(v)) / bf.texel_size;
                        let uv1 = [
                            (p.x as f32 + chart.x) / pw as f32,
                            (p.y as f32 + chart.y) / ph as f32,
                        ];
                        let uv0 = tri.uv_set(first)[c].to_array();
                        let bits = [
                            pos.x.to_bits(),
                            pos.y.to_bits(),
                            pos.z.to_bits(),
                            uv0[0].to_bits(),
                            uv0[1].to_bits(),
                            uv1[0].to_bits(),
                            uv1[1].to_bits(),
                            n[0].to_bits(),
                            n[1].to_bits(),
                            n[2].to_bits(),
                            color[0].to_bits(),
                            color[1].to_bits(),
                            color[2].to_bits(),
                            uv2[0].to_bits(),
                            uv2[1].to_bits(),
                        ];
                        let next = prim.positions.len() as u32;
                        let index = *prim.dedup.entry(bits).or_insert(next);
                        if index == next {
                            prim.positions.push(pos.to_array());
                            prim.normals.push(n);
                            prim.colors.push(color);
                            prim.uv0.push(uv0);
                            prim.uv1.push(uv1);
                            prim.uv2.push(uv2);
                        }
                        prim.indices.push(index);
                    }
                }
            }
        }
        for ((m, back, page), prim) in prims {
            if prim.indices.is_empty() {
                continue;
            }
            let material = self.material(m, back, page)?;
            // TEXCOORD_0 always (the source's, zeros where it had none): glTF numbers
            // TEXCOORD sets from 0 without gaps.
            let mut attributes = json!({
                "POSITION": self.buf.floats(&prim.positions, true),
                "NORMAL": self.buf.floats(&prim.normals, false),
                "TEXCOORD_0": self.buf.floats(&prim.uv0, false),
                "TEXCOORD_1": self.buf.floats(&prim.uv1, false),
            });
            if export_sets(&scene.materials[m as usize]).1.is_some() {
                attributes["TEXCOORD_2"] = json!(self.buf.floats(&prim.uv2, false));
            }
            if colored[m as usize] {
                attributes["COLOR_0"] = json!(self.buf.floats(&prim.colors, false));
            }
            self.triangles += prim.indices.len() / 3;
            self.vertices += prim.positions.len();
            self.primitives.push(json!({
                "attributes": attributes,
                "indices": self.buf.indices(&prim.indices),
                "material": material,
                "mode": 4,
            }));
        }
        Ok(())
    }

    fn cameras(&mut self, lf: &LightField) {
        for (i, c) in lf.cameras.iter().enumerate() {
            let mut persp = json!({ "yfov": c.yfov, "znear": c.znear });
            if let Some(a) = c.aspect_ratio {
                persp["aspectRatio"] = json!(a);
            }
            if let Some(z) = c.zfar {
                persp["zfar"] = json!(z);
            }
            let name = c.name.clone().unwrap_or_else(|| format!("camera {i}"));
            self.cameras
                .push(json!({ "type": "perspective", "perspective": persp, "name": name }));
            self.nodes.push(json!({
                "name": name,
                "camera": self.cameras.len() - 1,
                "translation": c.position.to_array(),
                "rotation": c.rotation.normalize().to_array(),
            }));
        }
    }

    fn finish(mut self, lf: &LightField, layout: &pack::Layout) -> Result<Exported, ExportError> {
        self.nodes
            .insert(0, json!({ "name": "vlf scene", "mesh": 0 }));
        let node_list: Vec<usize> = (0..self.nodes.len()).collect();
        let lightmaps: Vec<Value> = self
            .lightmap_textures
            .iter()
            .zip(&layout.pages)
            .map(|(t, (w, h))| json!({ "texture": t, "width": w, "height": h }))
            .collect();
        let mut lightmap = json!({
            "encoding": self.encoding.name(),
            "quantity": "irradiance",
            "texCoord": 1,
            "intensity": 1.0,
            "textures": lightmaps,
            "shading": "outgoing radiance = baseColor × (1 − metallic) / π × intensity × lightmap \
                        + emission (three.js MeshStandardMaterial.lightMap)",
            "gutterTexels": layout.gutter,
        });
        if let Some(r) = self.rgbm_range {
            lightmap["rgbmRange"] = json!(r);
            lightmap["rgbmDecode"] = json!("rgb / 255 × a / 255 × rgbmRange (linear, no sRGB)");
        }
        if self.encoding == LightmapEncoding::Exr {
            lightmap["textureExtension"] = json!(EXR_EXTENSION);
            lightmap["fallback"] = json!(
                "each lightmap texture's core `source` is the same page as RGBM PNG (rgbmRange); \
                 VLF_texture_exr.bufferView holds the OpenEXR (linear half float)"
            );
        }
        let mut root = json!({
            "asset": { "version": "2.0", "generator": concat!("vlf-bake export ", env!("CARGO_PKG_VERSION")) },
            "scene": 0,
            "scenes": [{ "name": "vlf", "nodes": node_list }],
            "nodes": self.nodes,
            "meshes": [{ "name": "vlf scene", "primitives": self.primitives }],
            "materials": self.materials,
            "textures": self.textures,
            "images": self.images,
            "samplers": self.samplers,
            "accessors": self.buf.accessors,
            "bufferViews": self.buf.views,
            "buffers": [{ "byteLength": self.buf.bin.len().next_multiple_of(4) }],
            "extensionsUsed": self.extensions,
            "extras": { "vlf": {
                "source": lf.scene.source,
                "lightmap": lightmap,
                "notExported": NOT_EXPORTED,
            } },
        });
        if !self.cameras.is_empty() {
            root["cameras"] = json!(self.cameras);
        }
        let bytes = glb::glb(&root, &self.buf.bin).ok_or(ExportError::TooLarge)?;
        let summary = ExportSummary {
            encoding: self.encoding.name(),
            pages: layout.pages.clone(),
            triangles: self.triangles,
            vertices: self.vertices,
            materials: root["materials"].as_array().map_or(0, Vec::len),
            cameras: lf.cameras.len(),
            rgbm_range: self.rgbm_range,
            bytes: bytes.len(),
        };
        Ok(Exported {
            glb: bytes,
            summary,
        })
    }
}

#[cfg(test)]
mod tests;
