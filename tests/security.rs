//! Signed V2V (`[security]`, docs/security.md) in process: signing changes nothing in a run
//! without attacks; an outsider's forged leave notice and forged join request (the catalogue's
//! `forge_maneuver`, which rewrites genuine packets, and a fresh forgery, unsealed or sealed
//! with a key of another PKI) are refused at verification and change nothing: the run is the
//! same bit for bit as without the forgery. A signed run over iceoryx2 (contract v5 carries
//! the seal) is the same bit for bit as in process, and both say in timing.json what signing
//! and verifying took per step (an unsigned run's timing.json has neither).
use crate::common;

use common::maneuvers::{forged_to_leader, nothing, of, run_with, Log, FAKE_JOIN_REQUEST};
use common::repo;
use platoon_attacks::inject::Step;
use platoon_control::security::{Sealing, SecurityParams};
use platoon_control::{Delivery, Role, SealCounts};
use platoon_maneuver::Body;
use platoon_model::VehicleId;
use platoon_sim::{Scenario, StepRow};

fn config(name: &str) -> String {
    std::fs::read_to_string(repo().join(format!("configs/{name}.toml"))).unwrap()
}

fn scenario(text: &str) -> Scenario {
    platoon_config::parse(text, std::path::Path::new("signed.toml"))
        .unwrap()
        .1
}

/// `text` with `[security]` (its keys `keys`) at its end.
fn signed(text: &str, keys: &str) -> String {
    format!("{text}\n[security]\n{keys}")
}

/// The refusals of `seals` by name.
fn refused(seals: &SealCounts, name: &str) -> u64 {
    seals.by_reason().find(|(n, _)| *n == name).unwrap().1
}

/// Whether two runs' rows are the same bit for bit (NaN included: a radar without a target).
fn same(a: &[StepRow], b: &[StepRow]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| format!("{x:?}") == format!("{y:?}"))
}

