//! Tests of batch discovery, stale temporary files, the up-to-date rule and reports.

use super::scan::same_params;
use super::*;
use std::fs;

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

/// `--shard I/N` over a folder: the N shards are disjoint, their union is every scene
/// `discover` lists, their sizes differ by at most one output, the split is the same when
/// asked again (it depends only on the sorted list), and two scenes with the same output
/// (`x.gltf`, `x.glb`) land in the same shard, where the batch reports the clash.
#[test]
fn shards_partition_the_folder() {
    let d = tmpdir("shards");
    for k in 0..11 {
        let p = d.join(["a", "b/c", "."][k % 3]).join(format!("s{k}.gltf"));
        fs::create_dir_all(p.parent().unwrap()).unwrap();
        fs::write(&p, b"{}").unwrap();
    }
    fs::write(d.join("a/s0.glb"), b"glTF").unwrap();
    let all = discover(&d).unwrap();
    assert_eq!(all.len(), 12);
    assert_eq!(shard(all.clone(), None), all);
    for count in 1..=13u32 {
        let mut union = Vec::new();
        let mut sizes = Vec::new();
        for index in 1..=count {
            let sh = Some(Shard { index, count });
            let part = shard(discover(&d).unwrap(), sh);
            assert_eq!(part, shard(all.clone(), sh), "stable");
            let s0 = part
                .iter()
                .filter(|p| p.to_string_lossy().starts_with("a/s0."))
                .count();
            assert!(
                s0 == 0 || s0 == 2,
                "{count} shards split a/s0.gltf from a/s0.glb"
            );
            sizes.push(part.len() - s0 / 2);
            union.extend(part);
        }
        union.sort();
        let before = union.len();
        union.dedup();
        assert_eq!(union.len(), before, "{count} shards overlap");
        assert_eq!(union, all, "{count} shards miss scenes");
        let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
        assert!(hi - lo <= 1, "{count} shards: outputs {sizes:?}");
    }
    let _ = fs::remove_dir_all(&d);
}
