//! The project's own Cornell box scenes, generated from the measured Cornell
//! data (Cornell University Program of Computer Graphics, "Cornell Box Data").
//!
//! `generate` writes glTF 2.0 files with one embedded base64 buffer. The output
//! is byte-identical on every run and machine: only IEEE-exact arithmetic
//! (+, -, *, /, sqrt) is used, numbers are printed by serde_json (shortest
//! round-trip form) and object keys are emitted in sorted order.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde_json::{Map, Value, json};

/// A point of the measured data, in millimetres.
type Mm = [f64; 3];
/// A quad of the measured data, in its original (counter-clockwise seen from
/// the front) vertex order.
type Quad = [Mm; 4];

const FLOOR: [Quad; 1] = [[
    [552.8, 0.0, 0.0],
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 559.2],
    [549.6, 0.0, 559.2],
]];

const CEILING: [Quad; 1] = [[
    [556.0, 548.8, 0.0],
    [556.0, 548.8, 559.2],
    [0.0, 548.8, 559.2],
    [0.0, 548.8, 0.0],
]];

const BACK_WALL: [Quad; 1] = [[
    [549.6, 0.0, 559.2],
    [0.0, 0.0, 559.2],
    [0.0, 548.8, 559.2],
    [556.0, 548.8, 559.2],
]];

/// Red; seen from the camera it is on the left (x ≈ 0.55 m).
const LEFT_WALL: [Quad; 1] = [[
    [552.8, 0.0, 0.0],
    [549.6, 0.0, 559.2],
    [556.0, 548.8, 559.2],
    [556.0, 548.8, 0.0],
]];

/// Green; seen from the camera it is on the right (x = 0).
const RIGHT_WALL: [Quad; 1] = [[
    [0.0, 0.0, 559.2],
    [0.0, 0.0, 0.0],
    [0.0, 548.8, 0.0],
    [0.0, 548.8, 559.2],
]];

/// Top and four sides (the data has no bottom face).
const SHORT_BLOCK: [Quad; 5] = [
    [
        [130.0, 165.0, 65.0],
        [82.0, 165.0, 225.0],
        [240.0, 165.0, 272.0],
        [290.0, 165.0, 114.0],
    ],
    [
        [290.0, 0.0, 114.0],
        [290.0, 165.0, 114.0],
        [240.0, 165.0, 272.0],
        [240.0, 0.0, 272.0],
    ],
    [
        [130.0, 0.0, 65.0],
        [130.0, 165.0, 65.0],
        [290.0, 165.0, 114.0],
        [290.0, 0.0, 114.0],
    ],
    [
        [82.0, 0.0, 225.0],
        [82.0, 165.0, 225.0],
        [130.0, 165.0, 65.0],
        [130.0, 0.0, 65.0],
    ],
    [
        [240.0, 0.0, 272.0],
        [240.0, 165.0, 272.0],
        [82.0, 165.0, 225.0],
        [82.0, 0.0, 225.0],
    ],
];

/// Top and four sides (the data has no bottom face).
const TALL_BLOCK: [Quad; 5] = [
    [
        [423.0, 330.0, 247.0],
        [265.0, 330.0, 296.0],
        [314.0, 330.0, 456.0],
        [472.0, 330.0, 406.0],
    ],
    [
        [423.0, 0.0, 247.0],
        [423.0, 330.0, 247.0],
        [472.0, 330.0, 406.0],
        [472.0, 0.0, 406.0],
    ],
    [
        [472.0, 0.0, 406.0],
        [472.0, 330.0, 406.0],
        [314.0, 330.0, 456.0],
        [314.0, 0.0, 456.0],
    ],
    [
        [314.0, 0.0, 456.0],
        [314.0, 330.0, 456.0],
        [265.0, 330.0, 296.0],
        [265.0, 0.0, 296.0],
    ],
    [
        [265.0, 0.0, 296.0],
        [265.0, 330.0, 296.0],
        [423.0, 330.0, 247.0],
        [423.0, 0.0, 247.0],
    ],
];

