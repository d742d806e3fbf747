//! Content checks shared by the writer and the reader: parameters, transform, cameras,
//! geometry and shading (every element named in the error).

use crate::lightfield::{BakeFace, BakeParams, BakeTriangle, FACE_MIXED, Shading};
use crate::scene::{Camera, Similarity};

/// (element, reason) of a failed check.
pub(super) type Invalid = (String, String);

fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

pub(super) fn validate_header_content(
    params: &BakeParams,
    to_vlf: &Similarity,
    cameras: &[Camera],
) -> Result<(), Invalid> {
    params
        .validate()
        .map_err(|e| ("parameters".to_string(), e.to_string()))?;
    if !(to_vlf.center.is_finite() && to_vlf.scale.is_finite() && to_vlf.scale > 0.0) {
        return Err((
            "transform".into(),
            format!(
                "centre {:?} and scale {} must be finite with a positive scale",
                to_vlf.center, to_vlf.scale
            ),
        ));
    }
    for (i, c) in cameras.iter().enumerate() {
        let ok = c.position.is_finite()
            && c.rotation.is_finite()
            && c.yfov.is_finite()
            && c.znear.is_finite()
            && c.aspect_ratio.is_none_or(f32::is_finite)
            && c.zfar.is_none_or(|z| !z.is_nan());
        if !ok {
            return Err((format!("camera {i}"), "non-finite value".into()));
        }
    }
    Ok(())
}

pub(super) fn validate_geometry(
    triangles: &[BakeTriangle],
    faces: &[BakeFace],
    texels: u64,
    materials: usize,
) -> Result<(), Invalid> {
    for (i, f) in faces.iter().enumerate() {
        let el = || format!("face {i}");
        let floats = [
            &f.normal[..],
            &f.origin,
            &f.u,
            &f.v,
            &[f.offset, f.texel_size, f.specular],
        ];
        if !floats.iter().all(|v| finite(v)) {
            return Err((el(), "non-finite value".into()));
        }
        if f.width == 0 || f.height == 0 {
            return Err((
                el(),
                format!("empty chart ({} × {} texels)", f.width, f.height),
            ));
        }
        if f.texel_size <= 0.0 {
            return Err((el(), format!("texel size {} is not positive", f.texel_size)));
        }
        if f.kind > FACE_MIXED {
            return Err((el(), format!("unknown face kind {}", f.kind)));
        }
        if f.material as usize >= materials {
            return Err((
                el(),
                format!(
                    "material {} is out of range ({materials} materials)",
                    f.material
                ),
            ));
        }
        let end = u128::from(f.texel_base) + 2 * u128::from(f.width) * u128::from(f.height);
        if end > u128::from(texels) {
            return Err((
                el(),
                format!(
                    "texels {}..{end} lie beyond the irradiance array ({texels} texels)",
                    f.texel_base
                ),
            ));
        }
    }
    for (i, t) in triangles.iter().enumerate() {
        if t.face as usize >= faces.len() {
            return Err((
                format!("triangle {i}"),
                format!(
                    "face index {} is out of range ({} faces)",
                    t.face,
                    faces.len()
                ),
            ));
        }
        if !(finite(&t.p0) && finite(&t.p1) && finite(&t.p2)) {
            return Err((
                format!("triangle {i}"),
                "non-finite vertex coordinate".into(),
            ));
        }
    }
    Ok(())
}

/// Materials, uvs and textures fit together and the geometry ([`Shading::check`]).
pub(super) fn validate_shading(shading: &Shading, triangles: usize) -> Result<(), Invalid> {
    shading.check(triangles).map_err(|e| (e.element, e.reason))
}
