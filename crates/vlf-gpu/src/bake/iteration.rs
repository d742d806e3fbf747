//! One propagation iteration on the GPU: upload the unshot radiance, clear the accumulators,
//! run the passes of every direction, read the accumulators back and finish the iteration on
//! the CPU with `reference::finish_iteration` and `reference::Shooting` (what the next
//! iteration shoots), as the CPU reference does.

use glam::Vec4;
use vlf_core::bake::reference::{self, EnergyStats, IterationEnergy, Shooting, TexelAccum};

use super::pipelines::BakePipelines;
use super::resources::{Host, SceneResources};
use super::stats::{IterationStats, PassKind, PassTimer};
use super::{DIR_STRIDE, GpuBakeError, Progress};
use crate::GpuContext;
use crate::layout;
use crate::readback::read_buffers;
use crate::wgpu_util::dispatch_2d;

/// Directions encoded per submission (progress granularity).
pub(super) const DIRS_PER_SUBMIT: usize = 32;

/// The radiance the host keeps between iterations.
pub(super) struct HostRadiance {
    /// Unshot radiance of the texels and what the next iteration sends.
    pub shooting: Shooting,
    pub unshot_tiles: Vec<[f32; 4]>,
    /// Total radiance of the mirror tiles (specular part), all iterations.
    pub total_tiles: Vec<[f32; 4]>,
    /// Scratch: the radiance the current iteration leaves unshot.
    next: Vec<[f32; 4]>,
    /// Irradiance per texel, all iterations (what the final gather reads).
    pub irradiance: Vec<[f32; 4]>,
    /// The point and spot lights' direct irradiance, injected in the first iteration: the CPU
    /// reference's array (`vlf_core::bake::punctual`), computed on the host.
    punctual: Option<Vec<[f32; 4]>>,
    pub energy: EnergyStats,
}

impl HostRadiance {
    /// Before the first iteration: the emission is unshot.
    pub fn new(host: &Host) -> HostRadiance {
        let scene = host.scene;
        let tile_len = host.tile_len();
        HostRadiance {
            shooting: Shooting::new(
                scene,
                reference::accelerates(host.params, host.setup.spec.is_some()),
            ),
            unshot_tiles: vec![[0f32; 4]; tile_len],
            total_tiles: vec![[0f32; 4]; tile_len],
            next: vec![[0f32; 4]; host.texels()],
            irradiance: vec![[0f32; 4]; host.texels()],
            punctual: vlf_core::bake::punctual::injected_irradiance(scene, 0),
            energy: EnergyStats {
                emitted: scene
                    .emitted_power()
                    .to_array()
                    .iter()
                    .map(|&x| f64::from(x))
                    .sum(),
                ..Default::default()
            },
        }
    }
}

