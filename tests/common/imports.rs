//! The file-level import graph of `src/`: which source file names which (through `use` lines and
//! paths written inline), read from the source text. `tests/house.rs` checks it against the layers
//! of `docs/architecture.md` (no circles, no arrow from a lower layer to a higher one), and
//! `tools/module_map.rs` draws it.
//!
//! A path is resolved through the file system the way rustc finds module files: `crate::a::b::c`
//! from the library is `src/a/b.rs` (or `src/a/b/mod.rs`) if `c` is not a module of its own;
//! `super::` and `self::` are relative to the file's module; `wavetrace::` (from the binary's
//! files) is the library's root. Comments, strings and inline `mod tests { … }` blocks are left
//! out: a doc link or a unit test is no import.

#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, as paths relative to `root`, sorted.
pub fn rust_files(root: &Path, dir: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![root.join(dir)];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(relative(root, &path));
            }
        }
    }
    out.sort();
    out
}

fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap()
        .to_string_lossy()
        .replace('\\', "/")
}

/// The source without comments, string and character literals, and inline `mod NAME { … }`
/// blocks (unit tests), so that only code is left.
pub fn code_only(source: &str) -> String {
    let bytes = source.as_bytes();
    let mut out = String::with_capacity(source.len());
    let mut i = 0;
    while i < bytes.len() {
        let rest = &source[i..];
        if rest.starts_with("//") {
            i += rest.find('\n').unwrap_or(rest.len());
        } else if rest.starts_with("/*") {
            i += rest.find("*/").map_or(rest.len(), |e| e + 2);
        } else if rest.starts_with("r#\"") || rest.starts_with("r\"") {
            let hashes = rest[1..].bytes().take_while(|&b| b == b'#').count();
            let close = format!("\"{}", "#".repeat(hashes));
            let body = 2 + hashes;
            i += rest[body..]
                .find(&close)
                .map_or(rest.len(), |e| body + e + close.len());
            out.push_str("\"\"");
        } else if bytes[i] == b'"' {
            let mut j = i + 1;
            while j < bytes.len() && bytes[j] != b'"' {
                j += if bytes[j] == b'\\' { 2 } else { 1 };
            }
            i = j + 1;
            out.push_str("\"\"");
        } else if bytes[i] == b'\'' && is_char_literal(rest) {
            let len = rest[1..].find('\'').unwrap() + 2;
            i += len;
            out.push_str("' '");
        } else {
            let c = rest.chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    strip_inline_modules(&out)
}

/// Whether `rest` (starting at a quote) is a character literal rather than a lifetime.
fn is_char_literal(rest: &str) -> bool {
    let b = rest.as_bytes();
    (b.len() > 2 && b[1] == b'\\') || (b.len() > 2 && rest[1..].chars().nth(1) == Some('\''))
}

/// `code` without the bodies of inline modules (`mod tests { … }`).
fn strip_inline_modules(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(at) = find_inline_mod(rest) {
        out.push_str(&rest[..at]);
        let open = at + rest[at..].find('{').unwrap();
        let mut depth = 0usize;
        let mut end = rest.len();
        for (k, c) in rest[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + k + 1;
                        break;
                    }
                }
                _ => {}
            }
        }
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

/// Where the next `mod NAME {` starts in `code`.
fn find_inline_mod(code: &str) -> Option<usize> {
    let mut from = 0;
    while let Some(k) = code[from..].find("mod ") {
        let at = from + k;
        let before_ok = at == 0 || !is_ident(code.as_bytes()[at - 1]);
        let after = code[at + 4..].trim_start();
        let name_len = after.bytes().take_while(|&b| is_ident(b)).count();
        if before_ok && name_len > 0 && after[name_len..].trim_start().starts_with('{') {
            return Some(at);
        }
        from = at + 4;
    }
    None
}

fn is_ident(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

/// The module paths a piece of code names: every `use` tree expanded (`use a::{b, c::d}` gives
/// `a::b` and `a::c::d`), and every inline path that starts with `crate::`, `super::`, `self::`
/// or `wavetrace::`.
pub fn named_paths(code: &str) -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    let bytes = code.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let word_start = i == 0 || !is_ident(bytes[i - 1]);
        if word_start && code[i..].starts_with("use ") {
            let end = i + code[i..].find(';').unwrap_or(code.len() - i);
            expand_use_tree(code[i + 4..end].trim(), &mut Vec::new(), &mut paths);
            i = end;
            continue;
        }
        if word_start && (bytes[i].is_ascii_alphabetic() || bytes[i] == b'_') {
            let len = code[i..]
                .bytes()
                .take_while(|&b| is_ident(b) || b == b':')
                .count();
            let text = &code[i..i + len];
            if text.contains("::") {
                paths.push(
                    text.split("::")
                        .filter(|s| !s.is_empty())
                        .map(str::to_owned)
                        .collect(),
                );
            }
            i += len.max(1);
            continue;
        }
        i += 1;
    }
    paths
}

/// Expands one `use` tree after `use ` into whole paths, each prefixed by `prefix`.
fn expand_use_tree(tree: &str, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    let tree = tree.trim();
    if let Some(open) = tree.find('{') {
        let head: Vec<String> = tree[..open]
            .split("::")
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::to_owned)
            .collect();
        let n = prefix.len();
        prefix.extend(head);
        let close = tree.rfind('}').unwrap_or(tree.len());
        for part in split_top_level(&tree[open + 1..close]) {
            expand_use_tree(part, prefix, out);
        }
        prefix.truncate(n);
    } else {
        let path = tree.split(" as ").next().unwrap().trim();
        if path.is_empty() {
            return;
        }
        let mut whole = prefix.clone();
        whole.extend(
            path.split("::")
                .map(str::trim)
                .filter(|s| !s.is_empty() && *s != "self")
                .map(str::to_owned),
        );
        out.push(whole);
    }
}

