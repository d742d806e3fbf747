//! The viewer's pinhole camera in VLF coordinates, its matrices and the sub-pixel sample pattern.
//!
//! Conventions (those of the shared references): the camera looks down its local −Z with +Y up,
//! `yfov` is the vertical field of view, aspect = image width / height, row 0 is the top of the
//! image. Image points are given in pixels from the top-left corner: pixel `(x, y)` covers the
//! square `[x, x+1) × [y, y+1)` and its centre is `(x + 0.5, y + 0.5)`.

use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use vlf_core::scene::{Camera, Similarity};

/// Near-plane distance used for the direction-set passes (the flat sphere triangles are at least
/// ~0.79 from the centre, for the coarsest set).
const DIRECTION_NEAR: f32 = 0.01;

/// Smallest near-plane distance (VLF units) a camera may use.
pub const MIN_ZNEAR: f32 = 1e-5;

/// A pinhole camera in VLF coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraView {
    /// Eye position (VLF).
    pub position: Vec3,
    /// Orientation: local −Z is the viewing direction, local +Y is up.
    pub rotation: Quat,
    /// Vertical field of view, radians.
    pub yfov: f32,
    /// Near-plane distance (VLF units). The far plane is at infinity.
    pub znear: f32,
}

impl CameraView {
    /// The glTF camera `cam` (world space, node transform applied by the importer) converted to
    /// VLF coordinates with `to_vlf`. The camera's own aspect ratio is ignored: the image's is
    /// used, as the reference conventions require.
    pub fn from_gltf(cam: &Camera, to_vlf: &Similarity) -> Self {
        Self {
            position: to_vlf.apply(cam.position),
            rotation: cam.rotation.normalize(),
            yfov: cam.yfov,
            znear: to_vlf.apply_length(cam.znear).max(MIN_ZNEAR),
        }
    }

    /// A camera at `position` looking at `target` with world +Y up (falls back to +Z up when
    /// looking straight up or down).
    pub fn look_at(position: Vec3, target: Vec3, yfov: f32) -> Self {
        let forward = (target - position).try_normalize().unwrap_or(Vec3::NEG_Z);
        let up = if forward.cross(Vec3::Y).length_squared() < 1e-8 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        // Camera basis: x = right, y = up, z = −forward.
        let z = -forward;
        let x = up.cross(z).normalize();
        let y = z.cross(x);
        let rotation = Quat::from_mat3(&glam::Mat3::from_cols(x, y, z));
        Self {
            position,
            rotation,
            yfov,
            znear: 1e-3,
        }
    }

    /// Viewing direction (local −Z).
    pub fn forward(&self) -> Vec3 {
        self.rotation * Vec3::NEG_Z
    }

    /// Up direction (local +Y).
    pub fn up(&self) -> Vec3 {
        self.rotation * Vec3::Y
    }

    /// Right direction (local +X).
    pub fn right(&self) -> Vec3 {
        self.rotation * Vec3::X
    }

    /// VLF → camera space.
    pub fn view(&self) -> Mat4 {
        Mat4::from_rotation_translation(self.rotation, self.position).inverse()
    }

    /// Clip-space offset that moves the sample point of every pixel from its centre to
    /// `jitter` (in `[0, 1)²`, pixel units from the pixel's top-left corner).
    fn jitter_matrix(width: u32, height: u32, jitter: Vec2) -> Mat4 {
        let dx = 2.0 * (0.5 - jitter.x) / width as f32;
        let dy = 2.0 * (jitter.y - 0.5) / height as f32;
        Mat4::from_translation(Vec3::new(dx, dy, 0.0))
    }

    /// Reverse-Z, infinite-far, right-handed perspective (camera looks down −Z): depth 1 at the
    /// near plane, → 0 at infinity. Written out here (glam 0.34 moved its projections).
    fn perspective(yfov: f32, aspect: f32, znear: f32) -> Mat4 {
        let f = 1.0 / (0.5 * yfov).tan();
        Mat4::from_cols(
            Vec4::new(f / aspect, 0.0, 0.0, 0.0),
            Vec4::new(0.0, f, 0.0, 0.0),
            Vec4::new(0.0, 0.0, 0.0, -1.0),
            Vec4::new(0.0, 0.0, znear, 0.0),
        )
    }

    /// Reverse-Z, infinite-far projection for a `width × height` image whose pixels sample the
    /// scene at sub-pixel offset `jitter` (`(0.5, 0.5)` = pixel centres).
    pub fn projection(&self, width: u32, height: u32, jitter: Vec2) -> Mat4 {
        let aspect = width as f32 / height as f32;
        Self::jitter_matrix(width, height, jitter)
            * Self::perspective(self.yfov, aspect, self.znear.max(MIN_ZNEAR))
    }

