//! The committed config reference is what the schema types generate: `docs/config.schema.json`
//! (the JSON Schema editors read) and `docs/config-reference.md`. After changing a schema type,
//! `PLATOON_BLESS=1 cargo test -p platoon-config --test config reference::` rewrites both (never
//! where `CI` is set, `CI=true` say: CI checks the committed files, it does not make them).
use std::path::{Path, PathBuf};

fn docs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs")
}

/// Whether `PLATOON_BLESS` asks for the committed files to be rewritten. With `CI=true` it is
/// refused: a blessed file in CI would pass whatever the code generates.
fn bless(bless: Option<&str>, ci: Option<&str>) -> Result<bool, String> {
    match (bless, ci) {
        (None, _) => Ok(false),
        // CI is set by CI services as `true` (or `1`, `yes`): anything but empty, 0 or false.
        (Some(_), Some(ci)) if !matches!(ci.trim(), "" | "0" | "false") => Err(format!(
            "PLATOON_BLESS is set with CI={ci}: CI checks the committed docs/ files and never \
             rewrites them; bless locally and commit the result"
        )),
        (Some(_), _) => Ok(true),
    }
}

fn check(name: &str, generated: &str) {
    let path = docs().join(name);
    let var = |k: &str| std::env::var_os(k).map(|v| v.to_string_lossy().into_owned());
    if bless(var("PLATOON_BLESS").as_deref(), var("CI").as_deref())
        .unwrap_or_else(|e| panic!("{e}"))
    {
        std::fs::write(&path, generated)
            .unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != generated {
        let line = committed
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| committed.lines().count().min(generated.lines().count()));
        panic!(
            "docs/{name} is not what the schema types generate (first difference at line {}): \
             run `PLATOON_BLESS=1 cargo test -p platoon-config --test config reference::` and \
             commit it",
            line + 1
        );
    }
}

#[test]
fn the_json_schema_is_current() {
    check("config.schema.json", &platoon_config::schema_json());
}

#[test]
fn the_reference_page_is_current() {
    check("config-reference.md", &platoon_config::reference_markdown());
}

#[test]
fn the_reference_names_every_key_of_every_table() {
    let page = platoon_config::reference_markdown();
    for key in [
        "`[trigger]`",
        "**`rule = \"dynamic\"`**",
        "`theta0`",
        "`[[channel.attacks]]`",
        "**`kind = \"gilbert_elliott\"`**",
        "`loss_bad`",
        "`spacing_policy = \"time_headway\"`",
        "`[topology]`",
        "`[fallback.acc]`",
        "`[attack.assumption2]`",
        "`[output]`",
        "`\"parquet\"`",
    ] {
        assert!(page.contains(key), "{key} in the reference");
    }
    // Defaults come from the code, not from comments.
    assert!(page.contains("| `gap_m` | number | `200.0` |"), "{page}");
    assert!(page.contains("| `end_s` | number | `inf` |"), "{page}");
}

#[test]
fn bless_is_refused_in_ci() {
    assert_eq!(bless(None, Some("true")), Ok(false));
    assert_eq!(bless(None, None), Ok(false));
    assert_eq!(bless(Some("1"), None), Ok(true));
    assert_eq!(bless(Some("1"), Some("false")), Ok(true));
    assert_eq!(bless(Some("1"), Some("")), Ok(true));
    let refused = bless(Some("1"), Some("true")).unwrap_err();
    assert!(refused.contains("CI=true"), "{refused}");
    assert!(bless(Some("1"), Some("1")).is_err());
}
