//! Adapter and device creation.
//!
//! We request features and limits explicitly so that device creation fails loudly, naming what is
//! missing, instead of failing later inside a pass. In particular wgpu silently falls back to its
//! GL backend when no Vulkan driver is installed; GL lacks float32 filtering and float render
//! targets, so the feature request below rejects it with a clear message.

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::fmt;
use std::sync::{Arc, Mutex};

/// Features every vlf GPU path needs.
///
/// `FLOAT32_FILTERABLE`: the viewer filters the radiance atlas (f32) bilinearly.
pub const REQUIRED_FEATURES: wgpu::Features = wgpu::Features::FLOAT32_FILTERABLE;

/// Features used when present, never needed for correctness.
///
/// `DEPTH32FLOAT_STENCIL8`: the renderer marks textured faces in a stencil beside its f32
/// depth, so that untextured ones skip the texture code (`render::final_radiance`).
pub const OPTIONAL_FEATURES: wgpu::Features =
    wgpu::Features::TIMESTAMP_QUERY.union(wgpu::Features::DEPTH32FLOAT_STENCIL8);

/// The minimum limits vlf needs; anything the adapter offers beyond this (buffer sizes in
/// particular) is requested too so large bakes can use the whole device.
///
/// Storage buffers per stage: 10. The GPU path tracer and the final gather bind 9 (their 8,
/// then the alpha masks every BVH traversal reads, `shaders/common/alpha_mask.wgsl`); WebGPU's
/// default is 8, but Vulkan, Metal and D3D12 drivers offer 16 and more (lavapipe 32).
pub fn minimum_limits() -> wgpu::Limits {
    wgpu::Limits {
        max_storage_buffers_per_shader_stage: 10,
        max_storage_buffer_binding_size: 128 << 20,
        max_buffer_size: 256 << 20,
        max_compute_workgroup_size_x: 256,
        max_compute_invocations_per_workgroup: 256,
        max_texture_dimension_2d: 8192,
        ..wgpu::Limits::default()
    }
}

/// Which adapters may be used.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// Any adapter wgpu offers, software (lavapipe) included.
    #[default]
    Any,
    /// Only a hardware GPU (integrated, discrete or virtual); software rasterisers are refused.
    HardwareOnly,
}

#[derive(Clone, Debug, Default)]
pub struct DeviceOptions {
    pub adapter: AdapterChoice,
    /// Optional label for logs.
    pub label: Option<String>,
}

/// A short, serialisable description of the adapter in use (for logs, `--json` and benchmarks).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
}

impl fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}, {}", self.name, self.backend, self.device_type)?;
        if !self.driver.is_empty() {
            write!(f, ", {}", self.driver)?;
        }
        write!(f, ")")
    }
}

impl AdapterSummary {
    fn new(info: &wgpu::AdapterInfo) -> Self {
        let driver = [info.driver.as_str(), info.driver_info.as_str()]
            .iter()
            .filter(|s| !s.is_empty())
            .copied()
            .collect::<Vec<_>>()
            .join(" ");
        Self {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver,
        }
    }

    /// True for software rasterisers (lavapipe/llvmpipe, WARP, SwiftShader): the "GPU" work
    /// runs on the CPU cores ([`is_software_adapter`]).
    pub fn is_software(&self) -> bool {
        self.device_type == "Cpu" || is_software_name(&self.name, &self.driver)
    }
}

/// Whether an adapter is a software rasteriser: it says so (device type `Cpu`, as lavapipe,
/// SwiftShader and WARP do), or its name or driver is one of theirs (in case a driver reports
/// another type). The one home of this rule: the adapter ranking puts these last and
/// `vlf-bake --device auto` prefers the CPU path to them.
pub fn is_software_adapter(info: &wgpu::AdapterInfo) -> bool {
    info.device_type == wgpu::DeviceType::Cpu
        || is_software_name(&info.name, &format!("{} {}", info.driver, info.driver_info))
}

