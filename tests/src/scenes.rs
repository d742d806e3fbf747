//! Test scenes shared by vlf-core's integration tests (included with `#[path]`) and the GPU
//! suite (`vlf_tests::scenes`): the rectangles, squares, materials and textures scenes are built
//! from, and surfaces that let light through.

use glam::{Vec2, Vec3, Vec4};
use vlf_core::bake::BakeScene;
use vlf_core::scene::{
    AlphaMode, FilterMode, Material, MaterialKind, PunctualKind, PunctualLight, Scene,
    SceneBuilder, TexRef, Texture, Transparency, WrapMode,
};

/// An `n × n`-texel checkerboard texture of `cell × cell`-texel squares: `even` where the
/// square's column + row is even, else `odd` (repeating, linear filter).
pub fn checker(n: u32, cell: u32, even: Vec4, odd: Vec4) -> Texture {
    Texture {
        name: None,
        width: n,
        height: n,
        pixels: (0..n * n)
            .map(|i| {
                let (x, y) = (i % n / cell, i / n / cell);
                if (x + y).is_multiple_of(2) { even } else { odd }
            })
            .collect(),
        has_alpha: false,
        wrap_s: WrapMode::Repeat,
        wrap_t: WrapMode::Repeat,
        filter: FilterMode::Linear,
        gltf_texture: 0,
    }
}

/// Adds the rectangle `o, o + e1, o + e1 + e2, o + e2`; its front normal is `e1 × e2`.
pub fn rect(b: &mut SceneBuilder, o: Vec3, e1: Vec3, e2: Vec3, m: u32) {
    b.quad([o, o + e1, o + e1 + e2, o + e2], m);
}

/// Horizontal rectangle `[x0, x1] × [z0, z1]` at height `y`, facing up or down.
pub fn hrect(b: &mut SceneBuilder, y: f32, x: (f32, f32), z: (f32, f32), up: bool, m: u32) {
    let o = Vec3::new(x.0, y, z.0);
    let (ex, ez) = (Vec3::X * (x.1 - x.0), Vec3::Z * (z.1 - z.0));
    if up {
        rect(b, o, ez, ex, m);
    } else {
        rect(b, o, ex, ez, m);
    }
}

/// Horizontal quad at height y spanning [-s, s]², facing up (`up`) or down.
pub fn hquad(b: &mut SceneBuilder, y: f32, s: f32, up: bool, m: u32) {
    let mut q = [
        Vec3::new(-s, y, -s),
        Vec3::new(-s, y, s),
        Vec3::new(s, y, s),
        Vec3::new(s, y, -s),
    ];
    if !up {
        q.reverse();
    }
    b.quad(q, m);
}

/// A square facing up at height y spanning [-s, s]² (a floor or a blocker): corners (-s, s),
/// (s, s), (s, -s), (-s, -s), counter-clockwise seen from above. Its triangles split along
/// (-s, s)–(s, -s), not along [`hquad`]'s other diagonal.
pub fn up_square(b: &mut SceneBuilder, y: f32, s: f32, m: u32) {
    b.quad(
        [
            Vec3::new(-s, y, s),
            Vec3::new(s, y, s),
            Vec3::new(s, y, -s),
            Vec3::new(-s, y, -s),
        ],
        m,
    );
}

/// A square facing down at height y spanning [-s, s]² (a ceiling lamp): corners (-s, -s),
/// (s, -s), (s, s), (-s, s), counter-clockwise seen from below. Its triangles split along
/// (-s, -s)–(s, s), not along [`hquad`]'s other diagonal.
pub fn down_square(b: &mut SceneBuilder, y: f32, s: f32, m: u32) {
    b.quad(
        [
            Vec3::new(-s, y, -s),
            Vec3::new(s, y, -s),
            Vec3::new(s, y, s),
            Vec3::new(-s, y, s),
        ],
        m,
    );
}

/// A white GGX metal named `name` of roughness α (reflectance 1, double-sided).
pub fn metal(b: &mut SceneBuilder, name: &str, alpha: f32) -> u32 {
    b.material(Material {
        name: name.into(),
        base_color: Vec3::ONE,
        base_color_texture: None,
        emission: Vec3::ZERO,
        emissive_texture: None,
        double_sided: true,
        kind: MaterialKind::Mirror,
        metallic: 1.0,
        roughness: alpha.sqrt(),
        transparency: Default::default(),
    })
}

