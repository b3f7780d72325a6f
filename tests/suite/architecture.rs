//! Imports run one way: in every crate of the workspace, no module imports (through
//! `crate::` or `super::` paths, outside comments) a module that imports it back, file by
//! file; and in the root package the layers of `src/lib.rs` hold: no group (`play`, `run`,
//! `sweep`, `report`, ...) reaches a group that reaches it back. And tensor values are
//! read back to the host in one place only, `foosball_nets::host`, which counts the
//! reads (a GPU training step is tested to make none).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path (`play::evaluation`, `""` for the crate root) -> the modules it uses.
type Graph = BTreeMap<String, BTreeSet<String>>;

/// The module path of `file` under the crate's `src` directory.
fn module_of(src: &Path, file: &Path) -> String {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib")) {
        parts.pop();
    }
    parts.join("::")
}

/// Every `.rs` file of a crate's library (binaries are leaves: nothing imports them).
fn sources(src: &Path) -> Vec<PathBuf> {
    crate::common::files_under(src, "rs", &["bin"])
}

/// The code of `text` without comments (whole-line `//` comments and line tails).
fn code(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The module paths a piece of code names through `crate::a::b` or `super::a` (from
/// `module`), each path's segments up to the first that is not a lower-case identifier;
/// `crate::{a, b::c}` groups give one path per branch.
fn named_paths(module: &str, code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for (prefix, base) in [("crate::", Vec::new()), ("super::", parent(module))] {
        let mut rest = code;
        while let Some(i) = rest.find(prefix) {
            let before = rest[..i].chars().last();
            rest = &rest[i + prefix.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
                continue;
            }
            if let Some(group) = rest.strip_prefix('{') {
                let end = group.find('}').unwrap_or(group.len());
                for branch in group[..end].split(',') {
                    let mut path = base.clone();
                    path.extend(segments(branch.trim()));
                    out.push(path);
                }
            } else {
                let mut path = base.clone();
                path.extend(segments(rest));
                out.push(path);
            }
        }
    }
    out
}

/// The parent of a module path, as segments.
fn parent(module: &str) -> Vec<String> {
    let mut parts: Vec<String> = module.split("::").map(String::from).collect();
    parts.pop();
    parts.retain(|p| !p.is_empty());
    parts
}

/// Leading `ident::ident::...` segments of lower-case identifiers.
fn segments(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    loop {
        let end = rest
            .find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'))
            .unwrap_or(rest.len());
        if end == 0 {
            break;
        }
        out.push(rest[..end].to_string());
        match rest[end..].strip_prefix("::") {
            Some(r) => rest = r,
            None => break,
        }
    }
    out
}

/// The import graph of modules given as (module path, source text).
fn graph(modules: &[(String, String)]) -> Graph {
    let known: BTreeSet<&str> = modules.iter().map(|(m, _)| m.as_str()).collect();
    let mut g = Graph::new();
    for (module, text) in modules {
        let uses = g.entry(module.clone()).or_default();
        for path in named_paths(module, &code(text)) {
            let target = (0..=path.len())
                .rev()
                .map(|n| path[..n].join("::"))
                .find(|p| known.contains(p.as_str()))
                .unwrap_or_default();
            // A module naming its ancestors' items (or the crate root's re-exports) is not
            // a dependency on a layer: `mod` declarations run the other way by design.
            let ancestor = target.is_empty() || module.starts_with(&format!("{target}::"));
            if target != *module && !ancestor {
                uses.insert(target);
            }
        }
    }
    g
}

/// A cycle of `g`, if any, as the modules along it.
fn cycle(g: &Graph) -> Option<Vec<String>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        Open,
        Done,
    }
    fn visit(
        g: &Graph,
        n: &str,
        marks: &mut BTreeMap<String, Mark>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match marks.get(n) {
            Some(Mark::Done) => return None,
            Some(Mark::Open) => {
                let start = path.iter().position(|p| p == n).unwrap();
                let mut c = path[start..].to_vec();
                c.push(n.to_string());
                return Some(c);
            }
            None => {}
        }
        marks.insert(n.to_string(), Mark::Open);
        path.push(n.to_string());
        for m in g.get(n).into_iter().flatten() {
            if let Some(c) = visit(g, m, marks, path) {
                return Some(c);
            }
        }
        path.pop();
        marks.insert(n.to_string(), Mark::Done);
        None
    }
    let mut marks = BTreeMap::new();
    g.keys()
        .find_map(|n| visit(g, n, &mut marks, &mut Vec::new()))
}

