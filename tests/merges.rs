//! Two platoons merging over V2V, in process: `configs/merge.toml` (the leader's platoon of
//! followers 1-2, and the rear platoon headed by vehicle 3 on its ACC, vehicles 4-5 following
//! it; the head asks to merge at 5 s), a lost request, a merge jammed half way and a forged
//! in-position report, each ending in a safe formation; and one platoon splitting in two,
//! `configs/split.toml` (follower 3 heads followers 4-5 off at 20 s). Both transports agree on
//! them bit for bit (tests/cosim.rs), SUMO with the native plant (tests/sumo.rs).
use crate::common;

use common::maneuvers::{altered_only, of, run, run_with};
use common::repo;
use platoon_control::Role;
use platoon_maneuver::{Body, Change};
use platoon_model::VehicleId;
use platoon_sim::truth::Label;
use platoon_sim::{Scenario, StepRow};

const LENGTH: f64 = 4.5;
/// The platoon's gap (m, bumper to bumper): `[control] spacing_m`.
const GAP: f64 = 15.5;

fn merge_config() -> String {
    std::fs::read_to_string(repo().join("configs/merge.toml")).unwrap()
}

fn parse(text: &str) -> Result<Scenario, String> {
    platoon_config::parse(text, std::path::Path::new("merge.toml"))
        .map(|(_, s)| s)
        .map_err(|e| e.to_string())
}

/// Vehicle `behind`'s gap to vehicle `behind - 1` at every step (m, bumper to bumper).
fn gaps(rows: &[StepRow], behind: u16) -> Vec<f64> {
    of(rows, behind - 1)
        .iter()
        .zip(of(rows, behind))
        .map(|(a, b)| a.p - b.p - LENGTH)
        .collect()
}

/// Follower `v`'s largest change of command from one step to the next over `steps`.
fn largest_step(rows: &[StepRow], v: u16, steps: std::ops::Range<usize>) -> f64 {
    let u: Vec<f64> = of(rows, v).iter().map(|r| r.u).collect();
    steps.map(|k| (u[k + 1] - u[k]).abs()).fold(0.0, f64::max)
}

/// Whom follower `v` took as its leader at every step (the `head` column).
fn heads(rows: &[StepRow], v: u16) -> Vec<u16> {
    of(rows, v).iter().map(|r| r.head.unwrap()).collect()
}

/// `text` with the catalogue's forged `message` on `sender`'s packets to the leader over
/// `[start_s, start_s + 0.2)`.
fn with_forged(text: &str, message: &str, sender: u16, start_s: f64) -> String {
    text.replace(
        "[maneuvers]\n",
        &format!(
            "[[channel.attacks]]\nkind = \"forge_maneuver\"\nmessage = \"{message}\"\n\
             senders = [{sender}]\nreceivers = [0]\nstart_s = {start_s}\nend_s = {}\n\n\
             [maneuvers]\n",
            start_s + 0.2
        ),
    )
}

/// `text`'s run in process through the recording channel, its attacks the config's own.
fn run_attacked(text: &str) -> (Vec<StepRow>, common::maneuvers::Log) {
    run_with(parse(text).unwrap(), |_, _| false, |_, _| {})
}

/// Asserts that the rear platoon stayed apart for the whole run: its head outside the
/// leader's platoon, its followers following it.
fn apart_to_the_end(rows: &[StepRow]) {
    assert!(of(rows, 3).iter().all(|r| r.mode == Role::Outside));
    for v in [4, 5] {
        assert!(heads(rows, v).iter().all(|&h| h == 3), "vehicle {v}");
    }
}

/// Asserts that no vehicle came within 10 m of the one ahead.
fn nobody_near_another(rows: &[StepRow]) {
    for v in 1..=5 {
        let smallest = gaps(rows, v).into_iter().fold(f64::INFINITY, f64::min);
        assert!(smallest > 10.0, "vehicle {v}: {smallest}");
    }
}