/// A horizontal white GGX metal square of roughness α at y = 0 over [-1, 1]² (the scene's
/// only face).
pub fn metal_plane(alpha: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let m = metal(&mut b, &format!("metal α {alpha}"), alpha);
    hquad(&mut b, 0.0, 1.0, true, m);
    b.build("metal plane")
}

/// pbrt-v4's furnace: a closed 2 × 1.4 × 0.8 box facing in, emitting `le` with albedo `rho`.
pub fn furnace_box(le: Vec3, rho: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("furnace", Vec3::splat(rho), le);
    b.aabox(
        Vec3::new(-1.0, -0.7, -0.4),
        Vec3::new(1.0, 0.7, 0.4),
        true,
        m,
    );
    b.build("furnace box")
}

/// A lone grey square of albedo `rho` at y = 0 over [-1, 1]², facing up.
pub fn sky_plane(rho: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.diffuse("plane", Vec3::splat(rho), Vec3::ZERO);
    hquad(&mut b, 0.0, 1.0, true, m);
    b.build("sky plane")
}

/// A lit closed room with a red decal quad lying exactly on its floor (same plane and facing).
pub fn decal_room() -> Scene {
    let mut b = SceneBuilder::new();
    let white = b.diffuse("white", Vec3::splat(0.7), Vec3::ZERO);
    let red = b.diffuse("decal", Vec3::new(0.8, 0.1, 0.1), Vec3::ZERO);
    let light = b.diffuse("light", Vec3::ZERO, Vec3::splat(10.0));
    b.aabox(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 1.5, 1.0),
        true,
        white,
    );
    hrect(&mut b, 0.0, (-0.3, 0.3), (-0.3, 0.3), true, red);
    hrect(&mut b, 1.48, (-0.3, 0.3), (-0.3, 0.3), false, light);
    b.build("decal")
}

/// A point light at `position` of `intensity` (W/sr), no range.
pub fn point_light(position: Vec3, intensity: Vec3) -> PunctualLight {
    PunctualLight {
        name: None,
        kind: PunctualKind::Point,
        position,
        direction: Vec3::NEG_Z,
        intensity,
        range: None,
    }
}

/// A spot light at `position` along unit `direction` of `intensity`, cone angles `(inner,
/// outer)` (radians) and `range`.
pub fn spot_light(
    position: Vec3,
    direction: Vec3,
    intensity: Vec3,
    (inner, outer): (f32, f32),
    range: Option<f32>,
) -> PunctualLight {
    PunctualLight {
        name: None,
        kind: PunctualKind::Spot { inner, outer },
        position,
        direction,
        intensity,
        range,
    }
}

/// Stripes across the screen: texture periods over its width (each period one opaque and one
/// transparent texel, NEAREST). The stripes are 3/93.4 = 0.032 units wide, 0.015 in VLF units:
/// under half the ray spacing of the bakes below.
pub const PERIODS: f32 = 46.7;

/// An emitter (radiance 1, black) at y = 1 facing down over a grey receiver at y = 0 facing
/// up, both 2 × 2; with `screen`, a black 3 × 3 screen at y = 0.5 between them whose alpha
/// mask (a 2 × 1 NEAREST texture, alpha 1 and 0, repeated) removes half its area in stripes
/// along z.
pub fn striped_screen(screen: bool) -> Scene {
    let mut b = SceneBuilder::new();
    let lamp = b.diffuse("lamp", Vec3::ZERO, Vec3::ONE);
    let grey = b.diffuse("receiver", Vec3::splat(0.5), Vec3::ZERO);
    let square = |y: f32, r: f32| {
        [
            Vec3::new(-r, y, -r),
            Vec3::new(-r, y, r),
            Vec3::new(r, y, r),
            Vec3::new(r, y, -r),
        ]
    };
    let mut down = square(1.0, 1.0);
    down.reverse();
    b.quad(down, lamp);
    b.quad(square(0.0, 1.0), grey);
    if screen {
        let tex = b.texture(Texture {
            name: Some("stripes".into()),
            width: 2,
            height: 1,
            pixels: vec![Vec4::new(0.0, 0.0, 0.0, 1.0), Vec4::ZERO],
            has_alpha: true,
            wrap_s: WrapMode::Repeat,
            wrap_t: WrapMode::Repeat,
            filter: FilterMode::Nearest,
            gltf_texture: 0,
        });
        let m = b.material(Material {
            name: "screen".into(),
            base_color: Vec3::ONE,
            base_color_texture: Some(TexRef {
                index: tex,
                texcoord: 0,
            }),
            emission: Vec3::ZERO,
            emissive_texture: None,
            double_sided: true,
            kind: MaterialKind::Diffuse,
            metallic: 0.0,
            roughness: 1.0,
            transparency: Transparency {
                alpha_mode: AlphaMode::Mask,
                alpha_cutoff: 0.5,
                alpha: 1.0,
                ..Transparency::default()
            },
        });
        let p = PERIODS;
        b.uv_quad(
            square(0.5, 1.5),
            [
                Vec2::new(0.0, 0.0),
                Vec2::new(0.0, 1.0),
                Vec2::new(p, 1.0),
                Vec2::new(p, 0.0),
            ],
            m,
        );
    }
    b.build("striped screen")
}

