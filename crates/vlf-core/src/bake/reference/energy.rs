//! Step 5 (the next unshot radiance from the gathered irradiance) and the energy bookkeeping
//! of a bake: per-iteration terms, their sums, the stopping rule.

use glam::{Vec3, Vec4};
use serde::Serialize;

use crate::bake::BakeScene;
use crate::directions::DirectionSet;
use crate::lightfield::{BakeStats, Iterations, TileIndex};
use crate::psf::PsfGrid;

/// Energy bookkeeping of a bake (powers in VLF units², summed over r, g, b).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct EnergyStats {
    /// Σ π·L_e·area of emitting texels.
    pub emitted: f64,
    /// Power received directly from the sky, suns, point and spot lights (first iteration).
    pub injected: f64,
    /// Power absorbed by surfaces, all iterations.
    pub absorbed: f64,
    /// Power that left the scene (rays reaching the unit sphere), all iterations.
    pub escaped: f64,
    /// Power still unshot after the last iteration (signed: a texel that shot more than it
    /// had, `reference::Shooting`, holds a negative residual).
    pub unshot: f64,
    /// Σ |unshot| power after the last iteration (what the stopping rule reads); equal to
    /// `unshot` when no residual is negative.
    pub unshot_magnitude: f64,
    /// Unshot power after each iteration.
    pub unshot_history: Vec<f64>,
    /// [`IterationEnergy::lagging`] of the last iteration.
    pub lagging: f64,
}

impl EnergyStats {
    /// Adds one finished iteration's terms (shared by the CPU and GPU propagators).
    pub fn record(&mut self, e: &IterationEnergy) {
        self.injected += e.injected;
        self.absorbed += e.absorbed;
        self.escaped += e.escaped;
        self.unshot = e.next;
        self.unshot_magnitude = e.magnitude;
        self.unshot_history.push(e.next);
        self.lagging = e.lagging;
    }

    /// Whether the unshot power (its magnitude) is at most `threshold` × (emitted + injected)
    /// and the last iteration added at most [`LOCAL_FACTOR`] × `threshold` of their light to
    /// all but 1 % of the lit texel area ([`IterationEnergy::lagging`]); never for a threshold
    /// of 0 (fixed iteration counts). The local test is what keeps a room lit through its
    /// windows iterating: the sky-lit ground outside holds nearly all the power, so the global
    /// test alone stopped window-room after 3 iterations with the room short of its
    /// interreflected light (`docs/PROPAGATION.md`, *Stopping*).
    pub fn converged(&self, threshold: f32) -> bool {
        let src = self.emitted + self.injected;
        let t = f64::from(threshold);
        threshold > 0.0
            && (src <= 0.0
                || (self.unshot_magnitude <= t * src && self.lagging <= LOCAL_FACTOR * t))
    }

    /// (emitted + injected) − (absorbed + escaped + unshot), relative to emitted + injected.
    pub fn relative_imbalance(&self) -> f64 {
        let src = self.emitted + self.injected;
        if src <= 0.0 {
            return 0.0;
        }
        (src - (self.absorbed + self.escaped + self.unshot)) / src
    }

    /// Copies the totals into a bake's statistics (what the file keeps of them).
    pub fn copy_into(&self, stats: &mut BakeStats) {
        stats.emitted = self.emitted;
        stats.injected = self.injected;
        stats.absorbed = self.absorbed;
        stats.escaped = self.escaped;
        stats.unshot = self.unshot;
        stats.unshot_history = self.unshot_history.clone();
    }
}

/// Per-iteration energy terms computed by [`finish_iteration`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IterationEnergy {
    pub sent: f64,
    pub received: f64,
    pub injected: f64,
    pub absorbed: f64,
    pub escaped: f64,
    /// Unshot power left after the iteration (signed).
    pub next: f64,
    /// Σ |unshot| power left after the iteration (set by `Shooting::finish`).
    pub magnitude: f64,
    /// The 99th percentile, over the lit texel area, of this iteration's irradiance as a share
    /// of the texel's total so far (luminance): how far the slowest 1 % of the surfaces still
    /// are from converged.
    pub lagging: f64,
}

