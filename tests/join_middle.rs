//! A join in the middle negotiated over V2V, in process: `configs/join-middle.toml` (vehicle 4
//! drives in the lane beside and asks at 5 s for the slot behind follower 1; follower 2 opens
//! the gap), the order of the messages, the gap opened and taken without a jump in any
//! command, and a join jammed half way (the move-in never arrives: the leader calls it off and
//! the opener closes its gap). Both transports agree on it bit for bit (tests/cosim.rs), SUMO
//! with the native plant (tests/sumo.rs).
use crate::common;

use common::maneuvers::{forged_to_leader, of, run, run_with};
use common::repo;
use platoon_attacks::inject::Step;
use platoon_control::Delivery;
use platoon_control::{Mode, Role};
use platoon_maneuver::{Body, Change, Message};
use platoon_model::VehicleId;
use platoon_sim::truth::Label;
use platoon_sim::{Scenario, StepRow};

const LENGTH: f64 = 4.5;
/// The platoon's gap (m, bumper to bumper).
const GAP: f64 = 15.5;

fn scenario() -> Scenario {
    let text = std::fs::read_to_string(repo().join("configs/join-middle.toml")).unwrap();
    platoon_config::parse(&text, std::path::Path::new("join-middle.toml"))
        .unwrap()
        .1
}

/// Vehicle `behind`'s gap to vehicle `ahead` at the last step (m, bumper to bumper).
fn last_gap(rows: &[StepRow], ahead: u16, behind: u16) -> f64 {
    of(rows, ahead).last().unwrap().p - of(rows, behind).last().unwrap().p - LENGTH
}

