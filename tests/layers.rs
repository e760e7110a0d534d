//! The layers of every crate, checked from the sources: no module of a lower layer
//! imports a higher one, and no files import each other in a circle.
//!
//! Each `use` tree and each `crate::`/`super::`/`self::` path in a file's code (unit
//! tests included; comments and strings are not code) is resolved to the file that
//! defines what it names: `crate::map::grid::GridIndex` names `src/map/grid.rs`, and
//! `crate::map::CliffMap` names the file that `src/map/mod.rs` re-exports it from, and
//! `src/map/mod.rs` itself, whose re-export the name goes through. The re-exports of a
//! module's front file (`lib.rs`, `main.rs`, `mod.rs`) are its face, not imports of its
//! own; anything else a front file's code uses is an import like any other, so a front
//! file that imports a file which takes a name through that front's re-exports closes a
//! circle.
//!
//! The core library's layers, lowest first (see docs/architecture.md):
//! `math` and `bounded_read`, `tracks`, `motion`, `map`, `predict`, `occupancy`, `eval`,
//! `plot`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The core library's top-level modules, lowest layer first; modules of one layer may
/// import each other (files still may not form a circle).
const CORE_LAYERS: &[&[&str]] = &[
    &["math", "bounded_read", "framed"],
    &["tracks"],
    &["motion"],
    &["map"],
    &["predict"],
    &["occupancy"],
    &["eval"],
    &["plot"],
];

/// One crate's sources: a name for messages and its root file.
struct CrateSrc {
    name: String,
    root: PathBuf,
}

/// The packages of the workspace whose sources are checked.
const PACKAGES: &[&str] = &[".", "client", "service", "python", "ros2"];

/// Every crate of the workspace's packages: the library and each binary
/// (`src/main.rs`, `src/bin/NAME.rs`, `src/bin/NAME/main.rs`); the core library first.
fn crates() -> Vec<CrateSrc> {
    let top = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = Vec::new();
    for pkg in PACKAGES {
        let src = top.join(pkg).join("src");
        if !src.is_dir() {
            continue;
        }
        let mut roots = vec![src.join("lib.rs"), src.join("main.rs")];
        if let Ok(dir) = std::fs::read_dir(src.join("bin")) {
            let mut bins: Vec<PathBuf> = dir
                .flatten()
                .map(|e| e.path())
                .map(|p| if p.is_dir() { p.join("main.rs") } else { p })
                .filter(|p| p.extension().is_some_and(|x| x == "rs"))
                .collect();
            bins.sort();
            roots.extend(bins);
        }
        for root in roots.into_iter().filter(|r| r.exists()) {
            out.push(CrateSrc {
                name: rel(&root),
                root,
            });
        }
    }
    out
}

/// Source text with comments, string and char literals blanked (same length, so byte
/// offsets stay), leaving only code.
fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = b.to_vec();
    let mut i = 0;
    let blank = |out: &mut Vec<u8>, from: usize, to: usize| {
        for c in &mut out[from..to] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
    };
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            let end = text[i..].find('\n').map_or(b.len(), |n| i + n);
            blank(&mut out, i, end);
            i = end;
        } else if b[i..].starts_with(b"/*") {
            let (mut depth, mut j) = (1, i + 2);
            while j < b.len() && depth > 0 {
                if b[j..].starts_with(b"/*") {
                    depth += 1;
                    j += 2;
                } else if b[j..].starts_with(b"*/") {
                    depth -= 1;
                    j += 2;
                } else {
                    j += 1;
                }
            }
            blank(&mut out, i, j);
            i = j;
        } else if b[i] == b'r'
            && (b.get(i + 1) == Some(&b'"') || b.get(i + 1) == Some(&b'#'))
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_'))
        {
            // raw string r"..." or r#"..."#
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&b'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&b'"') {
                i += 1;
                continue;
            }
            let close: Vec<u8> = std::iter::once(b'"')
                .chain(std::iter::repeat_n(b'#', hashes))
                .collect();
            let end = (j + 1..b.len())
                .find(|&k| b[k..].starts_with(&close))
                .map_or(b.len(), |k| k + close.len());
            blank(&mut out, i, end);
            i = end;
        } else if b[i] == b'"' {
            let mut j = i + 1;
            while j < b.len() && b[j] != b'"' {
                j += if b[j] == b'\\' { 2 } else { 1 };
            }
            blank(&mut out, i, (j + 1).min(b.len()));
            i = j + 1;
        } else if b[i] == b'\'' {
            // a char literal ('a', '\n', '\u{1F600}') or a lifetime ('a): blank literals only
            let lit_end = if b.get(i + 1) == Some(&b'\\') {
                (i + 2..b.len().min(i + 12)).find(|&k| b[k] == b'\'')
            } else {
                let ch_len = text[i + 1..].chars().next().map_or(1, char::len_utf8);
                (b.get(i + 1 + ch_len) == Some(&b'\'')).then_some(i + 1 + ch_len)
            };
            match lit_end {
                Some(e) => {
                    blank(&mut out, i, e + 1);
                    i = e + 1;
                }
                None => i += 1,
            }
        } else {
            i += 1;
        }
    }
    String::from_utf8(out).expect("blanking keeps UTF-8")
}