fn is_software_name(name: &str, driver: &str) -> bool {
    let text = format!("{name} {driver}").to_ascii_lowercase();
    text.contains("microsoft basic render driver")
        || text
            .split(|c: char| !c.is_ascii_alphanumeric())
            .any(|w| matches!(w, "llvmpipe" | "lavapipe" | "swiftshader" | "warp"))
}

#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    #[error(
        "no GPU adapter found (tried backends: {backends}); install a Vulkan driver, e.g. Mesa's software driver: apt-get install -y mesa-vulkan-drivers libvulkan1"
    )]
    NoAdapter { backends: String },
    #[error("only a software adapter is available ({adapter}) but a hardware GPU was required")]
    SoftwareOnly { adapter: Box<AdapterSummary> },
    #[error("adapter {adapter} lacks required features: {missing:?}")]
    MissingFeatures {
        adapter: Box<AdapterSummary>,
        missing: wgpu::Features,
    },
    #[error("adapter {adapter} has insufficient limits: {}", .missing.join(", "))]
    InsufficientLimits {
        adapter: Box<AdapterSummary>,
        missing: Vec<String>,
    },
    #[error("device request failed on adapter {adapter}: {source}")]
    RequestDevice {
        adapter: Box<AdapterSummary>,
        #[source]
        source: wgpu::RequestDeviceError,
    },
}

impl fmt::Display for AdapterChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            AdapterChoice::Any => "any",
            AdapterChoice::HardwareOnly => "hardware-only",
        })
    }
}

/// Everything a pass needs to talk to the GPU.
pub struct GpuContext {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub summary: AdapterSummary,
    /// Optional features that were available and enabled.
    pub features: wgpu::Features,
    /// Objects made once per device and shared by every use of it ([`GpuContext::shared`]).
    shared: Mutex<HashMap<TypeId, Arc<dyn Any + Send + Sync>>>,
}