/// Iteration `it` of `max_iter`: propagates `state`'s unshot radiance along every direction
/// (the suns in the first iteration only) and adds what arrives to the irradiance and the tiles'
/// totals.
pub(super) fn run_iteration(
    (ctx, pipelines, res): (&GpuContext, &BakePipelines, &SceneResources),
    host: &Host,
    state: &mut HostRadiance,
    (it, max_iter): (u32, u32),
    mut timer: Option<&mut PassTimer>,
    stats: &mut IterationStats,
    progress: &mut dyn FnMut(Progress),
) -> Result<(), GpuBakeError> {
    let (device, queue) = (&ctx.device, &ctx.queue);
    let b = &res.buffers;
    let first = it == 0;
    let n_tex = host.texels();
    let tile_len = host.tile_len();
    let shot = state.shooting.prepare();
    queue.write_buffer(&b.unshot, 0, bytemuck::cast_slice(shot));
    if tile_len > 0 {
        queue.write_buffer(
            &b.unshot,
            n_tex as u64 * 16,
            bytemuck::cast_slice(&state.unshot_tiles),
        );
    }
    if it == 1 {
        // The sky enters in the first iteration only.
        queue.write_buffer(&b.directions, 0, &host.direction_uniforms(glam::Vec3::ZERO));
    }
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("Bake::clear"),
    });
    encoder.clear_buffer(&b.accumulators, 0, None);
    encoder.clear_buffer(&b.next_tiles, 0, None);
    encoder.clear_buffer(&b.spec_escape, 0, None);
    encoder.clear_buffer(&b.pane_energy, 0, None);
    queue.submit(Some(encoder.finish()));
    stats.submits += 1;

    let n = host.params.resolution;
    let m = host.params.tile;
    let max_dim = device.limits().max_compute_workgroups_per_dimension;
    let cell_groups = dispatch_2d(n * n, 64, max_dim);
    let texel_groups = dispatch_2d(host.active.len() as u32, 64, max_dim);
    let active_dirs: Vec<usize> = (0..host.setup.dirs.len())
        .filter(|&i| i < host.setup.quadrature || first)
        .collect();
    for (submit_i, batch) in active_dirs.chunks(DIRS_PER_SUBMIT).enumerate() {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("Bake::directions"),
        });
        {
            let mut pass =
                PassTimer::begin(timer.as_deref_mut(), &mut encoder, "directions (all kinds)");
            for &d in batch {
                let offset = [(d as u64 * DIR_STRIDE) as u32];
                let chunk = &res.chunks[host.slots[d].chunk];
                pass.set_bind_group(0, &res.globals, &offset);
                pass.set_pipeline(&pipelines.cells.pipeline);
                pass.set_bind_group(1, &chunk.cells, &[]);
                pass.dispatch_workgroups(cell_groups.0, cell_groups.1, 1);
                stats.dispatched(PassKind::Cells);
                pass.set_pipeline(&pipelines.interface.pipeline);
                pass.set_bind_group(1, &res.interface, &[]);
                pass.dispatch_workgroups(cell_groups.0, cell_groups.1, 1);
                stats.dispatched(PassKind::Interface);
                if !host.active.is_empty() {
                    pass.set_pipeline(&pipelines.gather.pipeline);
                    pass.set_bind_group(1, &res.gather, &[]);
                    pass.dispatch_workgroups(texel_groups.0, texel_groups.1, 1);
                    stats.dispatched(PassKind::Gather);
                }
                let count = host.items(d);
                if count > 0 {
                    let g = dispatch_2d(count * m * m, 64, max_dim);
                    pass.set_pipeline(&pipelines.reflect.pipeline);
                    pass.set_bind_group(1, &chunk.reflect, &[]);
                    pass.dispatch_workgroups(g.0, g.1, 1);
                    stats.dispatched(PassKind::Reflect);
                }
            }
        }
        queue.submit(Some(encoder.finish()));
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        stats.submits += 1;
        stats.waits += 1;
        progress(Progress {
            iteration: it,
            max_iterations: max_iter,
            directions_done: (submit_i * DIRS_PER_SUBMIT + batch.len()).min(active_dirs.len()),
            directions: active_dirs.len(),
        });
    }

    // Everything the host reads of this iteration, in one copy and one wait.
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("Bake::readback"),
    });
    let ticks = timer
        .as_deref()
        .and_then(|t| t.resolve(device, &mut encoder));
    let panes = host.scene.panes.iter().any(|p| p.weight > 0.0);
    let spec = host.setup.spec.is_some();
    fn whole(buffer: &wgpu::Buffer, wanted: bool) -> (&wgpu::Buffer, u64) {
        (buffer, if wanted { buffer.size() } else { 0 })
    }
    let mut sources = vec![
        whole(&b.overflow, true),
        whole(&b.accumulators, true),
        whole(&b.pane_energy, panes),
        whole(&b.next_tiles, spec),
        whole(&b.spec_escape, spec),
    ];
    sources.extend(ticks.as_ref().map(|(buffer, bytes)| (buffer, *bytes)));
    let parts =
        read_buffers(device, queue, encoder, &sources).map_err(|_| GpuBakeError::Readback)?;
    stats.submits += 1;
    stats.waits += 1;
    stats.readback_bytes += parts.iter().map(|p| p.len() as u64).sum::<u64>();
    if let Some(t) = timer {
        stats.device_ms = parts
            .get(5)
            .map_or_else(Vec::new, |p| t.take(&bytemuck::pod_collect_to_vec(p)));
    }
    let over: Vec<u32> = bytemuck::pod_collect_to_vec(&parts[0]);
    if over[0] > 0 {
        return Err(GpuBakeError::DepthComplexity {
            crossings: over[0],
            max: host.plan.crossings_per_ray(),
        });
    }
    let gpu_acc: Vec<layout::TexelAccum> = bytemuck::pod_collect_to_vec(&parts[1]);
    let acc_host: Vec<TexelAccum> = gpu_acc
        .iter()
        .take(n_tex)
        .map(|a| TexelAccum {
            irradiance: Vec4::from(a.irradiance),
            open: Vec4::from(a.open),
        })
        .collect();
    let sky = if first {
        host.params.sky
    } else {
        glam::Vec3::ZERO
    };
    let scene = host.scene;
    let mut e = reference::finish_iteration(
        scene,
        &host.tex_face,
        host.setup.spec.as_ref().map_or(&[][..], |s| &s.unresolved),
        &acc_host,
        state.shooting.shot(),
        sky,
        state.punctual.as_deref().filter(|_| first),
        &mut state.next,
        &mut state.irradiance,
    );
    if panes {
        let pe: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&parts[2]);
        let sum = |k: usize| pe.iter().map(|v| f64::from(v[k])).sum::<f64>();
        reference::PaneEnergy {
            absorbed: sum(0),
            escaped: sum(1),
            sun_through: sum(2),
        }
        .apply(&mut e);
    }
    if let Some(sp) = &host.setup.spec {
        let mut next_tiles: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&parts[3]);
        next_tiles.truncate(tile_len);
        let esc: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&parts[4]);
        e.escaped += esc
            .iter()
            .map(|v| f64::from(v[0]) + f64::from(v[1]) + f64::from(v[2]))
            .sum::<f64>();
        let (set, grid) = (host.set, &host.setup.grid);
        e.sent += reference::tile_power(&sp.index, &state.unshot_tiles, set, grid);
        e.absorbed += reference::take_tile_loss(&sp.index, &mut next_tiles, set, grid);
        e.next += reference::tile_power(&sp.index, &next_tiles, set, grid);
        reference::accumulate(&mut state.total_tiles, &next_tiles);
        state.unshot_tiles = next_tiles;
    }
    state.shooting.finish(scene, &state.next, &mut e);
    log_energy(it, &e);
    state.energy.record(&e);
    Ok(())
}

fn log_energy(it: u32, e: &IterationEnergy) {
    log::debug!(
        "GPU iteration {it}: sent {:.5} received {:.5} escaped {:.5} next {:.5}",
        e.sent,
        e.received,
        e.escaped,
        e.next
    );
}
