// Thin glass panes (KHR_materials_transmission, shared/reference/README.md): both interfaces and
// their interreflections (Mitsuba's thindielectric), no refraction. Mirrors
// vlf_core::scene::pane_reflectance and vlf_core::bake::prep::PaneFace operation for operation
// (the propagation stays bit-identical to the CPU's).

// A face's pane as the propagation reads it (mirrors vlf_core::bake::prep::PaneFace): light
// crossing it passes tint × T(θ) straight through; all zero for a face without a pane.
struct PaneFace {
    tint: vec3<f32>,
    weight: f32,
    ior: f32,
    _pad: array<f32, 3>,
}

// Reflectance of a thin pane of index `ior` at incidence cosine `c`: 2r / (1 + r), r the
// unpolarised Fresnel reflectance of one interface (= r + (1 − r)² r / (1 − r²)).
fn pane_reflectance(cos_theta: f32, ior: f32) -> f32 {
    let c = min(abs(cos_theta), 1.0);
    let s2 = (1.0 - c * c) / (ior * ior);
    if s2 >= 1.0 {
        return 1.0;
    }
    let ct = sqrt(1.0 - s2);
    let rs = (c - ior * ct) / (c + ior * ct);
    let rp = (ior * c - ct) / (ior * c + ct);
    let r = 0.5 * (rs * rs + rp * rp);
    return 2.0 * r / (1.0 + r);
}

// What a crossing at |cos θ| = c of pane `p` passes straight through (PaneFace::transmittance).
fn pane_transmittance(p: PaneFace, c: f32) -> vec3<f32> {
    if p.weight <= 0.0 {
        return vec3<f32>(0.0);
    }
    let t = 1.0 - pane_reflectance(c, p.ior);
    return p.tint * t;
}

// weight × T(θ): what it passes before the tint (PaneFace::untinted).
fn pane_untinted(p: PaneFace, c: f32) -> f32 {
    if p.weight <= 0.0 {
        return 0.0;
    }
    return p.weight * (1.0 - pane_reflectance(c, p.ior));
}
