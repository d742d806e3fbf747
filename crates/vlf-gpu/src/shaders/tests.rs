use std::collections::BTreeMap;
use std::path::Path;

use super::*;

/// Every `.wgsl` file under `dir`, as `/`-separated paths relative to it, sorted.
fn wgsl_files(dir: &Path) -> Vec<String> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
        let entries =
            std::fs::read_dir(dir).unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()));
        for entry in entries {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, out);
            } else if path.extension().is_some_and(|x| x == "wgsl") {
                let rel = path.strip_prefix(root).unwrap();
                let parts: Vec<_> = rel.iter().map(|p| p.to_string_lossy()).collect();
                out.push(parts.join("/"));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

#[test]
fn registry_matches_folder() {
    let on_disk = wgsl_files(&source_dir());
    let mut registered: Vec<String> = ALL.iter().map(|s| s.file.to_owned()).collect();
    registered.sort();
    assert!(registered.iter().any(|f| f.starts_with(IMPORT_DIR)));
    assert_eq!(on_disk, registered, "shaders/ and shaders::ALL disagree");
}

#[test]
fn every_registered_shader_resolves_and_validates() {
    let mut errors = Vec::new();
    for shader in ALL {
        if let Err(e) = shader.validate() {
            errors.push(e.to_string());
        }
    }
    assert!(errors.is_empty(), "invalid shaders:\n{}", errors.join("\n"));
    // The resolved source is what pipelines compile; it no longer holds an import.
    for shader in ALL {
        let r = shader.resolved().unwrap();
        assert!(!r.source.contains("#import"), "{}", shader.file);
        assert_eq!(r.files[0], shader.file);
    }
    assert_eq!(
        RAYTRACE_PATH.resolved().unwrap().files,
        [
            "raytrace_path.wgsl",
            "common/rt_scene.wgsl",
            "common/bvh.wgsl",
            "common/rays.wgsl",
            "common/alpha_mask.wgsl",
            "common/texture.wgsl",
            "common/random.wgsl",
            "common/hash.wgsl",
            "common/sampling.wgsl",
            "common/pane_trace.wgsl",
            "common/pane.wgsl",
        ]
    );
}

/// A lookup over a fixed table of (name, source).
fn table<'a>(files: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<(&'a str, &'a str)> {
    move |name| files.iter().find(|(n, _)| *n == name).copied()
}

#[test]
fn imports_are_transitive_and_each_file_is_included_once() {
    let files = [
        (
            "common/a.wgsl",
            "#import \"common/b.wgsl\"\nconst A: u32 = B;\n",
        ),
        ("common/b.wgsl", "const B: u32 = 2u;\n"),
        (
            "common/c.wgsl",
            "#import \"common/b.wgsl\"\nconst C: u32 = B + 1u;\n",
        ),
    ];
    let root = "#import \"common/a.wgsl\"\n  #import \"common/c.wgsl\"  \n#import \"common/b.wgsl\"\nconst R: u32 = A + C;\n";
    let r = resolve("root.wgsl", root, &table(&files)).unwrap();
    assert_eq!(
        r.source,
        "const B: u32 = 2u;\nconst A: u32 = B;\nconst C: u32 = B + 1u;\nconst R: u32 = A + C;\n"
    );
    assert_eq!(
        r.files,
        [
            "root.wgsl",
            "common/a.wgsl",
            "common/b.wgsl",
            "common/c.wgsl"
        ]
    );
    assert_eq!(r.origin(1), Some(("common/b.wgsl", 1)));
    assert_eq!(r.origin(2), Some(("common/a.wgsl", 2)));
    assert_eq!(r.origin(3), Some(("common/c.wgsl", 2)));
    assert_eq!(r.origin(4), Some(("root.wgsl", 4)));
    assert_eq!(r.origin(5), None);
    // Commented-out imports are ordinary lines.
    let r = resolve(
        "root.wgsl",
        "// #import \"common/x.wgsl\"\n",
        &table(&files),
    )
    .unwrap();
    assert_eq!(r.files, ["root.wgsl"]);
}