impl GpuContext {
    /// Creates an instance, picks an adapter and requests a device with [`REQUIRED_FEATURES`]
    /// and at least [`minimum_limits`]. Backends: Vulkan/Metal/DX12 by default (GL lacks the
    /// float formats we need); `WGPU_BACKEND` overrides.
    pub fn new(opts: &DeviceOptions) -> Result<Self, DeviceError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::PRIMARY;
        let desc = desc.with_env();
        let backends = desc.backends;
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(select_adapter(&instance, backends, opts.adapter))?;
        Self::from_adapter(instance, adapter)
    }

    /// Requests the device on an adapter chosen by the caller (the viewer picks one compatible
    /// with its window surface).
    pub fn from_adapter(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
    ) -> Result<Self, DeviceError> {
        let summary = AdapterSummary::new(&adapter.get_info());
        let available = adapter.features();
        let missing = REQUIRED_FEATURES - available;
        if !missing.is_empty() {
            return Err(DeviceError::MissingFeatures {
                adapter: Box::new(summary),
                missing,
            });
        }
        let limits = negotiate_limits(&adapter.limits()).map_err(|missing| {
            DeviceError::InsufficientLimits {
                adapter: Box::new(summary.clone()),
                missing,
            }
        })?;
        let features = REQUIRED_FEATURES | (OPTIONAL_FEATURES & available);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("vlf::device"),
            required_features: features,
            required_limits: limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|source| DeviceError::RequestDevice {
            adapter: Box::new(summary.clone()),
            source,
        })?;
        log::info!("GPU adapter: {summary}");
        Ok(Self {
            instance,
            adapter,
            device,
            queue,
            summary,
            features,
            shared: Mutex::default(),
        })
    }

    /// The one `T` of this device: made by `make` on the first call, shared afterwards (the
    /// pipelines of a pass family are created once per device and reused by every bake or
    /// frame, as re_renderer keeps one renderer per type in its render context). Calls from
    /// several threads wait for the first one's `make`.
    pub fn shared<T: Any + Send + Sync>(&self, make: impl FnOnce(&GpuContext) -> T) -> Arc<T> {
        let mut map = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        let any = map
            .entry(TypeId::of::<T>())
            .or_insert_with(|| Arc::new(make(self)))
            .clone();
        any.downcast::<T>().expect("keyed by its TypeId")
    }

    /// Runs `f` with the GPU's errors trapped: an out-of-memory, validation or internal error
    /// raised on this thread while `f` runs (wgpu error scopes), or a lost device, becomes a
    /// [`GpuFault`] instead of wgpu's default panic. The first error of each kind is kept; a
    /// lost device outranks out-of-memory, which outranks the others. `f`'s own result is
    /// returned only when the GPU reported nothing.
    pub fn trap<T>(&self, f: impl FnOnce() -> T) -> Result<T, GpuFault> {
        let lost: Arc<Mutex<Option<String>>> = Arc::default();
        let l = lost.clone();
        self.device.set_device_lost_callback(move |reason, msg| {
            let mut g = l.lock().unwrap_or_else(|p| p.into_inner());
            g.get_or_insert_with(|| format!("{reason:?}: {msg}"));
        });
        let scopes = [
            wgpu::ErrorFilter::OutOfMemory,
            wgpu::ErrorFilter::Validation,
            wgpu::ErrorFilter::Internal,
        ]
        .map(|filter| self.device.push_error_scope(filter));
        let out = f();
        // Scopes pop innermost first.
        let mut errors: Vec<wgpu::Error> = scopes
            .into_iter()
            .rev()
            .filter_map(|s| pollster::block_on(s.pop()))
            .collect();
        errors.reverse();
        if let Some(detail) = lost.lock().unwrap_or_else(|p| p.into_inner()).take() {
            return Err(GpuFault::DeviceLost { detail });
        }
        let Some(first) = errors
            .iter()
            .find(|e| is_out_of_memory(e))
            .or(errors.first())
        else {
            return Ok(out);
        };
        let kind = error_kind(first);
        let message = first.to_string();
        log::debug!("wgpu error ({kind}): {message}");
        Err(if is_out_of_memory(first) {
            GpuFault::OutOfMemory { detail: message }
        } else {
            GpuFault::Error { kind, message }
        })
    }

    /// Blocks until all submitted work is done.
    pub fn wait_idle(&self) {
        // An error here means the device was lost; later calls report it properly.
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }
}

/// What the GPU reported while [`GpuContext::trap`] ran its closure.
#[derive(Debug, thiserror::Error)]
pub enum GpuFault {
    #[error("the GPU ran out of memory ({detail})")]
    OutOfMemory { detail: String },
    #[error("the GPU device was lost ({detail})")]
    DeviceLost { detail: String },
    /// Any other error (a validation error is a bug in vlf); `kind` names wgpu's variant.
    #[error("{kind}: {message}")]
    Error { kind: String, message: String },
}

/// The variant name of a wgpu error (`OutOfMemory`, `Validation`, `Internal`).
fn error_kind(e: &wgpu::Error) -> String {
    format!("{e:?}")
        .split(|c: char| !c.is_alphanumeric())
        .next()
        .unwrap_or_default()
        .to_string()
}

/// Out of memory by kind, or by its message (drivers report some allocation failures as
/// internal or validation errors).
fn is_out_of_memory(e: &wgpu::Error) -> bool {
    matches!(e, wgpu::Error::OutOfMemory { .. })
        || e.to_string().to_ascii_lowercase().contains("out of memory")
}

/// Picks the best adapter: hardware before software, Vulkan/Metal/DX12 before GL.
async fn select_adapter(
    instance: &wgpu::Instance,
    backends: wgpu::Backends,
    choice: AdapterChoice,
) -> Result<wgpu::Adapter, DeviceError> {
    let mut adapters = instance.enumerate_adapters(backends).await;
    adapters.sort_by_key(|a| adapter_rank(&a.get_info()));
    for a in &adapters {
        log::debug!("adapter candidate: {}", AdapterSummary::new(&a.get_info()));
    }
    let Some(best) = adapters.into_iter().next() else {
        return Err(DeviceError::NoAdapter {
            backends: format!("{backends:?}"),
        });
    };
    let summary = AdapterSummary::new(&best.get_info());
    if choice == AdapterChoice::HardwareOnly && summary.is_software() {
        return Err(DeviceError::SoftwareOnly {
            adapter: Box::new(summary),
        });
    }
    Ok(best)
}