/// The local stopping test allows each texel's last increment to be this many times the
/// global threshold (the global one is a share of all the power; a texel's increments fall
/// geometrically by its surroundings' albedo, so its remaining light is a few times its last
/// increment).
pub const LOCAL_FACTOR: f64 = 30.0;

/// The area-weighted quantile `q` of `(value, area)` pairs (0 when there are none).
fn area_quantile(mut v: Vec<(f32, f32)>, q: f64) -> f64 {
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = v.iter().map(|x| f64::from(x.1)).sum();
    let mut acc = 0.0;
    for (x, a) in &v {
        acc += f64::from(*a);
        if acc >= q * total {
            return f64::from(*x);
        }
    }
    v.last().map_or(0.0, |x| f64::from(x.0))
}

/// Per texel-side accumulators of one iteration (the GPU gather pass keeps the same two vec4s).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexelAccum {
    /// Σ |cos|·ΔΩ·L over valid quadrature directions (rgb) and Σ |cos|·ΔΩ of them (w).
    pub irradiance: Vec4,
    /// Σ E_sun·|cos|·open over suns (rgb) and Σ |cos|·ΔΩ·open over quadrature directions (w).
    pub open: Vec4,
}

/// Step 5: from the accumulators, the next unshot radiance per texel, and the energy terms.
/// Normalises the quadrature so that Σ|cos|ΔΩ over a texel's valid directions is π (uniform
/// incoming radiance L then gives irradiance exactly πL: furnace-exact).
///
/// `unresolved` (per face, or empty for none): the share of a face's specular part that its
/// tiles cannot receive because rays reach the face in only some directions
/// (`SpecularSetup::unresolved`); it leaves with the diffuse part, the rest through the tiles.
///
/// `punctual` (first iteration): the irradiance of the point and spot lights per texel
/// ([`crate::bake::punctual::injected_irradiance`]), added to what arrived. It leaves
/// diffusely only: no tile carries a lamp's reflection, so the specular part of it on a
/// mirror or glossy face is counted as absorbed.
#[allow(clippy::too_many_arguments)]
pub fn finish_iteration(
    scene: &BakeScene,
    tex_face: &[u32],
    unresolved: &[f32],
    acc: &[TexelAccum],
    unshot: &[[f32; 4]],
    sky: Vec3,
    punctual: Option<&[[f32; 4]]>,
    next: &mut [[f32; 4]],
    irradiance: &mut [[f32; 4]],
) -> IterationEnergy {
    let mut e = IterationEnergy::default();
    let lum = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722));
    let mut shares = Vec::new();
    for t in 0..scene.texel_count() {
        let area = f64::from(scene.texel_area[t]);
        let u = Vec4::from(unshot[t]).truncate();
        e.sent += sum3(u) * std::f64::consts::PI * area;
        let a = acc[t];
        let e_lamp = punctual.map_or(Vec3::ZERO, |p| Vec4::from(p[t]).truncate());
        // A texel no direction's rays reached still receives the lamps' light.
        if area <= 0.0 || (a.irradiance.w <= 0.0 && e_lamp == Vec3::ZERO) {
            next[t] = [0.0; 4];
            continue;
        }
        let k = if a.irradiance.w > 0.0 {
            std::f32::consts::PI / a.irradiance.w
        } else {
            0.0
        };
        let e_surf = a.irradiance.truncate() * k;
        let e_inj = sky * (a.open.w * k) + a.open.truncate() + e_lamp;
        let irr = e_surf + e_inj;
        irradiance[t] = (Vec4::from(irradiance[t]) + irr.extend(0.0)).into();
        let total = lum(Vec4::from(irradiance[t]).truncate());
        if total > 0.0 {
            shares.push(((lum(irr) / total).abs(), scene.texel_area[t]));
        }
        let face = tex_face[t] as usize;
        let mut rho = Vec4::from(scene.albedo[t]).truncate();
        // The specular part leaves through the tiles (their power is counted from the tiles),
        // but for the share the rays cannot carry there.
        let mut rho_s = Vec4::from(scene.specular[face]).truncate();
        if let Some(&u) = unresolved.get(face).filter(|&&u| u > 0.0) {
            rho += rho_s * u;
            rho_s *= 1.0 - u;
        }
        let b = rho * irr;
        let spec = rho_s * (irr - e_lamp);
        next[t] = (b / std::f32::consts::PI).extend(0.0).into();
        e.received += sum3(e_surf) * area;
        e.injected += sum3(e_inj) * area;
        e.absorbed += sum3(irr - b - spec) * area;
        e.next += sum3(b) * area;
        e.escaped += sum3(u) * f64::from(a.open.w * k) * area;
    }
    e.lagging = area_quantile(shares, 0.99);
    // What `Shooting::finish` sets for shots of mixed sign and with the tiles' power.
    e.magnitude = e.next;
    e
}

