//! The house: the module map in docs/architecture.md is true (every file it names exists, every
//! file of src/ and shaders/ is named, each Rust file in one layer), the source files import each
//! other without circles and without an arrow from a lower layer to a higher one, and the
//! picture of the module map is the one the source draws (`tools/module_map.sh` draws it again).

#[path = "common/imports.rs"]
mod imports;

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

const ARCHITECTURE: &str = "docs/architecture.md";

/// The "## Module map" section of docs/architecture.md.
fn module_map() -> String {
    let doc = std::fs::read_to_string(root().join(ARCHITECTURE)).unwrap();
    let start = doc
        .find("\n## Module map")
        .expect("docs/architecture.md has a '## Module map' section");
    let rest = &doc[start + 1..];
    let end = rest[3..].find("\n## ").map_or(rest.len(), |e| e + 3);
    rest[..end].to_owned()
}

/// The backticked paths of `text` under src/ or shaders/.
fn named_paths(text: &str) -> Vec<String> {
    text.split('`')
        .skip(1)
        .step_by(2)
        .filter(|t| t.starts_with("src/") || t.starts_with("shaders/"))
        .map(str::to_owned)
        .collect()
}

/// Each Rust file of the map's layer tables ("### Layer N: …", first column) with its layer.
fn layers(map: &str) -> BTreeMap<String, u32> {
    let mut out = BTreeMap::new();
    let mut layer = None;
    for line in map.lines() {
        if let Some(heading) = line.strip_prefix("### ") {
            layer = heading
                .strip_prefix("Layer ")
                .and_then(|h| h.split(':').next())
                .and_then(|n| n.trim().parse::<u32>().ok());
        } else if let (Some(n), Some(cell)) = (layer, line.strip_prefix("| `")) {
            let file = cell.split('`').next().unwrap();
            if file.starts_with("src/") {
                let before = out.insert(file.to_owned(), n);
                assert!(before.is_none(), "{file} stands in the module map twice");
            }
        }
    }
    out
}

