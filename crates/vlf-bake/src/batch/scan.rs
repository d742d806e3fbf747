//! Which scenes a batch bakes: discovery under DIR, the up-to-date check of an existing
//! output, and the removal of stale temporary files of killed runs.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use vlf_core::lightfield::BakeParams;

use super::BatchError;
use crate::cli::Shard;

/// Scene files under `dir`, relative to it, sorted; symbolic links are not followed.
pub fn discover(dir: &Path) -> Result<Vec<PathBuf>, BatchError> {
    let meta = fs::metadata(dir).map_err(|e| {
        BatchError::Input(format!(
            "cannot read scene directory {}: {e}",
            dir.display()
        ))
    })?;
    if !meta.is_dir() {
        return Err(BatchError::Input(format!(
            "{} is not a directory (use `vlf-bake bake` for one scene)",
            dir.display()
        )));
    }
    let mut out = Vec::new();
    walk(dir, Path::new(""), &mut out)?;
    out.sort();
    if out.is_empty() {
        return Err(BatchError::Input(format!(
            "no .gltf or .glb scene found under {}",
            dir.display()
        )));
    }
    Ok(out)
}

fn walk(root: &Path, rel: &Path, out: &mut Vec<PathBuf>) -> Result<(), BatchError> {
    let here = root.join(rel);
    let entries = fs::read_dir(&here)
        .map_err(|e| BatchError::Input(format!("cannot read directory {}: {e}", here.display())))?;
    let mut entries: Vec<_> = entries
        .filter_map(|e| match e {
            Ok(e) => Some(e),
            Err(err) => {
                log::warn!("skipping an entry of {}: {err}", here.display());
                None
            }
        })
        .collect();
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let r = rel.join(e.file_name());
        let Ok(ft) = e.file_type() else { continue };
        if ft.is_symlink() {
            log::debug!("not following symbolic link {}", root.join(&r).display());
        } else if ft.is_dir() {
            walk(root, &r, out)?;
        } else if ft.is_file() && is_scene(&r) {
            out.push(r);
        }
    }
    Ok(())
}

fn is_scene(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// The scenes of `shard` among `scenes` (as [`discover`] lists them, sorted). The distinct
/// outputs (a scene's path without its extension: `a.gltf` and `a.glb` both bake to `a.vlf`)
/// are numbered in sorted order and shard I of N takes those numbered I, I + N, I + 2N, …
/// (1-based), with every scene that bakes to them: the N shards partition the list, their
/// numbers of outputs differ by at most one, two scenes with the same output land in the same
/// shard (whose batch reports the clash), and the split depends only on the list (the same on
/// every machine that sees the same folder). No shard: every scene.
pub fn shard(scenes: Vec<PathBuf>, shard: Option<Shard>) -> Vec<PathBuf> {
    let Some(Shard { index, count }) = shard else {
        return scenes;
    };
    let mut outputs: Vec<PathBuf> = scenes.iter().map(|p| p.with_extension("")).collect();
    outputs.sort();
    outputs.dedup();
    scenes
        .into_iter()
        .filter(|p| {
            let k = outputs
                .binary_search(&p.with_extension(""))
                .expect("every scene's output is listed");
            k % count as usize == (index - 1) as usize
        })
        .collect()
}

/// `Ok(header)` when `output` can be skipped, `Err(reason to bake)` otherwise (`None` when
/// there is no output yet).
pub(super) fn up_to_date(
    input: &Path,
    output: &Path,
    exe_time: SystemTime,
    want: &BakeParams,
) -> Result<vlf_core::format::FileInfo, Option<String>> {
    let Ok(out_meta) = fs::metadata(output) else {
        return Err(None);
    };
    let out_time = out_meta.modified().map_err(|_| None)?;
    let in_time = fs::metadata(input)
        .and_then(|m| m.modified())
        .unwrap_or(SystemTime::now());
    if out_time <= in_time {
        return Err(Some("output older than the scene".into()));
    }
    if out_time <= exe_time {
        return Err(Some("output older than vlf-bake".into()));
    }
    let info = vlf_core::format::describe(output)
        .map_err(|e| Some(format!("existing output unreadable ({e})")))?;
    if !same_params(&info.params, want) {
        return Err(Some("existing output baked with other parameters".into()));
    }
    Ok(info)
}

/// The file's parameters are the requested ones, or those with a resolution (and tile) the
/// memory budget lowered.
pub(super) fn same_params(file: &BakeParams, want: &BakeParams) -> bool {
    let rest_equal = BakeParams {
        resolution: want.resolution,
        tile: want.tile,
        ..file.clone()
    } == *want;
    rest_equal
        && ((file.resolution == want.resolution && file.tile == want.tile)
            || file.resolution < want.resolution)
}

/// Removes `.NAME.tmp.PID.N` files next to `output`: those of process `only_pid`, or (with
/// `None`) those whose process no longer exists (never this process's own). Returns how many.
pub fn remove_stale_temps(output: &Path, only_pid: Option<u32>) -> usize {
    let (Some(name), Some(dir)) = (output.file_name(), output.parent()) else {
        return 0;
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let prefix = format!(".{}.tmp.", name.to_string_lossy());
    let Ok(entries) = fs::read_dir(dir) else {
        return 0;
    };
    let own = std::process::id();
    let mut removed = 0;
    for e in entries.flatten() {
        let fname = e.file_name();
        let fname = fname.to_string_lossy();
        let Some(rest) = fname.strip_prefix(&prefix) else {
            continue;
        };
        let mut parts = rest.splitn(2, '.');
        let (Some(Ok(pid)), Some(Ok(_))) = (
            parts.next().map(str::parse::<u32>),
            parts.next().map(str::parse::<u64>),
        ) else {
            continue;
        };
        let remove = match only_pid {
            Some(p) => pid == p,
            None => pid != own && !process_exists(pid),
        };
        if remove && e.file_type().is_ok_and(|t| t.is_file()) {
            match fs::remove_file(e.path()) {
                Ok(()) => removed += 1,
                Err(err) => log::warn!("cannot remove {}: {err}", e.path().display()),
            }
        }
    }
    removed
}

/// Whether process `pid` exists (true when that cannot be known: no /proc).
fn process_exists(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    Path::new("/proc").join(pid.to_string()).exists()
}
