//! Tests of batch discovery, stale temporary files, the up-to-date rule and reports.

use super::scan::same_params;
use super::*;

fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vlf-batch-{tag}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn discovery_is_recursive_sorted_and_skips_links() {
    let d = tmpdir("discover");
    for f in [
        "b.glb",
        "a/z.gltf",
        "a/b/c.GLTF",
        "a.gltf",
        "x.txt",
        "a/b/d.bin",
    ] {
        let p = d.join(f);
        fs::create_dir_all(p.parent().unwrap()).unwrap();
        fs::write(&p, b"{}").unwrap();
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(d.join("a"), d.join("link-dir")).unwrap();
        std::os::unix::fs::symlink(d.join("b.glb"), d.join("link.glb")).unwrap();
    }
    let found = discover(&d).unwrap();
    let found: Vec<String> = found.iter().map(|p| p.display().to_string()).collect();
    assert_eq!(found, ["a/b/c.GLTF", "a/z.gltf", "a.gltf", "b.glb"]);
    assert!(matches!(
        discover(&d.join("x.txt")),
        Err(BatchError::Input(_))
    ));
    assert!(matches!(
        discover(&d.join("missing")),
        Err(BatchError::Input(_))
    ));
    fs::remove_dir_all(&d).unwrap();
}

#[test]
fn stale_temps_of_dead_processes_are_removed() {
    let d = tmpdir("temps");
    let out = d.join("s.vlf");
    let own = std::process::id();
    // pid 0 never names a user process (no /proc/0).
    for f in [
        ".s.vlf.tmp.0.3".to_string(),
        format!(".s.vlf.tmp.{own}.0"),
        ".s.vlf.tmp.x.1".into(),
        ".t.vlf.tmp.0.1".into(),
        "s.vlf".into(),
    ] {
        fs::write(d.join(f), b"x").unwrap();
    }
    assert_eq!(remove_stale_temps(&out, None), 1);
    assert!(!d.join(".s.vlf.tmp.0.3").exists());
    assert!(d.join(format!(".s.vlf.tmp.{own}.0")).exists());
    assert_eq!(remove_stale_temps(&out, Some(own)), 1);
    assert!(d.join(".s.vlf.tmp.x.1").exists() && d.join(".t.vlf.tmp.0.1").exists());
    assert!(d.join("s.vlf").exists());
    fs::remove_dir_all(&d).unwrap();
}

#[test]
fn lowered_resolution_counts_as_the_same_parameters() {
    let want = BakeParams::paper();
    assert!(same_params(&want, &want));
    let lowered = crate::memory::halve(&want).unwrap();
    assert!(same_params(&lowered, &want));
    assert!(!same_params(&want, &lowered));
    let other = BakeParams {
        directions: 126,
        ..want.clone()
    };
    assert!(!same_params(&other, &want));
}

#[test]
fn reports_are_written_atomically() {
    let d = tmpdir("report");
    let p = d.join("r.json");
    write_json_atomic(&p, &serde_json::json!({"a": 1})).unwrap();
    write_json_atomic(&p, &serde_json::json!({"a": 2})).unwrap();
    let v: serde_json::Value = serde_json::from_slice(&fs::read(&p).unwrap()).unwrap();
    assert_eq!(v["a"], 2);
    assert_eq!(
        fs::read_dir(&d).unwrap().count(),
        1,
        "no temporary file left"
    );
    fs::remove_dir_all(&d).unwrap();
}
