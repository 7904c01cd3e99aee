//! Reading a crate's own sources, for the workspace's source checks (the card's and the
//! orchestrator's layering, the typed-errors check of mcc-ring and mcc-station): the crates
//! take this crate as a dev-dependency (it depends on no workspace crate, so no cycle).
//!
//! Test code is what compiles only under `#[cfg(test)]`: files named `tests*.rs` or
//! `*_tests.rs`, and inline `#[cfg(test)] mod … {` blocks.

use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir` (recursively), sorted; none when `dir` cannot be read.
pub fn rust_files(dir: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, &mut out);
    out.sort();
    out
}

/// Whether `path` is a test file: `tests*.rs` or `*_tests.rs`.
pub fn is_test_file(path: &Path) -> bool {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    stem.starts_with("tests") || stem.ends_with("_tests")
}

/// The code of a source file before its first inline `#[cfg(test)] mod … {`, without `//`
/// comments.
pub fn production_code(text: &str) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_files_and_test_code_are_told_apart() {
        assert!(is_test_file(Path::new("src/a/tests_drive.rs")));
        assert!(is_test_file(Path::new("src/tests.rs")));
        assert!(is_test_file(Path::new("src/station_app_tests.rs")));
        assert!(!is_test_file(Path::new("src/station_app.rs")));
        assert!(!is_test_file(Path::new("src/attests.rs")));
        let text = "use a::b; // c\n#[cfg(test)]\nfn helper() {}\n#[cfg(test)]\nmod tests {\n \
                    use crate::x;\n}\n";
        assert_eq!(
            production_code(text),
            "use a::b; \n#[cfg(test)]\nfn helper() {}"
        );
    }

    #[test]
    fn the_walk_finds_this_crates_sources_sorted() {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let files = rust_files(&src);
        assert!(files.contains(&src.join("source.rs")), "{files:?}");
        assert!(files.contains(&src.join("lib.rs")), "{files:?}");
        assert!(files.windows(2).all(|w| w[0] < w[1]));
        assert!(files
            .iter()
            .all(|f| f.extension().is_some_and(|x| x == "rs")));
        assert!(rust_files(&src.join("no-such-dir")).is_empty());
    }
}