#[test]
fn import_cycles_are_errors_naming_the_files() {
    let files = [
        ("common/a.wgsl", "#import \"common/b.wgsl\"\n"),
        (
            "common/b.wgsl",
            "const B: u32 = 2u;\n#import \"common/a.wgsl\"\n",
        ),
    ];
    let e = resolve("root.wgsl", "#import \"common/a.wgsl\"\n", &table(&files)).unwrap_err();
    assert_eq!(
        e,
        ShaderError::ImportCycle {
            chain: vec![
                "common/a.wgsl".into(),
                "common/b.wgsl".into(),
                "common/a.wgsl".into()
            ],
            file: "root.wgsl".into(),
        }
    );
    assert_eq!(
        e.to_string(),
        "#import cycle common/a.wgsl -> common/b.wgsl -> common/a.wgsl: root.wgsl"
    );
    let selfish = [("common/s.wgsl", "#import \"common/s.wgsl\"\n")];
    let e = resolve("common/s.wgsl", selfish[0].1, &table(&selfish)).unwrap_err();
    assert!(matches!(e, ShaderError::ImportCycle { ref chain, .. } if chain.len() == 2));
}

#[test]
fn unknown_and_malformed_imports_are_errors_naming_the_file_and_line() {
    let files = [("common/a.wgsl", "\n#import \"common/nope.wgsl\"\n")];
    let e = resolve("root.wgsl", "#import \"common/a.wgsl\"\n", &table(&files)).unwrap_err();
    assert_eq!(
        e,
        ShaderError::UnknownImport {
            name: "common/nope.wgsl".into(),
            line: 2,
            file: "common/a.wgsl".into(),
        }
    );
    assert!(e.to_string().ends_with(": common/a.wgsl"), "{e}");
    for bad in [
        "#import common/a.wgsl",
        "#import \"common/a.wgsl",
        "#import \"\"",
        "#import",
        "#import \"common/a.wgsl\" // why",
    ] {
        let source = format!("const X: u32 = 1u;\n{bad}\n");
        let e = resolve("root.wgsl", &source, &table(&files)).unwrap_err();
        assert_eq!(
            e,
            ShaderError::MalformedImport {
                line: 2,
                file: "root.wgsl".into()
            },
            "{bad}"
        );
    }
    // The registry imports only from common/: a pass file is not importable.
    assert!(importable("bake_cells.wgsl").is_none());
    assert!(importable("common/bvh.wgsl").is_some());
}

#[test]
fn wgsl_errors_point_into_the_original_file() {
    let files = [(
        "common/bad.wgsl",
        "const OK: u32 = 1u;\nfn broken() -> u32 {\n    return missing;\n}\n",
    )];
    let source = "// a pass\n#import \"common/bad.wgsl\"\nconst P: u32 = OK;\n";
    let r = resolve("pass.wgsl", source, &table(&files)).unwrap();
    let e = validate_resolved("pass.wgsl", &r).unwrap_err();
    let ShaderError::Wgsl { ref at, .. } = e else {
        panic!("{e}")
    };
    assert_eq!(at, "common/bad.wgsl:3:12", "{e}");
    let text = e.to_string();
    assert!(
        text.contains("missing") && text.contains("pass.wgsl"),
        "{text}"
    );
}

/// A module-scope definition found by [`definitions`].
#[derive(Debug)]
struct Definition {
    kind: &'static str,
    name: String,
    line: usize,
    entry_point: bool,
}

