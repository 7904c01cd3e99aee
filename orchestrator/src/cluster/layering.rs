//! The orchestrator's layering check (run with the unit tests): cluster plumbing
//! (`src/cluster/`) never names a verb module (`crate::verbs`, `verbs::…`), so the verbs sit
//! on top of the plumbing with no import cycle between the two layers. Test code may reach
//! upwards.

use std::path::{Path, PathBuf};

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

/// The non-test code of a source file: up to an inline `#[cfg(test)] mod … {`, comments aside.
fn production_code(text: &str) -> String {
    let mut cut = text.len();
    for (i, _) in text.match_indices("#[cfg(test)]") {
        let rest = text[i + "#[cfg(test)]".len()..].trim_start();
        if rest.starts_with("mod ") && rest.lines().next().is_some_and(|l| l.ends_with('{')) {
            cut = cut.min(i);
        }
    }
    text[..cut]
        .lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

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
    let mut files = Vec::new();
    rust_files(&src.join("cluster"), &mut files);
    assert!(files.len() > 10, "the cluster plumbing's files: {files:?}");
    let mut bad = Vec::new();
    for f in &files {
        let name = f.file_name().unwrap_or_default().to_string_lossy();
        if name.ends_with("_tests.rs") || name == "layering.rs" {
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
