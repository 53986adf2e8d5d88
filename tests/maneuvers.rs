//! Maneuvers negotiated over V2V, in process: the join at the tail of `configs/join.toml`
//! (vehicle 4 starts 60 m behind the platoon, asks at 5 s), its messages as the injector sees
//! them on the packets, the joiner's command at the hand-over to the law, a join whose
//! messages the channel loses, and the errors a bad `[maneuvers]` gets. Both transports
//! agree on it bit for bit: tests/cosim.rs.
use crate::common;

use common::maneuvers::{altered_only, forged_to_leader, of, run, run_with, FAKE_JOIN_REQUEST};
use common::{cut_in_config, repo};
use platoon_attacks::inject::Step;
use platoon_control::{Delivery, Mode, Role};
use platoon_maneuver::{Body, Change, Refusal};
use platoon_model::VehicleId;
use platoon_sim::truth::Label;
use platoon_sim::{Scenario, StepRow};

fn join_config() -> String {
    std::fs::read_to_string(repo().join("configs/join.toml")).unwrap()
}

fn scenario(text: &str) -> Scenario {
    platoon_config::parse(text, std::path::Path::new("join.toml"))
        .unwrap()
        .1
}

/// The smallest gap between consecutive vehicles over the run (m, bumper to bumper).
fn smallest_gap(rows: &[StepRow], length: f64) -> f64 {
    rows.chunks(5)
        .flat_map(|step| step.windows(2).map(|w| w[0].p - w[1].p - length))
        .fold(f64::INFINITY, f64::min)
}

/// A ghost: at 3 s an outsider sends the leader a join request in the name of vehicle 7, which
/// is not there (the joiner's state on the packet), for the slot behind the tail.
fn ghost(step: &Step<'_>, out: &mut Vec<Delivery>) {
    if step.k == 300 {
        let state = step.states[4];
        out.push(forged_to_leader(
            step.k,
            7,
            state,
            (1, 1),
            Body::JoinRequest {
                behind: VehicleId(3),
            },
        ));
    }
}