/// The receiver's face (normal +y at y = 0).
pub fn receiver(scene: &Scene) -> usize {
    (0..scene.faces.len())
        .find(|&f| scene.faces[f].normal.y > 0.99 && scene.face_triangles(f)[0].p[0].y == 0.0)
        .expect("the receiver")
}

/// Area-weighted mean irradiance of the texels of `face`'s front side whose centres lie within
/// `r` (world units) of the y axis.
pub fn central_mean(scene: &Scene, prep: &BakeScene, irr: &[[f32; 4]], face: usize, r: f32) -> f32 {
    let f = &prep.faces[face];
    let (mut sum, mut area) = (0f64, 0f64);
    for t in f.texel_base..f.texel_base + f.texels_per_side() {
        let t = t as usize;
        let a = prep.texel_area[t];
        let c = scene
            .to_vlf
            .inverse(Vec4::from(prep.texel_center[t]).truncate());
        if a <= 0.0 || c.x.abs() > r || c.z.abs() > r {
            continue;
        }
        sum += f64::from(Vec4::from(irr[t]).truncate().y * a);
        area += f64::from(a);
    }
    (sum / area) as f32
}

/// A black 1 × 1 receiver at y = 0 facing up under a 4 × 4 horizontal glass pane at y =
/// `height` (transmission 1, white, roughness 0: a pure thin pane of IOR 1.5), or without
/// the pane, over a black 4 × 4 ground at y = −0.01 (so that what the pane's underside
/// reflects onto the receiver is black, not the sky below).
pub fn pane_over_floor(pane: bool, height: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let floor = b.diffuse("receiver", Vec3::ZERO, Vec3::ZERO);
    let ground = b.diffuse("ground", Vec3::ZERO, Vec3::ZERO);
    let square = |y: f32, r: f32| {
        [
            Vec3::new(-r, y, -r),
            Vec3::new(-r, y, r),
            Vec3::new(r, y, r),
            Vec3::new(r, y, -r),
        ]
    };
    b.quad(square(0.0, 0.5), floor);
    b.quad(square(-0.01, 2.0), ground);
    if pane {
        let glass = glass(&mut b, "glass", Vec3::ONE, None);
        b.quad(square(height, 2.0), glass);
    }
    b.build("pane over floor")
}

/// [`pane_over_floor`]`(true, 0.3)` with the pane tinted (0.9, 0.7, 0.5), the floor grey 0.6,
/// under a sun of irradiance 2 from (0.5, −1, 0.2).
pub fn tinted_pane_in_sun() -> Scene {
    let mut scene = pane_over_floor(true, 0.3);
    for m in &mut scene.materials {
        m.base_color = if m.name == "glass" {
            Vec3::new(0.9, 0.7, 0.5)
        } else {
            Vec3::splat(0.6)
        };
    }
    scene.suns.push(vlf_core::scene::Sun {
        name: None,
        direction: Vec3::new(0.5, -1.0, 0.2).normalize(),
        irradiance: Vec3::splat(2.0),
    });
    scene
}

/// A thin glass pane material named `name`: transmission 1, roughness 0, IOR 1.5, base colour
/// `tint` (times `texture`, read at `TEXCOORD_0`, when given).
pub fn glass(b: &mut SceneBuilder, name: &str, tint: Vec3, texture: Option<u32>) -> u32 {
    b.material(Material {
        name: name.into(),
        base_color: tint,
        base_color_texture: texture.map(|index| TexRef { index, texcoord: 0 }),
        emission: Vec3::ZERO,
        emissive_texture: None,
        double_sided: true,
        kind: MaterialKind::Diffuse,
        metallic: 0.0,
        roughness: 0.0,
        transparency: Transparency {
            transmission: 1.0,
            ..Transparency::default()
        },
    })
}

