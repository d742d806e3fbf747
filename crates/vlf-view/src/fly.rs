//! Walkthrough camera: WASD movement and mouse-look in VLF coordinates (the world's axes,
//! scaled: +Y stays up), plus the choice of start camera.

use glam::{Quat, Vec3};
use vlf_core::lightfield::LightField;
use vlf_gpu::render::CameraView;

/// Keys held down, sampled each frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct Held {
    pub forward: bool,
    pub back: bool,
    pub left: bool,
    pub right: bool,
    pub up: bool,
    pub down: bool,
    pub fast: bool,
}

/// A free-flying camera.
#[derive(Clone, Copy, Debug)]
pub struct FlyCamera {
    pub view: CameraView,
    /// Movement speed, VLF units per second (the scene fits the unit sphere).
    pub speed: f32,
    /// Radians of rotation per pixel of mouse movement.
    pub sensitivity: f32,
}

impl FlyCamera {
    pub fn new(view: CameraView) -> Self {
        Self {
            view,
            speed: 0.4,
            sensitivity: 0.003,
        }
    }

    /// Moves by the held keys over `dt` seconds (Shift: 4× faster).
    pub fn update(&mut self, held: &Held, dt: f32) {
        let axis = |a: bool, b: bool| f32::from(u8::from(a)) - f32::from(u8::from(b));
        let v = &self.view;
        let dir = v.forward() * axis(held.forward, held.back)
            + v.right() * axis(held.right, held.left)
            + Vec3::Y * axis(held.up, held.down);
        if let Some(d) = dir.try_normalize() {
            let speed = self.speed * if held.fast { 4.0 } else { 1.0 };
            self.view.position += d * speed * dt;
        }
    }

    /// Mouse-look by a cursor movement of (dx, dy) pixels: yaw about world +Y, pitch about the
    /// camera's right axis, never past straight up or down. Roll of the start camera is kept.
    pub fn look(&mut self, dx: f32, dy: f32) {
        let yawed = Quat::from_rotation_y(-dx * self.sensitivity) * self.view.rotation;
        let pitched = yawed * Quat::from_rotation_x(-dy * self.sensitivity);
        let forward = pitched * Vec3::NEG_Z;
        self.view.rotation = if forward.y.abs() < 0.995 {
            pitched.normalize()
        } else {
            yawed.normalize()
        };
    }
}

/// The camera named `sel` (index or node/camera name), the first glTF camera without `sel`, or
/// an overview of the unit sphere when the file has no camera.
pub fn start_camera(lf: &LightField, sel: Option<&str>) -> Result<CameraView, String> {
    match sel {
        Some(s) => {
            let index = s
                .parse::<usize>()
                .ok()
                .filter(|&i| i < lf.cameras.len())
                .or_else(|| lf.cameras.iter().position(|c| c.name.as_deref() == Some(s)));
            match index {
                Some(i) => Ok(CameraView::from_gltf(&lf.cameras[i], &lf.to_vlf)),
                None => Err(format!(
                    "no camera {s:?}: the file has {} camera(s){}",
                    lf.cameras.len(),
                    camera_list(lf)
                )),
            }
        }
        None => Ok(lf
            .cameras
            .first()
            .map(|c| CameraView::from_gltf(c, &lf.to_vlf))
            .unwrap_or_else(overview)),
    }
}

/// A look-at camera given in world space (`fov_deg` vertical), up = +Y.
pub fn look_at_camera(
    lf: &LightField,
    from: Vec3,
    at: Vec3,
    fov_deg: f32,
) -> Result<CameraView, String> {
    if !(fov_deg > 0.0 && fov_deg < 180.0) {
        return Err(format!(
            "--fov {fov_deg}: the field of view must lie in (0, 180) degrees"
        ));
    }
    if (at - from).length_squared() <= 0.0 {
        return Err("--look-from and --look-at are the same point".into());
    }
    Ok(CameraView::look_at(
        lf.to_vlf.apply(from),
        lf.to_vlf.apply(at),
        fov_deg.to_radians(),
    ))
}

/// A view of the whole unit sphere from outside (+Z side), for files without cameras.
pub fn overview() -> CameraView {
    CameraView::look_at(Vec3::new(0.0, 0.3, 2.6), Vec3::ZERO, 50f32.to_radians())
}

fn camera_list(lf: &LightField) -> String {
    if lf.cameras.is_empty() {
        return String::new();
    }
    let names: Vec<String> = lf
        .cameras
        .iter()
        .enumerate()
        .map(|(i, c)| format!("{i} ({})", c.name.as_deref().unwrap_or("unnamed")))
        .collect();
    format!(": {}", names.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wasd_moves_along_the_view() {
        let mut cam = FlyCamera::new(CameraView::look_at(Vec3::ZERO, Vec3::NEG_X, 1.0));
        cam.update(
            &Held {
                forward: true,
                ..Default::default()
            },
            0.5,
        );
        assert!((cam.view.position - Vec3::new(-0.2, 0.0, 0.0)).length() < 1e-5);
        cam.update(
            &Held {
                up: true,
                fast: true,
                ..Default::default()
            },
            0.5,
        );
        assert!((cam.view.position.y - 0.8).abs() < 1e-5);
    }

    #[test]
    fn mouse_look_turns_and_stops_at_the_poles() {
        let mut cam = FlyCamera::new(CameraView::look_at(Vec3::ZERO, Vec3::NEG_Z, 1.0));
        // Moving the mouse right turns right (towards +X).
        cam.look(100.0, 0.0);
        assert!(cam.view.forward().x > 0.2);
        // Moving it far up never flips over the pole.
        for _ in 0..100 {
            cam.look(0.0, -100.0);
        }
        assert!(cam.view.forward().y > 0.9 && cam.view.up().y > 0.0);
    }
}
