//! Validation of glTF files with Khronos glTF-Validator (the npm package
//! `gltf-validator`, pinned in `xtask/validator/package-lock.json` and
//! installed on demand with `npm ci`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use anyhow::{Context, Result, bail};
use serde_json::Value;

const VALIDATOR_DIR: &str = "xtask/validator";
const RUNNER: &str = "xtask/validator/validate.mjs";
const INSTALL_HINT: &str = "install Node.js and npm: `apt-get install -y nodejs npm`";

/// Issue severities as numbered in the validator's report.
const SEVERITIES: [&str; 4] = ["error", "warning", "info", "hint"];

/// Runs gltf-validator on each file; fails if any file has an error or a
/// warning (infos and hints are printed but allowed).
pub fn validate_gltf(repo_root: &Path, files: &[PathBuf]) -> Result<()> {
    if files.is_empty() {
        return Ok(());
    }
    ensure_installed(repo_root)?;

    let mut absolute = Vec::with_capacity(files.len());
    for f in files {
        absolute
            .push(std::path::absolute(f).with_context(|| format!("resolving {}", f.display()))?);
    }
    let output = run(
        Command::new("node")
            .arg(RUNNER)
            .args(&absolute)
            .current_dir(repo_root),
        "node",
    )?;
    if !output.status.success() {
        bail!(
            "`node {RUNNER}` failed ({}):\n{}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        );
    }

    let stdout = String::from_utf8(output.stdout).context("validator output is not UTF-8")?;
    let mut failures = Vec::new();
    let mut seen = 0;
    for line in stdout.lines().filter(|l| !l.trim().is_empty()) {
        let entry: Value = serde_json::from_str(line)
            .with_context(|| format!("parsing validator output line: {line}"))?;
        seen += 1;
        if let Some(failure) = judge(&entry)? {
            failures.push(failure);
        }
    }
    if seen != files.len() {
        bail!(
            "the validator reported on {seen} of {} files:\n{stdout}",
            files.len()
        );
    }
    if !failures.is_empty() {
        bail!("glTF validation failed:\n{}", failures.join("\n"));
    }
    Ok(())
}

/// Prints a summary of one file's report; returns a description of its
/// errors and warnings, if it has any.
fn judge(entry: &Value) -> Result<Option<String>> {
    let file = entry["file"].as_str().unwrap_or("<unknown file>");
    if let Some(error) = entry.get("error") {
        return Ok(Some(format!(
            "{file}: the validator could not read it: {error}"
        )));
    }
    let report = &entry["report"];
    let issues = &report["issues"];
    let count = |key: &str| -> Result<u64> {
        issues[key]
            .as_u64()
            .with_context(|| format!("{file}: report has no issues.{key}"))
    };
    let (errors, warnings, infos, hints) = (
        count("numErrors")?,
        count("numWarnings")?,
        count("numInfos")?,
        count("numHints")?,
    );
    println!(
        "{file}: gltf-validator {}: {errors} errors, {warnings} warnings, {infos} infos, {hints} hints",
        report["validatorVersion"].as_str().unwrap_or("?"),
    );

    let messages = issues["messages"]
        .as_array()
        .map(Vec::as_slice)
        .unwrap_or(&[]);
    let mut bad = Vec::new();
    for m in messages {
        let severity = m["severity"].as_u64().unwrap_or(0);
        let text = format!(
            "  {} {} at {}: {}",
            SEVERITIES
                .get(severity as usize)
                .copied()
                .unwrap_or("issue"),
            m["code"].as_str().unwrap_or("?"),
            location(m),
            m["message"].as_str().unwrap_or(""),
        );
        if severity <= 1 {
            bad.push(text);
        } else {
            println!("{text}");
        }
    }
    if errors == 0 && warnings == 0 {
        return Ok(None);
    }
    Ok(Some(format!(
        "{file}: {errors} errors, {warnings} warnings\n{}",
        bad.join("\n")
    )))
}

/// Runs `npm ci` in `xtask/validator` unless the pinned validator is already
/// installed there.
fn ensure_installed(repo_root: &Path) -> Result<()> {
    let dir = repo_root.join(VALIDATOR_DIR);
    let (pinned, installed) = npm_pinned(&dir, "gltf-validator")?;
    if installed {
        return Ok(());
    }

    println!("installing gltf-validator {pinned} (npm ci --prefix {VALIDATOR_DIR})");
    let output = run(
        Command::new("npm")
            .args(["ci", "--prefix", VALIDATOR_DIR, "--no-audit", "--no-fund"])
            .current_dir(repo_root),
        "npm",
    )?;
    if !output.status.success() {
        bail!(
            "`npm ci --prefix {VALIDATOR_DIR}` failed ({}):\n{}{}",
            output.status,
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
    }
    Ok(())
}

/// The version of `package` that `dir/package-lock.json` pins, and whether `dir/node_modules`
/// holds that version (then `npm ci` there has nothing to do).
pub(crate) fn npm_pinned(dir: &Path, package: &str) -> Result<(String, bool)> {
    let lock_path = dir.join("package-lock.json");
    let lock: Value = serde_json::from_slice(
        &std::fs::read(&lock_path).with_context(|| format!("reading {}", lock_path.display()))?,
    )
    .with_context(|| format!("parsing {}", lock_path.display()))?;
    let pinned = lock["packages"][format!("node_modules/{package}")]["version"]
        .as_str()
        .with_context(|| format!("{} does not pin {package}", lock_path.display()))?;
    let installed = std::fs::read(dir.join(format!("node_modules/{package}/package.json")))
        .ok()
        .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
        .and_then(|p| p["version"].as_str().map(str::to_owned));
    let current = installed.as_deref() == Some(pinned);
    Ok((pinned.to_owned(), current))
}

/// Where an issue is: its JSON pointer (glTF) or byte offset (GLB).
fn location(message: &Value) -> String {
    match (message["pointer"].as_str(), message["offset"].as_u64()) {
        (Some(pointer), _) => pointer.to_owned(),
        (None, Some(offset)) => format!("byte {offset}"),
        (None, None) => "(no pointer)".to_owned(),
    }
}

fn run(cmd: &mut Command, program: &str) -> Result<Output> {
    match cmd.output() {
        Ok(output) => Ok(output),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("`{program}` was not found: {INSTALL_HINT}")
        }
        Err(e) => Err(e).with_context(|| format!("running `{program}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::npm_pinned;

    /// The pinned version is read from the lock file; installed only when node_modules holds
    /// that same version; a lock file without the package is an error naming the file.
    #[test]
    fn npm_pinned_compares_the_lock_with_node_modules() {
        let dir = std::env::temp_dir().join(format!("vlf-xtask-npm-{}", std::process::id()));
        let pkg = dir.join("node_modules/left-pad");
        std::fs::create_dir_all(&pkg).unwrap();
        let lock = r#"{"packages": {"node_modules/left-pad": {"version": "1.3.0"}}}"#;
        std::fs::write(dir.join("package-lock.json"), lock).unwrap();
        assert_eq!(
            npm_pinned(&dir, "left-pad").unwrap(),
            ("1.3.0".into(), false)
        );
        std::fs::write(pkg.join("package.json"), r#"{"version": "1.2.0"}"#).unwrap();
        assert_eq!(
            npm_pinned(&dir, "left-pad").unwrap(),
            ("1.3.0".into(), false)
        );
        std::fs::write(pkg.join("package.json"), r#"{"version": "1.3.0"}"#).unwrap();
        assert_eq!(
            npm_pinned(&dir, "left-pad").unwrap(),
            ("1.3.0".into(), true)
        );
        let e = npm_pinned(&dir, "three").unwrap_err().to_string();
        assert!(e.contains("package-lock.json does not pin three"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