/// The smallest gap on the platoon's lane over the run, in road order, those beside it left
/// out.
fn smallest_gap_on_the_lane(rows: &[StepRow]) -> f64 {
    let per_step = rows.len() / of(rows, 0).len();
    rows.chunks(per_step)
        .map(|step| {
            let mut on: Vec<&StepRow> = step
                .iter()
                .filter(|r| !r.mode.is_beside_the_lane())
                .collect();
            on.sort_by(|a, b| b.p.total_cmp(&a.p));
            on.windows(2)
                .map(|w| w[0].p - w[1].p - LENGTH)
                .fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min)
}

/// The largest change of follower `v`'s command from one step to the next, the steps around
/// the leader's changes of acceleration (10, 15, 35 and 40 s) left out: those are fed forward
/// to every follower by design.
fn largest_step(rows: &[StepRow], v: u16) -> f64 {
    let u: Vec<f64> = of(rows, v).iter().map(|r| r.u).collect();
    let edge = |k: usize| {
        [1000, 1500, 3500, 4000]
            .iter()
            .any(|&e| k + 30 >= e && k <= e + 30)
    };
    (0..u.len() - 1)
        .filter(|&k| !edge(k))
        .map(|k| (u[k + 1] - u[k]).abs())
        .fold(0.0, f64::max)
}

fn bodies(sent: &[(u64, Message)]) -> Vec<Body> {
    let mut out: Vec<Body> = Vec::new();
    for (_, m) in sent {
        if out.last() != Some(&m.body) {
            out.push(m.body);
        }
    }
    out
}

#[test]
fn a_join_in_the_middle_opens_a_gap_and_moves_in_without_a_jump() {
    let (rows, sent) = run(scenario(), |_, _| false);
    let (v1, v2, v4) = (VehicleId(1), VehicleId(2), VehicleId(4));
    assert_eq!(
        bodies(&sent),
        [
            Body::JoinRequest { behind: v1 },
            Body::JoinAccept {
                behind: v1,
                middle: true
            },
            Body::OpenGap { joiner: v4 },
            Body::GapReady { joiner: v4 },
            Body::MoveIn,
            Body::InPosition,
            Body::Update {
                generation: 1,
                change: Change::Joined {
                    vehicle: v4,
                    behind: v1
                }
            },
        ]
    );
    // The opener is follower 2, the member behind the slot; the gap is ready before the joiner
    // is told to move in, and it moves in (changes lanes) when in position.
    let opener = sent
        .iter()
        .find(|(_, m)| matches!(m.body, Body::OpenGap { .. }))
        .unwrap();
    assert_eq!(opener.1.to, v2);
    let joiner = of(&rows, 4);
    let moved_in = joiner.iter().position(|r| r.mode != Role::Beside).unwrap();
    let ready = sent
        .iter()
        .find(|(_, m)| matches!(m.body, Body::GapReady { .. }))
        .unwrap()
        .0 as usize;
    assert!(ready < moved_in, "{ready} {moved_in}");
    assert!(joiner[..moved_in].iter().all(|r| r.mode == Role::Beside));
    assert!(joiner[moved_in..]
        .iter()
        .all(|r| !r.mode.is_beside_the_lane()));
    // It ends between followers 1 and 2, at the platoon's gaps.
    for (ahead, behind) in [(1, 4), (4, 2), (2, 3)] {
        let g = last_gap(&rows, ahead, behind);
        assert!((g - GAP).abs() < 0.5, "{ahead} -> {behind}: {g}");
    }
    // Spacing errors count the joiner in its slot: the last ones are small.
    for v in 1..=4 {
        let e = of(&rows, v).last().unwrap().spacing_error;
        assert!(e.abs() < 0.5, "follower {v}: {e}");
    }
    // No step in any command: the gap opens and closes on a smooth ramp, the joiner keeps its
    // command as it changes lanes, the opener takes it as its predecessor blended.
    for v in 1..=4 {
        let jump = largest_step(&rows, v);
        assert!(jump < 0.15, "follower {v}: {jump}");
    }
    let gap = smallest_gap_on_the_lane(&rows);
    assert!(gap > 10.0, "{gap}");
}

/// The maneuver jammed half way: every move-in is lost, so the joiner waits beside the open
/// gap; the leader calls the join off at its deadline (40 s after the accept), the opener
/// closes its gap again, the joiner stays beside, and nobody comes close.
#[test]
fn a_join_jammed_half_way_is_called_off_and_the_gap_closes() {
    let (rows, sent) = run(scenario(), |_, m| m.body == Body::MoveIn);
    let moves = sent.iter().filter(|(_, m)| m.body == Body::MoveIn).count();
    assert_eq!(moves, 3, "asked three times");
    assert!(sent.iter().any(|(_, m)| m.body
        == Body::Abort {
            joiner: VehicleId(4)
        }));
    assert!(!sent
        .iter()
        .any(|(_, m)| matches!(m.body, Body::Update { .. })));
    assert!(of(&rows, 4).iter().all(|r| r.mode == Role::Beside));
    let g = last_gap(&rows, 1, 2);
    assert!((g - GAP).abs() < 1.0, "the gap closes again: {g}");
    let gap = smallest_gap_on_the_lane(&rows);
    assert!(gap > 10.0, "{gap}");
}

/// A joiner that lies about its position: an in-position report in its name reaches the
/// leader at 27.5 s, after the gap is ready and before the joiner is in its slot (it is still
/// moving up beside). The leader admits it and announces it; the joiner, which never said so,
/// ignores an update while it is not in position, and the opener keeps following the member
/// its radar sees, so nobody steers into a gap that is not there. The joiner moves in when it
/// is in position and the leader's repeated update admits it then. The report is labelled
/// `forged`, everything else `genuine`.
#[test]
fn a_false_in_position_report_admits_nobody_into_a_slot_it_is_not_in() {
    fn early(step: &Step<'_>, out: &mut Vec<Delivery>) {
        if step.k == 2750 {
            let state = step.states[4];
            out.push(forged_to_leader(
                step.k,
                4,
                state,
                (u32::MAX, 100),
                Body::InPosition,
            ));
        }
    }
    let (rows, log) = run_with(scenario(), |_, _| false, early);
    let update = log
        .sent
        .iter()
        .find(|(_, m)| matches!(m.body, Body::Update { .. }))
        .unwrap()
        .0;
    assert_eq!(update, 2751, "admitted on the false report");
    let joiner = of(&rows, 4);
    let moved_in = joiner.iter().position(|r| r.mode != Role::Beside).unwrap();
    assert!(moved_in > 2752, "it moves in when in position: {moved_in}");
    assert!(joiner[2751..moved_in]
        .iter()
        .all(|r| r.mode == Role::Beside));
    assert!(
        joiner.last().unwrap().mode == Mode::Coop,
        "a member in the end"
    );
    let labels: Vec<_> = log
        .labelled
        .iter()
        .filter(|(_, l)| *l != Label::Genuine)
        .map(|(m, l)| (m.sender, m.body, *l))
        .collect();
    assert_eq!(labels, [(VehicleId(4), Body::InPosition, Label::Forged)]);
    let gap = smallest_gap_on_the_lane(&rows);
    assert!(gap > 8.0, "{gap}");
}

/// The same jam from the attack catalogue (`kind = "jam_maneuvers"`, `messages =
/// ["move_in"]`): a reactive jammer that loses every packet carrying a move-in.
#[test]
fn the_catalogues_maneuver_jammer_calls_the_join_off_safely() {
    let text = std::fs::read_to_string(repo().join("configs/join-middle.toml")).unwrap()
        + "\n[[channel.attacks]]\nkind = \"jam_maneuvers\"\nmessages = [\"move_in\"]\n";
    let scenario = platoon_config::parse(&text, std::path::Path::new("join-middle.toml"))
        .unwrap()
        .1;
    let (rows, sent) = run(scenario, |_, _| false);
    assert!(sent.iter().any(|(_, m)| m.body
        == Body::Abort {
            joiner: VehicleId(4)
        }));
    assert!(of(&rows, 4).iter().all(|r| r.mode == Role::Beside));
    let g = last_gap(&rows, 1, 2);
    assert!((g - GAP).abs() < 1.0, "the gap closes again: {g}");
    assert!(smallest_gap_on_the_lane(&rows) > 10.0);
    let bad = text.replace("[\"move_in\"]", "[\"move_out\"]");
    let e = platoon_config::parse(&bad, std::path::Path::new("join-middle.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("channel.attacks[0].messages") && e.contains("move_out"),
        "{e}"
    );
}

#[test]
fn a_bad_slot_names_its_key() {
    let text = std::fs::read_to_string(repo().join("configs/join-middle.toml")).unwrap();
    let err = |from: &str, to: &str| {
        let t = text.replace(from, to);
        assert_ne!(t, text, "{from}");
        platoon_config::parse(&t, std::path::Path::new("join-middle.toml"))
            .unwrap_err()
            .to_string()
    };
    let e = err("behind = 1 ", "behind = 9 ");
    assert!(e.contains("maneuvers.joins[0].behind"), "{e}");
    let e = err("behind = 1 ", "behind = 4 ");
    assert!(e.contains("maneuvers.joins") && e.contains("behind"), "{e}");
}

/// While follower 2 opens the gap it heads the members behind it (its packets' `head` is
/// itself) and follower 3 takes it as its leader, blended, so its own gap holds while the
/// opener slows (Plexe's rule, docs/maneuvers.md "Beside Plexe's join"): within 0.5 m of the
/// platoon's gap from the request to the join, where following the platoon's leader it came
/// to 12.8 m. Once the joiner is in, follower 3 is back on the leader's packets, blended.
#[test]
fn the_members_behind_the_opener_follow_it_and_keep_their_gaps() {
    let (rows, sent) = run(scenario(), |_, _| false);
    let opened = sent
        .iter()
        .find(|(_, m)| matches!(m.body, Body::OpenGap { .. }))
        .map(|(k, _)| *k)
        .unwrap();
    let joined = of(&rows, 4)
        .iter()
        .find(|r| !matches!(r.mode.role(), Role::Beside | Role::Outside))
        .unwrap()
        .step;
    let (two, three) = (of(&rows, 2), of(&rows, 3));
    let gaps: Vec<f64> = two
        .iter()
        .zip(&three)
        .filter(|(a, _)| (opened..joined).contains(&a.step))
        .map(|(a, b)| a.p - b.p - LENGTH)
        .collect();
    let worst = gaps.iter().map(|g| (g - GAP).abs()).fold(0.0, f64::max);
    assert!(
        worst < 0.5,
        "follower 3's gap strayed {worst:.2} m from {GAP} m"
    );
    // Rebased twice (to the opener, back to the leader), blended each time.
    let blends = three
        .windows(2)
        .filter(|w| w[0].mode != Mode::Blend && w[1].mode == Mode::Blend)
        .count();
    assert_eq!(blends, 2);
    assert!(largest_step(&rows, 3) < 0.15);
}

/// A member that announces itself as a head (the catalogue's `forged_head` on follower 1's
/// packets, an insider, all through the opening) is not followed: the members behind it take a
/// member as their leader only while they know the leader asked it to open a gap, so every
/// row is that of the run without the attack. And a middle join cannot be combined with a
/// split behind a cut-in, which follows any announced head.
#[test]
fn a_forged_head_is_not_followed_in_a_middle_join() {
    let text = std::fs::read_to_string(repo().join("configs/join-middle.toml")).unwrap();
    let forged = format!(
        "{text}\n[[channel.attacks]]\nkind = \"forged_head\"\nsenders = [1]\ninsider = true\n\
         start_s = 4.0\nend_s = 40.0\n"
    );
    let parse = |t: &str| platoon_config::parse(t, std::path::Path::new("join-middle.toml"));
    let (plain, _) = run(parse(&text).unwrap().1, |_, _| false);
    let (attacked, log) = run_with(parse(&forged).unwrap().1, |_, _| false, |_, _| {});
    assert!(log.labelled.iter().all(|(_, l)| *l == Label::Genuine));
    // The attack did reach the wire: follower 1's beacons, 10 Hz for 36 s, to the members
    // that hear it, all announce a head they are not (a no-op attack would leave none).
    assert!(log.altered >= 360, "{} altered deliveries", log.altered);
    let first = plain
        .iter()
        .zip(&attacked)
        .find(|(a, b)| format!("{a:?}") != format!("{b:?}"));
    assert!(
        first.is_none(),
        "the forged head changed the run: {first:?}"
    );
    let split = text.replace(
        "closing_mps = 2.0",
        "closing_mps = 2.0\ncut_in = { split = true }",
    );
    assert_ne!(split, text);
    let e = parse(&split).unwrap_err().to_string();
    assert!(
        e.contains("maneuvers.joins[0].behind") && e.contains("cut-in"),
        "{e}"
    );
}
