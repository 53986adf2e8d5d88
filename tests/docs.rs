//! The repository stands alone: nothing cites documents that live outside it, every reading
//! of the paper that a file cites exists in `docs/paper-readings.md`, and every relative link in
//! its Markdown files resolves.
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

// ---------------------------------------------------------------------------------------------
// Relative links in the Markdown files resolve.

/// `text` with its fenced code blocks blanked out (spaces; newlines kept, so byte offsets and
/// line numbers stay those of `text`).
fn without_fences(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    // Fenced blocks: a line opening with ``` or ~~~ (up to three spaces in) until a line that
    // closes it with at least as many of the same character.
    let mut fence: Option<(u8, usize)> = None;
    for line in text.split_inclusive('\n') {
        let body = line.trim_end_matches(['\n', '\r']);
        let indent = body.len() - body.trim_start_matches(' ').len();
        let rest = &body[indent..];
        let run = |c: u8| rest.bytes().take_while(|&b| b == c).count();
        let opens = (indent <= 3)
            .then(|| [b'`', b'~'].into_iter().find(|&c| run(c) >= 3))
            .flatten();
        let blank = |s: &str| {
            s.chars()
                .map(|c| if c == '\n' { c } else { ' ' })
                .collect::<String>()
        };
        match (fence, opens) {
            (None, Some(c)) => {
                fence = Some((c, run(c)));
                out.push_str(&blank(line));
            }
            (Some((c, n)), _) => {
                if indent <= 3 && run(c) >= n && rest[run(c)..].trim().is_empty() {
                    fence = None;
                }
                out.push_str(&blank(line));
            }
            (None, None) => out.push_str(line),
        }
    }
    out
}

/// `text` with what Markdown shows literally blanked out: fenced code blocks and inline code
/// spans (offsets and line numbers kept).
fn without_code(text: &str) -> String {
    let out = without_fences(text);
    // Inline code: a run of n backticks up to the next run of exactly n, within a paragraph.
    let b = out.as_bytes();
    let mut bytes = b.to_vec();
    let mut i = 0;
    while i < b.len() {
        if b[i] != b'`' {
            i += 1;
            continue;
        }
        let n = b[i..].iter().take_while(|&&c| c == b'`').count();
        let mut j = i + n;
        let mut close = None;
        while j < b.len() {
            if b[j] == b'\n'
                && b[j + 1..]
                    .iter()
                    .take_while(|&&c| c != b'\n')
                    .all(|c| c.is_ascii_whitespace())
            {
                break; // a blank line ends the paragraph
            }
            if b[j] == b'`' {
                let m = b[j..].iter().take_while(|&&c| c == b'`').count();
                if m == n {
                    close = Some(j);
                    break;
                }
                j += m;
                continue;
            }
            j += 1;
        }
        match close {
            Some(j) => {
                for c in &mut bytes[i..j + n] {
                    if *c != b'\n' {
                        *c = b' ';
                    }
                }
                i = j + n;
            }
            None => i += n,
        }
    }
    // Only ASCII bytes were replaced by ASCII spaces, whole code spans at a time.
    String::from_utf8(bytes).unwrap()
}

/// The link targets of a Markdown text with their line numbers: inline links and images
/// `[text](target "title")`, and reference definitions `[label]: target`.
fn link_targets(text: &str) -> Vec<(usize, String)> {
    let prose = without_code(text);
    let b = prose.as_bytes();
    let line_of = |at: usize| prose[..at].matches('\n').count() + 1;
    let mut out = Vec::new();
    for (at, _) in prose.match_indices("](") {
        // The `[` that opens the link text, within its paragraph.
        let mut depth = 0usize;
        let mut opened = false;
        for k in (0..at).rev() {
            match b[k] {
                b']' => depth += 1,
                b'[' if depth == 0 => {
                    opened = true;
                    break;
                }
                b'[' => depth -= 1,
                b'\n' if k > 0 && b[k - 1] == b'\n' => break,
                _ => {}
            }
        }
        if !opened {
            continue;
        }
        let rest = prose[at + 2..].trim_start_matches([' ', '\t']);
        let target = if let Some(r) = rest.strip_prefix('<') {
            r.split('>').next().unwrap_or("").to_string()
        } else {
            let mut parens = 0usize;
            let end = rest
                .char_indices()
                .find(|&(_, c)| match c {
                    '(' => {
                        parens += 1;
                        false
                    }
                    ')' if parens == 0 => true,
                    ')' => {
                        parens -= 1;
                        false
                    }
                    c => c.is_whitespace(),
                })
                .map_or(rest.len(), |(i, _)| i);
            rest[..end].to_string()
        };
        out.push((line_of(at), target));
    }
    for (i, line) in prose.lines().enumerate() {
        let t = line.trim_start_matches(' ');
        if line.len() - t.len() > 3 || !t.starts_with('[') || t.starts_with("[^") {
            continue;
        }
        if let Some(close) = t.find("]:") {
            if let Some(target) = t[close + 2..].split_whitespace().next() {
                let target = target.trim_start_matches('<').trim_end_matches('>');
                out.push((i + 1, target.to_string()));
            }
        }
    }
    out
}