fn rows_and_log(text: &str, forge: fn(&Step<'_>, &mut Vec<Delivery>)) -> (Vec<StepRow>, Log) {
    run_with(scenario(text), |_, _| false, forge)
}

/// The catalogue's forged leave notice (as tests/leaves.rs): follower 2's packets to the leader
/// rewritten at 10 s; follower 5 leaves at 45 s on its own.
fn leave_with(forgery: &str) -> String {
    let mut text = config("leave");
    let cut = text.find("[[maneuvers.leaves]]").unwrap();
    text.truncate(cut);
    text.push_str("[[maneuvers.leaves]]\nvehicle = 5\nat_s = 45.0\n\n");
    text.push_str(forgery);
    text
}

const FORGED_LEAVE: &str = "[[channel.attacks]]\nkind = \"forge_maneuver\"\n\
    message = \"leave_notice\"\nsenders = [2]\nreceivers = [0]\nstart_s = 10.0\nend_s = 10.2\n";

/// A fresh forgery at 10 s: a leave notice in follower 2's name, carrying no seal.
fn unsealed_leave(step: &Step<'_>, out: &mut Vec<Delivery>) {
    if step.k == 1000 {
        let state = step.states[2];
        out.push(forged_to_leader(
            step.k,
            2,
            state,
            (1001, 1),
            Body::LeaveNotice,
        ));
    }
}

/// A fresh forgery at 3 s: a join request in the joiner's name, sealed by an outsider with a
/// pseudonym of a PKI of its own (another seed: another root).
fn foreign_join_request(step: &Step<'_>, out: &mut Vec<Delivery>) {
    if step.k == 300 {
        let outsider = SecurityParams {
            seed: 0xbad,
            ..SecurityParams::default()
        };
        let mut d = forged_to_leader(
            step.k,
            4,
            step.states[4],
            (301, 1),
            Body::JoinRequest {
                behind: VehicleId(3),
            },
        );
        let mut sealing = Sealing::new(outsider, step.states.len(), 0.01);
        sealing.seal(step.k, std::slice::from_mut(&mut d.packet));
        assert!(d.packet.seal.is_some());
        out.push(d);
    }
}

#[test]
fn signing_changes_nothing_in_a_run_without_attacks() {
    let text = config("join");
    let (plain, log) = rows_and_log(&text, nothing);
    assert!(log.seals.is_none());
    for keys in [
        "",
        "policy = \"on_demand\"\npseudonym_change_s = 5.0\ncertificate_period_s = 0.5\n",
    ] {
        let (rows, log) = rows_and_log(&signed(&text, keys), nothing);
        assert!(
            same(&rows, &plain),
            "{keys:?}: a genuine signed run differs"
        );
        let seals = log.seals.unwrap();
        assert_eq!(seals.refused_total(), 0, "{keys:?}: {seals:?}");
        assert!(
            seals.signed > 5000 && seals.verified >= seals.signed,
            "{seals:?}"
        );
    }
    // summary.json says it, every reason listed.
    let mut s = scenario(&signed(&text, ""));
    s.steps = 200;
    let summary = platoon_sim::run(s, |_| {}).unwrap();
    let security = summary.security.unwrap();
    assert_eq!(security.policy, "every");
    assert_eq!(security.refused.len(), 11);
    assert_eq!(security.refused_total, 0);
    assert!(security.signed > 0);
    let json = serde_json::to_value(&security).unwrap();
    assert_eq!(json["refused"]["bad_signature"], 0);
}

#[test]
fn an_outsiders_forged_leave_notice_is_refused_and_changes_nothing() {
    // Unsigned, the catalogue's forgery ejects follower 2 (tests/leaves.rs), and a fresh
    // forgery, which carries no seal, changes the run: the runs do not depend on the policy.
    let (unsigned, _) = rows_and_log(&leave_with(FORGED_LEAVE), nothing);
    assert!(of(&unsigned, 2).iter().any(|r| r.mode == Role::Left));
    let (plain, _) = rows_and_log(&leave_with(""), nothing);
    let (forged, _) = rows_and_log(&leave_with(""), unsealed_leave);
    assert!(
        !same(&forged, &plain),
        "the unsealed leave changes nothing even unsigned"
    );
    for policy in ["every", "on_demand"] {
        let keys = format!("policy = \"{policy}\"\n");
        let (genuine, _) = rows_and_log(&signed(&leave_with(""), &keys), nothing);
        // Follower 2 stays, follower 5 leaves at 45 s.
        assert!(of(&genuine, 2).iter().all(|r| r.mode != Role::Left));
        assert!(of(&genuine, 5).iter().any(|r| r.mode == Role::Left));

        // Signed: the rewritten packets keep follower 2's seal, which no longer holds.
        let (rows, log) = rows_and_log(&signed(&leave_with(FORGED_LEAVE), &keys), nothing);
        assert!(
            same(&rows, &genuine),
            "{policy}: the forged leave changed the run"
        );
        let seals = log.seals.unwrap();
        assert!(refused(&seals, "bad_signature") > 0, "{policy}: {seals:?}");
        assert_eq!(seals.refused_total(), refused(&seals, "bad_signature"));

        // The fresh forgery, signed: refused.
        let (rows, log) = rows_and_log(&signed(&leave_with(""), &keys), unsealed_leave);
        assert!(
            same(&rows, &genuine),
            "{policy}: the unsealed leave changed the run"
        );
        let seals = log.seals.unwrap();
        assert_eq!(
            (refused(&seals, "truncated"), seals.refused_total()),
            (1, 1)
        );
    }
}

#[test]
fn an_outsiders_forged_join_request_is_refused_and_changes_nothing() {
    let text = config("join");
    let (genuine, _) = rows_and_log(&signed(&text, ""), nothing);
    // The joiner joins.
    assert!(of(&genuine, 4).iter().any(|r| r.mode == Role::Member));
    // Unsigned, the catalogue's forgery keeps it out (tests/maneuvers.rs).
    let (unsigned, _) = rows_and_log(&format!("{text}{FAKE_JOIN_REQUEST}"), nothing);
    assert!(of(&unsigned, 4).iter().all(|r| r.mode == Role::Outside));

    let forged = signed(&format!("{text}{FAKE_JOIN_REQUEST}"), "");
    let (rows, log) = rows_and_log(&forged, nothing);
    assert!(
        same(&rows, &genuine),
        "the forged join request changed the run"
    );
    let seals = log.seals.unwrap();
    assert!(refused(&seals, "bad_signature") > 0, "{seals:?}");
    assert_eq!(seals.refused_total(), refused(&seals, "bad_signature"));

    // Sealed by an outsider's own PKI: its root is not the platoon's. Unsigned, it changes
    // the run.
    let (plain, _) = rows_and_log(&text, nothing);
    let (forged, _) = rows_and_log(&text, foreign_join_request);
    assert!(
        !same(&forged, &plain),
        "the outsider's join request changes nothing even unsigned"
    );
    let (rows, log) = rows_and_log(&signed(&text, ""), foreign_join_request);
    assert!(
        same(&rows, &genuine),
        "the outsider's join request changed the run"
    );
    let seals = log.seals.unwrap();
    assert_eq!(
        (refused(&seals, "foreign_root"), seals.refused_total()),
        (1, 1)
    );
}

/// A signed join with the catalogue's fake join request, verified on demand, with a detector
/// on, over both transports: the seals cross the wire (contract v5) and every output is the
/// same bit for bit, the summary's `security` and the detections' dataset included (the
/// controller process reports its counts in its DONE, its refusals as inspections); the
/// forgery is refused as `bad_signature`, which the dataset says of exactly the deliveries the
/// ground truth labels altered, and the joiner joins.
#[test]
fn a_signed_run_is_bit_identical_on_both_transports() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("signed.toml"),
        signed(
            &format!(
                "{}{FAKE_JOIN_REQUEST}\n[detection.plausibility]\n",
                config("join")
            ),
            "policy = \"on_demand\"\n",
        ),
    )
    .unwrap();
    for (out, transport) in [("ipc", "iceoryx2"), ("inproc", "inproc")] {
        common::run_config(
            &tmp.path().join("signed.toml"),
            out,
            &["--transport", transport],
            tmp.path(),
        );
    }
    for f in [
        "trajectories.csv",
        "events.csv",
        "channel.csv",
        "wire.csv",
        "summary.json",
        "detections.csv",
    ] {
        let a = std::fs::read(tmp.path().join("ipc").join(f)).unwrap();
        let b = std::fs::read(tmp.path().join("inproc").join(f)).unwrap();
        assert!(a == b, "{f} differs between the transports");
    }
    let summary = common::json(&tmp.path().join("ipc/summary.json"));
    let security = &summary["security"];
    assert_eq!(security["policy"], "on_demand", "{security}");
    assert!(
        security["refused"]["bad_signature"].as_u64().unwrap() > 0,
        "{security}"
    );
    assert_eq!(
        security["refused_total"],
        security["refused"]["bad_signature"]
    );
    assert!(security["signed"].as_u64().unwrap() > 5000, "{security}");
    let events = std::fs::read_to_string(tmp.path().join("ipc/events.csv")).unwrap();
    assert!(events.contains(",joined,"), "the joiner joins");
    let rows = std::fs::read_to_string(tmp.path().join("ipc/detections.csv")).unwrap();
    let head: Vec<&str> = rows.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (by, label) = (col("refused_by"), col("label"));
    let mut refused = 0;
    for r in rows
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
    {
        assert_eq!(
            r[by] == "bad_signature",
            r[label] == "altered",
            "only the altered deliveries are refused by their seal: {r:?}"
        );
        refused += u64::from(r[by] == "bad_signature");
    }
    assert_eq!(refused, security["refused_total"].as_u64().unwrap());
    // timing.json says what signing and verifying took per step, on both transports, over
    // every step (durations are the machine's: only their presence is asserted).
    let steps = |t: &serde_json::Value, stage: &str| t[stage]["n"].as_u64().unwrap_or(0);
    let (ipc, inproc) = (
        common::json(&tmp.path().join("ipc/timing.json")),
        common::json(&tmp.path().join("inproc/timing.json")),
    );
    for t in [&ipc, &inproc] {
        for stage in ["sign", "verify"] {
            assert!(steps(t, stage) > 5000, "{stage}: {t}");
            assert!(t[stage]["max_us"].as_f64().unwrap() > 0.0, "{stage}: {t}");
            assert!(t[stage]["p99_us"].as_f64().unwrap() > 0.0, "{stage}: {t}");
        }
    }
    assert_eq!(steps(&ipc, "sign"), steps(&inproc, "sign"));
    assert_eq!(steps(&ipc, "verify"), steps(&inproc, "verify"));
}

