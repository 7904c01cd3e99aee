//! The layering check (run in CI with the unit tests): every `crate::…` path in a module's
//! non-test code names only modules of lower layers, so the card's modules have no import
//! cycle. Lowest first:
//!
//! ```text
//! domain → model → motion, coord → program → lang, servo → core → service → host → runtime
//! ```
//!
//! Test code may reach upwards (a model test may build its input with the parser).
//!
//! Inside `lang`, the two dialects are siblings: `lang/pmac` never names `lang/power` and
//! `lang/power` never names `lang/pmac` (both reach the shared executor API through
//! `crate::lang::…`); outside `lang`, no production code names either dialect (a core
//! holds a `lang::Dialect`).
//!
//! A third check holds the typed refusals: outside `domain/error.rs` no production code
//! writes an error number as a literal (`Err(3)`, `fail(3)`, `code: 21`); a refusal is an
//! `ErrCode` or a `PowerErr`.

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
    let text = "use crate::lang::Card;\n#[cfg(test)]\nmod tests {\n use crate::runtime::x;\n}";
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

/// Error numbers written as literals in `text`: `Err(<digits>)`, `fail(<digits>)`,
/// `code: <digits>`.
fn bare_error_numbers(text: &str) -> Vec<String> {
    let mut v = Vec::new();
    for pat in ["Err(", "fail(", "code: "] {
        for (i, _) in text.match_indices(pat) {
            let before = text[..i].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let rest = &text[i + pat.len()..];
            let digits = rest.chars().take_while(char::is_ascii_digit).count();
            let after = rest[digits..].chars().next();
            let closes = pat == "code: " || after == Some(')');
            if digits > 0 && closes && !after.is_some_and(|c| c == '.' || c.is_alphanumeric()) {
                let close = if pat == "code: " { "" } else { ")" };
                v.push(format!("{pat}{}{close}", &rest[..digits]));
            }
        }
    }
    v
}

#[test]
fn refusals_are_typed_outside_the_error_module() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut violations = Vec::new();
    let mut checked = 0;
    for f in rust_files(&src).iter().filter(|f| !is_test_file(f)) {
        if f.ends_with("domain/error.rs") || f.ends_with("layering.rs") {
            continue;
        }
        let text = std::fs::read_to_string(f).unwrap_or_default();
        checked += 1;
        for n in bare_error_numbers(&production_code(&text)) {
            violations.push(format!("{}: {n}", f.display()));
        }
    }
    assert!(checked > 100, "only {checked} files checked");
    assert!(
        violations.is_empty(),
        "bare error numbers (use ErrCode / PowerErr):\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_checker_sees_a_bare_error_number() {
    let text = "return Err(3);\nrun.fail(17);\nSyntaxError { at, code: 21 }\nErr(ErrCode::Data)\nOk(3)\nmyErr(4)\nErr(3.0)";
    assert_eq!(bare_error_numbers(text), ["Err(3)", "fail(17)", "code: 21"]);
}

/// Dialect names a file's production code uses that its place forbids.
fn dialect_violations(place: &str, text: &str) -> Vec<&'static str> {
    let forbidden: &[&'static str] = match place {
        "pmac" => &["lang::power", "super::power", "super::super::power"],
        "power" => &["lang::pmac", "super::pmac", "super::super::pmac"],
        "lang" => &[],
        _ => &["lang::power", "lang::pmac", "Power::", "Dialect::Power"],
    };
    forbidden
        .iter()
        .copied()
        .filter(|f| text.contains(f))
        .collect()
}

#[test]
fn dialects_are_siblings_and_named_only_inside_lang() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut violations = Vec::new();
    let mut seen = [0usize; 3];
    for f in rust_files(&src).iter().filter(|f| !is_test_file(f)) {
        let rel = f
            .strip_prefix(&src)
            .unwrap_or(f)
            .to_string_lossy()
            .replace('\\', "/");
        let place = if rel.starts_with("lang/pmac/") {
            seen[0] += 1;
            "pmac"
        } else if rel.starts_with("lang/power/") {
            seen[1] += 1;
            "power"
        } else if rel.starts_with("lang/") || rel == "layering.rs" {
            "lang"
        } else {
            seen[2] += 1;
            "outside"
        };
        let text = std::fs::read_to_string(f).unwrap_or_default();
        for v in dialect_violations(place, &production_code(&text)) {
            violations.push(format!("{rel} names {v}"));
        }
    }
    assert!(
        seen.iter().all(|&n| n > 10),
        "files seen (pmac, power, outside): {seen:?}"
    );
    assert!(
        violations.is_empty(),
        "dialect seam violations:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_checker_sees_a_dialect_named_across_the_seam() {
    assert_eq!(
        dialect_violations("pmac", "use crate::lang::power::x;"),
        ["lang::power"]
    );
    assert_eq!(
        dialect_violations("power", "use crate::lang::pmac::ast;"),
        ["lang::pmac"]
    );
    assert_eq!(
        dialect_violations("outside", "let p = Power::new();"),
        ["Power::"]
    );
    assert!(dialect_violations("outside", "use crate::lang::Dialect;").is_empty());
    assert!(dialect_violations("lang", "use power::Power;").is_empty());
}

/// Card-state accesses (`.state`) in a file's production code.
fn state_accesses(text: &str) -> usize {
    text.match_indices(".state")
        .filter(|(i, _)| {
            let next = text[i + ".state".len()..].chars().next();
            !next.is_some_and(|c| c.is_alphanumeric() || c == '_')
        })
        .count()
}

/// One way into the card: the ring app only copies values between the ring core and the card
/// core's typed ring input and output (`core::ring_io`); it never touches the card's state.
#[test]
fn the_ring_app_never_touches_card_state() {
    let f = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/runtime/ring_app.rs");
    let text = std::fs::read_to_string(&f).unwrap_or_default();
    assert!(
        text.contains("impl RingApp for CardRingApp"),
        "{}",
        f.display()
    );
    assert_eq!(
        state_accesses(&production_code(&text)),
        0,
        "{}",
        f.display()
    );
    assert_eq!(
        state_accesses("card.state.global.ring_fault = true; x.state_of()"),
        1
    );
}
