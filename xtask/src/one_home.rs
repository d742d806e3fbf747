//! Part of `cargo xtask check-modules`: the wgpu boilerplate of vlf-gpu has one home,
//! `crates/vlf-gpu/src/wgpu_util.rs`. A bind-group layout entry written out, a compute
//! pipeline or a pipeline layout created by hand, or a second `dispatch_2d` anywhere else in
//! the crate fails the check, naming the file and line.

use std::path::Path;

use anyhow::{Context, Result, bail};

/// What only `wgpu_util.rs` may write.
const ONLY_IN_UTIL: [&str; 4] = [
    "wgpu::BindGroupLayoutEntry {",
    "create_compute_pipeline(",
    "create_pipeline_layout(",
    "fn dispatch_2d(",
];

/// The crate's sources (relative to the workspace root) and the one file allowed.
const CRATE_SRC: &str = "crates/vlf-gpu/src";
const HOME: &str = "wgpu_util.rs";

/// Fails listing every occurrence of [`ONLY_IN_UTIL`] outside [`HOME`]; returns how many files
/// were read.
pub fn check(root: &Path) -> Result<usize> {
    let mut files = Vec::new();
    collect(&root.join(CRATE_SRC), &mut files)?;
    let mut found = Vec::new();
    for f in &files {
        if f.file_name().is_some_and(|n| n == HOME) && f.parent() == Some(&root.join(CRATE_SRC)) {
            continue;
        }
        let text =
            std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
        found.extend(offences(&text).into_iter().map(|(line, what)| {
            let rel = f.strip_prefix(root).unwrap_or(f);
            format!("{}:{line}: {what}", rel.display())
        }));
    }
    if !found.is_empty() {
        bail!(
            "wgpu boilerplate outside {CRATE_SRC}/{HOME} (use its helpers):\n    {}",
            found.join("\n    ")
        );
    }
    Ok(files.len())
}

/// (1-based line, pattern) of every forbidden pattern in `text`, comments excluded.
fn offences(text: &str) -> Vec<(usize, &'static str)> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        for p in ONLY_IN_UTIL {
            if code.contains(p) {
                out.push((i + 1, p));
            }
        }
    }
    out
}

fn collect(dir: &Path, out: &mut Vec<std::path::PathBuf>) -> Result<()> {
    for e in std::fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let p = e?.path();
        if p.is_dir() {
            collect(&p, out)?;
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
    out.sort();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::offences;

    #[test]
    fn a_second_definition_is_found_and_comments_are_not() {
        let text = "fn a() {}\n// device.create_compute_pipeline(&d)\nlet p = device.create_compute_pipeline(&d);\npub fn dispatch_2d(n: u32) {}\n";
        assert_eq!(
            offences(text),
            vec![(3, "create_compute_pipeline("), (4, "fn dispatch_2d(")]
        );
    }
}