/// Height of the emitter: 1 mm below the ceiling (548.8 mm) so it does not
/// coincide with the ceiling quad.
const LIGHT_Y: f64 = 547.8;

/// The measured light quad (x 213–343 mm, z 227–332 mm), lowered to `LIGHT_Y`;
/// it faces −Y.
const LIGHT: [Quad; 1] = [[
    [343.0, LIGHT_Y, 227.0],
    [343.0, LIGHT_Y, 332.0],
    [213.0, LIGHT_Y, 332.0],
    [213.0, LIGHT_Y, 227.0],
]];

/// Emitted radiance of the light, split into a colour in [0, 1] and a strength.
const LIGHT_RADIANCE: [f64; 3] = [17.0, 12.0, 4.0];
const LIGHT_STRENGTH: f64 = 17.0;

/// Classic camera: eye (278, 273, −800) mm looking down +Z, 35 mm lens on a
/// 25 mm × 25 mm film, i.e. a vertical field of view of 39.3077°.
const CAMERA_POSITION: [f64; 3] = [0.278, 0.273, -0.8];
const CAMERA_YFOV_DEGREES: f64 = 39.3077;
const CAMERA_ZNEAR: f64 = 0.01;

const GENERATOR: &str = "vlf xtask assets";
const EMISSIVE_STRENGTH: &str = "KHR_materials_emissive_strength";

const GL_FLOAT: u32 = 5126;
const GL_UNSIGNED_SHORT: u32 = 5123;
const GL_ARRAY_BUFFER: u32 = 34962;
const GL_ELEMENT_ARRAY_BUFFER: u32 = 34963;
const GL_TRIANGLES: u32 = 4;

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Material {
    White,
    Red,
    Green,
    Light,
    Mirror,
    /// Jensen et al.'s marble as a scattering volume (`docs/SUBSURFACE.md`).
    Marble,
    /// A thin sheet that transmits half its diffuse light (`KHR_materials_diffuse_transmission`).
    Paper,
}

const IOR: &str = "KHR_materials_ior";
const VOLUME: &str = "KHR_materials_volume";
const VOLUME_SCATTER: &str = "KHR_materials_volume_scatter";
const DIFFUSE_TRANSMISSION: &str = "KHR_materials_diffuse_transmission";

/// Marble's extinction σ_t = σ_s′ + σ_a (Jensen et al. 2001: 2.1921, 2.6241, 3.0071 /mm) as
/// `attenuationColor` over an `attenuationDistance` of 1 mm: e^{−σ_t × 1 mm}, printed to five
/// digits (the generator uses only IEEE-exact arithmetic, so these are constants).
const MARBLE_ATTENUATION_COLOR: [f64; 3] = [0.11168, 0.072505, 0.049435];
/// Marble's total diffuse reflectance under the dipole at η = 1.5 (Jensen's closed form):
/// `multiscatterColor`, from which the importer recovers its reduced albedo.
const MARBLE_MULTISCATTER: [f64; 3] = [0.83031, 0.79110, 0.75277];

