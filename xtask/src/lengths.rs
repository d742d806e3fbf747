//! `cargo xtask check-lengths`: no non-test Rust source file above [`MAX_LINES`] lines.
//!
//! Counted: every `.rs` file under `crates/` and `xtask/`, whole (an inline `mod tests { … }`
//! counts: move it to a sibling `tests.rs`). Not counted: integration tests, benches and test
//! modules in their own files (a path component `tests` or `benches`, or a file named
//! `tests.rs`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// The house limit on a source file's length.
pub const MAX_LINES: usize = 800;

/// Fails naming every source file over [`MAX_LINES`] lines (longest first).
pub fn check(root: &Path) -> Result<usize> {
    let mut files = Vec::new();
    for dir in ["crates", "xtask"] {
        rust_files(&root.join(dir), &mut files)?;
    }
    let mut long = Vec::new();
    let mut checked = 0;
    for f in files {
        let rel = f.strip_prefix(root).unwrap_or(&f);
        let is_test = rel
            .components()
            .any(|c| matches!(c.as_os_str().to_str(), Some("tests" | "benches")))
            || rel.file_name().is_some_and(|n| n == "tests.rs");
        if is_test {
            continue;
        }
        checked += 1;
        let text =
            std::fs::read_to_string(&f).with_context(|| format!("cannot read {}", f.display()))?;
        let lines = text.lines().count();
        if lines > MAX_LINES {
            long.push((lines, rel.to_path_buf()));
        }
    }
    if !long.is_empty() {
        long.sort_by(|a, b| b.cmp(a));
        let list: Vec<String> = long
            .iter()
            .map(|(n, p)| format!("  {n:5} {}", p.display()))
            .collect();
        bail!(
            "{} source files over {MAX_LINES} lines (split them where a reader would look, or \
             move inline tests to a sibling tests.rs):\n{}",
            long.len(),
            list.join("\n")
        );
    }
    Ok(checked)
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))?;
    for e in entries {
        let e = e?;
        let p = e.path();
        let name = e.file_name();
        let name = name.to_string_lossy();
        if e.file_type()?.is_dir() {
            if !name.starts_with('.') && name != "target" && name != "node_modules" {
                rust_files(&p, out)?;
            }
        } else if name.ends_with(".rs") {
            out.push(p);
        }
    }
    Ok(())
}