/// `a, b::{c, d}, e` split at the commas outside braces.
fn split_top_level(list: &str) -> Vec<&str> {
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (k, c) in list.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&list[start..k]);
                start = k + 1;
            }
            _ => {}
        }
    }
    parts.push(&list[start..]);
    parts.into_iter().filter(|p| !p.trim().is_empty()).collect()
}

/// The module path of a source file (`src/cpu/path.rs` → `[cpu, path]`; `src/cpu/mod.rs`,
/// `src/lib.rs` and `src/main.rs` name their folder's module).
pub fn module_of(file: &str) -> Vec<String> {
    let inner = file
        .strip_prefix("src/")
        .unwrap()
        .strip_suffix(".rs")
        .unwrap();
    let mut parts: Vec<String> = inner.split('/').map(str::to_owned).collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The file that holds module `path` (relative to `src/`) or the deepest module on the way to
/// it: the items after the last module are the file's own.
pub fn file_of(root: &Path, path: &[String], crate_root: &str) -> String {
    let mut best = crate_root.to_owned();
    let mut dir = PathBuf::from("src");
    for segment in path {
        let flat = dir.join(format!("{segment}.rs"));
        let folder = dir.join(segment).join("mod.rs");
        if root.join(&flat).is_file() {
            best = relative(root, &root.join(&flat));
        } else if root.join(&folder).is_file() {
            best = relative(root, &root.join(&folder));
        } else {
            break;
        }
        dir = dir.join(segment);
    }
    best
}

/// The files of the binary: `src/main.rs` and the modules it declares, transitively.
pub fn binary_files(root: &Path) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let mut todo = vec!["src/main.rs".to_owned()];
    while let Some(file) = todo.pop() {
        if !found.insert(file.clone()) {
            continue;
        }
        let code = code_only(&std::fs::read_to_string(root.join(&file)).unwrap());
        let module = module_of(&file);
        for line in code.lines() {
            let line = line.trim();
            let declared = line
                .strip_prefix("pub(crate) mod ")
                .or_else(|| line.strip_prefix("pub mod "))
                .or_else(|| line.strip_prefix("mod "));
            if let Some(name) = declared.and_then(|d| d.strip_suffix(';')) {
                let mut path = module.clone();
                path.push(name.trim().to_owned());
                let child = file_of(root, &path, "");
                if !child.is_empty() && module_of(&child) == path {
                    todo.push(child);
                }
            }
        }
    }
    found
}

/// Every file-to-file import in `src/`: `from → {to}`, without a file's arrows to itself.
pub fn import_graph(root: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let binary = binary_files(root);
    let mut graph = BTreeMap::new();
    for file in rust_files(root, "src") {
        let code = code_only(&std::fs::read_to_string(root.join(&file)).unwrap());
        let module = module_of(&file);
        let crate_root = if binary.contains(&file) {
            "src/main.rs"
        } else {
            "src/lib.rs"
        };
        let mut targets = BTreeSet::new();
        for path in named_paths(&code) {
            let absolute: Vec<String> = match path.first().map(String::as_str) {
                Some("crate") => path[1..].to_vec(),
                Some("wavetrace") => {
                    let target = file_of(root, &path[1..], "src/lib.rs");
                    targets.insert(target);
                    continue;
                }
                Some("self") => module.iter().chain(&path[1..]).cloned().collect(),
                Some("super") => {
                    let supers = path.iter().take_while(|s| *s == "super").count();
                    let keep = module.len().saturating_sub(supers);
                    module[..keep]
                        .iter()
                        .chain(&path[supers..])
                        .cloned()
                        .collect()
                }
                // A path relative to the file's module: its child modules (2018 edition).
                Some(_) => {
                    let relative: Vec<String> = module.iter().chain(&path).cloned().collect();
                    let target = file_of(root, &relative, crate_root);
                    if module_of(&target).len() > module.len() {
                        targets.insert(target);
                    }
                    continue;
                }
                None => continue,
            };
            targets.insert(file_of(root, &absolute, crate_root));
        }
        targets.remove(&file);
        graph.insert(file, targets);
    }
    graph
}

/// The import circles of `graph`: its strongly connected components of more than one file
/// (Tarjan's algorithm), each sorted.
pub fn circles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct Walk<'a> {
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        found: Vec<Vec<String>>,
    }
    impl<'a> Walk<'a> {
        fn visit(&mut self, v: &'a str) {
            let n = self.index.len();
            self.index.insert(v, n);
            self.low.insert(v, n);
            self.stack.push(v);
            self.on_stack.insert(v);
            let graph = self.graph;
            for w in graph.get(v).into_iter().flatten() {
                let w = w.as_str();
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let low = self.low[v].min(self.low[w]);
                    self.low.insert(v, low);
                } else if self.on_stack.contains(w) {
                    let low = self.low[v].min(self.index[w]);
                    self.low.insert(v, low);
                }
            }
            if self.low[v] == self.index[v] {
                let mut component = Vec::new();
                loop {
                    let w = self.stack.pop().unwrap();
                    self.on_stack.remove(w);
                    component.push(w.to_owned());
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
    let mut walk = Walk {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in graph.keys() {
        if !walk.index.contains_key(v.as_str()) {
            walk.visit(v);
        }
    }
    walk.found
}