/// A file of a crate and the module path it defines (`["map", "grid"]`).
#[derive(Debug, Clone)]
struct ModFile {
    path: PathBuf,
    module: Vec<String>,
}

/// Every file of the crate rooted at `root`, following `mod name;` declarations.
fn crate_files(root: &Path) -> Vec<ModFile> {
    let mut out = Vec::new();
    let mut todo = vec![ModFile {
        path: root.to_path_buf(),
        module: Vec::new(),
    }];
    while let Some(f) = todo.pop() {
        let text = std::fs::read_to_string(&f.path)
            .unwrap_or_else(|e| panic!("{}: {e}", f.path.display()));
        let code = code_only(&text);
        let is_dir_owner = f.module.is_empty() || f.path.file_name().is_some_and(|n| n == "mod.rs");
        let dir = if is_dir_owner {
            f.path.parent().unwrap().to_path_buf()
        } else {
            f.path.with_extension("")
        };
        for name in declared_file_modules(&code) {
            let a = dir.join(format!("{name}.rs"));
            let b = dir.join(&name).join("mod.rs");
            let path = if a.exists() {
                a
            } else if b.exists() {
                b
            } else {
                panic!("{}: `mod {name};` has no file", f.path.display())
            };
            let mut module = f.module.clone();
            module.push(name);
            todo.push(ModFile { path, module });
        }
        out.push(f);
    }
    out
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// The words of code, with their byte offsets.
fn tokens(code: &str) -> Vec<(usize, &str)> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if is_ident(b[i]) {
            let s = i;
            while i < b.len() && is_ident(b[i]) {
                i += 1;
            }
            out.push((s, &code[s..i]));
        } else if b[i..].starts_with(b"::") {
            out.push((i, "::"));
            i += 2;
        } else if b[i].is_ascii_whitespace() {
            i += 1;
        } else {
            out.push((i, &code[i..i + 1]));
            i += 1;
        }
    }
    out
}

/// `mod name;` declarations (file modules; `mod name { ... }` is inline).
fn declared_file_modules(code: &str) -> Vec<String> {
    let t = tokens(code);
    let mut out = Vec::new();
    for w in t.windows(3) {
        if w[0].1 == "mod" && w[2].1 == ";" && w[1].1.bytes().all(is_ident) {
            out.push(w[1].1.to_string());
        }
    }
    out
}

/// Whether a file is a module's front (`lib.rs`, `main.rs`, `mod.rs`): its `pub use`
/// re-exports are the module's face, not imports its own code depends on.
fn is_front(f: &ModFile) -> bool {
    f.module.is_empty() || f.path.file_name().is_some_and(|n| n == "mod.rs")
}