#[test]
fn a_join_at_the_tail_is_negotiated_on_the_packets_and_taken_without_a_jump() {
    let s = scenario(&join_config());
    let dt = s.dt();
    let (rows, sent) = run(s, |_, _| false);
    let joiner = of(&rows, 4);
    // Outside from the start; the law from the step the update reached it, blended.
    assert_eq!(joiner[0].mode, Role::Outside);
    let joined = joiner.iter().position(|r| r.mode != Role::Outside).unwrap();
    assert_eq!(joiner[joined].mode, Mode::Blend);
    assert!(joiner[joined..].iter().all(|r| r.mode != Role::Outside));
    // The messages, on the packets the injector saw: request at 5 s, the leader's accept the
    // step after it arrived, in position, then the update announced three times.
    let bodies: Vec<(u16, Body)> = sent.iter().map(|(_, m)| (m.sender.0, m.body)).collect();
    let update = Body::Update {
        generation: 1,
        change: Change::Joined {
            vehicle: VehicleId(4),
            behind: VehicleId(3),
        },
    };
    assert_eq!(
        bodies,
        vec![
            (
                4,
                Body::JoinRequest {
                    behind: VehicleId(3)
                }
            ),
            (
                0,
                Body::JoinAccept {
                    behind: VehicleId(3),
                    middle: false
                }
            ),
            (4, Body::InPosition),
            (0, update),
            (0, update),
            (0, update),
        ]
    );
    let at = |i: usize| sent[i].0;
    // Asked at 5 s, on the next step's packet (a step decides in its receive phase and sends
    // in the next one's transmit phase).
    assert_eq!(at(0), (5.0 / dt).round() as u64 + 1);
    assert_eq!(
        at(1),
        at(0) + 1,
        "the leader answers the step after it heard"
    );
    // The joiner took the law at the step the update reached it (a packet sent in a step's
    // transmit phase arrives in its receive phase).
    assert_eq!(joiner[joined].step, at(3));
    // In position when it said so: its gap within 1 m of the platoon's 15.5 m.
    let in_position = joiner[(at(2) - 1) as usize];
    let ahead = &rows[(at(2) - 1) as usize * 5 + 3];
    assert!((ahead.p - in_position.p - 4.5 - 15.5).abs() <= 1.0);
    // No step in its command larger than the blend's first share of the mismatch allows:
    // the hand-over and the accept are smooth (the largest step is the leader's braking
    // ramp ending, fed forward by the law, as every follower has it).
    let steps = |v: u16| {
        of(&rows, v)
            .windows(2)
            .map(|w| (w[1].u - w[0].u).abs())
            .fold(0.0, f64::max)
    };
    let member = steps(3);
    assert!(steps(4) <= member + 1e-9, "{} vs {member}", steps(4));
    let around = |i: usize| (joiner[i].u - joiner[i - 1].u).abs();
    let accepted = at(1) as usize;
    assert!(around(joined) < 0.05 && around(accepted) < 0.05 && around(accepted + 1) < 0.05);
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

#[test]
fn a_join_whose_update_never_arrives_is_withdrawn_and_the_joiner_stays_out() {
    // The channel loses every update: the joiner says it is in position three times, then
    // withdraws with leave notices; the leader, which admitted it, lets it go again (its
    // update of that is lost as well).
    let (rows, sent) = run(scenario(&join_config()), |_, m| {
        matches!(m.body, Body::Update { .. })
    });
    let joiner = of(&rows, 4);
    assert!(joiner.iter().all(|r| r.mode == Role::Outside));
    let count = |b: fn(&Body) -> bool| sent.iter().filter(|(_, m)| b(&m.body)).count();
    assert_eq!(count(|b| *b == Body::InPosition), 3);
    // Its notices go unanswered too (the update is lost): it sends all three.
    assert_eq!(count(|b| *b == Body::LeaveNotice), 3);
    let left = sent.iter().any(|(_, m)| {
        m.body
            == Body::Update {
                generation: 2,
                change: Change::Left {
                    vehicle: VehicleId(4),
                },
            }
    });
    assert!(left, "the leader announces that vehicle 4 left");
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

#[test]
fn without_maneuvers_the_packets_carry_none_and_the_outputs_are_unchanged() {
    let text = join_config();
    let plain = text[..text.find("[maneuvers]").unwrap()].to_string();
    let (rows, sent) = run(scenario(&plain), |_, _| false);
    assert!(sent.is_empty());
    assert!(rows.iter().all(|r| r.mode != Role::Outside));
}

#[test]
fn a_bad_maneuvers_table_names_its_key() {
    let text = join_config();
    let err = |from: &str, to: &str| {
        let t = text.replace(from, to);
        assert_ne!(t, text, "{from}");
        platoon_config::parse(&t, std::path::Path::new("join.toml"))
            .unwrap_err()
            .to_string()
    };
    let e = err("vehicle = 4", "vehicle = 2");
    assert!(
        e.contains("maneuvers.joins") && e.contains("at the tail"),
        "{e}"
    );
    let e = err("vehicle = 4", "vehicle = 9");
    assert!(e.contains("maneuvers.joins[0].vehicle"), "{e}");
    // The paper's law runs maneuvers on the one pipeline (tests/cosim.rs): no longer refused.
    let paper = text.replace(
        "law = \"path_cacc\"\nspacing_m = 15.5",
        "gain = [4.81, 9.12, 2.97]\nbeta1 = 319.38\nbeta2 = 5.62",
    );
    assert_ne!(paper, text);
    platoon_config::parse(&paper, std::path::Path::new("join.toml")).unwrap();
    let e = err("tries = 3", "tries = 3\nin_position_km = 1.0");
    assert!(e.contains("in_position_km"), "{e}");
}

/// An outsider forges a join request from a vehicle that is not there (id 7) at 3 s: the
/// leader accepts it and is busy with it, so it refuses the real joiner at 5 s, which stays
/// outside on its ACC, safely; the leader calls the ghost's join off at its deadline. The
/// ground truth labels the forged message `forged` and every genuine one `genuine`.
#[test]
fn a_forged_join_request_keeps_the_real_joiner_out_and_is_labelled_forged() {
    let s = scenario(&join_config());
    let deadline = 300 + (40.0 / s.dt()).round() as u64;
    let (rows, log) = run_with(s, |_, _| false, ghost);
    assert!(of(&rows, 4).iter().all(|r| r.mode == Role::Outside));
    let refused = log.sent.iter().any(|(_, m)| {
        m.to == VehicleId(4)
            && m.body
                == Body::JoinRefuse {
                    reason: Refusal::Busy,
                }
    });
    assert!(
        refused,
        "the real joiner is refused: the leader is busy with the ghost"
    );
    let abort = log
        .sent
        .iter()
        .find(|(_, m)| {
            m.body
                == Body::Abort {
                    joiner: VehicleId(7),
                }
        })
        .map(|(k, _)| *k);
    assert_eq!(abort, Some(deadline + 1), "called off at its deadline");
    let forged: Vec<_> = log
        .labelled
        .iter()
        .filter(|(_, l)| *l == Label::Forged)
        .map(|(m, _)| m.sender)
        .collect();
    assert_eq!(forged, [VehicleId(7)]);
    assert!(log
        .labelled
        .iter()
        .all(|(m, l)| m.sender == VehicleId(7) || *l == Label::Genuine));
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

/// A replayed formation update: the injector keeps the leader's first update (the join's, at
/// 26.92 s) and delivers it again to every follower at 35 s. Every copy is labelled
/// `replayed`, and it changes nothing: the run is the run without it, bit for bit.
#[test]
fn a_replayed_update_changes_nothing_and_is_labelled_replayed() {
    use std::sync::Mutex;
    static KEPT: Mutex<Vec<Delivery>> = Mutex::new(Vec::new());
    fn replay(step: &Step<'_>, out: &mut Vec<Delivery>) {
        let mut kept = KEPT.lock().unwrap();
        if kept.is_empty() {
            kept.extend(out.iter().filter(|d| {
                matches!(d.packet.maneuver.map(|m| m.body), Some(Body::Update { .. }))
            }));
        }
        if step.k == 3500 {
            out.extend(kept.iter().copied());
        }
    }
    let (rows, log) = run_with(scenario(&join_config()), |_, _| false, replay);
    let (plain, _) = run(scenario(&join_config()), |_, _| false);
    let replayed = log
        .labelled
        .iter()
        .filter(|(_, l)| *l == Label::Replayed)
        .count();
    assert_eq!(replayed, 4, "one copy to each follower");
    assert!(log
        .labelled
        .iter()
        .all(|(_, l)| matches!(l, Label::Genuine | Label::Replayed)));
    assert_eq!(rows.len(), plain.len());
    // Debug strings: theta is NaN for these laws.
    let first = rows
        .iter()
        .zip(&plain)
        .find(|(a, b)| format!("{a:?}") != format!("{b:?}"));
    assert!(first.is_none(), "the replay changed the run: {first:?}");
}

/// A jam over the join's request (every maneuver message lost from 4.9 s to 6.6 s): the
/// joiner asks three times, gives up, and stays outside on its ACC; nobody comes close.
#[test]
fn a_jammed_request_ends_the_join_safely() {
    let (rows, sent) = run(scenario(&join_config()), |k, _| (490..660).contains(&k));
    let requests = sent
        .iter()
        .filter(|(_, m)| matches!(m.body, Body::JoinRequest { .. }))
        .count();
    assert_eq!(requests, 3);
    assert!(
        sent.iter().all(|(_, m)| m.sender == VehicleId(4)),
        "the leader heard nothing"
    );
    assert!(of(&rows, 4).iter().all(|r| r.mode == Role::Outside));
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

/// A man in the middle rewrites the joiner's requests to the leader into requests for the slot
/// behind follower 2 (a join in the middle): the leader accepts that slot, which the joiner did
/// not ask for, so it ignores the accepts, asks again (rewritten too) and gives up; the
/// leader's join is called off at its deadline, and the joiner stays outside, safely. Every
/// rewritten request is labelled `altered`, its maneuver field named.
#[test]
fn a_rewritten_join_request_is_labelled_altered_and_the_joiner_stays_out() {
    #[allow(clippy::ptr_arg)] // the forge hook's type: others push
    fn rewrite(_: &Step<'_>, out: &mut Vec<Delivery>) {
        for d in out.iter_mut().filter(|d| d.receiver.is_leader()) {
            if let Some(m) = d.packet.maneuver.as_mut() {
                if let Body::JoinRequest { behind } = &mut m.body {
                    *behind = VehicleId(2);
                }
            }
        }
    }
    let (rows, log) = run_with(scenario(&join_config()), |_, _| false, rewrite);
    assert!(of(&rows, 4).iter().all(|r| r.mode == Role::Outside));
    let altered: Vec<_> = log
        .labelled
        .iter()
        .filter(|(_, l)| !matches!(l, Label::Genuine))
        .collect();
    assert_eq!(altered.len(), 3, "the three requests: {altered:?}");
    for (m, l) in altered {
        assert_eq!(
            m.body,
            Body::JoinRequest {
                behind: VehicleId(2)
            }
        );
        assert_eq!(
            *l,
            Label::Altered {
                fields: platoon_sim::truth::Fields::MANEUVER
            }
        );
    }
    let opened = log.sent.iter().any(|(_, m)| {
        m.body
            == Body::OpenGap {
                joiner: VehicleId(4),
            }
    });
    assert!(opened, "the leader asked follower 3 to open a gap");
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

/// `configs/cut-in.toml`'s platoon for `law` (its distances, topology and guard, as
/// tests/traffic.rs runs the cut-in) without the car, follower 4 starting 60 m behind
/// follower 3 and joining as in `configs/join.toml`.
fn join_config_for(law: &str) -> String {
    let text = cut_in_config(law);
    let text = &text[..text.find("[[cut_ins]]").unwrap()];
    let headway = text
        .lines()
        .find_map(|l| l.strip_prefix("time_headway_s = "))
        .map_or(0.0, |h| h.trim().parse::<f64>().unwrap());
    let l = 20.0 + headway * 15.0;
    let states: Vec<String> = (0..4)
        .map(|i| format!("[{}, 15.0, 0.0]", -l * i as f64))
        .chain([format!("[{}, 15.0, 0.0]", -3.0 * l - 4.5 - 60.0)])
        .collect();
    let join = join_config();
    text.replace(
        "formation = { leader_position_m = 0.0 }",
        &format!("initial_states = [{}]", states.join(", ")),
    ) + &join[join.find("[maneuvers]").unwrap()..]
}

/// Every law of the controller seam takes the joiner: it is admitted, nobody collides, and
/// neither the accept nor the hand-over to the law steps its command more than its ACC does
/// between two radar readings while it waits outside (the radar's 20 Hz updates and noise).
#[test]
fn every_law_takes_a_joiner_at_the_tail() {
    for law in ["acc", "ploeg", "path_cacc", "consensus", "flatbed"] {
        let (rows, sent) = run(scenario(&join_config_for(law)), |_, _| false);
        let joiner = of(&rows, 4);
        let admitted = joiner.iter().position(|r| r.mode != Role::Outside);
        let Some(admitted) = admitted else {
            panic!("{law}: never admitted; sent {sent:?}");
        };
        assert!(joiner[admitted..].iter().all(|r| r.mode != Role::Outside));
        let gap = smallest_gap(&rows, 4.5);
        assert!(gap > 5.0, "{law}: smallest gap {gap} m");
        let accepted = sent
            .iter()
            .find(|(_, m)| matches!(m.body, Body::JoinAccept { .. }))
            .unwrap()
            .0 as usize;
        let step = |i: usize| (joiner[i].u - joiner[i - 1].u).abs();
        let waiting = (1..accepted).map(step).fold(0.0, f64::max);
        for (what, at) in [("accept", accepted), ("hand-over", admitted)] {
            for i in at..at + 2 {
                assert!(
                    step(i) <= waiting,
                    "{law}: the {what} steps the command by {} (outside: {waiting})",
                    step(i)
                );
            }
        }
    }
}

/// The fake join request from the attack catalogue (`kind = "forge_maneuver"`, `message =
/// "join_request"`): an outsider rewrites the joiner's packets to the leader at 3 s, before
/// it asks, into a request for the slot behind the tail. The leader accepts it and is busy
/// with a join the joiner never asked for; the joiner's own requests carry lower sequence
/// numbers and are dropped as old, so it stays outside, safely, until the leader calls the
/// join off at its deadline. The rewritten packets are labelled altered in their maneuver
/// field, and nothing else is.
#[test]
fn the_catalogues_fake_join_request_keeps_the_joiner_out_and_is_labelled_altered() {
    let mut text = join_config();
    text.push_str(FAKE_JOIN_REQUEST);
    let s = scenario(&text);
    let (rows, log) = run_with(s, |_, _| false, common::maneuvers::nothing);
    assert!(of(&rows, 4).iter().all(|r| r.mode == Role::Outside));
    altered_only(
        &log,
        4,
        Body::JoinRequest {
            behind: VehicleId(3),
        },
    );
    let accepted = log
        .sent
        .iter()
        .find(|(_, m)| m.sender.is_leader() && matches!(m.body, Body::JoinAccept { .. }))
        .map(|(k, _)| *k);
    assert!(
        accepted.is_some_and(|k| (300..320).contains(&k)),
        "the leader took the fake request: {accepted:?}"
    );
    let aborted = log.sent.iter().any(|(_, m)| {
        m.body
            == Body::Abort {
                joiner: VehicleId(4),
            }
    });
    assert!(aborted, "the leader called the join off");
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

/// The catalogue's replay (`kind = "replay"`) of the leader's packets from 8 s before, over
/// the steps that carried the join's update: the update arrives again, labelled `replayed`,
/// and every copy of the formation ignores it (its sequence number is old), so the joiner
/// stays a member and nobody leaves the lane.
#[test]
fn the_catalogues_replay_of_an_update_is_labelled_replayed_and_changes_no_formation() {
    let (_, plain) = run(scenario(&join_config()), |_, _| false);
    let update = plain
        .iter()
        .find(|(_, m)| matches!(m.body, Body::Update { .. }))
        .map(|(k, _)| *k)
        .unwrap();
    let mut text = join_config();
    let at = (update + 800) as f64 * 0.01;
    text.push_str(&format!(
        "\n[[channel.attacks]]\nkind = \"replay\"\nlag_s = 8.0\nsenders = [0]\n\
         start_s = {:.2}\nend_s = {:.2}\n",
        at - 0.05,
        at + 0.05
    ));
    let (rows, log) = run_with(scenario(&text), |_, _| false, common::maneuvers::nothing);
    let replayed: Vec<_> = log
        .labelled
        .iter()
        .filter(|(m, l)| *l == Label::Replayed && matches!(m.body, Body::Update { .. }))
        .collect();
    assert!(!replayed.is_empty(), "the update was replayed");
    let joiner = of(&rows, 4);
    let joined = joiner.iter().position(|r| r.mode != Role::Outside).unwrap();
    assert!(joiner[joined..].iter().all(|r| r.mode != Role::Outside));
    assert!(rows.iter().all(|r| r.mode != Role::Left));
    assert!(smallest_gap(&rows, 4.5) > 10.0);
}

/// `summary.json`'s `maneuvers` against what the recording injector saw on the packets and
/// the rows: the join asked when the joiner's request was broadcast, completed when the
/// joiner left its ACC for the law, the messages about it counted between, the errors and
/// gaps from the request on; and a join kept out by the fake request is `failed`.
#[test]
fn the_summary_measures_the_join_as_the_packets_and_rows_tell_it() {
    let s = scenario(&join_config());
    let dt = s.dt();
    let (rows, sent) = run(s.clone(), |_, _| false);
    let summary = platoon_sim::run(s, |_| {}).unwrap();
    let m = summary.maneuvers.expect("a run with [maneuvers]");
    assert_eq!(m.messages_sent, sent.len() as u64);
    let [join] = &m.maneuvers[..] else {
        panic!("{:?}", m.maneuvers)
    };
    let asked = sent
        .iter()
        .find(|(_, m)| matches!(m.body, Body::JoinRequest { .. }))
        .map(|(k, _)| *k)
        .unwrap();
    let joiner = of(&rows, 4);
    let done = joiner
        .iter()
        .find(|r| r.mode != Role::Outside)
        .unwrap()
        .step;
    let about = sent
        .iter()
        .filter(|(k, m)| {
            (asked..=done).contains(k)
                && (m.sender == VehicleId(4)
                    || m.to == VehicleId(4)
                    || matches!(m.body, Body::Update { .. }))
        })
        .count();
    let worst = rows
        .iter()
        .filter(|r| r.step >= asked && r.vehicle > 0 && r.mode != Role::Outside)
        .map(|r| r.spacing_error.abs())
        .fold(0.0, f64::max);
    let gap = rows
        .chunks(5)
        .filter(|step| step[0].step >= asked)
        .flat_map(|step| step.windows(2).map(|w| w[0].p - w[1].p - 4.5))
        .fold(f64::INFINITY, f64::min);
    assert_eq!(
        (join.maneuver.as_str(), join.vehicle, join.outcome.as_str()),
        ("join", 4, "completed")
    );
    assert_eq!(join.requested_t_s, Some(asked as f64 * dt));
    assert_eq!(join.completion_s, Some((done - asked) as f64 * dt));
    assert_eq!(join.messages, about as u64);
    assert_eq!(join.max_spacing_error_m, Some(worst));
    assert!(
        (join.min_gap_m.unwrap() - gap).abs() < 1e-9,
        "{join:?} vs {gap}"
    );

    let mut text = join_config();
    text.push_str(FAKE_JOIN_REQUEST);
    let summary = platoon_sim::run(scenario(&text), |_| {}).unwrap();
    let join = &summary.maneuvers.unwrap().maneuvers[0];
    assert_eq!(join.outcome, "failed");
    assert_eq!(join.completion_s, None);
    assert!(join.requested_t_s.is_some());
}

/// A join timeout far beyond any run (2e17 s, 2e19 steps, more than a u64 holds) is a join
/// that never times out: the join completes as with the config's 40 s, every row bit for bit
/// (it failed at once when the deadline wrapped, issue 53).
#[test]
fn a_huge_join_timeout_never_times_out() {
    let text = join_config();
    assert!(text.contains("timeout_s = 40.0"));
    let (rows, _) = run(scenario(&text), |_, _| false);
    for timeout in ["2e17", "1e300"] {
        let huge = text.replacen("timeout_s = 40.0", &format!("timeout_s = {timeout}"), 1);
        let s = scenario(&huge);
        assert_eq!(
            s.control.maneuvers.as_ref().unwrap().timing.maneuver_steps,
            u64::MAX
        );
        let (again, _) = run(s.clone(), |_, _| false);
        // Debug: the rows hold NaN where nothing is measured.
        assert_eq!(again.len(), rows.len());
        let first = rows
            .iter()
            .zip(&again)
            .position(|(a, b)| format!("{a:?}") != format!("{b:?}"));
        assert_eq!(
            first,
            None,
            "{timeout}: {:?} vs {:?}",
            first.map(|i| &rows[i]),
            first.map(|i| &again[i])
        );
        let summary = platoon_sim::run(s, |_| {}).unwrap();
        assert_eq!(summary.maneuvers.unwrap().maneuvers[0].outcome, "completed");
    }
}

/// `[maneuvers] check_reports` drops a join request from a vehicle the leader never heard
/// beaconing: the ghost's request (vehicle 7, no vehicle of the run) never reaches the leader's
/// machine, so the real joiner joins as if there had been no attack, every row bit for bit;
/// a genuine request passes (the run without the ghost is the run without the check).
#[test]
fn checked_requests_drop_the_ghost_and_keep_the_real_join() {
    let checked = join_config().replace("[maneuvers]\n", "[maneuvers]\ncheck_reports = true\n");
    assert_ne!(checked, join_config());
    let (attacked, log) = run_with(scenario(&checked), |_, _| false, ghost);
    let (plain, _) = run(scenario(&checked), |_, _| false);
    let (unchecked, _) = run(scenario(&join_config()), |_, _| false);
    assert!(log
        .sent
        .iter()
        .all(|(_, m)| m.to != VehicleId(7) && m.sender != VehicleId(7)));
    assert_eq!(
        log.rejected.unknown_sender, 1,
        "the ghost's request, counted"
    );
    for (a, b) in [(&attacked, &plain), (&plain, &unchecked)] {
        assert_eq!(a.len(), b.len());
        let first = a
            .iter()
            .zip(b)
            .find(|(x, y)| format!("{x:?}") != format!("{y:?}"));
        assert!(first.is_none(), "{first:?}");
    }
    assert!(of(&attacked, 4).iter().any(|r| r.mode != Role::Outside));
}

/// With `[detection]` on, the leader's checks of maneuver messages (`check_reports`) are
/// measured against the ground truth like the followers' detectors, apart from them
/// (`detection.maneuver_checks`): with no attack every request and report they test is genuine
/// and passes; the catalogue's forged in-position reports are each labelled `altered` and each
/// flagged; and the followers' detectors' figures are those of the run without the checks.
#[test]
fn the_leaders_checks_are_scored_against_the_ground_truth() {
    let checked = join_config().replace(
        "[maneuvers]\n",
        "[detection.plausibility]\n\n[maneuvers]\ncheck_reports = true\n",
    );
    let forged = checked.replace(
        "[maneuvers]\n",
        "[[channel.attacks]]\nkind = \"forge_maneuver\"\nmessage = \"in_position\"\n\
         senders = [4]\nreceivers = [0]\nstart_s = 6.0\nend_s = 6.2\n\n[maneuvers]\n",
    );
    let score = |text: &str| {
        platoon_sim::run(scenario(text), |_| {})
            .unwrap()
            .detection
            .unwrap()
    };
    let clean = score(&checked);
    let m = clean.maneuver_checks.clone().unwrap();
    assert_eq!((m.totals.tp, m.totals.fp, m.totals.fn_), (0, 0, 0), "{m:?}");
    assert!(
        m.totals.tn >= 2,
        "the request and the report, at least: {m:?}"
    );
    assert_eq!(m.false_alarm_rate, Some(0.0));
    let unchecked = score(&checked.replace("check_reports = true\n", ""));
    assert!(unchecked.maneuver_checks.is_none());
    assert_eq!(
        (&unchecked.detectors, &unchecked.any, unchecked.inspected),
        (&clean.detectors, &clean.any, clean.inspected)
    );
    let m = score(&forged).maneuver_checks.unwrap();
    assert!(m.totals.tp > 0, "{m:?}");
    assert_eq!((m.totals.fp, m.totals.fn_), (0, 0), "{m:?}");
    assert_eq!(m.by_label["altered"].tp, m.totals.tp);
    assert_eq!((m.precision, m.recall), (Some(1.0), Some(1.0)));
    assert_eq!(m.time_to_detect_s, Some(0.0));
}

/// Every shipped maneuver config runs on passenger cars with limits, and no law asks beyond
/// them there: each follower's `saturated_time_s` is 0 (docs/traffic.md#vehicles-with-limits).
#[test]
fn the_maneuver_configs_run_on_cars_within_their_limits() {
    for config in ["join", "join-middle", "leave", "merge", "split"] {
        let path = repo().join(format!("configs/{config}.toml"));
        let (_, s) = platoon_config::load(&path).unwrap();
        assert!(
            !s.vehicles.is_empty()
                && s.vehicles
                    .iter()
                    .all(|v| v.emergency_decel_mps2 == Some(9.0)),
            "{config}"
        );
        let summary = platoon_sim::run(s, |_| {}).unwrap();
        for v in &summary.vehicles {
            assert_eq!(
                v.saturated_time_s,
                Some(0.0),
                "{config}: follower {}",
                v.vehicle
            );
        }
    }
}
