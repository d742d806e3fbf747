//! What one bake may use: `--max-memory`, the system RAM, the adapter's binding limit.

use serde::Serialize;

use crate::Compute;

/// Default share of the system RAM (MemTotal) one batch may use: 3/4.
const RAM_SHARE: (u64, u64) = (3, 4);

/// Parses `--max-memory`: a number of bytes with an optional binary suffix `K`, `M`, `G`, `T`
/// (also `KB`/`KiB`…, all powers of 1024), e.g. `2G`, `512M`, `1.5G`, `1048576`.
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let unit = unit.trim().to_ascii_uppercase();
    let shift = match unit.trim_end_matches('B').trim_end_matches('I') {
        "" => 0,
        "K" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => return Err(format!("unknown size unit in `{s}` (use K, M, G or T)")),
    };
    if (unit.ends_with("IB") && shift == 0) || unit == "I" {
        return Err(format!("unknown size unit in `{s}` (use K, M, G or T)"));
    }
    let value: f64 = num
        .parse()
        .map_err(|_| format!("expected a size such as 2G or 512M, got `{s}`"))?;
    let bytes = value * (1u64 << shift) as f64;
    if !bytes.is_finite() || bytes < 1.0 || bytes > u64::MAX as f64 / 2.0 {
        return Err(format!("size `{s}` is out of range (at least 1 byte)"));
    }
    Ok(bytes as u64)
}

/// `1.5 GiB`-style text for byte counts.
pub fn human(bytes: u64) -> String {
    vlf_core::format::human_bytes(bytes, 1)
}

/// One limit of a [`Budget`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Limit {
    pub bytes: u64,
    /// Where it comes from (`--max-memory 2.0 GiB`, `3/4 of MemTotal …`, an adapter limit).
    pub source: String,
}

/// What one bake may use.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Budget {
    /// Host RAM: everything on the CPU path; host-side copies on the GPU path (plus the GPU
    /// buffers on a software adapter, whose "GPU memory" is system RAM).
    pub host: Option<Limit>,
    /// All GPU buffers together (GPU path with `--max-memory` on a hardware adapter; wgpu does
    /// not report the size of device memory, so there is no default).
    pub device: Option<Limit>,
    /// One GPU buffer: the adapter's `max_storage_buffer_binding_size` (≤ `max_buffer_size`).
    pub buffer: Option<Limit>,
}

impl Budget {
    /// The budget of one of `jobs` concurrent bakes on `compute`, `--max-memory` = `max_memory`.
    pub fn new(max_memory: Option<u64>, compute: &Compute, jobs: u32) -> Budget {
        let jobs = u64::from(jobs.max(1));
        let ram = system_ram().map(|total| {
            let share = total / RAM_SHARE.1 * RAM_SHARE.0;
            Limit {
                bytes: share / jobs,
                source: if jobs > 1 {
                    format!(
                        "3/4 of the system RAM ({} MemTotal) shared by {jobs} jobs",
                        human(total)
                    )
                } else {
                    format!("3/4 of the system RAM ({} MemTotal)", human(total))
                },
            }
        });
        let given = max_memory.map(|b| Limit {
            bytes: b,
            source: format!("--max-memory {}", human(b)),
        });
        match compute {
            Compute::Cpu(_) => Budget {
                host: given.or(ram),
                device: None,
                buffer: None,
            },
            Compute::Gpu(ctx, _) => {
                let limits = ctx.device.limits();
                let buffer = Some(Limit {
                    bytes: limits
                        .max_storage_buffer_binding_size
                        .min(limits.max_buffer_size),
                    source: format!("max_storage_buffer_binding_size of {}", ctx.summary.name),
                });
                if ctx.summary.is_software() {
                    // lavapipe: GPU buffers are system RAM.
                    Budget {
                        host: given.or(ram),
                        device: None,
                        buffer,
                    }
                } else {
                    Budget {
                        host: ram,
                        device: given,
                        buffer,
                    }
                }
            }
        }
    }
}

/// MemTotal from /proc/meminfo, in bytes.
pub fn system_ram() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_meminfo(&text)
}

pub(super) fn parse_meminfo(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let mut parts = line["MemTotal:".len()..].split_whitespace();
    let value: u64 = parts.next()?.parse().ok()?;
    let scale = match parts.next() {
        Some("kB") | Some("KB") | Some("kiB") => 1024,
        None => 1,
        Some(_) => return None,
    };
    Some(value * scale)
}