/// The module paths (relative to the crate root) that the code of file `f` names:
/// every `use` tree (but the re-exports of a module's front file), every path that
/// starts with `crate`, `super` or `self`, and every path that starts with a module the
/// file declares (`grid::Grid` in the file that says `mod grid;`).
fn imports(f: &ModFile, code: &str) -> Vec<Vec<String>> {
    let t = tokens(code);
    let children = declared_file_modules(code);
    // inline modules: (token index where the body opens, brace depth), to resolve `super`
    let mut inline: Vec<(String, i32)> = Vec::new();
    let mut depth = 0i32;
    let mut out = Vec::new();
    let mut i = 0;
    while i < t.len() {
        let w = t[i].1;
        match w {
            "{" => depth += 1,
            "}" => {
                depth -= 1;
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
            }
            "mod" if t.get(i + 2).is_some_and(|x| x.1 == "{") => {
                inline.push((t[i + 1].1.to_string(), depth));
            }
            _ => {}
        }
        let here = || {
            let mut m = f.module.clone();
            m.extend(inline.iter().map(|(n, _)| n.clone()));
            m
        };
        let starts_path = (matches!(w, "crate" | "super" | "self")
            || (inline.is_empty() && children.iter().any(|c| c == w)))
            && t.get(i + 1).is_some_and(|x| x.1 == "::")
            && !(i > 0 && t[i - 1].1 == "::");
        let re_export = w == "use"
            && is_front(f)
            && inline.is_empty()
            && (i >= 1 && t[i - 1].1 == "pub"
                || i >= 4 && t[i - 1].1 == ")" && t[i - 4].1 == "pub");
        if re_export {
            i = use_tree(&t, i + 1).1.max(i + 1);
            continue;
        }
        if w == "use" || starts_path {
            let start = if w == "use" { i + 1 } else { i };
            let (paths, end) = use_tree(&t, start);
            for p in paths {
                if let Some(abs) = absolute(&here(), &p) {
                    out.push(abs);
                }
            }
            i = end.max(i + 1);
            continue;
        }
        i += 1;
    }
    out
}

/// The paths of a `use` tree (or of one path expression) starting at token `i`, and
/// the token index after it.
fn use_tree(t: &[(usize, &str)], mut i: usize) -> (Vec<Vec<String>>, usize) {
    let mut prefix: Vec<String> = Vec::new();
    let mut out = Vec::new();
    loop {
        match t.get(i).map(|x| x.1) {
            Some("{") => {
                i += 1;
                loop {
                    let (inner, next) = use_tree(t, i);
                    for p in inner {
                        let mut full = prefix.clone();
                        full.extend(p);
                        out.push(full);
                    }
                    i = next;
                    match t.get(i).map(|x| x.1) {
                        Some(",") => i += 1,
                        Some("}") => {
                            i += 1;
                            break;
                        }
                        _ => break,
                    }
                    if t.get(i).map(|x| x.1) == Some("}") {
                        i += 1;
                        break;
                    }
                }
                return (out, i);
            }
            Some(w) if w.bytes().all(is_ident) && w != "as" => {
                prefix.push(w.to_string());
                i += 1;
                if t.get(i).map(|x| x.1) == Some("::") {
                    i += 1;
                    continue;
                }
                if t.get(i).map(|x| x.1) == Some("as") {
                    i += 2;
                }
                break;
            }
            Some("*") => {
                i += 1;
                break;
            }
            _ => break,
        }
    }
    out.push(prefix);
    (out, i)
}

/// A path relative to the crate root.
fn absolute(here: &[String], p: &[String]) -> Option<Vec<String>> {
    let mut m: Vec<String>;
    let mut rest = p;
    match p.first().map(String::as_str) {
        Some("crate") => {
            m = Vec::new();
            rest = &p[1..];
        }
        Some("self") => {
            m = here.to_vec();
            rest = &p[1..];
        }
        Some("super") => {
            m = here.to_vec();
            while rest.first().map(String::as_str) == Some("super") {
                m.pop();
                rest = &rest[1..];
            }
        }
        // relative to this module: a child module, or another crate (`std::`, `glam::`),
        // which resolves to this very file and is dropped
        _ => m = here.to_vec(),
    }
    m.extend(rest.iter().cloned());
    Some(m)
}

/// The re-exports of a module's front file: `(name, path it names)`, and the modules
/// it re-exports whole (`pub use limits::*`).
#[derive(Default)]
struct ReExports {
    named: Vec<(String, Vec<String>)>,
    globs: Vec<Vec<String>>,
}

