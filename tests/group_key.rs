//! A platoon's group key (`[security.group]`, docs/security.md#a-group-key-at-join): a join
//! agrees it over the maneuver messages and the joiner's messages then pass; every leave
//! renews it; a thief, who signs with a member's stolen key but holds no group key, has its
//! forged leave notice refused and changes nothing, on both transports alike; an insider, a
//! member, still tags its lies.
use crate::common;

use common::maneuvers::{nothing, of, run_with, Log};
use common::repo;
use common::signed::{config, refused, same, scenario};
use platoon_control::Role;
use platoon_sim::StepRow;

fn run(text: &str) -> (Vec<StepRow>, Log) {
    run_with(scenario(text), |_, _| false, nothing)
}

/// `text` signed, with a group key protecting `mac`.
fn grouped(text: &str, mac: &str) -> String {
    format!("{text}\n[security]\n\n[security.group]\nmac = \"{mac}\"\n")
}

/// `configs/leave.toml` without its leaves, 30 s, with `attacks`.
fn without_leaves(attacks: &str) -> String {
    let mut text = config("leave");
    let cut = text.find("[[maneuvers.leaves]]").unwrap();
    text.truncate(cut);
    let text = text.replace("duration_s = 70.0", "duration_s = 30.0");
    assert!(text.contains("duration_s = 30.0"));
    format!("{text}\n{attacks}")
}

/// A Sybil with follower 4's stolen key forges a leave notice in follower 3's name at 10 s
/// (the study's `stolen-key-sybil`).
const THIEF: &str = "[[channel.attacks]]\nkind = \"forge_maneuver\"\nmessage = \"leave_notice\"\n\
    senders = [3]\nreceivers = [0]\nstart_s = 10.0\nend_s = 10.2\nacts_as = \"thief\"\nkey_of = 4\n";

/// Signatures alone take the thief's notice, and the leader ejects follower 3; with a group
/// key the notice carries no valid tag and is refused, and the run is the same bit for bit
/// as without the thief (its forgery rewrote only packets to the leader, which it refuses).
#[test]
fn a_thiefs_forged_leave_notice_is_refused_under_a_group_key() {
    let signed = format!("{}\n[security]\n", without_leaves(THIEF));
    let (rows, log) = run(&signed);
    assert!(of(&rows, 3).iter().any(|r| r.mode == Role::Left), "ejected");
    assert_eq!(log.seals.unwrap().refused_total(), 0);
    let (genuine, _) = run(&grouped(&without_leaves(""), "maneuvers"));
    for (mac, reason) in [("maneuvers", "untagged"), ("all", "bad_tag")] {
        let (rows, log) = run(&grouped(&without_leaves(THIEF), mac));
        assert!(of(&rows, 3).iter().all(|r| r.mode != Role::Left), "{mac}");
        let seals = log.seals.unwrap();
        // The notice rode on follower 3's packets to the leader over 0.2 s: under "maneuvers" a
        // beacon turned notice carries no tag; under "all" the beacon's tag no longer holds.
        assert!(refused(&seals, reason) > 0, "{mac}: {seals:?}");
        assert_eq!(refused(&seals, reason), seals.refused_total(), "{mac}");
        if mac == "maneuvers" {
            // The same motion and modes (a run with a forged leave notice keeps lanes, so its
            // rows say each vehicle's lane: the rows' lane fields differ, not what happened).
            let motion = |rows: &[StepRow]| -> Vec<String> {
                (rows.iter())
                    .map(|r| format!("{:?}", (r.p, r.v, r.a, r.u, r.mode, r.triggered)))
                    .collect()
            };
            assert!(
                motion(&rows) == motion(&genuine),
                "the refused notice changes nothing"
            );
        }
    }
}

/// The same thief over iceoryx2: the group fields cross the wire (contract v7) and the
/// injector process forwards the thief's packets as the in-process channel does, so the
/// files are the same bytes.
#[test]
fn a_group_keyed_run_is_bit_identical_on_both_transports() {
    let tmp = tempfile::tempdir().unwrap();
    let text = grouped(&without_leaves(THIEF), "maneuvers");
    std::fs::write(tmp.path().join("thief.toml"), &text).unwrap();
    for (out, transport) in [("ipc", "iceoryx2"), ("inproc", "inproc")] {
        common::run_config(
            &tmp.path().join("thief.toml"),
            out,
            &["--transport", transport],
            tmp.path(),
        );
    }
    for f in ["trajectories.csv", "events.csv", "summary.json", "wire.csv"] {
        let a = std::fs::read(tmp.path().join("ipc").join(f)).unwrap();
        let b = std::fs::read(tmp.path().join("inproc").join(f)).unwrap();
        assert!(a == b, "{f} differs between the transports");
    }
    let summary = common::json(&tmp.path().join("ipc/summary.json"));
    assert!(summary["security"]["refused"]["untagged"].as_u64().unwrap() > 0);
    assert_eq!(summary["security"]["group"]["mac"], "maneuvers");
}