/// Power carried by tile radiance (Σ L × cell area × ΔΩ), summed over channels.
pub fn tile_power(
    index: &TileIndex,
    values: &[[f32; 4]],
    set: &DirectionSet,
    grid: &PsfGrid,
) -> f64 {
    let mut p = 0f64;
    each_tile(index, set, grid, |cells, a, omega| {
        for v in &values[cells] {
            p += sum3(Vec4::from(*v).truncate()) * a * omega;
        }
    });
    p
}

/// Calls `f(values, a, ω)` for every stored tile in index order: the range of its values
/// (both senses), the area a of a ray cell and the solid angle ω of its fixed direction.
fn each_tile(
    index: &TileIndex,
    set: &DirectionSet,
    grid: &PsfGrid,
    mut f: impl FnMut(std::ops::Range<usize>, f64, f64),
) {
    let m2 = (index.m * index.m) as usize;
    let a = f64::from(grid.cell_size() * grid.cell_size());
    for k in 0..index.index_start.len() - 1 {
        let j = k % index.directions as usize;
        let omega = f64::from(set.solid_angle(j as u32));
        for slot in index.index_start[k] as usize..index.index_start[k + 1] as usize {
            f(slot * 2 * m2..(slot + 1) * 2 * m2, a, omega);
        }
    }
}

/// Power the glossy lobes absorbed in one iteration: the fourth components the reflect step
/// wrote (`ReflectJob::loss` × what it reflected), weighted as [`tile_power`] weights
/// radiance. Clears them, so the values hold radiance alone from then on.
pub fn take_tile_loss(
    index: &TileIndex,
    values: &mut [[f32; 4]],
    set: &DirectionSet,
    grid: &PsfGrid,
) -> f64 {
    let mut p = 0f64;
    each_tile(index, set, grid, |cells, a, omega| {
        for v in &mut values[cells] {
            p += f64::from(v[3]) * a * omega;
            v[3] = 0.0;
        }
    });
    p
}

/// (maximum iterations, convergence threshold or 0) of a stopping rule.
pub fn stopping(rule: Iterations) -> (u32, f32) {
    match rule {
        Iterations::Fixed(n) => (n, 0.0),
        Iterations::Converge { threshold, max } => (max, threshold),
    }
}

/// `total += next`, element by element.
pub fn accumulate(total: &mut [[f32; 4]], next: &[[f32; 4]]) {
    for (t, n) in total.iter_mut().zip(next) {
        *t = (Vec4::from(*t) + Vec4::from(*n)).into();
    }
}

/// Σ π·L·area over texels, summed over channels.
pub(super) fn power(radiance: &[[f32; 4]], area: &[f32]) -> f64 {
    radiance
        .iter()
        .zip(area)
        .map(|(l, a)| sum3(Vec4::from(*l).truncate()) * std::f64::consts::PI * f64::from(*a))
        .sum()
}

pub(super) fn sum3(v: Vec3) -> f64 {
    f64::from(v.x) + f64::from(v.y) + f64::from(v.z)
}