fn re_exports(f: &ModFile, code: &str) -> ReExports {
    let t = tokens(code);
    let mut out = ReExports::default();
    if !is_front(f) {
        return out;
    }
    let mut depth = 0;
    for i in 0..t.len() {
        match t[i].1 {
            "{" => depth += 1,
            "}" => depth -= 1,
            "use"
                if depth == 0
                    && (i >= 1 && t[i - 1].1 == "pub"
                        || i >= 4 && t[i - 1].1 == ")" && t[i - 4].1 == "pub") =>
            {
                let is_glob = |end: usize| end >= 1 && t[end - 1].1 == "*";
                let (paths, end) = use_tree(&t, i + 1);
                for p in paths {
                    let Some(abs) = absolute(&f.module, &p) else {
                        continue;
                    };
                    if is_glob(end) && paths_is_single_glob(&t, i + 1, end) {
                        out.globs.push(abs);
                    } else if let Some(name) = p.last() {
                        out.named.push((name.clone(), abs));
                    }
                }
            }
            _ => {}
        }
    }
    out
}

/// Whether the use tree between `from` and `to` is one glob (`a::b::*`).
fn paths_is_single_glob(t: &[(usize, &str)], from: usize, to: usize) -> bool {
    !t[from..to].iter().any(|x| x.1 == "{") && t[to - 1].1 == "*"
}

/// Whether the code of a file defines an item called `name`.
fn defines(code: &str, name: &str) -> bool {
    let t = tokens(code);
    t.windows(2).any(|w| {
        w[1].1 == name
            && matches!(
                w[0].1,
                "fn" | "struct" | "enum" | "const" | "static" | "trait" | "type" | "mod" | "union"
            )
    })
}

/// The files (indices into `files`) that what `path` names depends on: first the file
/// that defines it (the deepest module of the path, followed through the re-exports of
/// module front files), then every front file whose re-export the path went through. A
/// name taken through a front file depends on that front file too: its re-export is
/// what the name resolves by, so a front file that imports the importer back closes a
/// circle (`settings.rs` names `crate::learn::LearnSettings`, re-exported by
/// `learn/mod.rs`, which imports `crate::settings::StartError`).
fn resolve(
    files: &[ModFile],
    fronts: &[ReExports],
    codes: &[String],
    path: &[String],
) -> Vec<usize> {
    let mut path = path.to_vec();
    let mut through = Vec::new();
    for _ in 0..16 {
        let (n, i) = (0..=path.len())
            .rev()
            .find_map(|n| {
                files
                    .iter()
                    .position(|f| f.module == path[..n])
                    .map(|i| (n, i))
            })
            .expect("the crate root matches every path");
        let done = |through: Vec<usize>| std::iter::once(i).chain(through).collect();
        let Some(name) = path.get(n) else {
            return done(through);
        };
        if let Some((_, to)) = fronts[i].named.iter().find(|(nm, _)| nm == name) {
            let mut next = to.clone();
            next.extend(path[n + 1..].iter().cloned());
            if next == path {
                return done(through);
            }
            through.push(i);
            path = next;
            continue;
        }
        let glob = fronts[i].globs.iter().find(|g| {
            files
                .iter()
                .position(|f| &f.module == *g)
                .is_some_and(|j| defines(&codes[j], name))
        });
        match glob {
            Some(g) => {
                let mut next = g.clone();
                next.extend(path[n..].iter().cloned());
                through.push(i);
                path = next;
            }
            None => return done(through),
        }
    }
    panic!("re-exports of {path:?} go round in a circle")
}

struct Graph {
    files: Vec<ModFile>,
    edges: BTreeMap<usize, BTreeSet<usize>>,
}

fn graph(c: &CrateSrc) -> Graph {
    let files = crate_files(&c.root);
    let codes: Vec<String> = files
        .iter()
        .map(|f| code_only(&std::fs::read_to_string(&f.path).unwrap()))
        .collect();
    graph_of(files, &codes)
}