impl Material {
    fn name(self) -> &'static str {
        match self {
            Material::White => "white",
            Material::Red => "red",
            Material::Green => "green",
            Material::Light => "light",
            Material::Mirror => "mirror",
            Material::Marble => "marble",
            Material::Paper => "paper",
        }
    }

    fn to_json(self) -> Value {
        let lambert = |rgb: [f64; 3]| {
            json!({
                "baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            })
        };
        let mut m = Map::new();
        m.insert("name".into(), self.name().into());
        let pbr = match self {
            Material::White => lambert([0.725, 0.71, 0.68]),
            Material::Red => lambert([0.63, 0.065, 0.05]),
            Material::Green => lambert([0.14, 0.45, 0.091]),
            Material::Light => lambert([0.78, 0.78, 0.78]),
            Material::Mirror => json!({
                "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                "metallicFactor": 1.0,
                "roughnessFactor": 0.0,
            }),
            Material::Marble => lambert([0.9, 0.9, 0.9]),
            Material::Paper => lambert([0.8, 0.8, 0.8]),
        };
        match self {
            Material::Marble => {
                m.insert(
                    "extensions".into(),
                    json!({
                        IOR: { "ior": 1.5 },
                        VOLUME: {
                            "thicknessFactor": 0.33,
                            "attenuationDistance": 0.001,
                            "attenuationColor": MARBLE_ATTENUATION_COLOR,
                        },
                        VOLUME_SCATTER: { "multiscatterColor": MARBLE_MULTISCATTER },
                        DIFFUSE_TRANSMISSION: { "diffuseTransmissionFactor": 1.0 },
                    }),
                );
            }
            Material::Paper => {
                m.insert(
                    "extensions".into(),
                    json!({ DIFFUSE_TRANSMISSION: { "diffuseTransmissionFactor": 0.5 } }),
                );
            }
            _ => {}
        }
        m.insert("pbrMetallicRoughness".into(), pbr);
        if self == Material::Light {
            let factor: Vec<f64> = LIGHT_RADIANCE.iter().map(|c| c / LIGHT_STRENGTH).collect();
            m.insert("emissiveFactor".into(), json!(factor));
            m.insert(
                "extensions".into(),
                json!({ EMISSIVE_STRENGTH: { "emissiveStrength": LIGHT_STRENGTH } }),
            );
        }
        Value::Object(m)
    }
}

/// Which way the front faces of an object must point (checked on generation).
#[derive(Clone, Copy, Debug)]
enum Facing {
    /// Room surfaces: towards the inside of the box.
    IntoRoom,
    /// Blocks: away from the block.
    OutOfSolid,
    /// The emitter: straight down.
    Down,
}

struct Object {
    name: &'static str,
    material: Material,
    quads: &'static [Quad],
    facing: Facing,
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Variant {
    /// All-diffuse classic box.
    Diffuse,
    /// The tall block is a perfect mirror.
    Mirror,
    /// The tall block is marble (a dipole medium), the short one a paper shell (thin diffuse
    /// transmission; `docs/SUBSURFACE.md`).
    Translucent,
}

/// The generated files, relative to the output (or `assets/`) directory.
const OUTPUTS: [(&str, Variant); 3] = [
    ("cornell-box/cornell-box.gltf", Variant::Diffuse),
    ("cornell-mirror/cornell-mirror.gltf", Variant::Mirror),
    (
        "cornell-translucent/cornell-translucent.gltf",
        Variant::Translucent,
    ),
];

fn objects(variant: Variant) -> [Object; 8] {
    let obj = |name, material, quads, facing| Object {
        name,
        material,
        quads,
        facing,
    };
    let tall = match variant {
        Variant::Diffuse => Material::White,
        Variant::Mirror => Material::Mirror,
        Variant::Translucent => Material::Marble,
    };
    let short = match variant {
        Variant::Translucent => Material::Paper,
        _ => Material::White,
    };
    [
        obj("floor", Material::White, &FLOOR, Facing::IntoRoom),
        obj("ceiling", Material::White, &CEILING, Facing::IntoRoom),
        obj("back_wall", Material::White, &BACK_WALL, Facing::IntoRoom),
        obj("left_wall_red", Material::Red, &LEFT_WALL, Facing::IntoRoom),
        obj(
            "right_wall_green",
            Material::Green,
            &RIGHT_WALL,
            Facing::IntoRoom,
        ),
        obj("short_block", short, &SHORT_BLOCK, Facing::OutOfSolid),
        obj("tall_block", tall, &TALL_BLOCK, Facing::OutOfSolid),
        obj("light", Material::Light, &LIGHT, Facing::Down),
    ]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Unit normal of the counter-clockwise triangle `t`.
fn normal(t: [Mm; 3]) -> [f64; 3] {
    let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
    let len = dot(n, n).sqrt();
    [n[0] / len, n[1] / len, n[2] / len]
}

/// The two triangles of a quad (fan around its first vertex, keeping the
/// winding).
fn triangles(quads: &[Quad]) -> impl Iterator<Item = [Mm; 3]> + '_ {
    quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
}

/// The centre of the box (mm), used to tell which way is "into the room".
const ROOM_CENTRE: Mm = [278.0, 274.4, 279.6];

/// The triangles of `o` whose front face points the wrong way.
fn misoriented(o: &Object) -> Vec<[Mm; 3]> {
    let vertices: Vec<Mm> = o.quads.iter().flatten().copied().collect();
    let solid_centre = vertices
        .iter()
        .fold([0.0; 3], |s, v| [s[0] + v[0], s[1] + v[1], s[2] + v[2]])
        .map(|c| c / vertices.len() as f64);
    triangles(o.quads)
        .filter(|t| {
            let centre = [0, 1, 2].map(|i| (t[0][i] + t[1][i] + t[2][i]) / 3.0);
            let wanted = match o.facing {
                Facing::IntoRoom => sub(ROOM_CENTRE, centre),
                Facing::OutOfSolid => sub(centre, solid_centre),
                Facing::Down => [0.0, -1.0, 0.0],
            };
            dot(normal(*t), wanted) <= 0.0
        })
        .collect()
}

/// Flat-shaded triangle soup of one object: per-triangle vertices in metres,
/// per-triangle normals, and trivial indices.
struct MeshData {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    indices: Vec<u16>,
}

fn mesh_data(quads: &[Quad]) -> MeshData {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for t in triangles(quads) {
        let n = normal(t);
        for p in t {
            positions.push(p.map(|c| (c / 1000.0) as f32));
            normals.push(n.map(|c| c as f32));
        }
    }
    let indices = (0..positions.len())
        .map(|i| u16::try_from(i).expect("mesh too large for u16 indices"))
        .collect();
    MeshData {
        positions,
        normals,
        indices,
    }
}

/// Accumulates the binary buffer, its views and accessors.
#[derive(Default)]
struct BufferBuilder {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl BufferBuilder {
    fn view(&mut self, data: Vec<u8>, target: u32) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": self.bytes.len(),
            "byteLength": data.len(),
            "target": target,
        }));
        self.bytes.extend_from_slice(&data);
        self.views.len() - 1
    }

    fn vec3(&mut self, data: &[[f32; 3]], bounds: bool) -> usize {
        let bytes = data
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let view = self.view(bytes, GL_ARRAY_BUFFER);
        let mut a = Map::new();
        a.insert("bufferView".into(), view.into());
        a.insert("componentType".into(), GL_FLOAT.into());
        a.insert("count".into(), data.len().into());
        a.insert("type".into(), "VEC3".into());
        if bounds {
            let mut min = [f32::INFINITY; 3];
            let mut max = [f32::NEG_INFINITY; 3];
            for p in data {
                for i in 0..3 {
                    min[i] = min[i].min(p[i]);
                    max[i] = max[i].max(p[i]);
                }
            }
            // Widen to f64 so the printed number is exactly the stored f32.
            a.insert("min".into(), json!(min.map(f64::from)));
            a.insert("max".into(), json!(max.map(f64::from)));
        }
        self.accessors.push(Value::Object(a));
        self.accessors.len() - 1
    }

    fn indices(&mut self, data: &[u16]) -> usize {
        let bytes = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(bytes, GL_ELEMENT_ARRAY_BUFFER);
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": GL_UNSIGNED_SHORT,
            "count": data.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }
}

