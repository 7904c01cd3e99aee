//! The layering check (run in CI with the unit tests): every `crate::…` path in a module's
//! non-test code names only modules of lower layers, so the card's modules have no import
//! cycle. Lowest first:
//!
//! ```text
//! domain → model → motion, coord → program → lang, servo → core → service → host → runtime
//! ```
//!
//! Test code may reach upwards (a model test may build its input with the parser).

use std::path::{Path, PathBuf};

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

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn is_test_file(p: &Path) -> bool {
    let name = p
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    name.starts_with("tests")
}

/// The non-test part of a source file: up to an inline `#[cfg(test)] mod … {`.
fn production_part(text: &str) -> &str {
    let mut cut = text.len();
    for (i, _) in text.match_indices("#[cfg(test)]") {
        let rest = text[i + "#[cfg(test)]".len()..].trim_start();
        if rest.starts_with("mod ") && rest.lines().next().is_some_and(|l| l.ends_with('{')) {
            cut = cut.min(i);
        }
    }
    &text[..cut]
}

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
        let mut files = Vec::new();
        rust_files(&src.join(name), &mut files);
        assert!(!files.is_empty(), "module {name} has no files");
        for f in files.iter().filter(|f| !is_test_file(f)) {
            let text = std::fs::read_to_string(f).unwrap_or_default();
            checked += 1;
            for m in used_modules(production_part(&text)) {
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
    assert_eq!(used_modules(production_part(text)), ["lang"]);
}

/// One test-file convention: unit tests live beside the code, inline (`mod tests { … }`) or
/// in a file named `tests_<topic>.rs` in the module's folder.
#[test]
fn test_files_follow_one_convention() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
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
