//! Every test file builds and runs. The files of `tests/` are modules of one binary
//! (tests/main.rs), and so are those of a crate whose Cargo.toml sets `autotests = false`
//! (`crates/<crate>/tests/main.rs`): cargo compiles only what a `mod` line names, so a file added
//! without one would silently never run.
use crate::common::repo;
use std::collections::BTreeSet;
use std::path::Path;

/// The modules `dir/main.rs` declares (`mod NAME;` lines).
fn declared(dir: &Path) -> BTreeSet<String> {
    let text = std::fs::read_to_string(dir.join("main.rs")).unwrap();
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("mod ")?.strip_suffix(';'))
        .map(str::to_string)
        .collect()
}

/// The modules the files of `dir` make: `NAME.rs` but main.rs, and `NAME/mod.rs`.
fn present(dir: &Path) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        if path.extension().is_some_and(|e| e == "rs") && name != "main" {
            names.insert(name);
        } else if path.join("mod.rs").is_file() {
            names.insert(path.file_name().unwrap().to_string_lossy().into_owned());
        }
    }
    names
}

#[test]
fn every_test_file_is_a_module_of_its_binary() {
    let repo = repo();
    let mut dirs = vec![repo.join("tests")];
    for entry in std::fs::read_dir(repo.join("crates")).unwrap() {
        let krate = entry.unwrap().path();
        let tests = krate.join("tests");
        if !tests.join("main.rs").is_file() {
            continue;
        }
        // Without `autotests = false` cargo would also build each file as a binary of its own.
        let manifest = std::fs::read_to_string(krate.join("Cargo.toml")).unwrap();
        assert!(
            manifest.lines().any(|l| l.trim() == "autotests = false"),
            "{} has tests/main.rs but not `autotests = false`",
            krate.join("Cargo.toml").display()
        );
        dirs.push(tests);
    }
    assert!(
        dirs.len() > 1,
        "no crate gathers its tests in tests/main.rs"
    );
    for dir in dirs {
        let (declared, present) = (declared(&dir), present(&dir));
        let missing: Vec<_> = present.difference(&declared).collect();
        assert!(
            missing.is_empty(),
            "{}: add `mod NAME;` to main.rs for {missing:?}",
            dir.display()
        );
    }
}