#[test]
fn two_platoons_merge_over_v2v_and_close_up_without_a_jump() {
    let (rows, sent) = run(parse(&merge_config()).unwrap(), |_, _| false);
    let bodies: Vec<(u64, VehicleId, Body)> =
        sent.iter().map(|(k, m)| (*k, m.sender, m.body)).collect();
    let request = Body::MergeRequest {
        behind: VehicleId(2),
        tail: VehicleId(5),
    };
    assert_eq!(bodies[0], (501, VehicleId(3), request));
    let merged = Change::Merged {
        head: VehicleId(3),
        tail: VehicleId(5),
    };
    let updates: Vec<u64> = bodies
        .iter()
        .filter(|(_, s, b)| {
            *s == VehicleId::LEADER && matches!(b, Body::Update { change, .. } if *change == merged)
        })
        .map(|(k, ..)| *k)
        .collect();
    assert_eq!(updates.len(), 3, "announced three times: {updates:?}");
    let at = updates[0] as usize;
    // The head takes the law on the update (heard at the step it is sent) and passes it on; its
    // followers, which hear only it, follow it until then and the leader from the next step.
    let relayed: Vec<u64> = bodies
        .iter()
        .filter(|(_, s, b)| {
            *s == VehicleId(3) && matches!(b, Body::Update { change, .. } if *change == merged)
        })
        .map(|(k, ..)| *k)
        .collect();
    assert_eq!(relayed[0], updates[0] + 1, "{relayed:?}");
    for v in [4, 5] {
        let h = heads(&rows, v);
        assert!(h[..=at].iter().all(|&h| h == 3), "vehicle {v}");
        assert!(h[at + 1..].iter().all(|&h| h == 0), "vehicle {v}");
    }
    assert!(heads(&rows, 3).iter().all(|&h| h == 0));
    let head = of(&rows, 3);
    assert!(head[..at].iter().all(|r| r.mode == Role::Outside));
    assert!(head[at..].iter().all(|r| r.mode != Role::Outside));
    // Closed up: every gap the platoon's, nobody near another, no step in any command at the
    // hand-over (the largest steps of the run are the leader's profile's, at 10, 15, 35, 40 s).
    for v in 1..=5 {
        let g = gaps(&rows, v);
        let last = *g.last().unwrap();
        assert!((last - GAP).abs() < 0.5, "vehicle {v}: {last}");
        let smallest = g.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(smallest > 10.0, "vehicle {v}: {smallest}");
        let jump = largest_step(&rows, v, at - 200..at + 500);
        assert!(jump < 0.15, "vehicle {v}: {jump}");
    }
    // Until the request the rear platoon kept its head's ACC gap (15.5 m + 2 s x v).
    let before = gaps(&rows, 3)[500];
    let v = head[500].v;
    assert!(
        (before - (GAP + 2.0 * v)).abs() < 0.5,
        "{before} at {v} m/s"
    );
}

/// A merge request the channel loses every time is asked three times; then the head gives up
/// and the platoons stay apart to the end, safely: the rear platoon still follows its head.
#[test]
fn a_lost_merge_request_leaves_the_platoons_apart_safely() {
    let (rows, sent) = run(parse(&merge_config()).unwrap(), |_, m| {
        matches!(m.body, Body::MergeRequest { .. })
    });
    let requests: Vec<u64> = sent
        .iter()
        .filter(|(_, m)| matches!(m.body, Body::MergeRequest { .. }))
        .map(|(k, _)| *k)
        .collect();
    assert_eq!(requests, [501, 551, 601]);
    assert!(sent
        .iter()
        .all(|(_, m)| !matches!(m.body, Body::Update { .. })));
    apart_to_the_end(&rows);
    nobody_near_another(&rows);
}

/// The field's laws on the predecessor and the leader merge the platoons; the consensus law,
/// which weighs its neighbours by vehicle for the whole run, is refused a merge and a split
/// with the key to change.
#[test]
fn every_law_but_consensus_merges() {
    let text = merge_config();
    for law in ["ploeg", "flatbed"] {
        let mut t = text.replace(
            "law = \"path_cacc\"\nspacing_m = 15.5",
            &format!("law = \"{law}\"\nspacing_m = 15.5"),
        );
        if law == "ploeg" {
            // Ploeg's CACC keeps its own time headway and standstill gap.
            t = t
                .replace("law = \"ploeg\"\nspacing_m = 15.5", "law = \"ploeg\"")
                .replace(
                    "spacing_m = 20.0 ",
                    "spacing_m = 6.5\nspacing_policy = \"time_headway\"\ntime_headway_s = 0.5 ",
                );
        }
        let (rows, _) = run(parse(&t).unwrap(), |_, _| false);
        let head = of(&rows, 3);
        assert_ne!(head.last().unwrap().mode, Role::Outside, "{law}");
        for v in 1..=5 {
            let smallest = gaps(&rows, v).into_iter().fold(f64::INFINITY, f64::min);
            assert!(smallest > 5.0, "{law}: vehicle {v}: {smallest}");
        }
    }
    let t = text
        .replace(
            "law = \"path_cacc\"\nspacing_m = 15.5",
            "law = \"consensus\"",
        )
        .replace(
            "spacing_m = 20.0 ",
            "spacing_m = 19.5\nspacing_policy = \"time_headway\"\ntime_headway_s = 0.8 ",
        );
    let e = parse(&t).unwrap_err();
    assert!(e.contains("maneuvers") && e.contains("merge"), "{e}");
    let split = t.replace("[maneuvers.merge]", "[maneuvers.split]");
    let e = parse(&split).unwrap_err();
    assert!(e.contains("maneuvers") && e.contains("split"), "{e}");
}

