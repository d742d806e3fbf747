//! GPU ray tracing: a ray engine and a reference path tracer on top of it.
//!
//! * [`engine`]: the ray engine, in the spirit of Carr, Hall & Hart's "The Ray Engine" (2002):
//!   WGSL compute kernels answer closest-hit and any-hit queries for batches of rays against the
//!   binned-SAH BVH that `vlf_core::pathtrace` builds (uploaded unchanged: 32-byte nodes and
//!   48-byte triangles, [`scene`]).
//! * [`path`]: the GPU path tracer, the estimator of `vlf_core::pathtrace` (same conventions,
//!   same per-path random streams) as a wavefront over the engine's kernels (generate →
//!   closest hit → shade/NEE with compaction → any hit → resolve, per bounce) or as a
//!   megakernel; both agree with the CPU tracer within noise.

pub mod engine;
pub mod path;
pub mod scene;

use wgpu::util::DeviceExt;

pub use engine::{Query, RayBatch, RayEngine};
pub use path::{GpuPathTracer, GpuRenderOptions, Kernel};
pub use scene::PackedScene;

use vlf_core::pathtrace::{PathTraceError, PreparedScene};

/// Failures of GPU ray tracing.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RaytraceError {
    /// Reading a result back failed (device lost).
    #[error("reading GPU ray-tracing results back failed: {0}")]
    Readback(#[from] wgpu::BufferAsyncError),
    /// A buffer would exceed the device's limits.
    #[error("{what} needs {bytes} bytes, more than the device allows in one buffer ({limit})")]
    TooLarge {
        /// Which buffer.
        what: &'static str,
        /// Bytes needed.
        bytes: u64,
        /// The device limit.
        limit: u64,
    },
    /// Invalid settings or camera.
    #[error(transparent)]
    Settings(#[from] PathTraceError),
}

/// A BVH uploaded for the shared traversal (`shaders/common/bvh.wgsl`, bind group 1 bindings 0
/// and 1): its nodes and leaf-order triangles, unchanged. The ray engine's scenes and pass 5's
/// mirror tracing ([`crate::render::mirror_trace`]) both upload theirs with it.
pub struct GpuBvh {
    /// BVH nodes (`array<BvhNode>`).
    pub nodes: wgpu::Buffer,
    /// Leaf-order triangles (`array<RtTriangle>`).
    pub triangles: wgpu::Buffer,
    /// The BVH's alpha masks ([`vlf_core::lightfield::AlphaMasks::words`], `array<u32>`,
    /// `shaders/common/alpha_mask.wgsl`, bind group 1 binding 6), indexed by
    /// `RtTriangle::prim`.
    pub masks: wgpu::Buffer,
}

impl GpuBvh {
    /// Uploads `bvh`; buffers are labelled `"{owner}::nodes"` and `"{owner}::triangles"`.
    pub fn upload(
        device: &wgpu::Device,
        owner: &str,
        bvh: &vlf_core::pathtrace::Bvh,
    ) -> Result<Self, RaytraceError> {
        let nodes = bvh.nodes();
        let tris = &bvh.triangles;
        check_binding(device, "BVH", std::mem::size_of_val(nodes))?;
        check_binding(
            device,
            "triangle buffer",
            std::mem::size_of_val(tris.as_slice()),
        )?;
        let mask_words = bvh.masks().words();
        check_binding(device, "alpha masks", 4 * mask_words.len())?;
        let dummy = [vlf_core::pathtrace::RtTriangle::default()];
        let tri_slice: &[vlf_core::pathtrace::RtTriangle] =
            if tris.is_empty() { &dummy } else { tris };
        Ok(Self {
            nodes: storage_init(
                device,
                &format!("{owner}::nodes"),
                bytemuck::cast_slice(nodes),
            ),
            triangles: storage_init(
                device,
                &format!("{owner}::triangles"),
                bytemuck::cast_slice(tri_slice),
            ),
            masks: storage_init(
                device,
                &format!("{owner}::masks"),
                bytemuck::cast_slice(&mask_words),
            ),
        })
    }
}

/// Fails with [`RaytraceError::TooLarge`] when `bytes` exceed what one storage binding allows.
fn check_binding(
    device: &wgpu::Device,
    what: &'static str,
    bytes: usize,
) -> Result<(), RaytraceError> {
    let limit = device
        .limits()
        .max_storage_buffer_binding_size
        .min(device.limits().max_buffer_size);
    if bytes as u64 > limit {
        return Err(RaytraceError::TooLarge {
            what,
            bytes: bytes as u64,
            limit,
        });
    }
    Ok(())
}

fn storage_init(device: &wgpu::Device, label: &str, contents: &[u8]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// A prepared scene uploaded to the GPU.
pub struct GpuScene {
    /// BVH nodes (`array<BvhNode>`).
    pub nodes: wgpu::Buffer,
    /// Leaf-order triangles (`array<RtTriangle>`).
    pub triangles: wgpu::Buffer,
    /// Alpha masks (see [`GpuBvh::masks`]).
    pub masks: wgpu::Buffer,
    /// Shading data (`array<vec4<f32>>`, see [`scene`]).
    pub blob: wgpu::Buffer,
    /// Where the blob's sections start (uniform [`crate::layout::RtSceneInfo`]).
    pub info: wgpu::Buffer,
    /// Section offsets of the blob (its `blob` vector is emptied after upload).
    pub packed: PackedScene,
    /// Number of triangles.
    pub triangle_count: u32,
}

impl GpuScene {
    /// Uploads the BVH, the triangles and the packed shading data of `prep`.
    pub fn upload(device: &wgpu::Device, prep: &PreparedScene) -> Result<Self, RaytraceError> {
        let mut packed = scene::pack(prep);
        let bvh = GpuBvh::upload(device, "RayScene", &prep.bvh)?;
        check_binding(device, "shading data and textures", packed.blob.len() * 16)?;
        let blob = storage_init(device, "RayScene::blob", bytemuck::cast_slice(&packed.blob));
        let info = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("RayScene::info"),
            contents: bytemuck::bytes_of(&packed.info()),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        packed.blob = Vec::new();
        Ok(Self {
            nodes: bvh.nodes,
            triangles: bvh.triangles,
            masks: bvh.masks,
            blob,
            info,
            packed,
            triangle_count: prep.bvh.triangles.len() as u32,
        })
    }
}

#[cfg(test)]
mod tests {
    use crate::shaders::{self, constant};
    use wgpu::naga::Literal;

    /// The WGSL traversal stack holds what the CPU's depth bound allows, and the WGSL `NONE` is
    /// the CPU's.
    #[test]
    fn traversal_constants_match_vlf_core() {
        let module = shaders::COMMON_BVH.validate().unwrap();
        let depth = u32::try_from(vlf_core::pathtrace::bvh::MAX_DEPTH).unwrap();
        assert_eq!(
            constant(&module, "BVH_STACK"),
            Some(Literal::U32(depth)),
            "common/bvh.wgsl: BVH_STACK must equal vlf_core's MAX_DEPTH"
        );
        assert_eq!(
            constant(&module, "NONE"),
            Some(Literal::U32(vlf_core::pathtrace::NONE))
        );
    }

    /// Rays pass as many panes on the GPU as `vlf_core::gather::through` lets them, and the
    /// materials' openness flags are the packer's.
    #[test]
    fn pane_constants_match_vlf_core() {
        let module = shaders::COMMON_PANE_TRACE.validate().unwrap();
        assert_eq!(
            constant(&module, "MAX_PANES"),
            Some(Literal::U32(vlf_core::gather::through::MAX_PANES)),
            "common/pane_trace.wgsl: MAX_PANES must equal vlf_core's"
        );
        let module = shaders::COMMON_RT_SCENE.validate().unwrap();
        assert_eq!(
            constant(&module, "MAT_PANE"),
            Some(Literal::U32(super::scene::MAT_PANE))
        );
        assert_eq!(
            constant(&module, "MAT_SEE_THROUGH"),
            Some(Literal::U32(super::scene::MAT_SEE_THROUGH))
        );
    }
}
