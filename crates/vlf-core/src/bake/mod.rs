//! Baking: quality presets and the scene rules that refine them, the prepared (VLF-space,
//! GPU-ready) scene, the diffuse atlas, and the CPU reference propagator. The GPU propagator in `vlf-gpu` consumes exactly the same prepared
//! arrays ([`prep::BakeScene`]) and must agree with [`reference`].
//!
//! See `docs/PROPAGATION.md` for the algorithm and why it departs from the paper's painter's
//! sort (exact per-ray depth lists) and float-atomic scatter (per-texel gather).

pub mod glossy;
pub mod prep;
pub mod punctual;
pub mod quality;
pub mod reference;
pub mod refine;
pub mod subsurface;

pub use prep::BakeScene;
pub use quality::{Preset, Quality};

use crate::directions::DirectionSet;
use crate::lightfield::{
    BakeParams, BakeStats, DEFAULT_ENCODING, LightField, MirrorTiles, ParamsError, Radiance,
    Shading,
};
use crate::scene::Scene;

/// Errors of a bake.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("invalid bake parameters: {0}")]
    Params(#[from] ParamsError),
    #[error("invalid direction count: {0}")]
    Directions(#[from] crate::directions::DirectionError),
    /// The propagated light holds a value no encoding can store (a bug or an overflow).
    #[error("{element}: {value:?} is not finite (NaN and infinity cannot be stored)")]
    NonFinite { element: String, value: [f32; 3] },
    /// The final gather's denoiser could not run (`--denoise oidn`; `gather::GatherError`).
    #[error("atlas denoiser: {0}")]
    Denoiser(String),
}

/// Assembles a [`LightField`] from a scene, an atlas and the irradiance propagated (or
/// gathered) on it, shared by the CPU and GPU paths, radiosity and the final gather (which
/// hands in its own finer atlas and irradiance as `prep` and `propagated.irradiance`). The
/// light field stores the irradiance, the atlas's faces (with their materials) and the
/// scene's [`Shading`] (materials, uvs, textures), from which the renderer computes each
/// pixel's radiance. Uncovered texels are dilated so bilinear filtering at polygon borders
/// reads covered neighbours instead of black. The irradiance and the mirror tiles' radiance
/// are then encoded once, in the file's default encoding ([`DEFAULT_ENCODING`]): that is how
/// the light field is kept in memory, written and rendered.
///
/// No encoding stores NaN or infinity. Should the propagation produce one (a bug or an
/// overflow), this logs a warning naming the first such value and stores those components as
/// the writer's encoders do (NaN and −∞ as 0, +∞ as the largest value); [`try_assemble`]
/// fails instead.
pub fn assemble(
    scene: &Scene,
    prep: &BakeScene,
    params: &BakeParams,
    directions: DirectionSet,
    propagated: reference::Propagated,
    stats: BakeStats,
) -> LightField {
    match assemble_impl(scene, prep, params, directions, propagated, stats, false) {
        Ok(lf) => lf,
        Err(e) => unreachable!("lenient encoding cannot fail: {e}"),
    }
}

/// [`assemble`], failing with [`BakeError::NonFinite`] (naming the first value) if an
/// irradiance or tile value is NaN or infinite.
pub fn try_assemble(
    scene: &Scene,
    prep: &BakeScene,
    params: &BakeParams,
    directions: DirectionSet,
    propagated: reference::Propagated,
    stats: BakeStats,
) -> Result<LightField, BakeError> {
    assemble_impl(scene, prep, params, directions, propagated, stats, true)
}

fn assemble_impl(
    scene: &Scene,
    prep: &BakeScene,
    params: &BakeParams,
    directions: DirectionSet,
    propagated: reference::Propagated,
    stats: BakeStats,
    strict: bool,
) -> Result<LightField, BakeError> {
    let mut irradiance = propagated.irradiance;
    dilate(prep, &mut irradiance);
    let irradiance = encode_radiance(irradiance, "irradiance texel", strict)?;
    let tiles = match propagated.tiles {
        Some((index, values)) => Some(MirrorTiles {
            index,
            radiance: encode_radiance(values, "tile radiance value", strict)?,
        }),
        None => None,
    };
    // The renderer's diffuse weight is the bake's: a rough metal folded into the diffuse part
    // renders with the albedo it was baked with.
    let mut shading = Shading::from_scene(scene);
    for (sm, b) in shading.materials.iter_mut().zip(&prep.materials) {
        sm.diffuse_weight = b.diffuse_weight;
    }
    Ok(LightField {
        params: params.clone(),
        directions,
        to_vlf: scene.to_vlf,
        scene: scene.summary(),
        cameras: scene.cameras.clone(),
        triangles: prep.triangles.clone(),
        faces: prep.faces.clone(),
        irradiance,
        shading,
        tiles,
        stats,
    })
}

/// Encodes `values` in the default encoding; non-finite values fail (`strict`) or are stored
/// as the encoders store them, with a warning.
fn encode_radiance(
    mut values: Vec<[f32; 4]>,
    what: &str,
    strict: bool,
) -> Result<Radiance, BakeError> {
    let e = match Radiance::from_f32(&values, DEFAULT_ENCODING) {
        Ok(r) => return Ok(r),
        Err(e) => e,
    };
    if strict {
        return Err(BakeError::NonFinite {
            element: format!("{what} {}", e.index),
            value: e.value,
        });
    }
    let mut count = 0usize;
    for c in values.iter_mut().flat_map(|v| &mut v[..3]) {
        if !c.is_finite() {
            *c = if *c == f32::INFINITY { f32::MAX } else { 0.0 };
            count += 1;
        }
    }
    log::warn!(
        "{what} {}: {:?} is not finite; {count} non-finite components stored as 0 (NaN, -inf) \
         or the largest value (+inf)",
        e.index,
        e.value
    );
    Radiance::from_f32(&values, DEFAULT_ENCODING).map_err(|e| BakeError::NonFinite {
        element: format!("{what} {}", e.index),
        value: e.value,
    })
}

/// Fills every uncovered texel (area 0) of each chart side with the mean of its covered
/// 8-neighbours, repeated outward (two rings are enough for bilinear filtering).
pub fn dilate(prep: &BakeScene, radiance: &mut [[f32; 4]]) {
    let filled: Vec<bool> = prep.texel_area.iter().map(|a| *a > 0.0).collect();
    dilate_where(prep, radiance, &filled);
}

/// [`dilate`] with the texels that hold a value given by `filled` (per texel of `prep`).
pub fn dilate_where(prep: &BakeScene, radiance: &mut [[f32; 4]], filled: &[bool]) {
    for f in &prep.faces {
        let (w, h) = (f.width as usize, f.height as usize);
        for side in 0..2 {
            let base = f.texel_base as usize + side * w * h;
            let mut filled: Vec<bool> = filled[base..base + w * h].to_vec();
            for _ring in 0..2 {
                let snapshot = filled.clone();
                for y in 0..h {
                    for x in 0..w {
                        if snapshot[y * w + x] {
                            continue;
                        }
                        let mut sum = glam::Vec4::ZERO;
                        let mut n = 0;
                        for dy in -1i64..=1 {
                            for dx in -1i64..=1 {
                                let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                                if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                                    continue;
                                }
                                let j = yy as usize * w + xx as usize;
                                if snapshot[j] {
                                    sum += glam::Vec4::from(radiance[base + j]);
                                    n += 1;
                                }
                            }
                        }
                        if n > 0 {
                            radiance[base + y * w + x] = (sum / n as f32).into();
                            filled[y * w + x] = true;
                        }
                    }
                }
            }
        }
    }
}