/// Standard base64 (RFC 4648, with padding).
fn base64(data: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(char::from(ALPHABET[(n >> (18 - 6 * i)) as usize & 63]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Rebuilds every object with its keys inserted in sorted order, so the
/// output is the same whether or not serde_json's `preserve_order` feature is
/// switched on by some other crate in the workspace (without it `Map` is a
/// `BTreeMap` and this changes nothing).
fn sorted_keys(v: Value) -> Value {
    match v {
        Value::Object(m) => {
            let mut entries: Vec<(String, Value)> = m.into_iter().collect();
            entries.sort_by(|a, b| a.0.cmp(&b.0));
            Value::Object(
                entries
                    .into_iter()
                    .map(|(k, v)| (k, sorted_keys(v)))
                    .collect(),
            )
        }
        Value::Array(a) => Value::Array(a.into_iter().map(sorted_keys).collect()),
        other => other,
    }
}

/// The glTF document of one variant.
fn scene_json(variant: Variant) -> Value {
    let objects = objects(variant);

    let mut materials = vec![
        Material::White,
        Material::Red,
        Material::Green,
        Material::Light,
    ];
    if variant == Variant::Mirror {
        materials.push(Material::Mirror);
    }
    if variant == Variant::Translucent {
        materials.extend([Material::Paper, Material::Marble]);
    }

    let mut buf = BufferBuilder::default();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    for (i, o) in objects.iter().enumerate() {
        let wrong = misoriented(o);
        assert!(
            wrong.is_empty(),
            "{}: misoriented triangles {wrong:?}",
            o.name
        );
        let data = mesh_data(o.quads);
        let position = buf.vec3(&data.positions, true);
        let normal = buf.vec3(&data.normals, false);
        let indices = buf.indices(&data.indices);
        let material = materials
            .iter()
            .position(|&m| m == o.material)
            .expect("every object's material is listed");
        meshes.push(json!({
            "name": o.name,
            "primitives": [{
                "attributes": { "NORMAL": normal, "POSITION": position },
                "indices": indices,
                "material": material,
                "mode": GL_TRIANGLES,
            }],
        }));
        nodes.push(json!({ "name": o.name, "mesh": i }));
    }
    // glTF cameras look down their local −Z: turn 180° about +Y to look down +Z.
    nodes.push(json!({
        "name": "camera",
        "camera": 0,
        "translation": CAMERA_POSITION,
        "rotation": [0.0, 1.0, 0.0, 0.0],
    }));
    let scene_nodes: Vec<usize> = (0..nodes.len()).collect();
    let scene_name = match variant {
        Variant::Diffuse => "cornell_box",
        Variant::Mirror => "cornell_mirror",
        Variant::Translucent => "cornell_translucent",
    };
    let mut used = vec![EMISSIVE_STRENGTH];
    if variant == Variant::Translucent {
        used.extend([DIFFUSE_TRANSMISSION, IOR, VOLUME, VOLUME_SCATTER]);
    }

    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64(&buf.bytes)
    );
    let doc = json!({
        "asset": { "generator": GENERATOR, "version": "2.0" },
        "extensionsUsed": used,
        "scene": 0,
        "scenes": [{ "name": scene_name, "nodes": scene_nodes }],
        "nodes": nodes,
        "cameras": [{
            "name": "camera",
            "type": "perspective",
            "perspective": {
                "aspectRatio": 1.0,
                "yfov": CAMERA_YFOV_DEGREES.to_radians(),
                "znear": CAMERA_ZNEAR,
            },
        }],
        "meshes": meshes,
        "materials": materials.iter().map(|m| m.to_json()).collect::<Vec<_>>(),
        "accessors": buf.accessors,
        "bufferViews": buf.views,
        "buffers": [{ "byteLength": buf.bytes.len(), "uri": uri }],
    });
    sorted_keys(doc)
}

/// The text of one generated file.
fn scene_text(variant: Variant) -> String {
    let mut text = serde_json::to_string_pretty(&scene_json(variant))
        .expect("serialising a serde_json::Value cannot fail");
    text.push('\n');
    text
}

/// Paths of the generated files under `dir` (e.g. the repository's `assets/`).
pub fn asset_files(dir: &Path) -> Vec<PathBuf> {
    OUTPUTS.iter().map(|(rel, _)| dir.join(rel)).collect()
}

/// Writes the Cornell box scenes under `out_dir` and returns their paths.
pub fn generate(out_dir: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for (rel, variant) in OUTPUTS {
        let path = out_dir.join(rel);
        let parent = path.parent().expect("output paths have a parent");
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
        std::fs::write(&path, scene_text(variant))
            .with_context(|| format!("writing {}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}

/// Regenerates the scenes into a temporary directory and fails if the
/// committed files under `assets/` differ from them byte for byte.
pub fn check(repo_root: &Path) -> Result<()> {
    let tmp = std::env::temp_dir().join(format!("vlf-xtask-assets-{}", std::process::id()));
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).with_context(|| format!("removing {}", tmp.display()))?;
    }
    let result = compare_with_fresh(repo_root, &tmp);
    // Best effort: a leftover temporary directory is harmless.
    let _ = std::fs::remove_dir_all(&tmp);
    result
}

fn compare_with_fresh(repo_root: &Path, tmp: &Path) -> Result<()> {
    let assets = repo_root.join("assets");
    let mut stale = Vec::new();
    for fresh in generate(tmp)? {
        let rel = fresh.strip_prefix(tmp).expect("generated under tmp");
        let committed = assets.join(rel);
        let expected =
            std::fs::read(&fresh).with_context(|| format!("reading {}", fresh.display()))?;
        match std::fs::read(&committed) {
            Ok(bytes) if bytes == expected => {}
            Ok(_) => stale.push(format!(
                "{} differs from the generator's output",
                committed.display()
            )),
            Err(e) => stale.push(format!("{} cannot be read: {e}", committed.display())),
        }
    }
    if !stale.is_empty() {
        bail!("{}\nrun `cargo xtask assets`", stale.join("\n"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (input, expected) in cases {
            assert_eq!(base64(input.as_bytes()), expected, "input {input:?}");
        }
        assert_eq!(base64(&[0xfb, 0xff, 0xfe]), "+//+");
    }

    #[test]
    fn output_is_deterministic() {
        for (_, variant) in OUTPUTS {
            assert_eq!(scene_text(variant), scene_text(variant));
        }
    }

    #[test]
    fn faces_point_into_the_room_and_out_of_the_blocks() {
        for variant in [Variant::Diffuse, Variant::Mirror, Variant::Translucent] {
            for o in objects(variant) {
                assert_eq!(misoriented(&o), Vec::<[Mm; 3]>::new(), "{}", o.name);
            }
        }
    }

    #[test]
    fn light_material_emits_17_12_4() {
        let m = Material::Light.to_json();
        let strength = m["extensions"][EMISSIVE_STRENGTH]["emissiveStrength"]
            .as_f64()
            .unwrap();
        let radiance: Vec<f64> = m["emissiveFactor"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_f64().unwrap() * strength)
            .collect();
        for (got, want) in radiance.iter().zip(LIGHT_RADIANCE) {
            assert!((got - want).abs() < 1e-12, "{radiance:?}");
        }
    }

    #[test]
    fn only_the_mirror_variant_has_a_mirror() {
        let diffuse = scene_json(Variant::Diffuse);
        let mirror = scene_json(Variant::Mirror);
        let names = |doc: &Value| -> Vec<String> {
            doc["materials"]
                .as_array()
                .unwrap()
                .iter()
                .map(|m| m["name"].as_str().unwrap().to_owned())
                .collect()
        };
        assert_eq!(names(&diffuse), ["white", "red", "green", "light"]);
        assert_eq!(names(&mirror), ["white", "red", "green", "light", "mirror"]);
        let tall = mirror["meshes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"] == "tall_block")
            .unwrap();
        assert_eq!(tall["primitives"][0]["material"], 4);
    }
}
