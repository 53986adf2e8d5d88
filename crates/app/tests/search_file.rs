//! A search file's errors name the line its key stands on; a search's failures come back by
//! kind.
use platoon_app::campaign::{Execution, Executor};
use platoon_app::search::{SearchError, SearchOptions};
use platoon_app::Stop;
use std::path::Path;

#[test]
fn a_search_files_error_names_the_keys_own_line() {
    let text = "# a search\nseed = 1\n\nevaluations = 0\n";
    let e = platoon_app::search::parse(text, Path::new("s.toml"), None).unwrap_err();
    assert_eq!(e.key, "evaluations", "{e}");
    assert_eq!(e.line, Some(4), "{e}");

    let text = "seed = 1\n[budget]\nmax_jammed_s = 1.0\n\n\nharm_typo = 1\n";
    let e = platoon_app::search::parse(text, Path::new("s.toml"), None).unwrap_err();
    assert!(e.line.is_some(), "{e}");

    let text = "seed = 1\n\nharm = \"no_such_metric\"\n";
    let e = platoon_app::search::parse(text, Path::new("s.toml"), None).unwrap_err();
    assert_eq!((e.key.as_str(), e.line), ("harm", Some(3)), "{e}");
}

/// The committed search file reference is what the schema types generate: after changing them,
/// `PLATOON_BLESS=1 cargo test -p platoon-app --test app search_file::` rewrites it (never where
/// `CI` is set).
#[test]
fn the_search_reference_is_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/search-reference.md");
    let page = platoon_app::search::reference_markdown();
    for key in [
        "`[budget]`",
        "`[search]`",
        "`[random]`",
        "`[grid]`",
        "`[study]`",
        "`harm`",
    ] {
        assert!(page.contains(key), "{key} in the reference:\n{page}");
    }
    platoon_config::check_committed(
        &path,
        &page,
        "PLATOON_BLESS=1 cargo test -p platoon-app --test app search_file::",
    )
    .unwrap_or_else(|e| panic!("{e}"));
}

/// An executor of the caller's that fails at once.
struct Failing;

impl Executor for Failing {
    fn name(&self) -> String {
        "failing".into()
    }

    fn execute(&self, _run: Execution<'_>) -> Result<(), platoon_app::campaign::ExecutorError> {
        Err(platoon_app::OtherError::new("the cluster went away").into())
    }
}

#[test]
fn a_searchs_failures_come_back_by_kind() {
    let tmp = tempfile::tempdir().unwrap();
    let search = platoon_app::search::parse("", &tmp.path().join("s.toml"), Some(2)).unwrap();
    let opts = SearchOptions {
        force: false,
        plots: false,
    };
    let out = tmp.path().join("s");
    let e = platoon_app::search::run(&search, &out, &opts, &Failing, &Stop::default(), &())
        .unwrap_err();
    let SearchError::Executor(inner) = &e else {
        panic!("{e:?}");
    };
    assert_eq!(inner.to_string(), "the cluster went away");
    assert!(e.config().is_none());
    assert!(!out.exists(), "an unfinished search is not committed");

    // A directory that is there is refused before anything runs.
    std::fs::create_dir(&out).unwrap();
    let e = platoon_app::search::run(&search, &out, &opts, &Failing, &Stop::default(), &())
        .unwrap_err();
    assert!(matches!(e, SearchError::Output(_)), "{e:?}");
    assert!(e.to_string().contains("--force"), "{e}");
}