/// The graph of `g` with each module replaced by its top-level group.
fn groups(g: &Graph) -> Graph {
    let top = |m: &str| m.split("::").next().unwrap_or("").to_string();
    let mut out = Graph::new();
    for (m, uses) in g {
        let entry = out.entry(top(m)).or_default();
        entry.extend(uses.iter().map(|u| top(u)).filter(|u| *u != top(m)));
    }
    out
}

fn crate_modules(src: &Path) -> Vec<(String, String)> {
    sources(src)
        .iter()
        .map(|f| (module_of(src, f), std::fs::read_to_string(f).unwrap()))
        .collect()
}

#[test]
fn no_module_of_the_workspace_imports_one_that_imports_it_back() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for src in [
        "src",
        "crates/env/src",
        "crates/nets/src",
        "crates/algos/src",
    ] {
        let modules = crate_modules(&root.join(src));
        assert!(modules.len() > 3, "{src}: too few modules found");
        let g = graph(&modules);
        assert!(g.values().any(|u| !u.is_empty()), "{src}: no import found");
        if let Some(c) = cycle(&g) {
            panic!("{src}: import circle {}", c.join(" -> "));
        }
    }
}

#[test]
fn the_root_package_s_layers_import_one_way() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let g = groups(&graph(&crate_modules(&root.join("src"))));
    if let Some(c) = cycle(&g) {
        panic!("src: layers in a circle {}", c.join(" -> "));
    }
    // The layers of lib.rs: play below self_play below run, run below sweep; report and
    // league read play.
    let uses = |a: &str, b: &str| g.get(a).is_some_and(|u| u.contains(b));
    assert!(uses("run", "play") && uses("sweep", "run") && uses("report", "play"));
    assert!(uses("league", "play") && uses("self_play", "play") && uses("run", "self_play"));
    assert!(uses("play", "plan") && uses("play", "onnx"));
    assert!(!uses("onnx", "play"), "onnx imports play");
    for low in ["config", "agents", "files", "png", "plan", "onnx", "play"] {
        for high in ["self_play", "run", "sweep", "report", "league"] {
            assert!(!uses(low, high), "{low} imports {high}");
        }
    }
    assert!(!uses("plan", "play"), "plan imports play");
    for (a, b) in [
        ("league", "report"),
        ("report", "league"),
        ("league", "run"),
    ] {
        assert!(!uses(a, b), "{a} imports {b}");
    }
}

#[test]
fn tensors_are_read_back_through_the_counted_host_module_only() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut offenders = Vec::new();
    for src in [
        "src",
        "crates/env/src",
        "crates/nets/src",
        "crates/algos/src",
    ] {
        for file in sources(&root.join(src)) {
            if file.ends_with("crates/nets/src/host.rs") {
                continue;
            }
            let text = std::fs::read_to_string(&file).unwrap();
            // Unit tests read freely; the library code above them may not.
            let library = text.split("#[cfg(test)]").next().unwrap();
            for read in ["into_data(", "to_data(", "into_scalar", "Transaction"] {
                if code(library).contains(read) {
                    offenders.push(format!("{}: {read}", file.display()));
                }
            }
        }
    }
    assert!(
        offenders.is_empty(),
        "reads outside foosball_nets::host: {offenders:?}"
    );
}

#[test]
fn the_check_finds_circles_through_crate_super_and_grouped_paths() {
    let m = |name: &str, text: &str| (name.to_string(), text.to_string());
    let circle = [
        m("", "pub mod a; pub mod b;"),
        m(
            "a",
            "use crate::b::Thing;\n/// [`crate::c`] in a doc is no import",
        ),
        m("b", "use crate::{c::More, config};"),
        m("c", "pub fn f() { super::a::g() }"),
        m("config", ""),
    ];
    let g = graph(&circle);
    assert_eq!(
        g["b"],
        BTreeSet::from(["c".to_string(), "config".to_string()])
    );
    assert_eq!(cycle(&g).unwrap(), ["a", "b", "c", "a"]);
    let line = [
        m("a", "use crate::b::x;"),
        m("b", "// use crate::a::y;"),
        m("p::q", "use super::r;"),
        m("p::r", "use crate::a;"),
        m("p", ""),
    ];
    let g = graph(&line);
    assert!(cycle(&g).is_none(), "{g:?}");
    assert_eq!(g["p::q"], BTreeSet::from(["p::r".to_string()]));
    assert_eq!(groups(&g)["p"], BTreeSet::from(["a".to_string()]));
}