/// A small glazed room: a grey 2 × 1 × 2 room (walls facing in) whose +x wall has a 1 × 0.5
/// window glazed twice, a tinted pane in the wall's plane and, 4 cm outside it, a pane whose
/// tint is a 2 × 1 texture (two colours, linear); outside, a ground and an emitter facing the
/// window; inside, a grey block under the window. With `paper_box`, a closed box of thin
/// diffuse transmission (paper) stands on the floor: its inside is lit through its walls, so
/// the final gather's openness probes must see through them. [`glazed_room_lights`] adds a sun
/// and a point light outside.
// (vlf-core's tests include this file too; the GPU suite alone uses the glazed room.)
#[allow(dead_code)]
pub fn glazed_room(paper_box: bool) -> Scene {
    let mut b = SceneBuilder::new();
    let grey = b.diffuse("wall", Vec3::splat(0.6), Vec3::ZERO);
    let lamp = b.diffuse("lamp", Vec3::ZERO, Vec3::new(4.0, 3.5, 3.0));
    let inner = glass(&mut b, "inner pane", Vec3::new(0.9, 0.85, 0.7), None);
    let tex = b.texture(Texture {
        name: Some("tint".into()),
        width: 2,
        height: 1,
        pixels: vec![Vec4::new(1.0, 0.9, 0.8, 1.0), Vec4::new(0.7, 0.9, 1.0, 1.0)],
        has_alpha: false,
        wrap_s: WrapMode::Repeat,
        wrap_t: WrapMode::Repeat,
        filter: FilterMode::Linear,
        gltf_texture: 0,
    });
    let outer = glass(&mut b, "outer pane", Vec3::ONE, Some(tex));
    let v = Vec3::new;
    // The room, the +x wall left out.
    let (lo, hi) = (v(-1.0, 0.0, -1.0), v(1.0, 1.0, 1.0));
    let p = |x: usize, y: usize, z: usize| v([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]);
    for q in [
        [p(0, 1, 0), p(0, 1, 1), p(0, 0, 1), p(0, 0, 0)], // −x
        [p(0, 0, 1), p(1, 0, 1), p(1, 0, 0), p(0, 0, 0)], // floor
        [p(1, 1, 0), p(1, 1, 1), p(0, 1, 1), p(0, 1, 0)], // ceiling
        [p(1, 0, 0), p(1, 1, 0), p(0, 1, 0), p(0, 0, 0)], // −z
        [p(0, 1, 1), p(1, 1, 1), p(1, 0, 1), p(0, 0, 1)], // +z
    ] {
        b.quad(q, grey);
    }
    // The +x wall (facing −x) around the window y in [0.3, 0.8], z in [−0.5, 0.5].
    let wall = |y0: f32, y1: f32, z0: f32, z1: f32| {
        [
            v(1.0, y0, z0),
            v(1.0, y0, z1),
            v(1.0, y1, z1),
            v(1.0, y1, z0),
        ]
    };
    for q in [
        wall(0.0, 0.3, -1.0, 1.0),
        wall(0.8, 1.0, -1.0, 1.0),
        wall(0.3, 0.8, -1.0, -0.5),
        wall(0.3, 0.8, 0.5, 1.0),
    ] {
        b.quad(q, grey);
    }
    b.quad(wall(0.3, 0.8, -0.5, 0.5), inner);
    let o = |y: f32, z: f32| v(1.04, y, z);
    b.uv_quad(
        [o(0.3, -0.5), o(0.3, 0.5), o(0.8, 0.5), o(0.8, -0.5)],
        [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        outer,
    );
    // Outside: the ground and a lamp facing the window.
    let ground = b.diffuse("ground", Vec3::splat(0.5), Vec3::ZERO);
    b.quad(
        [
            v(1.0, 0.0, -1.5),
            v(1.0, 0.0, 1.5),
            v(3.0, 0.0, 1.5),
            v(3.0, 0.0, -1.5),
        ],
        ground,
    );
    b.quad(
        [
            v(2.5, 0.4, -0.3),
            v(2.5, 0.4, 0.3),
            v(2.5, 0.8, 0.3),
            v(2.5, 0.8, -0.3),
        ],
        lamp,
    );
    // A block under the window inside.
    b.aabox(v(0.3, 0.0, -0.4), v(0.7, 0.25, 0.1), false, grey);
    if paper_box {
        let paper = b.diffuse("paper", Vec3::new(0.9, 0.85, 0.8), Vec3::ZERO);
        b.translucent(
            paper,
            vlf_core::scene::Translucency::ThinDiffuseTransmission {
                factor: 0.5,
                color: Vec3::new(1.0, 0.9, 0.7),
            },
        );
        b.aabox(v(-0.7, 0.0, 0.2), v(-0.3, 0.4, 0.6), false, paper);
    }
    b.build("glazed room")
}

/// The lights of [`glazed_room`]: a sun shining in through the window (26° above the horizon) and
/// a point light outside it.
#[allow(dead_code)]
pub fn glazed_room_lights(scene: &mut Scene) {
    scene.suns.push(vlf_core::scene::Sun {
        name: None,
        direction: Vec3::new(-1.0, -0.5, 0.15).normalize(),
        irradiance: Vec3::new(3.0, 2.8, 2.5),
    });
    scene.lights.push(vlf_core::scene::PunctualLight {
        name: None,
        kind: vlf_core::scene::PunctualKind::Point,
        position: Vec3::new(1.8, 0.7, -0.2),
        direction: Vec3::NEG_Z,
        intensity: Vec3::new(1.0, 0.9, 0.8),
        range: None,
    });
}

/// The checks of a final gather through a pane, `gathered(scene, sky)` being the gathered
/// irradiance at the centre of the receiver: under a sky of radiance 1, `pane_over_floor(true,
/// 0.02)` receives [`pane_sky_irradiance`] within 1 %; under a sun at 45° (no sky), the pane
/// passes T(45°) of what the floor receives without it, within 1 %. `what` names the gather in
/// the printed figures.
pub fn check_pane_gather(what: &str, mut gathered: impl FnMut(&Scene, Vec3) -> f32) {
    let scene = pane_over_floor(true, 0.02);
    let got = gathered(&scene, Vec3::ONE);
    let want = pane_sky_irradiance(0.02) as f32;
    eprintln!("{what}, sky through a pane: {got:.4} vs {want:.4}");
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want}");
    let th = 45f32.to_radians();
    let mut e = Vec::new();
    for pane in [false, true] {
        let mut scene = pane_over_floor(pane, 0.02);
        scene.suns.push(vlf_core::scene::Sun {
            name: None,
            direction: Vec3::new(th.sin(), -th.cos(), 0.0),
            irradiance: Vec3::ONE,
        });
        e.push(gathered(&scene, Vec3::ZERO));
    }
    let want = 1.0 - vlf_core::scene::pane_reflectance(th.cos(), 1.5);
    eprintln!("{what}, sun at 45°: {:.4} vs T {want:.4}", e[1] / e[0]);
    assert!((e[1] / e[0] / want - 1.0).abs() < 0.01);
}

