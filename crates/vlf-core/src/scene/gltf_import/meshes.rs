//! Meshes: primitives decoded once (positions, texture coordinates, triangle lists, strips
//! and fans) and instanced into world-space triangles by the nodes that use them.

use std::rc::Rc;

use glam::{DMat4, DVec3, Vec2, Vec3};
use gltf::json::{self, validation::Checked};

use super::{Importer, element};
use crate::scene::faces::RawTriangle;
use crate::scene::{MAX_TRIANGLES, SceneError};

/// Decoded local data of one mesh primitive (shared by every instance).
pub(super) struct DecodedPrimitive {
    positions: Vec<DVec3>,
    uvs: Option<Vec<Vec2>>,
    uvs1: Option<Vec<Vec2>>,
    /// `NORMAL`s in the mesh's frame, as read (unchecked: the checks need the world
    /// transform and the triangle).
    normals: Option<Vec<DVec3>>,
    /// `COLOR_0` (rgb, finite, clamped to [0, 1]).
    colors: Option<Vec<Vec3>>,
    triangles: Vec<[u32; 3]>,
    material: u32,
}

/// Below this dot product with its triangle's geometric normal a shading normal is on the
/// back of the triangle (or perpendicular to it) and is replaced by the geometric normal.
const MIN_NORMAL_DOT: f64 = 0.0;

