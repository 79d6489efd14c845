//! The data flows one way (loader -> scene -> integrator -> film -> render -> viewer | cli):
//! each top-level module may use only the modules of the layers below it. Scans every
//! source file for `crate::` paths, so a new import against the flow fails here.

use std::collections::BTreeSet;
use std::path::Path;

/// Each module and what it may use (macros count as their module: `params!`, `choice_enum!`).
/// The parameter tables come first: math declares its sampler choice with `choice_enum!`.
const ALLOWED: &[(&str, &[&str])] = &[
    ("params", &[]),
    ("math", &["params"]),
    ("memory", &[]),
    ("guard", &[]),
    ("spectrum", &["math"]),
    ("bsdf", &["math", "memory", "guard", "spectrum"]),
    ("medium", &["math", "memory", "guard", "spectrum"]),
    ("scene", &["math", "medium", "memory", "guard", "spectrum", "bsdf", "params"]),
    ("loader", &["math", "medium", "memory", "guard", "params", "spectrum", "bsdf", "scene"]),
    ("integrator", &["math", "medium", "spectrum", "params", "bsdf", "scene"]),
    ("film", &["math", "memory", "guard", "spectrum", "params"]),
    ("render", &["math", "medium", "memory", "spectrum", "params", "scene", "integrator", "film"]),
    ("config", &["math", "medium", "memory", "spectrum", "params", "scene", "integrator", "film"]),
    ("open", &["math", "medium", "memory", "spectrum", "scene", "loader"]),
    (
        "viewer",
        &[
            "math",
            "medium",
            "memory",
            "spectrum",
            "params",
            "bsdf",
            "scene",
            "loader",
            "integrator",
            "film",
            "render",
            "config",
            "open",
        ],
    ),
    (
        "cli",
        &[
            "math",
            "medium",
            "memory",
            "spectrum",
            "params",
            "bsdf",
            "scene",
            "loader",
            "integrator",
            "film",
            "render",
            "config",
            "open",
            "viewer",
        ],
    ),
];

fn sources(path: &Path, out: &mut Vec<std::path::PathBuf>) {
    if path.is_dir() {
        for entry in std::fs::read_dir(path).unwrap() {
            sources(&entry.unwrap().path(), out);
        }
    } else if path.is_file() && path.extension().is_some_and(|e| e == "rs") {
        out.push(path.to_owned());
    }
}

/// The crate modules `crate::` paths in `text` name.
fn used(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (i, _) in text.match_indices("crate::") {
        let name: String = text[i + 7..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
        let name = match name.as_str() {
            "choice_enum" => "params".to_string(),
            _ => name,
        };
        out.insert(name);
    }
    out
}

#[test]
fn no_module_imports_one_downstream_of_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut violations = Vec::new();
    let mut modules_seen = 0;
    for (module, allowed) in ALLOWED {
        let mut files = Vec::new();
        sources(&src.join(module), &mut files);
        sources(&src.join(format!("{module}.rs")), &mut files);
        assert!(!files.is_empty(), "module {module} has no source");
        modules_seen += 1;
        for file in files {
            let text = std::fs::read_to_string(&file).unwrap();
            for name in used(&text) {
                if name != *module && !allowed.contains(&name.as_str()) {
                    violations.push(format!("{} uses crate::{name}", file.display()));
                }
            }
        }
    }
    assert_eq!(modules_seen, ALLOWED.len());
    assert!(violations.is_empty(), "imports against the data flow:\n{}", violations.join("\n"));
}

#[test]
fn the_check_sees_an_import_against_the_flow() {
    assert!(used("use crate::viewer::Launch;\nlet x = crate::cli::parse();").contains("cli"));
    assert!(used("crate::choice_enum!(X { A = \"a\": \"b\" });").contains("params"));
}
