//! The crate's layers import only downwards: no import cycles between its modules, and the
//! core, the pipeline and the methods import nothing of the layers above them. Read from the
//! sources' `use` lines and `crate::`/`super::` paths (test code left out), so a new upward
//! import fails here with the modules it joins.
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

type Module = Vec<String>;

/// Every module of the tree under `src`: its path (`["methods", "aaf_shadows"]`) and source
/// text without test code.
fn modules(src: &Path) -> BTreeMap<Module, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let rel = path.strip_prefix(src).unwrap().with_extension("");
            let mut parts: Module = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
            if parts.last().is_some_and(|p| p == "tests") || parts.iter().any(|p| p == "tests") {
                continue; // test modules may import anything
            }
            if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
                parts.pop();
            }
            let text = std::fs::read_to_string(&path).unwrap();
            let code = match text.find("#[cfg(test)]\nmod tests") {
                Some(i) => text[..i].to_string(),
                None => text,
            };
            out.insert(parts, code);
        }
    }
    out
}

/// `a::{b, c::{d, e}}` -> `a::b`, `a::c::d`, `a::c::e`.
fn expand(body: &str) -> Vec<String> {
    let body = body.trim();
    let Some(open) = body.find('{') else { return vec![body.to_string()] };
    let (prefix, inner) = (&body[..open], &body[open + 1..body.rfind('}').unwrap_or(body.len())]);
    let (mut items, mut depth, mut cur) = (Vec::new(), 0, String::new());
    for ch in inner.chars() {
        match ch {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(std::mem::take(&mut cur));
                continue;
            }
            _ => {}
        }
        cur.push(ch);
    }
    items.push(cur);
    items.iter().filter(|i| !i.trim().is_empty()).flat_map(|i| expand(&format!("{prefix}{}", i.trim()))).collect()
}

/// The paths a module's code names: its `use` items and inline `crate::`/`super::` paths.
fn paths(code: &str) -> Vec<String> {
    let lines: String = code.lines().filter(|l| !l.trim_start().starts_with("//")).map(|l| format!("{l}\n")).collect();
    let mut out = Vec::new();
    let mut rest = lines.as_str();
    while let Some(i) = rest.find("use ") {
        let before_ok = i == 0 || !rest.as_bytes()[i - 1].is_ascii_alphanumeric() && rest.as_bytes()[i - 1] != b'_';
        let tail = &rest[i + 4..];
        let end = tail.find(';').unwrap_or(tail.len());
        if before_ok && (tail.starts_with("crate::") || tail.starts_with("super::") || tail.starts_with("self::")) {
            out.extend(expand(&tail[..end]));
        }
        rest = &tail[end.min(tail.len())..];
    }
    for start in ["crate::", "super::"] {
        let mut rest = lines.as_str();
        while let Some(i) = rest.find(start) {
            let tail = &rest[i..];
            let end = tail.find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).unwrap_or(tail.len());
            out.push(tail[..end].trim_end_matches(':').to_string());
            rest = &tail[end..];
        }
    }
    out
}

/// The module a path names: the deepest module of the tree it reaches.
fn resolve(from: &Module, path: &str, all: &BTreeMap<Module, String>, file_is_mod_rs: bool) -> Option<Module> {
    let mut segs: Vec<&str> = path.split("::").map(str::trim).collect();
    let mut base: Module = match segs.first()? {
        &"crate" => Vec::new(),
        &"super" | &"self" => {
            // In a mod.rs, `super` is the parent of the folder's module; in a.rs, of a.
            let mut b = from.clone();
            if !file_is_mod_rs || segs[0] == "super" {
                b.pop();
            }
            if segs[0] == "self" && !file_is_mod_rs {
                b = from.clone();
            }
            b
        }
        _ => return None,
    };
    segs.remove(0);
    while segs.first() == Some(&"super") {
        base.pop();
        segs.remove(0);
    }
    let mut best = None;
    for s in segs {
        base.push(s.split_whitespace().next().unwrap_or(s).to_string());
        if all.contains_key(&base) {
            best = Some(base.clone());
        } else {
            break;
        }
    }
    best
}

