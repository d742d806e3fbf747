//! The node hierarchy: transforms, the mesh instances, cameras and lights it places, and the
//! scene they make (degenerate triangles dropped, faces built, the VLF transform fitted).

use glam::{DMat4, DQuat, DVec3, Vec3};
use gltf::json::{self, validation::Checked};

use super::{Importer, element};
use crate::scene::faces::{RawTriangle, build_faces};
use crate::scene::{
    Aabb, Camera, DEGENERATE_AREA_FACTOR, PunctualKind, PunctualLight, Scene, SceneError, Sun,
    fit_similarity,
};

impl Importer<'_> {
    fn node_local(&self, ni: usize) -> Result<DMat4, SceneError> {
        let node = &self.root.nodes[ni];
        let el = element("node", ni, node.name.as_ref());
        let m = if let Some(m) = node.matrix {
            if m.iter().any(|x| !x.is_finite()) {
                return Err(self.invalid(el, "matrix has non-finite entries"));
            }
            DMat4::from_cols_array(&m.map(f64::from))
        } else {
            let t = node.translation.unwrap_or([0.0; 3]);
            let r = node.rotation.unwrap_or_default().0;
            let s = node.scale.unwrap_or([1.0; 3]);
            if t.iter().chain(&r).chain(&s).any(|x| !x.is_finite()) {
                return Err(self.invalid(el, "translation/rotation/scale has non-finite values"));
            }
            let q = DQuat::from_array(r.map(f64::from));
            if q.length() < 1e-6 {
                return Err(self.invalid(el, "rotation quaternion has zero length"));
            }
            DMat4::from_scale_rotation_translation(
                DVec3::from_array(s.map(f64::from)),
                q.normalize(),
                DVec3::from_array(t.map(f64::from)),
            )
        };
        Ok(m)
    }

    pub(super) fn build(mut self) -> Result<Scene, SceneError> {
        // Default scene, or scene 0, or (no scenes at all) every root node.
        let (scene_label, roots): (String, Vec<usize>) = match self.root.scene {
            Some(s) => {
                let s = s.value();
                let scene = self.root.scenes.get(s).ok_or_else(|| {
                    self.invalid(
                        "scene",
                        format!(
                            "default scene index {s} is out of range ({} scenes)",
                            self.root.scenes.len()
                        ),
                    )
                })?;
                (
                    format!("scene {s}"),
                    scene.nodes.iter().map(|n| n.value()).collect(),
                )
            }
            None if !self.root.scenes.is_empty() => (
                "scene 0".to_string(),
                self.root.scenes[0]
                    .nodes
                    .iter()
                    .map(|n| n.value())
                    .collect(),
            ),
            None => {
                let mut has_parent = vec![false; self.root.nodes.len()];
                for node in &self.root.nodes {
                    for c in node.children.iter().flatten() {
                        if let Some(h) = has_parent.get_mut(c.value()) {
                            *h = true;
                        }
                    }
                }
                self.warn("the file defines no scene: every root node is imported".to_string());
                (
                    "root nodes".to_string(),
                    (0..self.root.nodes.len())
                        .filter(|&n| !has_parent[n])
                        .collect(),
                )
            }
        };

        let mut raw: Vec<RawTriangle> = Vec::new();
        let mut raw_source: Vec<u32> = Vec::new();
        let mut cameras = Vec::new();
        let mut suns = Vec::new();
        let mut lights = Vec::new();
        let mut visited = vec![false; self.root.nodes.len()];
        let mut stack: Vec<(usize, DMat4, String)> = roots
            .iter()
            .rev()
            .map(|&n| (n, DMat4::IDENTITY, scene_label.clone()))
            .collect();
        while let Some((ni, parent, referrer)) = stack.pop() {
            if ni >= self.root.nodes.len() {
                return Err(self.invalid(
                    referrer,
                    format!(
                        "node index {ni} is out of range ({} nodes)",
                        self.root.nodes.len()
                    ),
                ));
            }
            let node = self.root.nodes[ni].clone();
            let el = element("node", ni, node.name.as_ref());
            if visited[ni] {
                return Err(self.invalid(
                    el,
                    format!(
                        "is reached twice from {scene_label} (the node hierarchy must be a tree)"
                    ),
                ));
            }
            visited[ni] = true;
            let world = parent * self.node_local(ni)?;
            if !world.is_finite() {
                return Err(self.invalid(el, "world transform is not finite"));
            }
            if node.skin.is_some() {
                self.warn(format!(
                    "{el}: skin ignored (mesh drawn with the node transform)"
                ));
            }
            if let Some(mesh) = node.mesh {
                self.emit_mesh(mesh.value(), &el, &world, &mut raw, &mut raw_source)?;
            }
            if let Some(ci) = node.camera {
                self.add_camera(ci.value(), &el, node.name.as_ref(), &world, &mut cameras)?;
            }
            if let Some(light) = node
                .extensions
                .as_ref()
                .and_then(|e| e.khr_lights_punctual.as_ref())
            {
                self.add_light(
                    light.light.value(),
                    &el,
                    node.name.as_ref(),
                    &world,
                    (&mut suns, &mut lights),
                )?;
            }
            for c in node.children.iter().flatten().rev() {
                stack.push((c.value(), world, el.clone()));
            }
        }

        // Degenerate triangles, relative to the scene size.
        let mut bbox = Aabb::EMPTY;
        for t in &raw {
            for p in t.p {
                bbox.extend(p);
            }
        }
        let diag = (bbox.max.as_dvec3() - bbox.min.as_dvec3()).length();
        let threshold = DEGENERATE_AREA_FACTOR * diag * diag;
        let mut degenerate = vec![0usize; self.sources.len()];
        let mut kept = Vec::with_capacity(raw.len());
        for (t, src) in raw.into_iter().zip(raw_source) {
            let [a, b, c] = t.p.map(|p| p.as_dvec3());
            let area = 0.5 * (b - a).cross(c - a).length();
            if area == 0.0 || area < threshold {
                degenerate[src as usize] += 1;
            } else {
                kept.push(t);
            }
        }
        let total_degenerate: usize = degenerate.iter().sum();
        for (src, &count) in degenerate.iter().enumerate() {
            if count > 0 {
                let (mi, pi) = self.sources[src];
                let mesh_el = element("mesh", mi, self.root.meshes[mi].name.as_ref());
                self.warn(format!(
                    "{mesh_el} primitive {pi}: {count} degenerate triangle{} skipped",
                    if count == 1 { "" } else { "s" }
                ));
            }
        }
        if kept.is_empty() {
            let detail = if total_degenerate > 0 {
                format!("all {total_degenerate} triangles are degenerate")
            } else if self.skipped_primitives > 0 {
                format!(
                    "{} non-triangle primitives skipped and no triangles",
                    self.skipped_primitives
                )
            } else {
                format!("{scene_label} contains no triangle meshes")
            };
            return Err(SceneError::Empty {
                detail,
                path: self.path.to_path_buf(),
            });
        }

        let (triangles, faces) = build_faces(kept);
        let mut bounds = Aabb::EMPTY;
        for t in &triangles {
            for p in t.p {
                bounds.extend(p);
            }
        }
        let to_vlf = fit_similarity(&triangles, &bounds);
        let translucency = self.convert_translucency()?;
        Ok(Scene {
            triangles,
            faces,
            materials: self.materials,
            textures: self.textures,
            cameras,
            suns,
            lights,
            translucency,
            bounds,
            to_vlf,
            warnings: self.warnings,
            source: self.path.to_path_buf(),
            ignored_normal_maps: self.ignored_normal_maps,
        })
    }

    fn add_camera(
        &mut self,
        ci: usize,
        node_el: &str,
        node_name: Option<&String>,
        world: &DMat4,
        cameras: &mut Vec<Camera>,
    ) -> Result<(), SceneError> {
        use json::camera::Type;
        let cam = self.root.cameras.get(ci).cloned().ok_or_else(|| {
            self.invalid(
                node_el,
                format!(
                    "camera index {ci} is out of range ({} cameras)",
                    self.root.cameras.len()
                ),
            )
        })?;
        let cam_el = element("camera", ci, cam.name.as_ref());
        let persp = match (cam.type_, &cam.perspective) {
            (Checked::Valid(Type::Perspective), Some(p)) => p.clone(),
            (Checked::Valid(Type::Orthographic), _) => {
                self.warn(format!(
                    "{cam_el}: orthographic cameras are not supported; ignored"
                ));
                return Ok(());
            }
            _ => {
                self.warn(format!(
                    "{cam_el}: invalid camera (no perspective data); ignored"
                ));
                return Ok(());
            }
        };
        let valid = persp.yfov.is_finite()
            && persp.yfov > 0.0
            && persp.yfov < std::f32::consts::PI
            && persp.znear.is_finite()
            && persp.znear > 0.0
            && persp.zfar.is_none_or(|f| f.is_finite() && f > persp.znear)
            && persp.aspect_ratio.is_none_or(|a| a.is_finite() && a > 0.0);
        if !valid {
            self.warn(format!(
                "{cam_el}: invalid perspective parameters (yfov {}, znear {}, zfar {:?}, aspectRatio {:?}); ignored",
                persp.yfov, persp.znear, persp.zfar, persp.aspect_ratio
            ));
            return Ok(());
        }
        let (_, rotation, translation) = world.to_scale_rotation_translation();
        let rotation = rotation.normalize();
        if !rotation.is_finite() || !translation.is_finite() {
            self.warn(format!(
                "{cam_el} at {node_el}: degenerate node transform; camera ignored"
            ));
            return Ok(());
        }
        cameras.push(Camera {
            name: node_name.cloned().or(cam.name.clone()),
            position: translation.as_vec3(),
            rotation: rotation.as_quat(),
            yfov: persp.yfov,
            aspect_ratio: persp.aspect_ratio,
            znear: persp.znear,
            zfar: persp.zfar,
        });
        Ok(())
    }

    fn add_light(
        &mut self,
        li: usize,
        node_el: &str,
        node_name: Option<&String>,
        world: &DMat4,
        (suns, punctual): (&mut Vec<Sun>, &mut Vec<PunctualLight>),
    ) -> Result<(), SceneError> {
        use json::extensions::scene::khr_lights_punctual::Type;
        let lights = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map_or(&[][..], |l| &l.lights[..]);
        let light = lights.get(li).cloned().ok_or_else(|| {
            self.invalid(
                node_el,
                format!(
                    "KHR_lights_punctual light index {li} is out of range ({} lights)",
                    lights.len()
                ),
            )
        })?;
        let light_el = element("light", li, light.name.as_ref());
        let kind = match light.type_ {
            Checked::Valid(Type::Directional) => None,
            Checked::Valid(Type::Point) => Some(PunctualKind::Point),
            Checked::Valid(Type::Spot) => {
                let spot = light.spot.as_ref().ok_or_else(|| {
                    self.invalid(&light_el, "a spot light without its \"spot\" cone angles")
                })?;
                let (inner, outer) = (spot.inner_cone_angle, spot.outer_cone_angle);
                let valid = inner.is_finite()
                    && outer.is_finite()
                    && inner >= 0.0
                    && inner < outer
                    && outer <= std::f32::consts::FRAC_PI_2;
                if !valid {
                    return Err(self.invalid(
                        &light_el,
                        format!(
                            "spot cone angles innerConeAngle {inner}, outerConeAngle {outer} \
                             must satisfy 0 ≤ inner < outer ≤ π/2"
                        ),
                    ));
                }
                Some(PunctualKind::Spot { inner, outer })
            }
            Checked::Invalid => {
                self.warn(format!("{light_el}: invalid light type; ignored"));
                return Ok(());
            }
        };
        let direction = world.transform_vector3(DVec3::NEG_Z).normalize_or_zero();
        let Some(kind) = kind else {
            let irradiance = Vec3::from_array(light.color) * light.intensity;
            if direction == DVec3::ZERO || !direction.is_finite() {
                self.warn(format!(
                    "{light_el} at {node_el}: degenerate node transform; sun ignored"
                ));
                return Ok(());
            }
            if !irradiance.is_finite() || irradiance.min_element() < 0.0 {
                self.warn(format!(
                    "{light_el}: invalid color × intensity {:?}; sun ignored",
                    irradiance.to_array()
                ));
                return Ok(());
            }
            suns.push(Sun {
                name: light.name.clone().or(node_name.cloned()),
                direction: direction.as_vec3(),
                irradiance,
            });
            return Ok(());
        };
        // Point and spot lights: bad values are errors (a lamp silently dropped or made
        // negative would light the scene wrongly without a word).
        let color = Vec3::from_array(light.color);
        if !color.is_finite() || color.min_element() < 0.0 {
            return Err(self.invalid(
                &light_el,
                format!("color {:?} must be finite and non-negative", light.color),
            ));
        }
        if !light.intensity.is_finite() || light.intensity < 0.0 {
            return Err(self.invalid(
                &light_el,
                format!(
                    "intensity {} must be finite and non-negative",
                    light.intensity
                ),
            ));
        }
        let intensity = color * light.intensity;
        if !intensity.is_finite() {
            return Err(self.invalid(
                &light_el,
                format!("color × intensity {:?} overflows", intensity.to_array()),
            ));
        }
        if let Some(r) = light.range
            && !(r.is_finite() && r > 0.0)
        {
            return Err(self.invalid(&light_el, format!("range {r} must be finite and positive")));
        }
        let position = world.transform_point3(DVec3::ZERO);
        if !position.is_finite() || !position.as_vec3().is_finite() {
            return Err(self.invalid(node_el, format!("{light_el} has a non-finite position")));
        }
        let direction = match kind {
            PunctualKind::Spot { .. } if direction == DVec3::ZERO || !direction.is_finite() => {
                return Err(self.invalid(
                    node_el,
                    format!("degenerate node transform: {light_el} (spot) has no direction"),
                ));
            }
            // A point light's direction is unused; a degenerate transform leaves it −Z.
            _ if direction == DVec3::ZERO || !direction.is_finite() => Vec3::NEG_Z,
            _ => direction.as_vec3(),
        };
        punctual.push(PunctualLight {
            name: light.name.clone().or(node_name.cloned()),
            kind,
            position: position.as_vec3(),
            direction,
            intensity,
            range: light.range,
        });
        Ok(())
    }
}
