use super::*;

/// Writes `files` (path relative to `src`, content) into a fresh directory and checks it.
fn check_crate(name: &str, files: &[(&str, &str)]) -> Result<String> {
    let root = std::env::temp_dir().join(format!("xtask-modgraph-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    for (path, text) in files {
        let p = root.join("src").join(path);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    let result = check(&root, Path::new("src"));
    std::fs::remove_dir_all(&root).unwrap();
    result
}

fn idents(src: &str) -> Vec<String> {
    tokenize(src)
        .into_iter()
        .filter_map(|t| match t.tok {
            Tok::Ident(s) => Some(s),
            _ => None,
        })
        .collect()
}

#[test]
fn comments_literals_and_lifetimes_are_not_paths() {
    let src = r####"
        // crate::a::x
        /* crate::b /* nested */ crate::c */
        /// [`crate::d`]
        fn f<'a>(s: &'a str) -> char { let _ = "crate::e \" crate::f"; let _ = r#"crate::g"#;
            let _ = b'x'; let _ = '\''; let _ = br"crate::h"; 'x' }
    "####;
    assert_eq!(
        idents(src),
        [
            "fn", "f", "s", "str", "char", "let", "_", "let", "_", "let", "_", "let", "_", "let",
            "_"
        ]
    );
    // Lines are counted through comments and literals.
    let t = tokenize("/* a\nb */ \"x\ny\"\nz");
    assert_eq!(t.last().unwrap().line, 4);
}

#[test]
fn test_items_are_dropped() {
    let toks = strip_test_items(tokenize(
        "#[cfg(test)] use crate::{a, b};\n\
         #[cfg(test)]\n#[allow(dead_code)]\nfn helper() { crate::c::f() }\n\
         #[cfg(test)] mod tests { use crate::d; }\n\
         #[cfg(test)] mod more;\n\
         fn kept() { crate::e::g() }",
    ));
    let words: Vec<String> = toks
        .iter()
        .filter_map(|t| match &t.tok {
            Tok::Ident(s) => Some(s.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(words, ["fn", "kept", "crate", "e", "g"]);
}

#[test]
fn use_trees_expand_to_their_leaves() {
    let toks = tokenize("crate::a::{self, b::C as D, e::*, f::{G, h}}");
    let mut out = Vec::new();
    use_tree(&toks, &mut Vec::new(), &mut out);
    let got: Vec<(String, Option<String>)> =
        out.into_iter().map(|(p, b)| (p.join("::"), b)).collect();
    let want = [
        ("crate::a", Some("a")),
        ("crate::a::b::C", Some("D")),
        ("crate::a::e", None),
        ("crate::a::f::G", Some("G")),
        ("crate::a::f::h", Some("h")),
    ];
    assert_eq!(
        got,
        want.map(|(p, b)| (p.to_string(), b.map(str::to_string)))
    );
}

#[test]
fn a_cycle_through_a_re_export_is_found_and_named() {
    let e = check_crate(
        "cycle",
        &[
            ("lib.rs", "pub mod a;\npub mod b;\npub mod c;\n"),
            // `a` re-exports its child's item; `b` reaches it through the re-export.
            ("a/mod.rs", "mod inner;\npub use inner::Thing;\n"),
            ("a/inner.rs", "use crate::c::helper;\npub struct Thing;\n"),
            (
                "b.rs",
                "pub fn f() -> crate::a::Thing { crate::a::Thing }\n",
            ),
            (
                "c.rs",
                "pub fn helper() {}\n// crate::a is only mentioned here\nfn g() { super::b::f(); }\n",
            ),
        ],
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("a, b, c (submodules of the crate root) use each other:"),
        "{e}"
    );
    assert!(
        e.contains("a → c") && e.contains("c → b") && e.contains("b → a"),
        "{e}"
    );
    assert!(e.contains("src/a/inner.rs:1: crate::c::helper"), "{e}");
}

#[test]
fn parents_and_children_may_use_each_other_and_layers_are_printed() {
    let report = check_crate(
        "layers",
        &[
            ("lib.rs", "pub mod low;\npub mod mid;\npub mod top;\n"),
            ("low.rs", "pub struct L;\n"),
            // The parent defines what its children share and calls them; siblings go one way.
            (
                "mid/mod.rs",
                "mod x;\nmod y;\npub struct Shared;\npub fn run() { y::go() }\n",
            ),
            ("mid/x.rs", "use super::Shared;\nuse crate::low::L;\n"),
            ("mid/y.rs", "use super::{Shared, x};\npub fn go() {}\n"),
            (
                "top.rs",
                "use crate::{low, mid::run};\nfn f() { low::L; }\n#[cfg(test)]\nmod tests;\n",
            ),
        ],
    )
    .unwrap();
    assert!(report.contains("6 modules, no import cycle"), "{report}");
    assert!(
        report.contains("  the crate root: low < mid < top\n"),
        "{report}"
    );
    assert!(report.contains("  mid: x < y\n"), "{report}");
}

#[test]
fn sibling_cycles_inside_a_module_are_found() {
    let e = check_crate(
        "inner",
        &[
            ("lib.rs", "mod m;\n"),
            ("m.rs", "mod p;\nmod q;\n"),
            ("m/p.rs", "pub fn f() { super::q::g() }\n"),
            (
                "m/q.rs",
                "use crate::m::p;\npub fn g() {}\nfn h() { p::f() }\n",
            ),
        ],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("p, q (submodules of m) use each other:"), "{e}");
    assert!(e.contains("p → q") && e.contains("q → p"), "{e}");
}