/// Module -> the modules it imports, leaving out edges into its own ancestors (a child using
/// its parent's items) and into modules that only declare submodules.
fn graph(src: &Path) -> BTreeMap<Module, BTreeSet<Module>> {
    let all = modules(src);
    let only_declares = |code: &str| {
        !code.lines().any(|l| {
            let t = l.trim_start().trim_start_matches("pub ").trim_start_matches("pub(crate) ");
            ["fn ", "struct ", "enum ", "trait ", "impl", "const ", "static ", "type "].iter().any(|k| t.starts_with(k))
        })
    };
    let mut g = BTreeMap::new();
    for (m, code) in &all {
        let is_mod_rs = src.join(m.join("/")).join("mod.rs").exists() || m.is_empty();
        let mut to = BTreeSet::new();
        for p in paths(code) {
            let Some(t) = resolve(m, &p, &all, is_mod_rs) else { continue };
            if &t == m || m.starts_with(&t) || only_declares(&all[&t]) {
                continue;
            }
            to.insert(t);
        }
        g.insert(m.clone(), to);
    }
    g
}

/// Strongly connected groups of two or more modules (Tarjan).
fn cycles(g: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct State<'a> {
        g: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        stack: Vec<&'a Module>,
        on: BTreeSet<&'a Module>,
        out: Vec<Vec<Module>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a Module) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on.insert(v);
        for w in s.g.get(v).into_iter().flatten() {
            let Some((w, _)) = s.g.get_key_value(w) else { continue };
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                s.low.entry(v).and_modify(|l| *l = (*l).min(lw));
            } else if s.on.contains(w) {
                let iw = s.index[w];
                s.low.entry(v).and_modify(|l| *l = (*l).min(iw));
            }
        }
        if s.low[v] == s.index[v] {
            let mut group = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(w);
                group.push(w.clone());
                if w == v {
                    break;
                }
            }
            if group.len() > 1 {
                s.out.push(group);
            }
        }
    }
    let mut s = State {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in g.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

fn name(m: &Module) -> String {
    m.join("::")
}

#[test]
fn no_module_imports_a_module_that_imports_it_back() {
    let g = graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(g.len() > 50, "the scan found only {} modules", g.len());
    let found: Vec<String> = cycles(&g).iter().map(|c| c.iter().map(name).collect::<Vec<_>>().join(" <-> ")).collect();
    assert!(found.is_empty(), "import cycles: {found:#?}");
}

#[test]
fn lower_layers_import_nothing_above_them() {
    let g = graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    // (layer, what it may not import)
    let rules: &[(&str, &[&str])] = &[
        (
            "render",
            &["pipeline", "methods", "scene", "api", "runner", "server", "client", "cli", "bench", "output", "proto"],
        ),
        (
            "methods",
            &[
                "pipeline::registry",
                "pipeline::progressive",
                "scene",
                "api",
                "runner",
                "server",
                "cli",
                "bench",
                "proto",
            ],
        ),
        (
            "pipeline::job",
            &["pipeline::registry", "pipeline::progressive", "pipeline::strategy", "api", "server", "proto"],
        ),
        ("pipeline", &["scene", "api", "runner", "server", "client", "cli", "bench", "output"]),
        ("api", &["runner", "server", "client", "cli", "bench"]),
        ("runner", &["server", "client", "cli", "bench"]),
    ];
    let mut broken = Vec::new();
    for (m, to) in &g {
        let from = name(m);
        for (layer, banned) in rules {
            if from != *layer && !from.starts_with(&format!("{layer}::")) {
                continue;
            }
            for t in to {
                let t = name(t);
                if banned.iter().any(|b| t == *b || t.starts_with(&format!("{b}::"))) {
                    broken.push(format!("{from} -> {t}"));
                }
            }
        }
    }
    assert!(broken.is_empty(), "upward imports: {broken:#?}");
}

#[test]
fn the_check_finds_a_cycle_and_an_upward_import() {
    let dir = std::env::temp_dir().join(format!("wedge-layers-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("render")).unwrap();
    std::fs::write(dir.join("lib.rs"), "pub mod render;\npub mod pipeline;\n").unwrap();
    std::fs::write(dir.join("render/mod.rs"), "pub mod camera;\n").unwrap();
    std::fs::write(dir.join("render/camera.rs"), "use crate::pipeline::{job::Job, Other};\npub struct Camera;\n")
        .unwrap();
    std::fs::write(dir.join("pipeline.rs"), "use crate::render::camera::Camera;\npub struct Other;\n").unwrap();
    let g = graph(&dir);
    let c = cycles(&g);
    assert_eq!(c.len(), 1, "{g:?}");
    let mut names: Vec<String> = c[0].iter().map(name).collect();
    names.sort();
    assert_eq!(names, ["pipeline", "render::camera"]);
    std::fs::remove_dir_all(&dir).unwrap();
}
