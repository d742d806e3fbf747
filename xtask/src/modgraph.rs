//! `cargo xtask check-modules`: no import cycle between the modules of a crate (run on
//! `vlf-core` by `cargo xtask ci`).
//!
//! The check reads the crate's sources, not the compiler's view of them: a small tokenizer drops
//! comments, string and char literals and every item under `#[cfg(test)]` (test code may use
//! anything), then
//!
//! * the module tree comes from the `mod name;` declarations, starting at `lib.rs`;
//! * every `use` path and every path written inline (`crate::…`, `super::…`, `self::…`, a child
//!   module's name or a name a `use` brought in, followed by `::`) is resolved to the module it
//!   names; a name that a module re-exports (`pub use child::Name`, or any `use` at the module's
//!   top level) is followed to where it comes from;
//! * a reference from module `a::b::x` to module `a::c::y` is an edge `b → c` between the
//!   children of their lowest common ancestor `a`. So there is one graph per module with
//!   submodules (the crate root's is the graph of the top-level modules), and each reference
//!   counts once, at the level where the two sides part.
//!
//! A reference to an ancestor (a child using `super::Item` defined in its parent's own file) or
//! to a descendant (a parent using its child) is no edge: a module's own file is the common
//! ground of its submodules. Every graph must be acyclic; a cycle is printed with one
//! reference (file and line) per edge. On success the layering is printed, lowest layer first.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// Runs the check on the crate whose sources are in `src` (relative to `root`, as the messages
/// show it) and returns the report (the layering of every module with submodules); fails
/// listing every cycle with the references that make it.
pub fn check(root: &Path, src: &Path) -> Result<String> {
    let crate_ = load(root, src)?;
    let mut cycles = String::new();
    let mut report = String::new();
    for (parent, g) in &crate_.graphs() {
        let name = display(parent);
        match g.layers() {
            Ok(layers) => {
                let layers: Vec<String> = layers.iter().map(|l| l.join(", ")).collect();
                writeln!(report, "  {name}: {}", layers.join(" < ")).unwrap();
            }
            Err(components) => {
                for c in components {
                    writeln!(
                        cycles,
                        "{} (submodules of {name}) use each other:",
                        c.join(", ")
                    )
                    .unwrap();
                    for ((a, b), e) in &g.edges {
                        if c.contains(a) && c.contains(b) {
                            writeln!(
                                cycles,
                                "  {a} → {b}   ({}:{}: {})",
                                e.file.display(),
                                e.line,
                                e.path
                            )
                            .unwrap();
                        }
                    }
                }
            }
        }
    }
    if !cycles.is_empty() {
        bail!("import cycles in {}:\n{cycles}", src.display());
    }
    Ok(format!(
        "{}: {} modules, no import cycle; layers, each using only those before it:\n{report}",
        src.display(),
        crate_.modules.len()
    ))
}

/// Every module of the crate whose sources are in `src` (relative to `root`), as paths from the
/// crate root (`["bake", "reference"]`); the root itself is the empty path. Test modules are
/// left out.
pub fn modules(root: &Path, src: &Path) -> Result<BTreeSet<Vec<String>>> {
    Ok(load(root, src)?.modules.into_keys().collect())
}

fn display(module: &[String]) -> String {
    if module.is_empty() {
        "the crate root".into()
    } else {
        module.join("::")
    }
}

// ----- tokens -------------------------------------------------------------------------------

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    /// `::`
    PathSep,
    Punct(char),
    /// Any literal (its content does not matter here).
    Lit,
}

#[derive(Clone, Debug)]
struct Token {
    tok: Tok,
    line: usize,
}

