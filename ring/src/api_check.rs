//! The typed-errors check (run with the unit tests): no `pub fn` of the crate returns
//! `Result<_, String>`; public errors are enums that say what went wrong (issue 10 item 3).
//!
//! One file, compiled into the tests of each crate that keeps the rule (mcc-ring, and
//! mcc-contracts and mcc-station through `#[path]`); each copy scans its own crate's `src/`.
//! Test files (`tests*.rs`, `*_tests.rs`, compiled only under `#[cfg(test)]`) and inline
//! `#[cfg(test)] mod … {` blocks are skipped (`mcc_testing::source`).

use std::path::Path;

use mcc_testing::source::{is_test_file, production_code, rust_files};

/// Index just past the bracket closing the one opening at `open` (`(`/`)` or `<`/`>`).
fn skip_group(s: &[u8], open: usize, (o, c): (u8, u8)) -> usize {
    let mut depth = 0usize;
    for (k, b) in s.iter().enumerate().skip(open) {
        if *b == o {
            depth += 1;
        } else if *b == c {
            depth = depth.saturating_sub(1);
            if depth == 0 {
                return k + 1;
            }
        }
    }
    s.len()
}

/// Names of the `pub fn`s in `code` whose return type is `Result<…, String>`.
fn string_error_fns(code: &str) -> Vec<String> {
    // `->` would unbalance the angle brackets of generics such as `F: Fn() -> T`.
    let code = code.replace("->", "→");
    let mut found = Vec::new();
    for line_start in std::iter::once(0).chain(code.match_indices('\n').map(|(i, _)| i + 1)) {
        let rest = &code[line_start..];
        let Some(fn_at) = rest.find("fn ") else {
            continue;
        };
        let mut quals = rest[..fn_at].split_whitespace();
        let public = quals.next() == Some("pub")
            && quals.all(|q| matches!(q, "const" | "async" | "unsafe" | "extern" | "\"C\""));
        if !public || rest[..fn_at].contains('\n') {
            continue;
        }
        let sig = &rest[fn_at + 3..];
        let end = sig.find(['{', ';']).unwrap_or(sig.len());
        let sig = &sig.as_bytes()[..end];
        let name_end = sig
            .iter()
            .position(|b| !(b.is_ascii_alphanumeric() || *b == b'_'))
            .unwrap_or(sig.len());
        let mut at = name_end;
        if sig.get(at) == Some(&b'<') {
            at = skip_group(sig, at, (b'<', b'>'));
        }
        let Some(open) = sig[at..].iter().position(|b| *b == b'(') else {
            continue;
        };
        let after = skip_group(sig, at + open, (b'(', b')'));
        let tail = String::from_utf8_lossy(&sig[after..]);
        let ret = tail
            .split_whitespace()
            .take_while(|t| *t != "where")
            .collect::<String>()
            .replace(",>", ">");
        let Some(ret) = ret.strip_prefix('→') else {
            continue;
        };
        let result = ret.starts_with("Result<") || ret.contains("::Result<");
        let string_err = ret.ends_with(",String>") || ret.ends_with("::String>");
        if result && string_err {
            found.push(String::from_utf8_lossy(&sig[..name_end]).into_owned());
        }
    }
    found
}

#[test]
fn the_check_sees_a_string_error() {
    let code = "pub fn a(x: u8) -> Result<u8, String> {\n}\n\
        pub fn b<F: Fn() -> u8>(\n    f: F,\n) -> std::result::Result<(), std::string::String>\n\
        where F: Copy {\n}\n\
        pub fn c() -> Result<String, Error> {}\n\
        pub(crate) fn d() -> Result<(), String> {}\n\
        fn e() -> Result<(), String> {}\n\
        pub fn f(g: impl Fn() -> Result<(), String>) -> u8 {}\n\
        pub const fn h() -> Result<\n    Vec<u8>,\n    String,\n> {}\n";
    assert_eq!(string_error_fns(code), ["a", "b", "h"]);
    let tests =
        "pub fn ok() {}\n#[cfg(test)]\nmod tests {\n    pub fn t() -> Result<(), String> {}\n}\n";
    assert!(string_error_fns(&production_code(tests)).is_empty());
}

#[test]
fn no_public_fn_returns_a_string_error() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = rust_files(&src);
    assert!(files.len() > 10, "the crate's source files: {files:?}");
    let mut bad = Vec::new();
    for f in files.iter().filter(|f| !is_test_file(f)) {
        let text = std::fs::read_to_string(f).unwrap();
        for name in string_error_fns(&production_code(&text)) {
            let file = f.strip_prefix(&src).unwrap_or(f).display();
            bad.push(format!("{file}: {name}"));
        }
    }
    assert!(
        bad.is_empty(),
        "public functions returning Result<_, String> (use a thiserror enum): {bad:?}"
    );
}