/// The import graph of `files`, whose code (comments and strings blanked) is `codes`.
fn graph_of(files: Vec<ModFile>, codes: &[String]) -> Graph {
    let fronts: Vec<ReExports> = files
        .iter()
        .zip(codes)
        .map(|(f, c)| re_exports(f, c))
        .collect();
    let mut edges: BTreeMap<usize, BTreeSet<usize>> = BTreeMap::new();
    for (i, f) in files.iter().enumerate() {
        for p in imports(f, &codes[i]) {
            for j in resolve(&files, &fronts, codes, &p) {
                if j != i {
                    edges.entry(i).or_default().insert(j);
                }
            }
        }
    }
    Graph { files, edges }
}

fn rel(p: &Path) -> String {
    p.strip_prefix(env!("CARGO_MANIFEST_DIR"))
        .unwrap_or(p)
        .display()
        .to_string()
}

/// Every circle of files, each shown once as `a -> b -> ... -> a` with all the files
/// that import each other around it.
fn circles(g: &Graph) -> Vec<String> {
    let n = g.files.len();
    let next = |v: usize| g.edges.get(&v).into_iter().flatten().copied();
    // reach[v]: the files v imports, directly or through others
    let reach: Vec<BTreeSet<usize>> = (0..n)
        .map(|v| {
            let mut seen = BTreeSet::new();
            let mut todo: Vec<usize> = next(v).collect();
            while let Some(w) = todo.pop() {
                if seen.insert(w) {
                    todo.extend(next(w));
                }
            }
            seen
        })
        .collect();
    let mut done = BTreeSet::new();
    let mut out = Vec::new();
    for start in 0..n {
        if done.contains(&start) || !reach[start].contains(&start) {
            continue;
        }
        let comp: BTreeSet<usize> = (0..n)
            .filter(|&w| reach[start].contains(&w) && reach[w].contains(&start))
            .collect();
        done.extend(comp.iter().copied());
        // a shortest way round, breadth-first from `start` back to it
        let mut prev: BTreeMap<usize, usize> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([start]);
        let mut last = start;
        'search: while let Some(v) = queue.pop_front() {
            for w in next(v).filter(|w| comp.contains(w)) {
                if w == start {
                    last = v;
                    break 'search;
                }
                if let std::collections::btree_map::Entry::Vacant(e) = prev.entry(w) {
                    e.insert(v);
                    queue.push_back(w);
                }
            }
        }
        let mut chain = Vec::new();
        let mut v = last;
        while v != start {
            chain.push(v);
            v = prev[&v];
        }
        chain.reverse();
        let cycle: Vec<usize> = std::iter::once(start).chain(chain).chain([start]).collect();
        let name = |i: &usize| rel(&g.files[*i].path);
        out.push(format!(
            "{} (files of the circle: {})",
            cycle.iter().map(name).collect::<Vec<_>>().join(" -> "),
            comp.iter().map(name).collect::<Vec<_>>().join(", ")
        ));
    }
    out
}

#[test]
fn no_files_import_each_other_in_a_circle() {
    let mut found = Vec::new();
    for c in crates() {
        for circle in circles(&graph(&c)) {
            found.push(format!("{} (crate root): {circle}", c.name));
        }
    }
    assert!(
        found.is_empty(),
        "circles of files importing each other:\n{}",
        found.join("\n")
    );
}