/// Splits Rust source into identifiers, `::`, punctuation and literals; comments, lifetimes
/// and the contents of literals are dropped.
fn tokenize(src: &str) -> Vec<Token> {
    let c: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    let at = |i: usize| c.get(i).copied().unwrap_or('\0');
    let ident_start = |ch: char| ch == '_' || ch.is_alphabetic();
    let ident_char = |ch: char| ch == '_' || ch.is_alphanumeric();
    while i < c.len() {
        let ch = c[i];
        let start_line = line;
        let mut push = |tok: Tok| {
            out.push(Token {
                tok,
                line: start_line,
            })
        };
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if c[i] == '\n' {
                        line += 1;
                    }
                    i += 1;
                }
            }
        } else if let Some(len) = raw_string_start(&c, i) {
            // r"…", r#"…"#, br"…": no escapes; ends at a quote followed by as many #.
            let hashes = len - 1 - usize::from(at(i) == 'b') - 1;
            i += len;
            loop {
                if i >= c.len() {
                    break;
                }
                if c[i] == '"' && (1..=hashes).all(|k| at(i + k) == '#') {
                    i += 1 + hashes;
                    break;
                }
                if c[i] == '\n' {
                    line += 1;
                }
                i += 1;
            }
            push(Tok::Lit);
        } else if ch == '"' || (ch == 'b' && at(i + 1) == '"') || (ch == 'c' && at(i + 1) == '"') {
            i += if ch == '"' { 1 } else { 2 };
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    i += 1;
                }
                if at(i) == '\n' {
                    line += 1;
                }
                i += 1;
            }
            i += 1;
            push(Tok::Lit);
        } else if ch == '\'' || (ch == 'b' && at(i + 1) == '\'') {
            let q = if ch == 'b' { i + 1 } else { i };
            if at(q + 1) == '\\' {
                // Escaped char literal: skip to the closing quote.
                i = q + 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
                push(Tok::Lit);
            } else if at(q + 2) == '\'' {
                i = q + 3;
                push(Tok::Lit);
            } else {
                // A lifetime or a label.
                i = q + 1;
                while ident_char(at(i)) {
                    i += 1;
                }
            }
        } else if ident_start(ch) {
            let s = i;
            while ident_char(at(i)) {
                i += 1;
            }
            let mut word: String = c[s..i].iter().collect();
            if word == "r" && at(i) == '#' && ident_start(at(i + 1)) {
                let s = i + 1;
                i = s;
                while ident_char(at(i)) {
                    i += 1;
                }
                word = c[s..i].iter().collect();
            }
            push(Tok::Ident(word));
        } else if ch.is_ascii_digit() {
            while ident_char(at(i)) || (at(i) == '.' && at(i + 1).is_ascii_digit()) {
                i += 1;
            }
            push(Tok::Lit);
        } else if ch == ':' && at(i + 1) == ':' {
            i += 2;
            push(Tok::PathSep);
        } else if ch == '$' && c[i + 1..].starts_with(&['c', 'r', 'a', 't', 'e']) {
            // `$crate` in a macro is the crate.
            i += 6;
            push(Tok::Ident("crate".into()));
        } else {
            i += 1;
            push(Tok::Punct(ch));
        }
    }
    out
}

/// Length of the opening of a raw string literal at `i` (`r"`, `r#"`, `br##"`, …), if one
/// starts there.
fn raw_string_start(c: &[char], i: usize) -> Option<usize> {
    let prev_is_ident = i > 0 && (c[i - 1] == '_' || c[i - 1].is_alphanumeric());
    if prev_is_ident {
        return None;
    }
    let mut j = i;
    if c.get(j) == Some(&'b') {
        j += 1;
    }
    if c.get(j) != Some(&'r') {
        return None;
    }
    j += 1;
    while c.get(j) == Some(&'#') {
        j += 1;
    }
    (c.get(j) == Some(&'"')).then_some(j + 1 - i)
}

