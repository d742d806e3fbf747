//! Part of `cargo xtask check-modules`: the code map of `docs/ARCHITECTURE.md` and the crates'
//! modules agree.
//!
//! The code map is the document's `## Code map` section. A `### ` heading whose first
//! backquoted text is a workspace member (`### \`crates/vlf-core\`: …`) opens that crate's
//! part; its entries are the list items that start with a backquoted module path
//! (`- \`bake\`: …`, `- \`bake::reference\`: …`), written from the crate root. Headings that
//! name no crate (`shaders/`, `docs/`) are not checked. The check fails when
//!
//! * a workspace member has no part,
//! * a top-level module of a crate (a `mod` of its `lib.rs`, or of its `main.rs` when it has no
//!   `lib.rs`; test modules aside) has no entry,
//! * an entry names a module that does not exist (at any depth: submodules are listed by
//!   choice, but a listed one must be there), or is listed twice.
//!
//! The module trees come from [`crate::modgraph::modules`], the same reading of `mod`
//! declarations the import-cycle check uses.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use anyhow::{Context, Result, bail};

/// The document holding the code map, relative to the workspace root.
pub const DOCUMENT: &str = "docs/ARCHITECTURE.md";
const SECTION: &str = "## Code map";

/// One crate's part of the code map: its directory and its entries (1-based line, module path).
#[derive(Debug, PartialEq)]
struct Part {
    dir: String,
    entries: Vec<(usize, Vec<String>)>,
}

/// The modules of one crate, as [`crate::modgraph::modules`] gives them.
type Modules = BTreeSet<Vec<String>>;

/// Checks the code map against the workspace at `root`; returns a one-line summary.
pub fn check(root: &Path) -> Result<String> {
    let text = std::fs::read_to_string(root.join(DOCUMENT))
        .with_context(|| format!("cannot read {DOCUMENT}"))?;
    let members = workspace_members(root)?;
    let mut crates = BTreeMap::new();
    for m in &members {
        crates.insert(
            m.clone(),
            crate::modgraph::modules(root, &Path::new(m).join("src"))?,
        );
    }
    let parts = parse(&text)?;
    let problems = problems(&parts, &crates);
    if !problems.is_empty() {
        bail!(
            "{DOCUMENT}'s code map and the modules disagree:\n    {}",
            problems.join("\n    ")
        );
    }
    let entries: usize = parts.iter().map(|p| p.entries.len()).sum();
    Ok(format!(
        "{DOCUMENT}: code map of {} crates, {entries} modules, agrees with the sources",
        crates.len()
    ))
}

/// The workspace members of `root/Cargo.toml` (`members = [ "a", "b" ]`).
fn workspace_members(root: &Path) -> Result<Vec<String>> {
    let toml =
        std::fs::read_to_string(root.join("Cargo.toml")).context("cannot read Cargo.toml")?;
    let line = toml
        .lines()
        .find(|l| l.trim_start().starts_with("members"))
        .context("Cargo.toml: no workspace members")?;
    Ok(line
        .split('"')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect())
}

/// The first backquoted text of `s`, if it starts one.
fn backquoted(s: &str) -> Option<&str> {
    let rest = s.strip_prefix('`')?;
    Some(&rest[..rest.find('`')?])
}

/// The parts of the code map in `text` (every `###` heading of the section, crate or not).
fn parse(text: &str) -> Result<Vec<Part>> {
    let mut in_section = false;
    let mut parts: Vec<Part> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with("## ") {
            in_section = line.trim_end() == SECTION;
            continue;
        }
        if !in_section {
            continue;
        }
        if let Some(h) = line.strip_prefix("### ") {
            let dir = backquoted(h).unwrap_or(h).trim_end_matches('/');
            parts.push(Part {
                dir: dir.to_string(),
                entries: Vec::new(),
            });
        } else if let Some(item) = line.trim_start().strip_prefix("- ")
            && let Some(path) = backquoted(item)
            && let Some(part) = parts.last_mut()
        {
            let is_path = !path.is_empty()
                && path
                    .split("::")
                    .all(|s| !s.is_empty() && s.chars().all(|c| c == '_' || c.is_alphanumeric()));
            if is_path {
                let segs = path.split("::").map(str::to_string).collect();
                part.entries.push((i + 1, segs));
            }
        }
    }
    if parts.is_empty() {
        bail!("{DOCUMENT}: no `{SECTION}` section with `###` parts");
    }
    Ok(parts)
}