fn adapter_rank(info: &wgpu::AdapterInfo) -> (u8, u8) {
    let ty = match info.device_type {
        _ if is_software_adapter(info) => 4,
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    };
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    };
    (backend, ty)
}

/// Starts from [`minimum_limits`], raises the size limits to what the adapter offers, and lists
/// every limit the adapter cannot meet.
pub fn negotiate_limits(adapter: &wgpu::Limits) -> Result<wgpu::Limits, Vec<String>> {
    let min = minimum_limits();
    let mut missing = Vec::new();
    let mut check = |name: &str, have: u64, need: u64| {
        if have < need {
            missing.push(format!("{name} = {have} (need {need})"));
        }
    };
    check(
        "max_storage_buffers_per_shader_stage",
        adapter.max_storage_buffers_per_shader_stage.into(),
        min.max_storage_buffers_per_shader_stage.into(),
    );
    check(
        "max_storage_buffer_binding_size",
        adapter.max_storage_buffer_binding_size,
        min.max_storage_buffer_binding_size,
    );
    check(
        "max_buffer_size",
        adapter.max_buffer_size,
        min.max_buffer_size,
    );
    check(
        "max_compute_workgroup_size_x",
        adapter.max_compute_workgroup_size_x.into(),
        min.max_compute_workgroup_size_x.into(),
    );
    check(
        "max_compute_invocations_per_workgroup",
        adapter.max_compute_invocations_per_workgroup.into(),
        min.max_compute_invocations_per_workgroup.into(),
    );
    check(
        "max_texture_dimension_2d",
        adapter.max_texture_dimension_2d.into(),
        min.max_texture_dimension_2d.into(),
    );
    if !missing.is_empty() {
        return Err(missing);
    }
    Ok(wgpu::Limits {
        max_storage_buffer_binding_size: adapter.max_storage_buffer_binding_size,
        max_buffer_size: adapter.max_buffer_size,
        max_texture_dimension_2d: adapter.max_texture_dimension_2d,
        max_compute_workgroups_per_dimension: adapter.max_compute_workgroups_per_dimension,
        ..min
    })
}

#[cfg(test)]
mod tests {
    use super::AdapterSummary;

    fn summary(name: &str, device_type: &str, driver: &str) -> AdapterSummary {
        AdapterSummary {
            name: name.into(),
            backend: "Vulkan".into(),
            device_type: device_type.into(),
            driver: driver.into(),
        }
    }

    #[test]
    fn software_rasterisers_by_type_or_name() {
        for s in [
            summary(
                "llvmpipe (LLVM 15.0.6, 256 bits)",
                "Cpu",
                "llvmpipe Mesa 22.3.6",
            ),
            summary("llvmpipe (LLVM 15.0.6, 256 bits)", "Other", "llvmpipe"),
            summary("SwiftShader Device (Subzero)", "Other", ""),
            summary("Microsoft Basic Render Driver", "Other", ""),
            summary("Some CPU device", "Cpu", ""),
        ] {
            assert!(s.is_software(), "{s}");
        }
        for s in [
            summary("NVIDIA GeForce RTX 4090", "DiscreteGpu", "NVIDIA 550.54"),
            summary(
                "AMD Radeon Graphics (RADV RENOIR)",
                "IntegratedGpu",
                "radv Mesa",
            ),
            summary("Warpdrive X1", "DiscreteGpu", "warpdrive 1.0"),
        ] {
            assert!(!s.is_software(), "{s}");
        }
    }
}