/// Drops every item under `#[cfg(test)]` (modules, functions, imports, …).
fn strip_test_items(toks: Vec<Token>) -> Vec<Token> {
    let is = |t: Option<&Token>, want: &Tok| t.is_some_and(|t| &t.tok == want);
    let ident = |s: &str| Tok::Ident(s.into());
    let mut out = Vec::with_capacity(toks.len());
    let mut i = 0;
    while i < toks.len() {
        let cfg_test = is(toks.get(i), &Tok::Punct('#'))
            && is(toks.get(i + 1), &Tok::Punct('['))
            && is(toks.get(i + 2), &ident("cfg"))
            && is(toks.get(i + 3), &Tok::Punct('('))
            && is(toks.get(i + 4), &ident("test"))
            && is(toks.get(i + 5), &Tok::Punct(')'))
            && is(toks.get(i + 6), &Tok::Punct(']'));
        if !cfg_test {
            out.push(toks[i].clone());
            i += 1;
            continue;
        }
        i += 7;
        // Further attributes of the same item.
        while is(toks.get(i), &Tok::Punct('#')) && is(toks.get(i + 1), &Tok::Punct('[')) {
            i = skip_group(&toks, i + 1);
        }
        // The item: up to a `;` outside brackets, or through the first `{ … }` group (an
        // import's braces end at its `;`).
        let is_use = toks[i..]
            .iter()
            .take(4)
            .any(|t| t.tok == Tok::Ident("use".into()));
        while i < toks.len() {
            match toks[i].tok {
                Tok::Punct(';') => {
                    i += 1;
                    break;
                }
                Tok::Punct('{') if !is_use => {
                    i = skip_group(&toks, i);
                    break;
                }
                Tok::Punct('(' | '[' | '{') => i = skip_group(&toks, i),
                _ => i += 1,
            }
        }
    }
    out
}

/// Index just past the bracket group opening at `i`.
fn skip_group(toks: &[Token], mut i: usize) -> usize {
    let mut depth = 0i32;
    while i < toks.len() {
        match toks[i].tok {
            Tok::Punct('(' | '[' | '{') => depth += 1,
            Tok::Punct(')' | ']' | '}') => {
                depth -= 1;
                if depth == 0 {
                    return i + 1;
                }
            }
            _ => {}
        }
        i += 1;
    }
    i
}

// ----- modules and references ---------------------------------------------------------------

/// One path written in a source file: a `use` leaf or an inline path, as written.
#[derive(Clone, Debug)]
struct PathRef {
    segs: Vec<String>,
    line: usize,
    /// Written in a `use` at the module's top level (it may re-export).
    top_level_use: bool,
    /// The local name a `use` binds (`None` for globs and inline paths).
    binds: Option<String>,
}

struct Module {
    file: PathBuf,
    children: BTreeSet<String>,
    refs: Vec<PathRef>,
}

struct Crate {
    modules: BTreeMap<Vec<String>, Module>,
}

/// Reads the module tree from `src/lib.rs` (or `src/main.rs`) down.
fn load(root: &Path, src: &Path) -> Result<Crate> {
    let lib = ["lib.rs", "main.rs"]
        .iter()
        .map(|f| src.join(f))
        .find(|p| root.join(p).exists())
        .with_context(|| format!("no lib.rs or main.rs in {}", src.display()))?;
    let mut modules = BTreeMap::new();
    let mut todo = vec![(Vec::<String>::new(), lib, src.to_path_buf())];
    while let Some((path, file, dir)) = todo.pop() {
        let text = std::fs::read_to_string(root.join(&file))
            .with_context(|| format!("cannot read {}", file.display()))?;
        let toks = strip_test_items(tokenize(&text));
        let children = mod_declarations(&toks, &file)?;
        for child in &children {
            let candidates = [
                dir.join(format!("{child}.rs")),
                dir.join(child).join("mod.rs"),
            ];
            let Some(f) = candidates.iter().find(|p| root.join(p).exists()) else {
                bail!(
                    "{}: module {child} has no file ({} or {})",
                    file.display(),
                    candidates[0].display(),
                    candidates[1].display()
                );
            };
            let mut p = path.clone();
            p.push(child.clone());
            todo.push((p, f.clone(), dir.join(child)));
        }
        let refs = path_refs(&toks);
        modules.insert(
            path,
            Module {
                file,
                children,
                refs,
            },
        );
    }
    Ok(Crate { modules })
}

