//! The house: the module map in docs/architecture.md is true (every file it names exists, every
//! file of src/ and shaders/ is named), and the source files import each other without circles
//! and without an arrow from a lower layer to a higher one.

#[path = "common/imports.rs"]
mod imports;

use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
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
