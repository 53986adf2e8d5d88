//! The repository stands alone: nothing cites documents that live outside it, and every reading
//! of the paper that a file cites exists in `docs/paper-readings.md`.
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The repository root.
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

/// Directory names never walked, wherever they are: builds, VCS data, environments, caches.
const SKIP_NAMES: &[&str] = &[
    ".git",
    "target",
    "node_modules",
    "__pycache__",
    ".venv",
    ".pytest_cache",
];

/// Files larger than this are data, not text anyone cites from.
const MAX_BYTES: u64 = 4 << 20;

/// Paths the root `.gitignore` anchors (`/runs`, `/bridge/.venv`, ...): outputs of runs,
/// which may quote anything.
fn ignored_roots(root: &Path) -> Vec<PathBuf> {
    std::fs::read_to_string(root.join(".gitignore"))
        .unwrap_or_default()
        .lines()
        .map(str::trim)
        .filter_map(|l| l.strip_prefix('/'))
        .filter(|l| !l.is_empty() && !l.contains(['*', '?', '[', '!']))
        .map(|l| root.join(l.trim_end_matches('/')))
        .collect()
}

/// Every UTF-8 text file of the working tree (outside the skipped directories), with its
/// path relative to the root.
fn text_files() -> Vec<(String, String)> {
    let root = repo();
    let ignored = ignored_roots(&root);
    let mut out = Vec::new();
    let mut stack = vec![root.clone()];
    while let Some(dir) = stack.pop() {
        let mut entries: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap())
            .collect();
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let path = e.path();
            let name = e.file_name();
            let ty = e.file_type().unwrap();
            if ty.is_dir() {
                if !SKIP_NAMES.iter().any(|s| name == *s) && !ignored.contains(&path) {
                    stack.push(path);
                }
                continue;
            }
            if !ty.is_file() || ignored.contains(&path) || e.metadata().unwrap().len() > MAX_BYTES {
                continue;
            }
            if let Ok(text) = std::fs::read_to_string(&path) {
                let rel = path.strip_prefix(&root).unwrap().to_string_lossy().into();
                out.push((rel, text));
            }
        }
    }
    out
}

/// The numbers `n` of the word-bounded tokens `R<n>` in `s`.
fn reading_tokens(s: &str) -> Vec<u32> {
    let b = s.as_bytes();
    let word = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut out = Vec::new();
    for i in 0..b.len() {
        if b[i] != b'R' || (i > 0 && word(b[i - 1])) {
            continue;
        }
        let end = (i + 1..b.len())
            .find(|&j| !b[j].is_ascii_digit())
            .unwrap_or(b.len());
        if end > i + 1 && (end == b.len() || !word(b[end])) {
            out.push(s[i + 1..end].parse().unwrap());
        }
    }
    out
}

const READINGS: &str = "docs/paper-readings.md";

/// How a citation links into the document (spelled in pieces so this file does not match it).
const ANCHOR: &str = concat!("paper-readings.md", "#");

/// The readings defined in `docs/paper-readings.md`: its `## R<n>. Title` headings, each
/// preceded by its anchor `<a id="R<n>"></a>`.
fn defined_readings() -> BTreeSet<u32> {
    let text = std::fs::read_to_string(repo().join(READINGS)).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let mut numbers = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let Some(rest) = line.strip_prefix("## R") else {
            continue;
        };
        let (n, title) = rest.split_once(". ").unwrap_or_else(|| {
            panic!(
                "{READINGS}:{}: a reading heading is `## R<n>. Title`",
                i + 1
            )
        });
        let n: u32 = n
            .parse()
            .unwrap_or_else(|_| panic!("{READINGS}:{}: `R{n}` is not a number", i + 1));
        assert!(!title.trim().is_empty(), "{READINGS}:{}: no title", i + 1);
        let anchor = format!("<a id=\"R{n}\"></a>");
        assert!(
            i > 0 && lines[i - 1].trim() == anchor,
            "{READINGS}:{}: the heading of R{n} needs `{anchor}` on the line above it",
            i + 1
        );
        numbers.push(n);
    }
    // Numbers are stable: never reused, never reordered (a withdrawn reading keeps its heading).
    let expected: Vec<u32> = (1..=numbers.len() as u32).collect();
    assert_eq!(
        numbers, expected,
        "{READINGS}: readings are numbered R1, R2, ... in order"
    );
    numbers.into_iter().collect()
}

#[test]
fn nothing_cites_documents_outside_the_repository() {
    // Spelled in pieces so that this file does not match itself.
    let outside = [concat!("ERR", "ATA.md"), concat!("DES", "IGN.md")];
    let files = text_files();
    assert!(
        files.iter().any(|(p, _)| p == "README.md") && files.len() > 50,
        "the walk found too little"
    );
    let mut hits = Vec::new();
    for (path, text) in &files {
        for (i, line) in text.lines().enumerate() {
            if let Some(name) = outside.iter().find(|n| line.contains(*n)) {
                hits.push(format!("{path}:{}: {name}", i + 1));
            }
        }
    }
    assert!(
        hits.is_empty(),
        "cite {READINGS} (reading R<n>) instead of files outside the repository:\n{}",
        hits.join("\n")
    );
}

#[test]
fn every_cited_reading_exists() {
    let defined = defined_readings();
    let mut missing = Vec::new();
    let mut cited = BTreeSet::new();
    let mut citing_files = BTreeSet::new();
    for (path, text) in text_files() {
        // A file that names the readings document cites readings by `R<n>` anywhere in it;
        // any other file by "reading R<n>" (the rest of that line is checked as well).
        let whole_file = text.contains("paper-readings");
        for (i, line) in text.lines().enumerate() {
            let lower = line.to_ascii_lowercase();
            let cites = whole_file || lower.contains("reading r") || lower.contains("readings r");
            if !cites {
                continue;
            }
            // An anchor into the document must be one of its `R<n>` anchors.
            for (at, _) in line.match_indices(ANCHOR) {
                let after = &line[at + ANCHOR.len()..];
                let digits = after
                    .strip_prefix('R')
                    .map_or(0, |a| a.bytes().take_while(u8::is_ascii_digit).count());
                if digits == 0 {
                    missing.push(format!("{path}:{}: an anchor that is not #R<n>", i + 1));
                }
            }
            for n in reading_tokens(line) {
                citing_files.insert(path.clone());
                cited.insert(n);
                if !defined.contains(&n) {
                    missing.push(format!("{path}:{}: R{n}", i + 1));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "readings cited but not defined as `## R<n>. ...` in {READINGS}:\n{}",
        missing.join("\n")
    );
    // The check is not vacuous: the README and the code do cite readings.
    assert!(
        citing_files.contains("README.md") && citing_files.len() > 10 && cited.len() > 15,
        "too few citations found: {citing_files:?}"
    );
}

#[test]
fn reading_tokens_are_word_bounded() {
    assert_eq!(
        reading_tokens("(reading R3) R14-R21, #R7; R2D2 xR5 R_1 R"),
        [3, 14, 21, 7]
    );
}