#[test]
fn a_bad_merge_names_its_key() {
    let text = merge_config();
    let err = |from: &str, to: &str| {
        let t = text.replace(from, to);
        assert_ne!(t, text, "{from}");
        parse(&t).unwrap_err()
    };
    let e = err("head = 3", "head = 1");
    assert!(e.contains("maneuvers.merge") && e.contains("2 to 4"), "{e}");
    let e = err("head = 3", "head = 9");
    assert!(e.contains("maneuvers.merge.head"), "{e}");
    let e = err(
        "[maneuvers.merge]",
        "[[maneuvers.leaves]]\nvehicle = 1\nat_s = 9.0\n\n[maneuvers.merge]",
    );
    assert!(
        e.contains("maneuvers.merge") && e.contains("no joins, leaves"),
        "{e}"
    );
    let e = err("at_s = 5.0", "at_s = -1.0");
    assert!(e.contains("maneuvers.merge.at_s"), "{e}");
    let e = err(
        "[maneuvers.merge]",
        "[maneuvers.split]\nhead = 2\nat_s = 9.0\n\n[maneuvers.merge]",
    );
    assert!(e.contains("no joins, leaves or other regrouping"), "{e}");
    let e = err("[fallback]\n", "[fallback]\ncut_in = { split = true }\n");
    assert!(e.contains("maneuvers.merge") && e.contains("cut-in"), "{e}");
    // A forged split notice needs a run whose formations follow who heads whom.
    let joins = std::fs::read_to_string(repo().join("configs/join.toml")).unwrap();
    let forged = joins.replace(
        "[maneuvers]\n",
        "[[channel.attacks]]\nkind = \"forge_maneuver\"\nmessage = \"split_notice\"\n\n\
         [maneuvers]\n",
    );
    let e = parse(&forged).unwrap_err();
    assert!(
        e.contains("channel.attacks[0].message") && e.contains("[maneuvers.split]"),
        "{e}"
    );
}

fn split_config() -> String {
    std::fs::read_to_string(repo().join("configs/split.toml")).unwrap()
}

#[test]
fn a_platoon_splits_over_v2v_and_opens_the_gap_without_a_jump() {
    let (rows, sent) = run(parse(&split_config()).unwrap(), |_, _| false);
    let notices: Vec<(u64, VehicleId)> = sent
        .iter()
        .filter(|(_, m)| m.body == Body::SplitNotice)
        .map(|(k, m)| (*k, m.sender))
        .collect();
    assert_eq!(notices, [(2001, VehicleId(3))]);
    let split = Change::Split { head: VehicleId(3) };
    let updates: Vec<u64> = sent
        .iter()
        .filter(|(_, m)| {
            m.sender == VehicleId::LEADER
                && matches!(m.body, Body::Update { change, .. } if change == split)
        })
        .map(|(k, _)| *k)
        .collect();
    assert_eq!(updates.len(), 3, "announced three times: {updates:?}");
    let at = updates[0] as usize;
    // The members behind the splitter follow the leader until the update, the splitter from
    // then on; the splitter leaves the law for its ACC.
    for v in [4, 5] {
        let h = heads(&rows, v);
        assert!(h[..at].iter().all(|&h| h == 0), "vehicle {v}");
        assert!(h[at..].iter().all(|&h| h == 3), "vehicle {v}");
    }
    let head = of(&rows, 3);
    assert!(head[..at].iter().all(|r| r.mode != Role::Outside));
    assert!(head[at..].iter().all(|r| r.mode == Role::Outside));
    // Apart: the new head at its ACC's gap (15.5 m + 2 s x v), its platoon at the platoon's;
    // nobody near another, no step in any command at the hand-over.
    let last = gaps(&rows, 3).last().copied().unwrap();
    let v = head.last().unwrap().v;
    assert!((last - (GAP + 2.0 * v)).abs() < 1.0, "{last} at {v} m/s");
    for v in 1..=5 {
        let g = gaps(&rows, v);
        if v != 3 {
            let last = *g.last().unwrap();
            assert!((last - GAP).abs() < 0.5, "vehicle {v}: {last}");
        }
        let smallest = g.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(smallest > 10.0, "vehicle {v}: {smallest}");
        let jump = largest_step(&rows, v, at - 200..at + 500);
        assert!(jump < 0.15, "vehicle {v}: {jump}");
    }
}