impl Importer<'_> {
    /// Decodes mesh `mi` primitive `pi` once; `None` when it is skipped (points/lines).
    fn primitive(
        &mut self,
        mi: usize,
        pi: usize,
    ) -> Result<Option<Rc<DecodedPrimitive>>, SceneError> {
        if let Some(p) = self.primitives.get(&(mi, pi)) {
            return Ok(p.clone());
        }
        let decoded = self.decode_primitive(mi, pi)?.map(Rc::new);
        if decoded.is_none() {
            self.skipped_primitives += 1;
        }
        self.primitives.insert((mi, pi), decoded.clone());
        Ok(decoded)
    }

    fn decode_primitive(
        &mut self,
        mi: usize,
        pi: usize,
    ) -> Result<Option<DecodedPrimitive>, SceneError> {
        use json::mesh::{Mode, Semantic};
        let mesh = &self.root.meshes[mi];
        let el = format!("{} primitive {pi}", element("mesh", mi, mesh.name.as_ref()));
        let prim = mesh.primitives[pi].clone();
        let mode = match prim.mode {
            Checked::Valid(m) => m,
            Checked::Invalid => return Err(self.invalid(el, "invalid primitive mode")),
        };
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.warn(format!(
                "{el}: mode {mode:?} is not a triangle mode; primitive skipped"
            ));
            return Ok(None);
        }
        if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) {
            self.warn(format!("{el}: morph targets are ignored (base shape used)"));
        }
        let material = match prim.material {
            Some(m) if m.value() < self.root.materials.len() => m.value() as u32,
            Some(m) => {
                return Err(self.invalid(
                    el,
                    format!(
                        "material index {} is out of range ({} materials)",
                        m.value(),
                        self.root.materials.len()
                    ),
                ));
            }
            None => self.default_material(),
        };
        let pos_index = prim
            .attributes
            .get(&Checked::Valid(Semantic::Positions))
            .ok_or_else(|| self.invalid(&el, "has no POSITION attribute"))?
            .value();
        let pos = self.read_accessor(&format!("{el} POSITION"), pos_index)?;
        if pos.comps != 3 {
            return Err(self.invalid(
                format!("{el} POSITION: accessor {pos_index}"),
                "must be of type VEC3",
            ));
        }
        let vertex_count = pos.count();
        let mut positions = Vec::with_capacity(vertex_count);
        for v in 0..vertex_count {
            let p = DVec3::new(
                pos.attribute(v, 0),
                pos.attribute(v, 1),
                pos.attribute(v, 2),
            );
            positions.push(p);
        }
        drop(pos);
        let uvs = self.texcoords(&el, &prim, 0, vertex_count)?;
        let uvs1 = self.texcoords(&el, &prim, 1, vertex_count)?;
        let normals = match prim.attributes.get(&Checked::Valid(Semantic::Normals)) {
            None => None,
            Some(ni) => {
                let n = self.read_accessor(&format!("{el} NORMAL"), ni.value())?;
                if n.comps != 3 {
                    return Err(self.invalid(
                        format!("{el} NORMAL: accessor {}", ni.value()),
                        "must be of type VEC3",
                    ));
                }
                if n.count() < vertex_count {
                    self.warn(format!(
                        "{el}: NORMAL has {} elements for {vertex_count} vertices; normals ignored (shaded flat)",
                        n.count()
                    ));
                    None
                } else {
                    Some(
                        (0..vertex_count)
                            .map(|v| {
                                DVec3::new(n.attribute(v, 0), n.attribute(v, 1), n.attribute(v, 2))
                            })
                            .collect(),
                    )
                }
            }
        };
        let colors = match prim.attributes.get(&Checked::Valid(Semantic::Colors(0))) {
            None => None,
            Some(ci) => {
                let c = self.read_accessor(&format!("{el} COLOR_0"), ci.value())?;
                use json::accessor::ComponentType as C;
                let normalized_int = matches!(c.component, C::U8 | C::U16) && c.normalized();
                if !(c.comps == 3 || c.comps == 4) || !(c.component == C::F32 || normalized_int) {
                    return Err(self.invalid(
                        format!("{el} COLOR_0: accessor {}", ci.value()),
                        "must be VEC3 or VEC4 of float, or of normalized unsigned byte or short",
                    ));
                }
                if c.count() < vertex_count {
                    self.warn(format!(
                        "{el}: COLOR_0 has {} elements for {vertex_count} vertices; vertex colours ignored",
                        c.count()
                    ));
                    None
                } else {
                    let (mut bad, mut clamped) = (0usize, 0usize);
                    let list: Vec<Vec3> = (0..vertex_count)
                        .map(|v| {
                            Vec3::from_array([0, 1, 2].map(|k| {
                                let x = c.attribute(v, k) as f32;
                                if !x.is_finite() {
                                    bad += 1;
                                    1.0
                                } else if !(0.0..=1.0).contains(&x) {
                                    clamped += 1;
                                    x.clamp(0.0, 1.0)
                                } else {
                                    x
                                }
                            }))
                        })
                        .collect();
                    if bad > 0 {
                        self.warn(format!(
                            "{el}: {bad} non-finite COLOR_0 components replaced by 1"
                        ));
                    }
                    if clamped > 0 {
                        self.warn(format!(
                            "{el}: {clamped} COLOR_0 components outside [0, 1] clamped"
                        ));
                    }
                    Some(list)
                }
            }
        };
        let indices: Vec<u32> = match prim.indices {
            Some(ii) => {
                let idx = self.read_accessor(&format!("{el} indices"), ii.value())?;
                use json::accessor::ComponentType as C;
                if idx.comps != 1 || !matches!(idx.component, C::U8 | C::U16 | C::U32) {
                    return Err(self.invalid(
                        format!("{el} indices: accessor {}", ii.value()),
                        "must be SCALAR of unsigned byte, short or int",
                    ));
                }
                let mut out = Vec::with_capacity(idx.values.len());
                for &v in &idx.values {
                    if v >= vertex_count as f64 {
                        return Err(SceneError::IndexOutOfRange {
                            element: el,
                            index: v as u64,
                            vertex_count,
                            path: self.path.to_path_buf(),
                        });
                    }
                    out.push(v as u32);
                }
                out
            }
            None => {
                if vertex_count > u32::MAX as usize {
                    return Err(self.invalid(el, "too many vertices"));
                }
                (0..vertex_count as u32).collect()
            }
        };
        let n = indices.len();
        let mut triangles: Vec<[u32; 3]> = Vec::new();
        match mode {
            Mode::Triangles => {
                if !n.is_multiple_of(3) {
                    self.warn(format!(
                        "{el}: {n} indices is not a multiple of 3; the last {} ignored",
                        n % 3
                    ));
                }
                triangles.extend(indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
            }
            Mode::TriangleStrip => {
                for i in 0..n.saturating_sub(2) {
                    // glTF: p_i = {v_i, v_{i+(1+i%2)}, v_{i+(2−i%2)}}
                    let (a, b) = if i % 2 == 0 {
                        (i + 1, i + 2)
                    } else {
                        (i + 2, i + 1)
                    };
                    triangles.push([indices[i], indices[a], indices[b]]);
                }
            }
            Mode::TriangleFan => {
                for i in 0..n.saturating_sub(2) {
                    // glTF: p_i = {v_{i+1}, v_{i+2}, v_0}
                    triangles.push([indices[i + 1], indices[i + 2], indices[0]]);
                }
            }
            _ => unreachable!("non-triangle modes returned above"),
        }
        if triangles.is_empty() {
            self.warn(format!("{el}: no triangles ({n} indices)"));
        }
        Ok(Some(DecodedPrimitive {
            positions,
            uvs,
            uvs1,
            normals,
            colors,
            triangles,
            material,
        }))
    }

    /// `TEXCOORD_<set>` of a primitive with `vertex_count` vertices: `None` when absent or too
    /// short (with a warning); non-finite values read 0 (with a warning).
    fn texcoords(
        &mut self,
        el: &str,
        prim: &json::mesh::Primitive,
        set: u32,
        vertex_count: usize,
    ) -> Result<Option<Vec<Vec2>>, SceneError> {
        use json::mesh::Semantic;
        let Some(ti) = prim
            .attributes
            .get(&Checked::Valid(Semantic::TexCoords(set)))
        else {
            return Ok(None);
        };
        let name = format!("TEXCOORD_{set}");
        let uv = self.read_accessor(&format!("{el} {name}"), ti.value())?;
        if uv.comps != 2 {
            return Err(self.invalid(
                format!("{el} {name}: accessor {}", ti.value()),
                "must be of type VEC2",
            ));
        }
        if uv.count() < vertex_count {
            self.warn(format!(
                "{el}: {name} has {} elements for {vertex_count} vertices; texture coordinates ignored",
                uv.count()
            ));
            return Ok(None);
        }
        let mut bad = 0usize;
        let list: Vec<Vec2> = (0..vertex_count)
            .map(|v| {
                let t = Vec2::new(uv.attribute(v, 0) as f32, uv.attribute(v, 1) as f32);
                if t.is_finite() {
                    t
                } else {
                    bad += 1;
                    Vec2::ZERO
                }
            })
            .collect();
        if bad > 0 {
            let what = if set == 0 {
                "texture coordinates".to_string()
            } else {
                name
            };
            self.warn(format!("{el}: {bad} non-finite {what} replaced by (0, 0)"));
        }
        Ok(Some(list))
    }

    /// Appends the world-space triangles of mesh `mi` instanced by node `el`.
    pub(super) fn emit_mesh(
        &mut self,
        mi: usize,
        el: &str,
        world: &DMat4,
        raw: &mut Vec<RawTriangle>,
        raw_source: &mut Vec<u32>,
    ) -> Result<(), SceneError> {
        if mi >= self.root.meshes.len() {
            return Err(self.invalid(
                el,
                format!(
                    "mesh index {mi} is out of range ({} meshes)",
                    self.root.meshes.len()
                ),
            ));
        }
        let flip = world.determinant() < 0.0;
        // Normals transform with the inverse transpose of the linear part.
        let normal_matrix = glam::DMat3::from_mat4(*world).inverse().transpose();
        for pi in 0..self.root.meshes[mi].primitives.len() {
            let Some(prim) = self.primitive(mi, pi)? else {
                continue;
            };
            if raw.len() + prim.triangles.len() > MAX_TRIANGLES {
                return Err(SceneError::TooLarge {
                    limit: MAX_TRIANGLES,
                    path: self.path.to_path_buf(),
                });
            }
            let src = *self.source_of.entry((mi, pi)).or_insert_with(|| {
                self.sources.push((mi, pi));
                (self.sources.len() - 1) as u32
            });
            let prim_el = || {
                format!(
                    "{} primitive {pi} ({el})",
                    element("mesh", mi, self.root.meshes[mi].name.as_ref())
                )
            };
            let mut world_pos: Vec<Option<Vec3>> = vec![None; prim.positions.len()];
            let world_normals: Option<Vec<DVec3>> = prim
                .normals
                .as_ref()
                .map(|ns| ns.iter().map(|&n| normal_matrix * n).collect());
            let mut repaired = 0usize;
            for tri in &prim.triangles {
                let mut p = [Vec3::ZERO; 3];
                for k in 0..3 {
                    let v = tri[k] as usize;
                    p[k] = match world_pos[v] {
                        Some(w) => w,
                        None => {
                            let local = prim.positions[v];
                            let w = world.transform_point3(local).as_vec3();
                            if !local.is_finite() || !w.is_finite() {
                                return Err(SceneError::NonFinitePosition {
                                    element: prim_el(),
                                    vertex: v,
                                    value: format!(
                                        "{:?} (world {:?})",
                                        local.to_array(),
                                        w.to_array()
                                    ),
                                    path: self.path.to_path_buf(),
                                });
                            }
                            world_pos[v] = Some(w);
                            w
                        }
                    };
                }
                let mut uv = match &prim.uvs {
                    Some(uvs) => tri.map(|v| uvs[v as usize]),
                    None => [Vec2::ZERO; 3],
                };
                let mut uv1 = prim.uvs1.as_ref().map(|u| tri.map(|v| u[v as usize]));
                let mut colors = prim.colors.as_ref().map(|c| tri.map(|v| c[v as usize]));
                let mut normals = world_normals.as_ref().map(|n| tri.map(|v| n[v as usize]));
                if flip {
                    p.swap(1, 2);
                    uv.swap(1, 2);
                    if let Some(u) = uv1.as_mut() {
                        u.swap(1, 2);
                    }
                    if let Some(c) = colors.as_mut() {
                        c.swap(1, 2);
                    }
                    if let Some(n) = normals.as_mut() {
                        n.swap(1, 2);
                    }
                }
                let normals = normals.and_then(|n| shading_normals(&p, n, &mut repaired));
                // All white is no colour at all.
                let colors = colors.filter(|c| c.iter().any(|c| *c != Vec3::ONE));
                raw.push(RawTriangle {
                    p,
                    uv,
                    material: prim.material,
                    normals,
                    colors,
                    uv1,
                });
                raw_source.push(src);
            }
            if repaired > 0 {
                self.warn(format!(
                    "{}: {repaired} NORMAL{} not finite, zero or facing away from their triangle; replaced by the triangle's geometric normal",
                    prim_el(),
                    if repaired == 1 { " is" } else { "s are" }
                ));
            }
        }
        Ok(())
    }
}