/// The module-scope `struct`, `fn`, `const`, `override` and `alias` definitions of raw WGSL
/// (imports not resolved). `fn`s marked `@compute`, `@vertex` or `@fragment` are entry points.
fn definitions(source: &str) -> Vec<Definition> {
    const KINDS: [&str; 5] = ["struct", "fn", "const", "override", "alias"];
    let mut out = Vec::new();
    let (mut depth, mut in_block_comment) = (0usize, false);
    let (mut pending_kind, mut entry) = (None::<&'static str>, false);
    for (i, line) in source.lines().enumerate() {
        let mut chars = line.char_indices().peekable();
        while let Some((at, c)) = chars.next() {
            let rest = &line[at..];
            if in_block_comment {
                if rest.starts_with("*/") {
                    in_block_comment = false;
                    chars.next();
                }
                continue;
            }
            if rest.starts_with("//") {
                break;
            }
            if rest.starts_with("/*") {
                in_block_comment = true;
                chars.next();
                continue;
            }
            match c {
                '{' => depth += 1,
                '}' => depth = depth.saturating_sub(1),
                c if c == '@' || c == '_' || c.is_ascii_alphanumeric() => {
                    let len = rest[1..]
                        .find(|c: char| !(c == '_' || c.is_ascii_alphanumeric()))
                        .map_or(rest.len(), |n| n + 1);
                    let word = &rest[..len];
                    for _ in 1..word.chars().count() {
                        chars.next();
                    }
                    // Numbers (`64u`, `1e-6`) are words too, so their suffixes are not names.
                    if depth > 0 || c.is_ascii_digit() {
                        continue;
                    }
                    if let Some(kind) = pending_kind.take() {
                        out.push(Definition {
                            kind,
                            name: word.to_owned(),
                            line: i + 1,
                            entry_point: kind == "fn" && entry,
                        });
                        if kind == "fn" {
                            entry = false;
                        }
                    } else if matches!(word, "@compute" | "@vertex" | "@fragment") {
                        entry = true;
                    } else if let Some(kind) = KINDS.iter().find(|k| **k == word) {
                        pending_kind = Some(kind);
                    }
                }
                _ => {}
            }
        }
    }
    out
}

#[test]
fn definitions_finds_module_scope_names_only() {
    let source = "struct S {\n    a: u32, // fn not_this\n}\nconst C: u32 = 1u; /* struct Nor */\n\
        @compute @workgroup_size(64)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>) {\n    \
        const local = 2u;\n}\nfn helper() {}\nalias A = u32;\n";
    let found: Vec<_> = definitions(source)
        .into_iter()
        .map(|d| (d.kind, d.name, d.line, d.entry_point))
        .collect();
    assert_eq!(
        found,
        [
            ("struct", "S".to_owned(), 1, false),
            ("const", "C".to_owned(), 4, false),
            ("fn", "main".to_owned(), 6, true),
            ("fn", "helper".to_owned(), 9, false),
            ("alias", "A".to_owned(), 10, false),
        ]
    );
}

/// One home for each definition: no struct, function, constant, override or alias is defined in
/// two WGSL files (entry points aside: each pass names its own `main`, `vs_main`, `fs_main`), and
/// the importable files define no entry points. Scans the raw files on disk.
#[test]
fn no_name_is_defined_in_two_files() {
    let dir = source_dir();
    let mut homes: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut problems = Vec::new();
    for file in wgsl_files(&dir) {
        let source = std::fs::read_to_string(dir.join(&file)).unwrap();
        for d in definitions(&source) {
            if d.entry_point {
                if file.starts_with(IMPORT_DIR) {
                    problems.push(format!(
                        "entry point `{}` in importable {file}:{}",
                        d.name, d.line
                    ));
                }
                continue;
            }
            homes
                .entry(d.name)
                .or_default()
                .push(format!("{} in {file}:{}", d.kind, d.line));
        }
    }
    assert!(homes.len() > 50, "only {} definitions found", homes.len());
    for (name, places) in &homes {
        if places.len() > 1 {
            problems.push(format!(
                "`{name}` is defined {} times: {}",
                places.len(),
                places.join(", ")
            ));
        }
    }
    assert!(
        problems.is_empty(),
        "WGSL definitions without one home (move them to shaders/{IMPORT_DIR} and #import them):\n{}",
        problems.join("\n")
    );
}
