//! The committed campaign file reference is what the schema types generate: after changing
//! them, `PLATOON_BLESS=1 cargo test -p platoon-campaign --test reference` rewrites it (never
//! where `CI` is set).
use std::path::Path;

#[test]
fn the_campaign_reference_is_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/campaign-reference.md");
    platoon_config::check_committed(
        &path,
        &platoon_campaign::reference_markdown(),
        "PLATOON_BLESS=1 cargo test -p platoon-campaign --test reference",
    )
    .unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn the_campaign_reference_names_every_table() {
    let page = platoon_campaign::reference_markdown();
    for key in [
        "`[[axes]]`",
        "`[dos_window]`",
        "`[monte_carlo]`",
        "`transport`",
        "`zip`",
    ] {
        assert!(page.contains(key), "{key} in the reference:\n{page}");
    }
}