/// Split notices the channel loses are told again every 0.5 s; with none getting through the
/// splitter gives up after three and the platoon stays whole.
#[test]
fn a_split_nobody_hears_leaves_the_platoon_whole() {
    let (rows, sent) = run(parse(&split_config()).unwrap(), |_, m| {
        m.body == Body::SplitNotice
    });
    let notices: Vec<u64> = sent
        .iter()
        .filter(|(_, m)| m.body == Body::SplitNotice)
        .map(|(k, _)| *k)
        .collect();
    assert_eq!(notices, [2001, 2051, 2101]);
    assert!(sent
        .iter()
        .all(|(_, m)| !matches!(m.body, Body::Update { .. })));
    for v in 1..=5 {
        assert!(heads(&rows, v).iter().all(|&h| h == 0), "vehicle {v}");
        assert!(of(&rows, v).iter().all(|r| r.mode != Role::Outside));
        let last = gaps(&rows, v).last().copied().unwrap();
        assert!((last - GAP).abs() < 0.5, "vehicle {v}: {last}");
    }
}

/// The merge jammed half way (`kind = "jam_maneuvers"` on the leader's updates from the
/// request on): the head closes up and reports in position, never hears the update, asks
/// again, then withdraws; it stays on its ACC behind the tail and its platoon keeps following
/// it: two platoons to the end, nobody near another.
#[test]
fn a_merge_jammed_half_way_leaves_two_platoons_safely() {
    let text = merge_config().replace(
        "[maneuvers]\n",
        "[[channel.attacks]]\nkind = \"jam_maneuvers\"\nmessages = [\"update\"]\n\
         start_s = 5.0\n\n[maneuvers]\n",
    );
    let (rows, log) = run_attacked(&text);
    let from_head = |kind: fn(&Body) -> bool| {
        log.sent
            .iter()
            .filter(|(_, m)| m.sender == VehicleId(3) && kind(&m.body))
            .count()
    };
    assert_eq!(from_head(|b| *b == Body::InPosition), 3);
    assert!(from_head(|b| *b == Body::LeaveNotice) >= 1, "it withdraws");
    assert_eq!(from_head(|b| matches!(b, Body::Update { .. })), 0);
    // The leader, which had merged the head's platoon, splits it off again on the withdrawal.
    let split = Body::Update {
        generation: 2,
        change: Change::Split { head: VehicleId(3) },
    };
    assert!(log
        .sent
        .iter()
        .any(|(_, m)| m.sender == VehicleId::LEADER && m.body == split));
    apart_to_the_end(&rows);
    nobody_near_another(&rows);
}

/// An outsider's forged in-position report in the head's name 1 s after its request
/// (`kind = "forge_maneuver"`): the leader announces the merge early; the head, not in its
/// slot, ignores the update and does not pass it on, so its followers keep following it; the
/// forged packets are labelled altered in their maneuver field, and nobody comes near another.
#[test]
fn a_forged_in_position_report_merges_nobody_early() {
    let text = with_forged(&merge_config(), "in_position", 3, 6.0);
    let (rows, log) = run_attacked(&text);
    let early = log
        .sent
        .iter()
        .find(|(_, m)| m.sender == VehicleId::LEADER && matches!(m.body, Body::Update { .. }))
        .map(|(k, _)| *k)
        .unwrap();
    assert!((600..650).contains(&early), "{early}");
    altered_only(&log, 3, Body::InPosition);
    // The forged report used up the head's sequence numbers: its genuine reports are dropped
    // as old, it never joins, and its platoon follows it to the end.
    apart_to_the_end(&rows);
    nobody_near_another(&rows);
}

