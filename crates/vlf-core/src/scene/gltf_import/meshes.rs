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
    triangles: Vec<[u32; 3]>,
    material: u32,
}

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
        let uvs = match prim.attributes.get(&Checked::Valid(Semantic::TexCoords(0))) {
            None => None,
            Some(ti) => {
                let uv = self.read_accessor(&format!("{el} TEXCOORD_0"), ti.value())?;
                if uv.comps != 2 {
                    return Err(self.invalid(
                        format!("{el} TEXCOORD_0: accessor {}", ti.value()),
                        "must be of type VEC2",
                    ));
                }
                if uv.count() < vertex_count {
                    self.warn(format!(
                        "{el}: TEXCOORD_0 has {} elements for {vertex_count} vertices; texture coordinates ignored",
                        uv.count()
                    ));
                    None
                } else {
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
                        self.warn(format!(
                            "{el}: {bad} non-finite texture coordinates replaced by (0, 0)"
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
            triangles,
            material,
        }))
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
                if flip {
                    p.swap(1, 2);
                    uv.swap(1, 2);
                }
                raw.push(RawTriangle {
                    p,
                    uv,
                    material: prim.material,
                });
                raw_source.push(src);
            }
        }
        Ok(())
    }
}
