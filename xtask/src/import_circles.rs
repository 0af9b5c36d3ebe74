//! `cargo xtask import-circles`: modules of the crate that reach each other through
//! `crate::` and `super::` paths.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The command's help.
pub const HELP: &str = "\
usage: cargo xtask import-circles [SRC_DIR]

Reads every `.rs` file under SRC_DIR (default: src), takes each `crate::a::b::...` path in code
and `super::...` path in code (comments and `#[cfg(test)] mod tests` at the end of a file are
skipped; `use crate::{...}` and `use super::{...}` groups are expanded) and resolves it to the
longest module it names. Two graphs are checked: the files (a module file and the modules it
uses; a module's own `mod` children do not count) and the top-level modules
(`crate::solver::newton` counts as `solver`). Prints every circle with the edges that make it;
exit status 1 when there is one.";

type Graph = BTreeMap<String, BTreeSet<String>>;

/// Runs the command; returns its exit status.
pub fn main(args: &[String]) -> u8 {
    let root = PathBuf::from(args.first().map_or("src", String::as_str));
    let files = graph(&root);
    let mut top: Graph = BTreeMap::new();
    for (a, targets) in &files {
        let head = |m: &str| m.split("::").next().unwrap_or("").to_string();
        top.entry(head(a)).or_default();
        for b in targets {
            if head(a) != head(b) {
                top.entry(head(a)).or_default().insert(head(b));
                top.entry(head(b)).or_default();
            }
        }
    }
    let count = report("file", &files) + report("top-level module", &top);
    println!("{count} import circles ({} modules read)", files.len());
    u8::from(count > 0)
}

fn module_name(root: &Path, path: &Path) -> String {
    let relative = path.strip_prefix(root).unwrap_or(path).with_extension("");
    let mut parts: Vec<String> = relative
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts
        .last()
        .is_some_and(|last| ["mod", "lib", "main"].contains(&last.as_str()))
    {
        parts.pop();
    }
    parts.join("::")
}

/// The code of a file: without the `#[cfg(test)] mod tests` that ends it and without lines
/// that are comments.
fn code_of(source: &str) -> String {
    let source = match source.find("#[cfg(test)]\nmod tests") {
        Some(end) => &source[..end],
        None => source,
    };
    source
        .split('\n')
        .filter(|line| !line.trim().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

fn is_word(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The path `a::b::c` of words starting at `at` (the longest that does not end in `::`),
/// and where it ends; None when no word starts there.
fn word_path(chars: &[char], at: usize) -> Option<(String, usize)> {
    let word_end = |from: usize| {
        (from..chars.len())
            .find(|&k| !is_word(chars[k]))
            .unwrap_or(chars.len())
    };
    let mut end = word_end(at);
    if end == at {
        return None;
    }
    loop {
        let next = end + 2;
        if end + 1 < chars.len()
            && chars[end] == ':'
            && chars[end + 1] == ':'
            && next < chars.len()
            && is_word(chars[next])
        {
            end = word_end(next);
        } else {
            return Some((chars[at..end].iter().collect(), end));
        }
    }
}

/// Every path that follows `prefix` in `chars` (non-overlapping, left to right); with
/// `after_boundary`, only where the prefix is not preceded by a word character or `:`.
fn paths_after(chars: &[char], prefix: &str, after_boundary: bool) -> Vec<String> {
    let prefix: Vec<char> = prefix.chars().collect();
    let mut found = Vec::new();
    let mut k = 0;
    while k + prefix.len() <= chars.len() {
        let boundary = !after_boundary || k == 0 || !(is_word(chars[k - 1]) || chars[k - 1] == ':');
        if boundary && chars[k..k + prefix.len()] == prefix[..] {
            if let Some((path, end)) = word_path(chars, k + prefix.len()) {
                found.push(path);
                k = end;
                continue;
            }
        }
        k += 1;
    }
    found
}

/// The items of a `use` group body, each with `prefix` in front (nested groups expanded).
fn expand_group(prefix: &str, body: &str) -> Vec<String> {
    let mut paths = Vec::new();
    let mut depth = 0;
    let mut current = String::new();
    for ch in body.chars().chain(std::iter::once(',')) {
        if ch == '{' {
            depth += 1;
        }
        if ch == '}' {
            depth -= 1;
        }
        if ch == ',' && depth == 0 {
            let item = current.trim();
            if let Some(open) = item.find('{') {
                let head = item[..open].trim_end_matches(':').trim();
                let close = item.rfind('}').unwrap_or(item.len());
                paths.extend(expand_group(
                    &format!("{prefix}{head}::"),
                    item.get(open + 1..close).unwrap_or(""),
                ));
            } else if !item.is_empty() {
                paths.push(format!(
                    "{prefix}{}",
                    item.split(" as ").next().unwrap_or("").trim()
                ));
            }
            current.clear();
        } else {
            current.push(ch);
        }
    }
    paths
}

/// The bodies of every `<opening>{ ... }` group in `code`.
fn group_bodies(chars: &[char], opening: &str) -> Vec<String> {
    let opening: Vec<char> = opening.chars().collect();
    let mut bodies = Vec::new();
    let mut k = 0;
    while k + opening.len() <= chars.len() {
        if chars[k..k + opening.len()] != opening[..] {
            k += 1;
            continue;
        }
        let start = k + opening.len();
        let (mut end, mut depth) = (start, 1);
        while depth > 0 && end < chars.len() {
            depth += match chars[end] {
                '{' => 1,
                '}' => -1,
                _ => 0,
            };
            end += 1;
        }
        bodies.push(
            chars[start..end.saturating_sub(1).max(start)]
                .iter()
                .collect(),
        );
        k = start;
    }
    bodies
}

/// The module paths `code` names, from the crate root (`super::` resolved against `module`,
/// whether its file is `x.rs` or `x/mod.rs`).
fn paths_in(code: &str, module: &str) -> Vec<String> {
    let parent: Vec<&str> = if module.is_empty() {
        Vec::new()
    } else {
        let parts: Vec<&str> = module.split("::").collect();
        parts[..parts.len() - 1].to_vec()
    };
    let chars: Vec<char> = code.chars().collect();
    let mut paths = paths_after(&chars, "crate::", false);
    for found in paths_after(&chars, "super::", true) {
        paths.push(if parent.is_empty() {
            found
        } else {
            format!("{}::{found}", parent.join("::"))
        });
    }
    let prefix = if parent.is_empty() {
        String::new()
    } else {
        format!("{}::", parent.join("::"))
    };
    for body in group_bodies(&chars, "use super::{") {
        paths.extend(expand_group(&prefix, &body));
    }
    for body in group_bodies(&chars, "use crate::{") {
        paths.extend(expand_group("", &body));
    }
    paths
}

/// The files' graph: each module and the modules its code names.
fn graph(root: &Path) -> Graph {
    let mut sources = BTreeMap::new();
    read_sources(root, root, &mut sources);
    let modules: BTreeSet<String> = sources.keys().cloned().collect();
    let mut edges: Graph = modules
        .iter()
        .map(|m| (m.clone(), BTreeSet::new()))
        .collect();
    for (module, source) in &sources {
        let last = module.rsplit("::").next().unwrap_or("");
        if last == "tests" || last == "test_support" {
            continue;
        }
        for path in paths_in(&code_of(source), module) {
            let parts: Vec<&str> = path.split("::").collect();
            for k in (1..=parts.len()).rev() {
                let target = parts[..k].join("::");
                if modules.contains(&target) {
                    if &target != module && !module.starts_with(&format!("{target}::")) {
                        edges.get_mut(module).map(|e| e.insert(target));
                    }
                    break;
                }
            }
        }
    }
    edges
}

/// Reads every `.rs` file under `folder` in directory order (a later file of the same module
/// name, `lib.rs` and `main.rs` both being the root, replaces an earlier one, as the Python
/// walk did).
fn read_sources(root: &Path, folder: &Path, sources: &mut BTreeMap<String, String>) {
    let Ok(entries) = std::fs::read_dir(folder) else {
        return;
    };
    let mut folders = Vec::new();
    for entry in entries.flatten() {
        let path = entry.path();
        if entry.file_type().is_ok_and(|t| t.is_dir()) {
            folders.push(path);
        } else if path.extension().is_some_and(|e| e == "rs") {
            sources.insert(module_name(root, &path), crate::source::read_text(&path));
        }
    }
    for sub in folders {
        read_sources(root, &sub, sources);
    }
}

/// Strongly connected components with more than one node (Tarjan).
fn circles(edges: &Graph) -> Vec<Vec<String>> {
    struct Search<'a> {
        edges: &'a Graph,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        found: Vec<Vec<String>>,
    }
    impl<'a> Search<'a> {
        fn visit(&mut self, v: &'a str) {
            let n = self.index.len();
            self.index.insert(v, n);
            self.low.insert(v, n);
            self.stack.push(v);
            self.on_stack.insert(v);
            for w in self.edges.get(v).into_iter().flatten() {
                let w = w.as_str();
                if !self.index.contains_key(w) {
                    self.visit(w);
                    self.low.insert(v, self.low[v].min(self.low[w]));
                } else if self.on_stack.contains(w) {
                    self.low.insert(v, self.low[v].min(self.index[w]));
                }
            }
            if self.low[v] == self.index[v] {
                let mut component = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on_stack.remove(w);
                    component.push(w.to_string());
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    component.sort();
                    self.found.push(component);
                }
            }
        }
    }
    let mut search = Search {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in edges.keys() {
        if !search.index.contains_key(v.as_str()) {
            search.visit(v);
        }
    }
    search.found
}

fn report(title: &str, edges: &Graph) -> usize {
    let found = circles(edges);
    for component in &found {
        println!("{title} circle: {}", component.join(", "));
        for a in component {
            for b in edges.get(a).into_iter().flatten() {
                if component.contains(b) {
                    println!("  {a} -> {b}");
                }
            }
        }
    }
    found.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_and_groups_resolve_from_the_crate_root() {
        let code = "use crate::{a::b, c::{d, e as f}};\nuse super::{g, h::i};\nlet x = crate::j::k::{l};\nfoo::super::m;";
        let paths = paths_in(code, "p::q");
        for expected in ["j::k", "p::g", "p::h::i", "a::b", "c::d", "c::e"] {
            assert!(
                paths.contains(&expected.to_string()),
                "{expected} in {paths:?}"
            );
        }
        assert!(!paths.iter().any(|p| p.ends_with("m")), "{paths:?}");
    }

    #[test]
    fn a_circle_is_found_with_its_edges() {
        let mut graph: Graph = BTreeMap::new();
        graph.entry("a".into()).or_default().insert("b".into());
        graph.entry("b".into()).or_default().insert("a".into());
        graph.entry("c".into()).or_default().insert("a".into());
        assert_eq!(
            circles(&graph),
            vec![vec!["a".to_string(), "b".to_string()]]
        );
    }
}