#[test]
fn core_modules_import_only_lower_layers() {
    let core = crates().into_iter().next().unwrap();
    let g = graph(&core);
    let layer = |f: &ModFile| {
        f.module.first().map(|top| {
            CORE_LAYERS
                .iter()
                .position(|l| l.contains(&top.as_str()))
                .unwrap_or_else(|| panic!("module `{top}` has no layer: add it to CORE_LAYERS"))
        })
    };
    let mut wrong = Vec::new();
    for (&i, targets) in &g.edges {
        let Some(from) = layer(&g.files[i]) else {
            continue;
        };
        for &j in targets {
            if let Some(to) = layer(&g.files[j])
                && to > from
            {
                wrong.push(format!(
                    "{} (layer {}) imports {} (layer {})",
                    rel(&g.files[i].path),
                    CORE_LAYERS[from].join("/"),
                    rel(&g.files[j].path),
                    CORE_LAYERS[to].join("/")
                ));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the layers:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_core_library_has_no_transport() {
    let manifest =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml")).unwrap();
    let deps = manifest
        .split("[dependencies]")
        .nth(1)
        .unwrap()
        .split("\n[")
        .next()
        .unwrap();
    for ipc in ["iceoryx2", "zenoh", "ros2-client", "rustdds"] {
        assert!(
            !deps.lines().any(|l| l.trim_start().starts_with(ipc)),
            "the core library depends on {ipc}"
        );
    }
}

/// The checker itself: it must see the imports it is meant to see.
#[test]
fn the_checker_resolves_use_trees_and_paths() {
    let code = code_only(
        "use crate::map::{grid::Grid, CliffMap};\n// use crate::eval::x;\nlet s = \"crate::plot::y\";\n\
         fn f() { super::sibling::g(); crate::predict::Params::default(); }\nmod tests { use super::*; }\n",
    );
    let f = ModFile {
        path: PathBuf::from("x.rs"),
        module: vec!["motion".into(), "speed".into()],
    };
    let got = imports(&f, &code);
    let want: Vec<Vec<String>> = [
        vec!["map", "grid", "Grid"],
        vec!["map", "CliffMap"],
        vec!["motion", "sibling", "g"],
        vec!["predict", "Params", "default"],
        vec!["motion", "speed"],
    ]
    .iter()
    .map(|v| v.iter().map(|s| s.to_string()).collect())
    .collect();
    assert_eq!(got, want);
}

/// A small tree of files for the checker's own tests: `(path, code)`, the path relative
/// to the crate's `src` (`lib.rs`, `a.rs`, `b/mod.rs`, `b/c.rs`), the module it defines
/// taken from the path.
fn synthetic_graph(tree: &[(&str, &str)]) -> Graph {
    let files: Vec<ModFile> = tree
        .iter()
        .map(|(path, _)| {
            let mut module: Vec<String> = path
                .trim_end_matches(".rs")
                .split('/')
                .map(String::from)
                .collect();
            if matches!(module.last().map(String::as_str), Some("lib" | "mod")) {
                module.pop();
            }
            ModFile {
                path: PathBuf::from(path),
                module,
            }
        })
        .collect();
    let codes: Vec<String> = tree.iter().map(|(_, code)| code_only(code)).collect();
    graph_of(files, &codes)
}

/// The checker itself: a circle closed through a front file's re-export is a circle.
/// `settings.rs` names `crate::learn::LearnSettings`, which `learn/mod.rs` re-exports
/// from `learn/settings.rs`; `learn/mod.rs` imports `settings.rs` back.
#[test]
fn the_checker_finds_a_circle_through_a_re_export() {
    let tree = |settings: &str, re_export: &str| {
        let learn = format!(
            "mod settings;\nuse crate::settings::StartError;\n{re_export}\n\
             pub fn start() -> Result<(), StartError> {{ Ok(()) }}\n"
        );
        synthetic_graph(&[
            (
                "lib.rs",
                "mod learn;\nmod settings;\npub use settings::Settings;\n",
            ),
            ("settings.rs", settings),
            ("learn/mod.rs", &learn),
            ("learn/settings.rs", "pub struct LearnSettings;\n"),
        ])
    };
    let importer =
        "pub struct Settings { pub learn: crate::learn::LearnSettings }\npub struct StartError;\n";
    for re_export in ["pub use settings::LearnSettings;", "pub use settings::*;"] {
        let g = tree(importer, re_export);
        assert_eq!(
            circles(&g),
            [
                "settings.rs -> learn/mod.rs -> settings.rs (files of the circle: settings.rs, learn/mod.rs)"
            ],
            "the circle through learn/mod.rs's `{re_export}`"
        );
        // the import still reaches the file that defines the type
        let file = |p: &str| g.files.iter().position(|f| f.path == Path::new(p)).unwrap();
        assert!(g.edges[&file("settings.rs")].contains(&file("learn/settings.rs")));
        // without the import back there is no circle
        let g = tree("pub struct Settings;\npub struct StartError;\n", re_export);
        assert!(circles(&g).is_empty(), "{:?}", circles(&g));
    }
}