/// A join agrees the key (the joiner's request carries its share, the accept the leader's and
/// the wrapped key), after which the joiner's own messages are tagged and taken: the join
/// completes, nothing is refused, and the run is the signed run without a group key, bit for
/// bit. Every leave renews the key; the members take the new one and nothing is refused
/// under `maneuvers`.
#[test]
fn a_join_agrees_the_key_and_every_leave_renews_it() {
    let join = config("join");
    let (plain, _) = run(&format!("{join}\n[security]\n"));
    let (rows, log) = run(&grouped(&join, "maneuvers"));
    let seals = log.seals.unwrap();
    assert_eq!(seals.refused_total(), 0, "{seals:?}");
    assert!(seals.tagged > 0);
    assert_eq!(seals.renewals, 0);
    assert!(same(&rows, &plain), "the key changes no command");
    let joiner = of(&rows, 4);
    assert_eq!(joiner.first().unwrap().mode, Role::Outside);
    assert_eq!(joiner.last().unwrap().mode, Role::Member, "joined");

    let leave = config("leave");
    let leaves = leave.matches("[[maneuvers.leaves]]").count();
    assert!(leaves >= 2);
    let (rows, log) = run(&grouped(&leave, "maneuvers"));
    let seals = log.seals.unwrap();
    assert_eq!(seals.renewals, leaves as u64);
    assert_eq!(seals.refused_total(), 0, "{seals:?}");
    for v in [2, 5] {
        assert!(
            of(&rows, v).iter().any(|r| r.mode == Role::Left),
            "{v} left"
        );
    }
    // Pseudonym changes every 5 s break nothing: membership and the group key go by the
    // platoon's slots, not by the pseudonyms that sign.
    let changing = grouped(&leave, "maneuvers")
        .replace("[security]\n", "[security]\npseudonym_change_s = 5.0\n");
    assert!(changing.contains("pseudonym_change_s = 5.0"));
    let (changed, log) = run(&changing);
    let seals = log.seals.unwrap();
    assert_eq!((seals.renewals, seals.refused_total()), (leaves as u64, 0));
    assert!(same(&changed, &rows), "the same run as with one pseudonym");
}

/// An insider is a member: it holds the group key, so its lies (false data on its beacons,
/// tagged under `all`) are tagged again with its key and taken, as signed without a key.
#[test]
fn an_insider_still_tags_its_lies() {
    let insider = "[[channel.attacks]]\nkind = \"false_data\"\noffset = [3.0, 0.0, 0.0]\n\
        senders = [2]\nstart_s = 20.0\nend_s = 21.0\nacts_as = \"insider\"\n";
    let (honest, _) = run(&grouped(&without_leaves(""), "all"));
    let (rows, log) = run(&grouped(&without_leaves(insider), "all"));
    let seals = log.seals.unwrap();
    assert_eq!(seals.refused_total(), 0, "{seals:?}");
    assert!(!same(&rows, &honest), "the lies act");
    let (signed, _) = run(&format!("{}\n[security]\n", without_leaves(insider)));
    assert!(same(&rows, &signed), "as they act signed without a key");
}

/// The group fields cross Python intact (contract v7's `V2vPacket.group` in `platoon.wire`):
/// a Python injector that forwards every packet of a run whose every beacon carries a tag
/// (`mac = "all"`, with a join that agrees a key over the wire) gives the in-process run
/// without attacks, byte for byte, and nothing is refused.
#[test]
fn the_group_fields_cross_a_python_injector_intact() {
    let setup = repo().join("bridge/setup-venv.sh");
    let o = std::process::Command::new(&setup).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let injector = format!(
        "{} {}",
        repo().join("bridge/.venv/bin/python").display(),
        repo().join("bridge/examples/drop_sender.py").display()
    );
    let tmp = tempfile::tempdir().unwrap();
    let text = grouped(&config("join"), "all").replace("duration_s = 70.0", "duration_s = 30.0");
    assert!(text.contains("duration_s = 30.0"));
    std::fs::write(tmp.path().join("join.toml"), &text).unwrap();
    let path = tmp.path().join("join.toml");
    common::run_config(&path, "py", &["--injector", &injector], tmp.path());
    common::run_config(&path, "rust", &["--transport", "inproc"], tmp.path());
    for f in ["trajectories.csv", "events.csv"] {
        let a = std::fs::read(tmp.path().join("py").join(f)).unwrap();
        let b = std::fs::read(tmp.path().join("rust").join(f)).unwrap();
        assert!(a == b, "{f} differs behind the Python injector");
    }
    let summary = common::json(&tmp.path().join("py/summary.json"));
    assert_eq!(summary["security"]["refused_total"], 0);
    assert!(summary["security"]["group"]["tagged"].as_u64().unwrap() > 1000);
}
