//! The layering check (run in CI with the unit tests): every `crate::…` path in a module's
//! non-test code names only modules of lower layers, so the card's modules have no import
//! cycle. Lowest first:
//!
//! ```text
//! domain → model → motion, coord → program → lang, servo → core → service → host → runtime
//! ```
//!
//! Test code may reach upwards (a model test may build its input with the parser).

use std::path::Path;

use mcc_testing::source::{is_test_file, production_code, rust_files};

/// Each module with the modules it may use.
const LAYERS: &[(&str, &[&str])] = &[
    ("domain", &[]),
    ("model", &["domain"]),
    ("motion", &["domain", "model"]),
    ("coord", &["domain", "model"]),
    ("program", &["domain", "model", "motion", "coord"]),
    ("lang", &["domain", "model", "coord", "program"]),
    ("servo", &["domain", "model", "motion", "coord", "program"]),
    (
        "core",
        &[
            "domain", "model", "motion", "coord", "program", "lang", "servo",
        ],
    ),
    (
        "service",
        &[
            "domain", "model", "motion", "coord", "program", "lang", "servo", "core",
        ],
    ),
    (
        "host",
        &[
            "domain", "model", "motion", "coord", "program", "lang", "servo", "core", "service",
        ],
    ),
    (
        "runtime",
        &[
            "domain", "model", "motion", "coord", "program", "lang", "servo", "core", "service",
            "host",
        ],
    ),
];

/// `crate::X` module names used in `text` (comments aside).
fn used_modules(text: &str) -> Vec<String> {
    let code: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let text = code.as_str();
    let mut v = Vec::new();
    for (i, _) in text.match_indices("crate::") {
        let rest = &text[i + 7..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if !name.is_empty() && !v.contains(&name) {
            v.push(name);
        }
    }
    v
}

#[test]
fn the_layers_are_a_dag() {
    for (k, (name, uses)) in LAYERS.iter().enumerate() {
        for u in *uses {
            let pos = LAYERS.iter().position(|(n, _)| n == u);
            assert!(
                pos.is_some_and(|p| p < k),
                "{name} may use {u}, which is not a lower layer"
            );
        }
    }
}

#[test]
fn modules_only_use_lower_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut violations = Vec::new();
    let mut checked = 0;
    for (name, uses) in LAYERS {
        let files = rust_files(&src.join(name));
        assert!(!files.is_empty(), "module {name} has no files");
        for f in files.iter().filter(|f| !is_test_file(f)) {
            let text = std::fs::read_to_string(f).unwrap_or_default();
            checked += 1;
            for m in used_modules(&production_code(&text)) {
                let known = LAYERS.iter().any(|(n, _)| *n == m);
                if known && m != *name && !uses.contains(&m.as_str()) {
                    violations.push(format!("{} uses crate::{m}", f.display()));
                }
            }
        }
    }
    assert!(checked > 50, "only {checked} files checked");
    assert!(
        violations.is_empty(),
        "layering violations:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_checker_sees_an_upward_use() {
    let text =
        "use crate::lang::interp::Card;\n#[cfg(test)]\nmod tests {\n use crate::runtime::x;\n}";
    assert_eq!(used_modules(&production_code(text)), ["lang"]);
}

/// One test-file convention: unit tests live beside the code, inline (`mod tests { … }`) or
/// in a file named `tests_<topic>.rs` in the module's folder.
#[test]
fn test_files_follow_one_convention() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = rust_files(&src);
    let odd: Vec<_> = files
        .iter()
        .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
        .filter(|n| n.contains("test") && !n.starts_with("tests"))
        .collect();
    assert!(
        odd.is_empty(),
        "test files not named tests_<topic>.rs: {odd:?}"
    );
}