/// An unsigned run's timing.json is what it was before `[security]`: no `sign` or `verify`,
/// on either transport.
#[test]
fn an_unsigned_runs_timing_json_has_no_sign_or_verify() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("plain.toml"), config("join")).unwrap();
    for (out, transport) in [("ipc", "iceoryx2"), ("inproc", "inproc")] {
        common::run_config(
            &tmp.path().join("plain.toml"),
            out,
            &["--transport", transport],
            tmp.path(),
        );
        let t = common::json(&tmp.path().join(out).join("timing.json"));
        assert!(t["step"]["p50_us"].is_f64(), "{transport}: {t}");
        for stage in ["sign", "verify"] {
            assert!(t.get(stage).is_none(), "{transport}: {stage}: {t}");
        }
    }
}

/// A controller plug-in neither signs nor verifies: a signed run with one is refused, naming
/// the key, rather than run unsigned.
#[test]
fn a_signed_run_with_a_controller_plug_in_is_refused_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("signed.toml"), signed(&config("join"), "")).unwrap();
    let o = common::platoon(
        &["run", "signed.toml", "--out", "out", "--controller", "true"],
        tmp.path(),
    );
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("signed.toml") && err.contains("security") && err.contains("--controller"),
        "{err}"
    );
    assert!(!tmp.path().join("out").exists());
}