    /// VLF → clip space.
    pub fn view_proj(&self, width: u32, height: u32, jitter: Vec2) -> Mat4 {
        self.projection(width, height, jitter) * self.view()
    }

    /// Direction space → clip space: the camera moved to the sphere centre (rotation only), for
    /// the direction-set passes.
    pub fn direction_view_proj(&self, width: u32, height: u32, jitter: Vec2) -> Mat4 {
        let aspect = width as f32 / height as f32;
        Self::jitter_matrix(width, height, jitter)
            * Self::perspective(self.yfov, aspect, DIRECTION_NEAR)
            * Mat4::from_quat(self.rotation.conjugate())
    }

    /// Unit direction (VLF) of the view ray through image point `point` (pixels from the
    /// top-left corner) of a `width × height` image — the CPU counterpart of the rasterised
    /// passes, for tests and picking.
    pub fn pixel_ray(&self, width: u32, height: u32, point: Vec2) -> Vec3 {
        let aspect = width as f32 / height as f32;
        let t = (0.5 * self.yfov).tan();
        let ndc = Vec2::new(
            2.0 * point.x / width as f32 - 1.0,
            1.0 - 2.0 * point.y / height as f32,
        );
        let local = Vec3::new(ndc.x * t * aspect, ndc.y * t, -1.0);
        (self.rotation * local).normalize()
    }
}

/// The `spp` sub-pixel sample positions (in `[0, 1)²`, from the pixel's top-left corner) used
/// by stills: the Hammersley point set, `x = (i + ½)/spp`, `y` = base-2 radical inverse of `i`
/// shifted by `½/spp`. Stratified: every column `[i/spp, (i+1)/spp)` holds exactly one sample,
/// and for powers of two every elementary interval of area `1/spp` does. `spp = 1` samples the
/// pixel centre. The mean of a pixel's samples estimates the box-filtered (mean) radiance over
/// the pixel square.
pub fn sample_offsets(spp: u32) -> Vec<Vec2> {
    let n = spp.max(1);
    (0..n)
        .map(|i| {
            let x = (i as f32 + 0.5) / n as f32;
            let y = (i.reverse_bits() as f64 / 4_294_967_296.0 + 0.5 / f64::from(n)).fract() as f32;
            Vec2::new(x, y)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_maps_pixel_rays_to_their_pixel() {
        let cam = CameraView {
            position: Vec3::new(0.1, -0.2, 1.5),
            rotation: Quat::from_euler(glam::EulerRot::YXZ, 0.3, -0.2, 0.1),
            yfov: 0.7,
            znear: 0.01,
        };
        let (w, h) = (64, 48);
        for (point, jitter) in [
            (Vec2::new(10.5, 20.5), Vec2::splat(0.5)),
            (Vec2::new(63.25, 0.75), Vec2::new(0.25, 0.75)),
        ] {
            let d = cam.pixel_ray(w, h, point);
            let p = cam.position + d * 2.0;
            let clip = cam.view_proj(w, h, jitter) * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            // The jittered projection puts the point at the centre of the pixel it samples.
            let px = Vec2::new(
                (ndc.x + 1.0) * 0.5 * w as f32,
                (1.0 - ndc.y) * 0.5 * h as f32,
            );
            let want = point.floor() + Vec2::splat(0.5);
            assert!((px - want).abs().max_element() < 1e-3, "{px} vs {want}");
            assert!(ndc.z > 0.0 && ndc.z < 1.0);
            let dclip = cam.direction_view_proj(w, h, jitter) * d.extend(1.0);
            let dndc = dclip.truncate() / dclip.w;
            assert!((dndc.truncate() - ndc.truncate()).abs().max_element() < 1e-4);
        }
    }

    #[test]
    fn look_at_looks_at_the_target() {
        let cam = CameraView::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, 1.0);
        assert!((cam.forward() - Vec3::new(-1.0, -2.0, -3.0).normalize()).length() < 1e-5);
        assert!(cam.up().y > 0.0);
    }

    #[test]
    fn sample_offsets_are_stratified() {
        assert_eq!(sample_offsets(1), vec![Vec2::splat(0.5)]);
        for spp in [2, 4, 7, 16] {
            let s = sample_offsets(spp);
            assert_eq!(s.len(), spp as usize);
            let mut cols = vec![0; spp as usize];
            let mut rows = vec![0; spp as usize];
            for p in &s {
                assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
                cols[(p.x * spp as f32) as usize] += 1;
                rows[(p.y * spp as f32) as usize] += 1;
            }
            assert!(cols.iter().all(|&c| c == 1), "{spp}: {cols:?}");
            if spp.is_power_of_two() {
                assert!(rows.iter().all(|&c| c == 1), "{spp}: {rows:?}");
            }
        }
    }
}
