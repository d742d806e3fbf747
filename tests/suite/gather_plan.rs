//! The GPU final gather allocates exactly its plan (`vlf_gpu::gather::GatherPlan`), as the
//! propagation allocates its own (`bake_plan.rs`): every buffer and texture the gather made, as
//! wgpu reports its size, is the planned one, in the plan's order, and the plan is the one the
//! scene's counts give. The record (`GatherRecord`) covers the gather's own buffers, made from
//! the plan, and what it uploads through other modules (the ray-tracing scene, the direction
//! tables, the mirror-tile textures); the readback's staging buffer is not kept.

use glam::Vec3;
use vlf_core::gather::Grids;
use vlf_core::pathtrace::PreparedScene;
use vlf_core::scene::{PunctualKind, PunctualLight, Scene};
use vlf_gpu::gather::{
    GatherCounts, GatherOptions, GatherPipelines, GatherPlan, GatherRecord, final_gather_recorded,
};
use vlf_tests::gpu;

use crate::gather_gpu::{Field, cornell, gp};

/// `vlf_tests::scenes::striped_screen` (an alpha-masked, textured screen between an emitter and
/// a receiver) with a point light, and shading normals and vertex colours on the receiver:
/// every section of the ray-tracing scene's blob has entries.
fn masked_lit_and_attributed() -> Scene {
    let mut scene = vlf_tests::scenes::striped_screen(true);
    let receiver = vlf_tests::scenes::receiver(&scene);
    for t in scene
        .triangles
        .iter_mut()
        .filter(|t| t.face as usize == receiver)
    {
        t.normals = Some([Vec3::Y; 3]);
        t.colors = Some([Vec3::new(1.0, 0.9, 0.8); 3]);
    }
    scene.lights.push(PunctualLight {
        name: None,
        kind: PunctualKind::Point,
        position: Vec3::new(0.2, 0.9, 0.1),
        direction: Vec3::NEG_Y,
        intensity: Vec3::ONE,
        range: None,
    });
    scene
}

fn listed(buffers: &[vlf_gpu::gather::GatherBuffer]) -> Vec<(String, u64)> {
    buffers
        .iter()
        .map(|b| (b.name.to_string(), b.bytes))
        .collect()
}

/// On the mirror Cornell box (mirror tiles) and a masked, textured scene with a point light and
/// per-corner attributes: what the gather allocated for the whole gather and for each grid is
/// its plan, and that plan is `GatherPlan::new` of the scene's counts.
#[test]
fn gpu_gather_allocates_exactly_its_plan() {
    let Some(ctx) = gpu() else { return };
    let pipelines = GatherPipelines::of(ctx);
    let gp = gp();
    let options = GatherOptions::default();
    for (name, scene) in [
        (
            "cornell-mirror",
            cornell("cornell-mirror/cornell-mirror.gltf"),
        ),
        ("masked, lit, attributed", masked_lit_and_attributed()),
    ] {
        let field = Field::new(&scene, Vec3::splat(0.2));
        let conv = field.converged();
        let mut record = GatherRecord::default();
        final_gather_recorded(ctx, &pipelines, &scene, &conv, &gp, &options, &mut record).unwrap();

        let ps = PreparedScene::new(&scene);
        let counts = GatherCounts::of(&ps, &conv, &Grids::new(&scene, &conv, &gp).unwrap());
        let limits = ctx.device.limits();
        let plan = GatherPlan::new(
            &counts,
            &gp,
            &options,
            limits.max_storage_buffer_binding_size,
            limits.min_uniform_buffer_offset_alignment,
        );
        // The scenes exercise what they are here for.
        if name == "cornell-mirror" {
            assert!(
                counts.tile_values > 0 && counts.tile_index_words > 0,
                "{counts:?}"
            );
        } else {
            let c = &counts;
            assert!(c.mask_words > 4 && c.texture_texels > 0, "{c:?}");
            assert!(c.delta_lights == 1 && c.emitters > 0, "{c:?}");
            assert!(
                c.smooth_triangles > 0 && c.attributed_triangles > 0,
                "{c:?}"
            );
        }
        assert_eq!(plan.shared.len(), 11, "{name}");
        assert_eq!(
            listed(&plan.shared),
            record.shared,
            "{name}: shared buffers"
        );
        for (i, grid) in ["indirect", "direct"].iter().enumerate() {
            assert_eq!(
                record.plans[i].as_ref(),
                Some(&plan),
                "{name}, {grid} grid: gathered with the plan of the scene's counts (no batch halved)"
            );
            assert_eq!(plan.grids[i].len(), 4, "{name}, {grid} grid");
            assert_eq!(
                listed(&plan.grids[i]),
                record.grids[i],
                "{name}, {grid} grid: its buffers"
            );
        }
    }
}
