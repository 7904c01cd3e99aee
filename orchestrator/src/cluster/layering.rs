//! The orchestrator's layering check (run with the unit tests): cluster plumbing
//! (`src/cluster/`) never names a verb module (`crate::verbs`, `verbs::…`), so the verbs sit
//! on top of the plumbing with no import cycle between the two layers. Test code may reach
//! upwards.

use std::path::Path;

use mcc_testing::source::{is_test_file, production_code, rust_files};

/// Whether `code` names the verbs layer: the word `verbs` used as a path segment.
fn names_verbs(code: &str) -> bool {
    code.match_indices("verbs").any(|(i, _)| {
        let before = code[..i].chars().next_back();
        let after = &code[i + 5..];
        !before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_')
            && (after.starts_with("::") || before == Some(':'))
    })
}

#[test]
fn the_check_sees_a_verb_import() {
    assert!(names_verbs("use crate::verbs::up::cmd_up;"));
    assert!(names_verbs("let x = crate::verbs::send::reply_error(b);"));
    assert!(names_verbs("use super::super::verbs::down;"));
    assert!(!names_verbs("/// CLI verbs\nfn verbs_count() {}"));
    assert!(!names_verbs(&production_code(
        "// crate::verbs::up\nfn f() {}"
    )));
}

#[test]
fn plumbing_never_imports_a_verb() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = rust_files(&src.join("cluster"));
    assert!(files.len() > 10, "the cluster plumbing's files: {files:?}");
    let mut bad = Vec::new();
    for f in &files {
        if is_test_file(f) || f.ends_with("layering.rs") {
            continue;
        }
        let text = std::fs::read_to_string(f).unwrap();
        if names_verbs(&production_code(&text)) {
            bad.push(f.strip_prefix(&src).unwrap_or(f).display().to_string());
        }
    }
    assert!(
        bad.is_empty(),
        "plumbing that imports a verb module: {bad:?}"
    );
}
