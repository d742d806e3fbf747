//! The one source of truth for data shared between Rust and WGSL.
//!
//! Each `#[repr(C)]` struct here mirrors a WGSL struct of the same name. The test
//! `rust_structs_match_wgsl` parses the shaders with naga and checks size and alignment of every
//! registered pair, so a field added on one side only fails `cargo test`.

use bytemuck::{Pod, Zeroable};

/// Per-dispatch globals of the smoke pass (`shaders/smoke.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SmokeParams {
    pub a: f32,
    pub b: f32,
    pub count: u32,
    pub _pad: u32,
}

/// (WGSL struct name, shader file, Rust size, Rust alignment) for every shared struct.
pub fn registry() -> Vec<(&'static str, &'static str, usize, usize)> {
    vec![(
        "SmokeParams",
        "smoke.wgsl",
        std::mem::size_of::<SmokeParams>(),
        std::mem::align_of::<SmokeParams>(),
    )]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shaders::ALL;
    use wgpu::naga;

    #[test]
    fn rust_structs_match_wgsl() {
        let reg = registry();
        assert!(!reg.is_empty());
        for (name, file, size, align) in reg {
            let shader = ALL
                .iter()
                .find(|s| s.file == file)
                .unwrap_or_else(|| panic!("{file} not registered"));
            let module = shader.validate().unwrap();
            let mut layouter = naga::proc::Layouter::default();
            layouter.update(module.to_ctx()).unwrap();
            let (handle, ty) = module
                .types
                .iter()
                .find(|(_, t)| t.name.as_deref() == Some(name))
                .unwrap_or_else(|| panic!("struct {name} not found in {file}"));
            let naga::TypeInner::Struct { span, .. } = ty.inner else {
                panic!("{name} in {file} is not a struct");
            };
            assert_eq!(span as usize, size, "size of {name} (WGSL {file} vs Rust)");
            let wgsl_align = layouter[handle].alignment.round_up(1) as usize;
            assert!(
                wgsl_align <= 16 && size % wgsl_align == 0,
                "alignment of {name}: WGSL {wgsl_align}, Rust {align}, size {size}"
            );
        }
    }
}