/// The `mod name;` declarations (test modules are gone already).
fn mod_declarations(toks: &[Token], file: &Path) -> Result<BTreeSet<String>> {
    let path_attr = toks.windows(3).find(|w| {
        w[0].tok == Tok::Punct('#')
            && w[1].tok == Tok::Punct('[')
            && w[2].tok == Tok::Ident("path".into())
    });
    if let Some(w) = path_attr {
        bail!(
            "{}:{}: #[path] on a module is not supported",
            file.display(),
            w[0].line
        );
    }
    let mut out = BTreeSet::new();
    for (i, t) in toks.iter().enumerate() {
        if t.tok != Tok::Ident("mod".into()) {
            continue;
        }
        let (Some(Tok::Ident(name)), Some(next)) = (
            toks.get(i + 1).map(|t| &t.tok),
            toks.get(i + 2).map(|t| &t.tok),
        ) else {
            continue;
        };
        match next {
            Tok::Punct(';') => {
                out.insert(name.clone());
            }
            Tok::Punct('{') => bail!(
                "{}:{}: inline module {name} {{ … }}: move it to its own file (the check reads \
                 one module per file)",
                file.display(),
                t.line
            ),
            _ => {}
        }
    }
    Ok(out)
}

/// Every `use` leaf and every inline path of two or more segments.
fn path_refs(toks: &[Token]) -> Vec<PathRef> {
    let mut out = Vec::new();
    let mut depth = 0i32;
    let mut i = 0;
    while i < toks.len() {
        match &toks[i].tok {
            Tok::Punct('{') => depth += 1,
            Tok::Punct('}') => depth -= 1,
            Tok::Ident(w) if w == "use" => {
                let end = toks[i..]
                    .iter()
                    .position(|t| t.tok == Tok::Punct(';'))
                    .map_or(toks.len(), |p| i + p);
                let mut leaves = Vec::new();
                use_tree(&toks[i + 1..end], &mut Vec::new(), &mut leaves);
                for (segs, binds) in leaves {
                    out.push(PathRef {
                        segs,
                        line: toks[i].line,
                        top_level_use: depth == 0,
                        binds,
                    });
                }
                i = end + 1;
                continue;
            }
            Tok::Ident(first) => {
                let after_sep = i > 0 && toks[i - 1].tok == Tok::PathSep;
                if !after_sep && toks.get(i + 1).is_some_and(|t| t.tok == Tok::PathSep) {
                    let mut segs = vec![first.clone()];
                    let mut j = i + 1;
                    while toks.get(j).is_some_and(|t| t.tok == Tok::PathSep) {
                        match toks.get(j + 1).map(|t| &t.tok) {
                            Some(Tok::Ident(s)) => segs.push(s.clone()),
                            _ => break,
                        }
                        j += 2;
                    }
                    out.push(PathRef {
                        segs,
                        line: toks[i].line,
                        top_level_use: false,
                        binds: None,
                    });
                    i = j;
                    continue;
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// Expands a use tree (`a::{b, c::d as e, f::*}`) into its leaves: the full path and the name
/// it binds (`None` for a glob).
fn use_tree(
    toks: &[Token],
    prefix: &mut Vec<String>,
    out: &mut Vec<(Vec<String>, Option<String>)>,
) {
    let depth0 = prefix.len();
    let mut i = 0;
    // A leading `::` names an external crate: not ours.
    if toks.first().is_some_and(|t| t.tok == Tok::PathSep) {
        return;
    }
    while i < toks.len() {
        match &toks[i].tok {
            Tok::Ident(s) if s == "as" => {
                if let (Some(Tok::Ident(alias)), true) =
                    (toks.get(i + 1).map(|t| &t.tok), prefix.len() > depth0)
                {
                    out.push((prefix.clone(), Some(alias.clone())));
                }
                i += 2;
                prefix.truncate(depth0);
                continue;
            }
            Tok::Ident(s) => prefix.push(s.clone()),
            Tok::PathSep => {}
            Tok::Punct('*') => {
                out.push((prefix.clone(), None));
                prefix.truncate(depth0);
            }
            Tok::Punct('{') => {
                let end = skip_group(toks, i) - 1;
                // Split the group's content at top-level commas.
                let inner = &toks[i + 1..end];
                let mut start = 0;
                let mut d = 0;
                for (k, t) in inner.iter().enumerate() {
                    match t.tok {
                        Tok::Punct('{') => d += 1,
                        Tok::Punct('}') => d -= 1,
                        Tok::Punct(',') if d == 0 => {
                            use_tree(&inner[start..k], prefix, out);
                            start = k + 1;
                        }
                        _ => {}
                    }
                }
                use_tree(&inner[start..], prefix, out);
                prefix.truncate(depth0);
                i = end + 1;
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    if prefix.len() > depth0 {
        let mut segs = prefix.clone();
        // `a::b::{self}` binds `b`.
        if segs.last().is_some_and(|s| s == "self") {
            segs.pop();
        }
        let name = segs.last().cloned();
        if !segs.is_empty() {
            out.push((segs, name));
        }
        prefix.truncate(depth0);
    }
}

/// An edge between two sibling modules, with the first reference that makes it.
struct Edge {
    file: PathBuf,
    line: usize,
    path: String,
}

struct Graph {
    nodes: BTreeSet<String>,
    edges: BTreeMap<(String, String), Edge>,
}

impl Crate {
    /// The absolute path (from the crate root) that `segs`, written in `module`, names; `None`
    /// for paths outside the crate and local names.
    fn absolute(
        &self,
        module: &[String],
        segs: &[String],
        aliases: &HashMap<String, Vec<String>>,
    ) -> Option<Vec<String>> {
        let first = segs.first()?;
        let mut abs: Vec<String>;
        let mut rest = &segs[1..];
        match first.as_str() {
            "crate" => abs = Vec::new(),
            "self" => abs = module.to_vec(),
            "super" => {
                abs = module.to_vec();
                abs.pop()?;
                while rest.first().is_some_and(|s| s == "super") {
                    abs.pop()?;
                    rest = &rest[1..];
                }
            }
            name if self
                .modules
                .get(module)
                .is_some_and(|m| m.children.contains(name)) =>
            {
                abs = module.to_vec();
                abs.push(name.to_string());
            }
            name => abs = aliases.get(name)?.clone(),
        }
        abs.extend(rest.iter().cloned());
        Some(abs)
    }

    /// The names each module's top-level `use`s bind, as absolute paths (for re-exports).
    fn exports(&self) -> HashMap<Vec<String>, HashMap<String, Vec<String>>> {
        let mut out = HashMap::new();
        for (path, m) in &self.modules {
            let mut names = HashMap::new();
            // Twice, so that an import through another import of the same file resolves.
            for _ in 0..2 {
                for r in m.refs.iter().filter(|r| r.top_level_use) {
                    if let (Some(name), Some(abs)) =
                        (&r.binds, self.absolute(path, &r.segs, &names))
                    {
                        names.insert(name.clone(), abs);
                    }
                }
            }
            out.insert(path.clone(), names);
        }
        out
    }

    /// The module an absolute path names (following re-exports of the item it ends in).
    fn target(
        &self,
        abs: &[String],
        exports: &HashMap<Vec<String>, HashMap<String, Vec<String>>>,
    ) -> Vec<String> {
        let mut abs = abs.to_vec();
        for _ in 0..16 {
            let mut k = abs.len();
            while k > 0 && !self.modules.contains_key(&abs[..k]) {
                k -= 1;
            }
            let module = abs[..k].to_vec();
            let Some(item) = abs.get(k) else {
                return module;
            };
            match exports.get(&module).and_then(|e| e.get(item)) {
                Some(to) if to.as_slice() != abs.as_slice() => {
                    let mut next = to.clone();
                    next.extend(abs[k + 1..].iter().cloned());
                    abs = next;
                }
                _ => return module,
            }
        }
        abs
    }

    /// One graph per module with submodules: its children and the edges between them.
    fn graphs(&self) -> BTreeMap<Vec<String>, Graph> {
        let exports = self.exports();
        let mut graphs: BTreeMap<Vec<String>, Graph> = BTreeMap::new();
        for (path, m) in &self.modules {
            if !m.children.is_empty() {
                graphs.insert(
                    path.clone(),
                    Graph {
                        nodes: m.children.clone(),
                        edges: BTreeMap::new(),
                    },
                );
            }
        }
        for (from, m) in &self.modules {
            // Every name this file's `use`s bind (scopes ignored: a superset).
            let mut aliases = HashMap::new();
            for _ in 0..2 {
                for r in m.refs.iter().filter(|r| r.binds.is_some()) {
                    if let Some(abs) = self.absolute(from, &r.segs, &aliases) {
                        aliases.insert(r.binds.clone().unwrap(), abs);
                    }
                }
            }
            for r in &m.refs {
                let Some(abs) = self.absolute(from, &r.segs, &aliases) else {
                    continue;
                };
                let to = self.target(&abs, &exports);
                let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
                if common == from.len() || common == to.len() {
                    continue; // the module itself, an ancestor or a descendant
                }
                let Some(g) = graphs.get_mut(&from[..common]) else {
                    continue;
                };
                g.edges
                    .entry((from[common].clone(), to[common].clone()))
                    .or_insert_with(|| Edge {
                        file: m.file.clone(),
                        line: r.line,
                        path: r.segs.join("::"),
                    });
            }
        }
        graphs
    }
}

impl Graph {
    /// The nodes in layers (each uses only nodes of earlier layers), or the groups of nodes
    /// that use each other (the strongly connected components with more than one node).
    fn layers(&self) -> Result<Vec<Vec<String>>, Vec<Vec<String>>> {
        let nodes: Vec<&String> = self.nodes.iter().collect();
        let index = |n: &String| nodes.iter().position(|m| *m == n);
        let mut adj = vec![Vec::new(); nodes.len()];
        for (a, b) in self.edges.keys() {
            if let (Some(i), Some(j)) = (index(a), index(b)) {
                adj[i].push(j);
            }
        }
        // Reachability by repeated squaring is plenty for a few dozen modules.
        let n = nodes.len();
        let mut reach = vec![vec![false; n]; n];
        for (i, out) in adj.iter().enumerate() {
            for &j in out {
                reach[i][j] = true;
            }
        }
        for k in 0..n {
            for i in 0..n {
                if reach[i][k] {
                    for j in 0..n {
                        if reach[k][j] {
                            reach[i][j] = true;
                        }
                    }
                }
            }
        }
        let mut components: Vec<Vec<String>> = Vec::new();
        let mut seen = vec![false; n];
        for i in 0..n {
            if seen[i] || !reach[i][i] {
                continue;
            }
            let c: Vec<usize> = (0..n).filter(|&j| reach[i][j] && reach[j][i]).collect();
            for &j in &c {
                seen[j] = true;
            }
            components.push(c.iter().map(|&j| nodes[j].clone()).collect());
        }
        if !components.is_empty() {
            return Err(components);
        }
        // Acyclic: a node's layer is one more than the highest layer it uses.
        let mut layer = vec![None::<usize>; n];
        while layer.iter().any(Option::is_none) {
            for i in 0..n {
                if layer[i].is_none() && adj[i].iter().all(|&j| layer[j].is_some()) {
                    layer[i] = Some(
                        adj[i]
                            .iter()
                            .map(|&j| layer[j].unwrap() + 1)
                            .max()
                            .unwrap_or(0),
                    );
                }
            }
        }
        let mut out = vec![Vec::new(); layer.iter().flatten().max().map_or(0, |m| m + 1)];
        for (i, l) in layer.into_iter().enumerate() {
            out[l.unwrap()].push(nodes[i].clone());
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