/// Every disagreement between the code map's `parts` and the modules of each crate in
/// `crates` (keyed by directory), one message each.
fn problems(parts: &[Part], crates: &BTreeMap<String, Modules>) -> Vec<String> {
    let mut out = Vec::new();
    for (dir, modules) in crates {
        let Some(part) = parts.iter().find(|p| &p.dir == dir) else {
            out.push(format!("crate {dir} has no `### `{dir}`` part"));
            continue;
        };
        let mut listed = BTreeSet::new();
        for (line, path) in &part.entries {
            let name = path.join("::");
            if !modules.contains(path) {
                out.push(format!(
                    "{DOCUMENT}:{line}: {dir} has no module `{name}` (stale entry)"
                ));
            }
            if !listed.insert(path.clone()) {
                out.push(format!("{DOCUMENT}:{line}: `{name}` of {dir} listed twice"));
            }
        }
        for m in modules.iter().filter(|m| m.len() == 1) {
            if !listed.contains(m) {
                out.push(format!(
                    "{dir}: module `{}` is missing from the code map",
                    m[0]
                ));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAP: &str = "# Architecture\n\n## Code map\n\n### `crates/a`: the first crate\n\n\
        - `scene`: scenes.\n- `scene::import`: import.\n- `bake`: bakes.\n\n\
        ### `shaders/`\n\n- `shaders/common/`: not a crate.\n\n## Invariants\n\n- `other`: no.\n";

    fn crates(modules: &[&[&str]]) -> BTreeMap<String, Modules> {
        let set = modules
            .iter()
            .map(|m| m.iter().map(|s| s.to_string()).collect())
            .chain([Vec::new()])
            .collect();
        BTreeMap::from([("crates/a".to_string(), set)])
    }

    #[test]
    fn the_map_is_read_from_its_section_only() {
        let parts = parse(MAP).unwrap();
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0].dir, "crates/a");
        let paths: Vec<String> = parts[0].entries.iter().map(|e| e.1.join("::")).collect();
        assert_eq!(paths, ["scene", "scene::import", "bake"]);
        assert_eq!(parts[0].entries[0].0, 7);
        assert_eq!(parts[1].dir, "shaders");
        assert!(parts[1].entries.is_empty());
        assert!(parse("# No map\n\n- `a`: b\n").is_err());
    }

    #[test]
    fn an_agreeing_map_passes() {
        let parts = parse(MAP).unwrap();
        let c = crates(&[
            &["scene"],
            &["scene", "import"],
            &["scene", "faces"],
            &["bake"],
        ]);
        assert_eq!(problems(&parts, &c), Vec::<String>::new());
    }

    #[test]
    fn a_missing_entry_fails() {
        let parts = parse(MAP).unwrap();
        let c = crates(&[&["scene"], &["scene", "import"], &["bake"], &["gather"]]);
        assert_eq!(
            problems(&parts, &c),
            ["crates/a: module `gather` is missing from the code map"]
        );
    }

    #[test]
    fn a_stale_entry_fails() {
        let parts = parse(MAP).unwrap();
        // `scene::import` was renamed: the listed submodule is stale.
        let c = crates(&[&["scene"], &["scene", "gltf"], &["bake"]]);
        assert_eq!(
            problems(&parts, &c),
            [format!(
                "{DOCUMENT}:8: crates/a has no module `scene::import` (stale entry)"
            )]
        );
        // A top-level module removed from the crate but still listed.
        let c = crates(&[&["scene"], &["scene", "import"]]);
        assert_eq!(
            problems(&parts, &c),
            [format!(
                "{DOCUMENT}:9: crates/a has no module `bake` (stale entry)"
            )]
        );
    }

    #[test]
    fn a_crate_without_a_part_or_an_entry_twice_fails() {
        let twice = MAP.replace("- `bake`: bakes.", "- `bake`: bakes.\n- `bake`: again.");
        let parts = parse(&twice).unwrap();
        let mut c = crates(&[&["scene"], &["scene", "import"], &["bake"]]);
        c.insert("crates/b".into(), BTreeSet::from([Vec::new()]));
        assert_eq!(
            problems(&parts, &c),
            [
                format!("{DOCUMENT}:10: `bake` of crates/a listed twice"),
                "crate crates/b has no `### `crates/b`` part".to_string(),
            ]
        );
    }

    /// The repository's own map agrees with its crates (what `check-modules` runs).
    #[test]
    fn the_repository_map_agrees() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
        check(root).unwrap();
    }
}