/// GitHub's anchor for a heading's text: inline markup dropped, lower case, punctuation other
/// than `-` and `_` removed, each space a hyphen.
fn slug(heading: &str) -> String {
    // Links show their text, tags nothing.
    let mut text = String::new();
    let mut rest = heading;
    while let Some(at) = rest.find(['[', '<']) {
        text.push_str(&rest[..at]);
        let r = &rest[at..];
        if r.starts_with('<') {
            rest = r.find('>').map_or("", |e| &r[e + 1..]);
        } else if let Some(mid) = r.find("](") {
            let close = r[mid..].find(')').map_or(r.len(), |e| mid + e + 1);
            text.push_str(&r[1..mid]);
            rest = &r[close..];
        } else {
            text.push('[');
            rest = &r[1..];
        }
    }
    text.push_str(rest);
    text.trim()
        .to_lowercase()
        .chars()
        .filter(|&c| c.is_alphanumeric() || c == ' ' || c == '-' || c == '_')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The anchors a Markdown file has on GitHub: its headings' slugs (a repeated slug gets `-1`,
/// `-2`, ...) and the `id` and `name` attributes of its HTML tags.
fn anchors(text: &str) -> BTreeSet<String> {
    let prose = without_code(text);
    let headings = without_fences(text);
    let mut out = BTreeSet::new();
    let mut seen = std::collections::BTreeMap::<String, usize>::new();
    let mut add = |base: String, out: &mut BTreeSet<String>| {
        let n = seen.entry(base.clone()).or_insert(0);
        out.insert(if *n == 0 {
            base.clone()
        } else {
            format!("{base}-{n}")
        });
        *n += 1;
    };
    let lines: Vec<&str> = headings.lines().collect();
    for (i, line) in lines.iter().enumerate() {
        let t = line.trim_start_matches(' ');
        let hashes = t.bytes().take_while(|&c| c == b'#').count();
        if line.len() - t.len() <= 3 && (1..=6).contains(&hashes) {
            let rest = &t[hashes..];
            if rest.is_empty() || rest.starts_with([' ', '\t']) {
                let title = rest.trim().trim_end_matches('#').trim_end();
                add(slug(title), &mut out);
            }
            continue;
        }
        // Setext: a paragraph line underlined with = or -.
        let u = line.trim();
        let underline =
            !u.is_empty() && (u.bytes().all(|c| c == b'=') || u.bytes().all(|c| c == b'-'));
        if underline && i > 0 {
            let above = lines[i - 1].trim();
            let starts_block = ["#", "-", "*", "+", ">", "|"]
                .iter()
                .any(|p| above.starts_with(p));
            if !above.is_empty() && !starts_block {
                add(slug(above), &mut out);
            }
        }
    }
    for attr in [" id=\"", " name=\""] {
        for (at, _) in prose.match_indices(attr) {
            let value = &prose[at + attr.len()..];
            if let Some(end) = value.find('"') {
                out.insert(value[..end].to_string());
            }
        }
    }
    out
}

/// `%20`-style escapes in a link target, decoded.
fn percent_decoded(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// A path made of `base` and the relative `rel` without `.` and `..`, or None if it leaves
/// the root (`base` is relative to the root).
fn joined(base: &Path, rel: &str) -> Option<PathBuf> {
    let mut parts: Vec<String> = base
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    for part in rel.split('/') {
        match part {
            "" | "." => {}
            ".." => {
                parts.pop()?;
            }
            p => parts.push(p.to_string()),
        }
    }
    Some(parts.iter().collect())
}

/// How many relative links `files` (Markdown, with paths relative to `root`) hold, and which of
/// them do not resolve: a missing file or directory, a path out of the repository, or a
/// `#fragment` that names no anchor of the Markdown file it points into.
fn check_links(root: &Path, files: &[(String, String)]) -> (usize, Vec<String>) {
    let mut checked = 0;
    let mut broken = Vec::new();
    for (path, text) in files {
        let dir = Path::new(path).parent().unwrap_or(Path::new(""));
        for (line, target) in link_targets(text) {
            let scheme = target.split_once(':').is_some_and(|(s, _)| {
                !s.is_empty()
                    && s.bytes()
                        .all(|c| c.is_ascii_alphanumeric() || b"+-.".contains(&c))
            });
            if target.is_empty() || scheme || target.starts_with("//") {
                continue; // a URL (http, https, mailto, ...), not a file of the repository
            }
            checked += 1;
            let at = format!("{path}:{line}: ({target})");
            let target = percent_decoded(&target);
            let (file, fragment) = target.split_once('#').unwrap_or((&target, ""));
            if file.is_empty() {
                // `#fragment`: a heading or anchor of this file.
                if !anchors(text).contains(fragment) {
                    broken.push(format!("{at}: no heading or anchor #{fragment} in {path}"));
                }
                continue;
            }
            // `/path` is relative to the repository's root (as on GitHub), anything else to the
            // file's directory.
            let resolved = match file.strip_prefix('/') {
                Some(abs) => joined(Path::new(""), abs),
                None => joined(dir, file),
            };
            let Some(resolved) = resolved else {
                broken.push(format!("{at}: leaves the repository"));
                continue;
            };
            let full = root.join(&resolved);
            if !full.exists() {
                broken.push(format!("{at}: no file or directory {}", resolved.display()));
                continue;
            }
            if fragment.is_empty() || !full.is_file() || full.extension().is_none_or(|e| e != "md")
            {
                continue;
            }
            let target_text = std::fs::read_to_string(&full).unwrap_or_default();
            if !anchors(&target_text).contains(fragment) {
                broken.push(format!(
                    "{at}: no heading or anchor #{fragment} in {}",
                    resolved.display()
                ));
            }
        }
    }
    (checked, broken)
}

#[test]
fn every_relative_link_in_the_docs_resolves() {
    let files: Vec<(String, String)> = text_files()
        .into_iter()
        .filter(|(p, _)| p.ends_with(".md"))
        .collect();
    for expected in [
        "README.md",
        "ARCHITECTURE.md",
        "BENCHMARKS.md",
        "docs/README.md",
    ] {
        assert!(
            files.iter().any(|(p, _)| p == expected),
            "{expected} was not walked"
        );
    }
    let (checked, broken) = check_links(&repo(), &files);
    assert!(
        broken.is_empty(),
        "links that do not resolve (a path relative to the file, #fragment a heading's GitHub \
         slug or an <a id>):\n{}",
        broken.join("\n")
    );
    // Not vacuous: the README and the guide link to each other.
    assert!(checked > 50, "only {checked} relative links found");
}

#[test]
fn broken_links_are_found() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    std::fs::create_dir_all(root.join("docs")).unwrap();
    std::fs::write(root.join("a.rs"), "").unwrap();
    let guide =
        "# The guide\n\n<a id=\"R1\"></a>\n## R1. Fig. 9: `u = -K q`, robust\n\n## Setup\n\n\
                 ## Setup\n\nA paragraph\n---\n";
    std::fs::write(root.join("docs/guide.md"), guide).unwrap();
    let readme = "\
[fine](docs/guide.md) [fine](docs/) [fine](a.rs#L3) [fine](<docs/guide.md>)
[fine](docs/guide.md#R1) [fine](docs/guide.md#r1-fig-9-u---k-q-robust)
[fine](docs/guide.md#setup-1) [fine](docs/guide.md#a-paragraph) [fine](#top)
[`code` in
the text](/docs/guide.md \"title\") ![an image](a.rs) [fine](https://x.org/none) [mail](mailto:a@b)
`[in code](missing.md)` and
```
[in a fence](missing.md)
```
[ref]: docs/guide.md
[missing](missing.md) [gone](docs/gone.md#x) [anchor](docs/guide.md#nowhere)
[out](../outside.md) [self](#nowhere) [setup-2](docs/guide.md#setup-2)
[badref]: nothing/here

# Top
";
    let files = vec![("README.md".to_string(), readme.to_string())];
    let (checked, broken) = check_links(root, &files);
    let broken: Vec<&str> = broken
        .iter()
        .map(|b| b.split(": (").nth(1).unwrap().split(')').next().unwrap())
        .collect();
    assert_eq!(
        broken,
        [
            "missing.md",
            "docs/gone.md#x",
            "docs/guide.md#nowhere",
            "../outside.md",
            "#nowhere",
            "docs/guide.md#setup-2",
            "nothing/here",
        ]
    );
    assert_eq!(checked, 11 + broken.len() + 1, "{broken:?}");
}