/// A split nobody asked for (`kind = "forge_maneuver"`, `message = "split_notice"`): an
/// outsider's notice in follower 2's name at 10 s. The leader splits the platoon at follower 2,
/// which heads followers 3-5 on its ACC from then on; follower 3's own split notice at 20 s
/// goes to its new head, which has none to give, so it stays a member of follower 2's platoon.
/// The forged packets are labelled altered; nobody comes near another.
#[test]
fn a_forged_split_notice_splits_the_platoon_safely_and_is_labelled_altered() {
    let text = with_forged(&split_config(), "split_notice", 2, 10.0);
    let (rows, log) = run_attacked(&text);
    let at = of(&rows, 2)
        .iter()
        .position(|r| r.mode == Role::Outside)
        .expect("follower 2 heads a platoon");
    assert!((1001..1030).contains(&at), "{at}");
    for v in [3, 4, 5] {
        let h = heads(&rows, v);
        assert!(h[at + 1..].iter().all(|&h| h == 2), "vehicle {v}");
    }
    assert!(of(&rows, 3).iter().all(|r| r.mode != Role::Outside));
    altered_only(&log, 2, Body::SplitNotice);
    nobody_near_another(&rows);
}

/// `[maneuvers] check_reports`: the leader checks an in-position report against the sender's
/// own beacon and the beacon of the member its slot is behind. The forged reports of the
/// catalogue (`forge_maneuver`, `in_position`, a second after the request) put the sender tens
/// of metres from its slot, so the leader drops them before its sequence filter sees them:
/// the tail join and the merge complete as if there had been no attack, every row bit for bit;
/// and the genuine reports pass the check (with no attack, the same rows as without it).
#[test]
fn the_leaders_report_check_drops_forged_in_position_reports() {
    let joins = std::fs::read_to_string(repo().join("configs/join.toml")).unwrap();
    for (text, joiner, at) in [(merge_config(), 3, "6.0"), (joins, 4, "6.0")] {
        let checked = text.replace("[maneuvers]\n", "[maneuvers]\ncheck_reports = true\n");
        let forged = checked.replace(
            "[maneuvers]\n",
            &format!(
                "[[channel.attacks]]\nkind = \"forge_maneuver\"\nmessage = \"in_position\"\n\
                 senders = [{joiner}]\nreceivers = [0]\nstart_s = {at}\nend_s = 6.2\n\n\
                 [maneuvers]\n"
            ),
        );
        // Rows compared bit for bit (NaN included) through their debug form.
        let rows = |rows: Vec<StepRow>| format!("{rows:?}");
        let plain = rows(run(parse(&text).unwrap(), |_, _| false).0);
        let clean = rows(run(parse(&checked).unwrap(), |_, _| false).0);
        assert!(
            plain == clean,
            "vehicle {joiner}: a genuine report passes the check"
        );
        let (attacked, log) = run_attacked(&forged);
        assert!(
            log.labelled.iter().any(|(_, l)| *l != Label::Genuine),
            "the forger was at work"
        );
        assert!(
            rows(attacked) == clean,
            "vehicle {joiner}: the forged reports change nothing"
        );
        let unchecked = forged.replace("check_reports = true\n", "");
        let (unchecked, _) = run_attacked(&unchecked);
        assert!(
            rows(unchecked) != clean,
            "vehicle {joiner}: without the check they do"
        );
        // What the leader dropped is counted in the summary's refused packets.
        let refused = |text: &str| {
            let summary = platoon_sim::run(parse(text).unwrap(), |_| {}).unwrap();
            summary.rejected_packets.implausible_state
        };
        assert_eq!(refused(&checked), 0, "vehicle {joiner}");
        assert!(refused(&forged) > 0, "vehicle {joiner}");
    }
}

/// The rows measure a follower against the head its controller names only when that head is
/// a vehicle ahead of it: any other value (a plug-in's mistake) is measured against the
/// leader, never an index out of the plant's states.
#[test]
fn a_head_that_is_no_vehicle_ahead_is_measured_against_the_leader() {
    let s = parse(&merge_config()).unwrap();
    let states: Vec<platoon_model::State> = (0..6)
        .map(|i| platoon_model::State::new(-20.0 * f64::from(i), 15.0, 0.0))
        .collect();
    for head in [5, 200, u16::MAX] {
        let mut out = Vec::new();
        let step = |_| platoon_control::FollowerStep {
            head: VehicleId(head),
            ..Default::default()
        };
        let sources = platoon_sim::RowSources {
            k: 0,
            states: &states,
            leader_triggered: false,
            jammed: &[false; 6],
            ahead: &[],
            targets: &[],
            beside: &[],
        };
        platoon_sim::step_rows(&s, &sources, step, &mut out);
        // Vehicle 4 at its slot behind the leader: no error against the leader.
        assert_eq!(out[4].spacing_error, 0.0, "head {head}");
    }
}