/// Every file under `dir` (relative to the repository), sorted.
fn files_under(dir: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![root().join(dir)];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path.strip_prefix(root()).unwrap();
                out.push(rel.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn no_file_imports_a_file_that_imports_it_back() {
    let graph = imports::import_graph(root());
    if std::env::var_os("WAVETRACE_PRINT_IMPORTS").is_some() {
        for (from, to) in &graph {
            println!(
                "{from} -> {}",
                to.iter().cloned().collect::<Vec<_>>().join(" ")
            );
        }
    }
    let circles = imports::circles(&graph);
    assert!(
        circles.is_empty(),
        "import circles between files (each line one circle):\n{}",
        circles
            .iter()
            .map(|c| c.join(" ⇄ "))
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn the_module_map_names_every_file_and_only_files_that_exist() {
    let map = module_map();
    let named: BTreeSet<String> = named_paths(&map).into_iter().collect();
    let missing: Vec<&String> = named
        .iter()
        .filter(|p| {
            let path = root().join(p);
            if p.ends_with('/') {
                !path.is_dir()
            } else {
                !path.is_file()
            }
        })
        .collect();
    assert!(
        missing.is_empty(),
        "{ARCHITECTURE} names files that do not exist: {missing:?}"
    );
    let mut unnamed: Vec<String> = files_under("src")
        .into_iter()
        .chain(files_under("shaders"))
        .filter(|f| !named.contains(f))
        .collect();
    unnamed.sort();
    assert!(
        unnamed.is_empty(),
        "{ARCHITECTURE}'s module map does not name: {unnamed:?}"
    );
    let layers = layers(&map);
    let unplaced: Vec<String> = imports::rust_files(root(), "src")
        .into_iter()
        .filter(|f| !layers.contains_key(f))
        .collect();
    assert!(
        unplaced.is_empty(),
        "Rust files in no layer table of {ARCHITECTURE}: {unplaced:?}"
    );
}

#[test]
fn no_file_imports_from_a_layer_above_its_own() {
    let layers = layers(&module_map());
    let graph = imports::import_graph(root());
    let mut upward = Vec::new();
    for (from, targets) in &graph {
        for to in targets {
            if let (Some(a), Some(b)) = (layers.get(from), layers.get(to)) {
                if b > a {
                    upward.push(format!("{from} (layer {a}) imports {to} (layer {b})"));
                }
            }
        }
    }
    assert!(
        upward.is_empty(),
        "imports from a lower layer to a higher one:\n{}",
        upward.join("\n")
    );
}

/// The group a file is drawn in: its folder (`bsdf/`) or, for a file at the top of `src/`, its
/// name (`layout`); a file of a folder whose layer differs from its folder's `mod.rs` is drawn
/// on its own (`bsdf/sheen_table`).
fn unit(file: &str, layers: &BTreeMap<String, u32>) -> String {
    let inner = file
        .strip_prefix("src/")
        .unwrap()
        .strip_suffix(".rs")
        .unwrap();
    match inner.split_once('/') {
        None => inner.to_owned(),
        Some((folder, _)) => {
            let folder_layer = layers.get(&format!("src/{folder}/mod.rs"));
            if folder_layer.is_some() && folder_layer != layers.get(file) {
                inner.to_owned()
            } else {
                format!("{folder}/")
            }
        }
    }
}

/// The picture: a Mermaid flowchart of the units by layer, with the import arrows between units
/// (of the code, not its unit tests) that no longer path of arrows implies.
fn picture() -> String {
    let map = module_map();
    let layers = layers(&map);
    let titles: BTreeMap<u32, String> = map
        .lines()
        .filter_map(|l| l.strip_prefix("### Layer "))
        .filter_map(|h| {
            let (n, title) = h.split_once(':')?;
            Some((n.trim().parse().ok()?, title.trim().to_owned()))
        })
        .collect();
    let graph = imports::import_graph(root());
    let mut unit_layer: BTreeMap<String, u32> = BTreeMap::new();
    // (The Python package's files under src/python/ are not Rust: named in the map, not drawn.)
    for (file, layer) in layers.iter().filter(|(f, _)| f.ends_with(".rs")) {
        let u = unit(file, &layers);
        let l = unit_layer.entry(u).or_insert(*layer);
        *l = (*l).max(*layer);
    }
    let mut edges: BTreeSet<(String, String)> = BTreeSet::new();
    // (Unit tests are left out: they import what they test from, not what the code builds on.)
    for (from, targets) in graph.iter().filter(|(f, _)| !f.ends_with("/tests.rs")) {
        for to in targets {
            let (a, b) = (unit(from, &layers), unit(to, &layers));
            if a != b && layers.contains_key(to) {
                edges.insert((a, b));
            }
        }
    }
    // Transitive reduction: leave out a → b where b is reachable from a another way.
    let reachable = |from: &str, to: &str, skip: &(String, String)| -> bool {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.to_owned()];
        while let Some(u) = stack.pop() {
            for (a, b) in &edges {
                if a == &u && (a, b) != (&skip.0, &skip.1) && seen.insert(b.clone()) {
                    if b == to {
                        return true;
                    }
                    stack.push(b.clone());
                }
            }
        }
        false
    };
    let kept: Vec<&(String, String)> = edges.iter().filter(|e| !reachable(&e.0, &e.1, e)).collect();
    let id = |u: &str| u.trim_end_matches('/').replace('/', "_");
    let mut out = String::from("```mermaid\nflowchart BT\n");
    for (n, title) in titles.iter().rev() {
        out += &format!("  subgraph L{n}[\"{n}. {title}\"]\n");
        for (u, l) in &unit_layer {
            if l == n {
                out += &format!("    {}[\"{u}\"]\n", id(u));
            }
        }
        out += "  end\n";
    }
    for (a, b) in kept {
        out += &format!("  {} --> {}\n", id(a), id(b));
    }
    out += "```\n";
    out
}

#[test]
fn the_picture_of_the_house_is_the_one_the_source_draws() {
    let path = root().join(ARCHITECTURE);
    let doc = std::fs::read_to_string(&path).unwrap();
    let (open, close) = (
        "<!-- module-map-picture -->\n",
        "<!-- /module-map-picture -->",
    );
    let start = doc.find(open).expect("the picture's opening marker") + open.len();
    let end = doc.find(close).expect("the picture's closing marker");
    let drawn = picture();
    if std::env::var_os("WAVETRACE_WRITE_MODULE_MAP").is_some() {
        let updated = format!("{}{drawn}{}", &doc[..start], &doc[end..]);
        std::fs::write(&path, updated).unwrap();
        return;
    }
    assert_eq!(
        &doc[start..end],
        drawn,
        "the picture in {ARCHITECTURE} is out of date: run tools/module_map.sh"
    );
}