/// The unit shading normals of world triangle `p` from its world corner normals `n` (not
/// normalised): renormalised; those that are not finite, zero or facing away from the
/// triangle (dot with its geometric normal ≤ [`MIN_NORMAL_DOT`]) replaced by the geometric
/// normal and counted in `repaired`. `None` when the triangle is flat: all three within
/// 0.08° ([`FACE_COS_TOLERANCE`](crate::scene::FACE_COS_TOLERANCE)) of its geometric normal,
/// or it is degenerate (it will be skipped).
fn shading_normals(p: &[Vec3; 3], n: [DVec3; 3], repaired: &mut usize) -> Option<[Vec3; 3]> {
    let [a, b, c] = p.map(|p| p.as_dvec3());
    let g = (b - a).cross(c - a).normalize_or_zero();
    if g == DVec3::ZERO {
        return None;
    }
    let unit = n.map(|n| {
        let u = n.normalize_or_zero();
        if u.is_finite() && u != DVec3::ZERO && u.dot(g) > MIN_NORMAL_DOT {
            u
        } else {
            *repaired += 1;
            g
        }
    });
    if unit
        .iter()
        .all(|u| u.dot(g) > crate::scene::FACE_COS_TOLERANCE)
    {
        return None;
    }
    Some(unit.map(|u| u.as_vec3()))
}