/// The irradiance at the centre of `pane_over_floor(true, height)`'s receiver under a sky of
/// radiance 1: ∫ T(θ) cos θ dω over the directions through the pane, ∫ cos θ dω over the
/// others (a 2,000 × 2,000 midpoint quadrature in (cos θ, φ)). What the pane reflects onto
/// the receiver is the black ground's (for `height` 0.02, all directions but the last 1.4°
/// above the horizon, which carry 0.06 % of the sky's light).
pub fn pane_sky_irradiance(height: f32) -> f64 {
    let n = 2000;
    let mut e = 0f64;
    for i in 0..n {
        let mu = (i as f64 + 0.5) / n as f64;
        let sin = (1.0 - mu * mu).sqrt();
        let t = 1.0 - f64::from(vlf_core::scene::pane_reflectance(mu as f32, 1.5));
        for j in 0..n {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / n as f64;
            // Where the direction meets the pane's plane.
            let r = f64::from(height) * sin / mu;
            let (x, z) = (r * phi.cos(), r * phi.sin());
            let through = x.abs() <= 2.0 && z.abs() <= 2.0;
            // dω = dμ dφ; integrand cos θ = μ.
            e += mu * if through { t } else { 1.0 };
        }
    }
    e * std::f64::consts::TAU / (n as f64 * n as f64)
}
