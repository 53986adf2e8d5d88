//! Signed V2V (`[security]`, docs/security.md) in process: signing changes nothing in a run
//! without attacks; an outsider's forged leave notice and forged join request (the catalogue's
//! `forge_maneuver`, which rewrites genuine packets, and a fresh forgery, unsealed or sealed
//! with a key of another PKI) are refused at verification and change nothing: the run is the
//! same bit for bit as without the forgery. A signed run over iceoryx2 (contract v5 carries
//! the seal) is the same bit for bit as in process, and both say in timing.json what signing
//! and verifying took per step (an unsigned run's timing.json has neither).
use crate::common;

use common::maneuvers::{forged_to_leader, nothing, of, run_with, Log, FAKE_JOIN_REQUEST};
use common::signed::{config, refused, same, scenario};
use platoon_attacks::inject::Step;
use platoon_control::security::{Sealing, SecurityParams};
use platoon_control::{Delivery, Role};
use platoon_maneuver::Body;
use platoon_model::VehicleId;
use platoon_sim::StepRow;

/// `text` with `[security]` (its keys `keys`) at its end.
fn signed(text: &str, keys: &str) -> String {
    format!("{text}\n[security]\n{keys}")
}

/// Runs `text` (written as `name` in `dir`) over iceoryx2 (into `ipc`) and in process (into
/// `inproc`) and asserts that `files` are the same bytes in both; the iceoryx2 run's directory.
fn on_both_transports(
    dir: &std::path::Path,
    name: &str,
    text: &str,
    files: &[&str],
) -> std::path::PathBuf {
    std::fs::write(dir.join(name), text).unwrap();
    for (out, transport) in [("ipc", "iceoryx2"), ("inproc", "inproc")] {
        common::run_config(&dir.join(name), out, &["--transport", transport], dir);
    }
    for f in files {
        let a = std::fs::read(dir.join("ipc").join(f)).unwrap();
        let b = std::fs::read(dir.join("inproc").join(f)).unwrap();
        assert!(a == b, "{f} differs between the transports");
    }
    dir.join("ipc")
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
    assert_eq!(security.refused.len(), platoon_security::Refusal::ALL.len());
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
    on_both_transports(
        tmp.path(),
        "signed.toml",
        &signed(
            &format!(
                "{}{FAKE_JOIN_REQUEST}\n[detection.plausibility]\n",
                config("join")
            ),
            "policy = \"on_demand\"\n",
        ),
        &[
            "trajectories.csv",
            "events.csv",
            "channel.csv",
            "wire.csv",
            "summary.json",
            "detections.csv",
        ],
    );
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

/// Whom each attack acts as (issue 52, item 2), in the leave scenario: follower 2 an insider
/// claiming to be 3 m further ahead than it is, an outsider altering follower 1's packets to
/// follower 2, a thief with follower 4's key forging a leave notice in follower 3's name.
const ROLES: &str = "[[channel.attacks]]\nkind = \"false_data\"\noffset = [3.0, 0.0, 0.0]\n\
    senders = [2]\nstart_s = 20.0\nend_s = 21.0\nacts_as = \"insider\"\n\n\
    [[channel.attacks]]\nkind = \"false_data\"\noffset = [3.0, 0.0, 0.0]\nsenders = [1]\n\
    receivers = [2]\nstart_s = 30.0\nend_s = 31.0\n\n\
    [[channel.attacks]]\nkind = \"forge_maneuver\"\nmessage = \"leave_notice\"\n\
    senders = [3]\nreceivers = [0]\nstart_s = 10.0\nend_s = 10.2\nacts_as = \"thief\"\n\
    key_of = 4\n";

/// [`leave_with`] `attacks`, 35 s long (the attacks are over by 31 s; follower 5 leaves at
/// 32 s).
fn roles_with(attacks: &str) -> String {
    let text = leave_with(attacks);
    let shorter = text
        .replace("duration_s = 70.0", "duration_s = 35.0")
        .replace("vehicle = 5\nat_s = 45.0", "vehicle = 5\nat_s = 32.0");
    assert!(shorter.contains("duration_s = 35.0") && shorter.contains("at_s = 32.0"));
    shorter
}

/// An insider signs its lie with its own key and a thief with the member's it stole: the
/// receivers accept both, and they act as they do unsigned, bit for bit; an outsider's
/// alteration fails verification and its packets go nowhere, as if they were lost.
#[test]
fn insiders_and_thieves_sign_what_they_alter_and_outsiders_cannot() {
    let attack = |role: &str| {
        ROLES
            .split("\n\n")
            .find(|a| a.contains(role) || (role == "outsider" && !a.contains("acts_as")))
            .unwrap()
            .to_string()
    };
    let (genuine, _) = rows_and_log(&signed(&roles_with(""), ""), nothing);
    for role in ["insider", "thief"] {
        let text = roles_with(&attack(role));
        let (unsigned, _) = rows_and_log(&text, nothing);
        assert!(!same(&unsigned, &genuine), "{role}: the attack acts");
        let (rows, log) = rows_and_log(&signed(&text, ""), nothing);
        assert_eq!(log.seals.unwrap().refused_total(), 0, "{role}: accepted");
        assert!(same(&rows, &unsigned), "{role}: signed as it acts unsigned");
    }
    // The thief's forged leave ejects follower 3.
    let (rows, _) = rows_and_log(&signed(&roles_with(&attack("thief")), ""), nothing);
    assert!(of(&rows, 3).iter().any(|r| r.mode == Role::Left));
    let outsider = attack("outsider");
    let (unsigned, _) = rows_and_log(&roles_with(&outsider), nothing);
    let lost = outsider.replace(
        "kind = \"false_data\"\noffset = [3.0, 0.0, 0.0]",
        "kind = \"bernoulli\"\nloss = 1.0",
    );
    let (lost, _) = rows_and_log(&signed(&roles_with(&lost), ""), nothing);
    assert!(!same(&unsigned, &lost), "the outsider's lie acts unsigned");
    let (rows, log) = rows_and_log(&signed(&roles_with(&outsider), ""), nothing);
    assert!(
        same(&rows, &lost),
        "the outsider's refused lies are not lost packets"
    );
    let seals = log.seals.unwrap();
    assert!(refused(&seals, "bad_signature") > 0, "{seals:?}");
}

/// The ground truth of whom each attack acted as, told from the seals on the wire: the
/// detections dataset of a signed run says whose key signed each delivery and, for each
/// misbehaving one, `outsider`, `insider` or `thief`; the same bytes on both transports (the
/// injector process re-signs as the in-process channel does).
#[test]
fn the_dataset_says_whose_key_signed_each_delivery_on_both_transports() {
    let tmp = tempfile::tempdir().unwrap();
    let text = format!("{}\n[detection.plausibility]\n", roles_with(ROLES));
    let files = [
        "trajectories.csv",
        "summary.json",
        "detections.csv",
        "channel.csv",
    ];
    on_both_transports(tmp.path(), "roles.toml", &signed(&text, ""), &files);
    let rows = std::fs::read_to_string(tmp.path().join("ipc/detections.csv")).unwrap();
    let head: Vec<&str> = rows.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (sender, label, signed_by, acts_as, by) = (
        col("sender"),
        col("label"),
        col("signed_by"),
        col("acts_as"),
        col("refused_by"),
    );
    let mut seen = std::collections::BTreeMap::new();
    for r in rows
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
    {
        let want = match (r[label], r[sender]) {
            ("genuine", s) => ("", s),
            ("altered", "2") => ("insider", "2"),
            ("altered", "1") => ("outsider", ""),
            ("altered", "3") => ("thief", "4"),
            other => panic!("no attack makes {other:?}: {r:?}"),
        };
        assert_eq!((r[acts_as], r[signed_by]), want, "{r:?}");
        assert_eq!(r[by] == "bad_signature", want.0 == "outsider", "{r:?}");
        *seen.entry(want.0).or_insert(0) += 1;
    }
    assert_eq!(seen.len(), 4, "{seen:?}");
    let summary = common::json(&tmp.path().join("ipc/summary.json"));
    assert_eq!(summary["security"]["refused_total"], seen["outsider"]);
}

/// `configs/leave.toml` on the paper's law, 40 s, no leave of its own, the three detectors,
/// signed with misbehaviour reports (`reports` the keys of `[security.reports]`), and
/// `attacks`.
fn reported(attacks: &str, security: &str, reports: &str) -> String {
    let text = leave_with(attacks);
    let cut = text.find("[[maneuvers.leaves]]").unwrap();
    let end = text[cut..].find("\n\n").map_or(text.len(), |e| cut + e + 2);
    let text = format!("{}{}", &text[..cut], &text[end..]);
    let paper = text
        .replace("duration_s = 70.0", "duration_s = 40.0")
        .replace(
            "law = \"path_cacc\"\nspacing_m = 15.5",
            "gain = [4.81, 9.12, 2.97]\nbeta1 = 319.38\nbeta2 = 5.62",
        );
    assert!(paper.contains("beta1") && paper.contains("duration_s = 40.0"));
    assert!(!paper.contains("[[maneuvers.leaves]]"));
    format!(
        "{paper}\n[detection.plausibility]\n[detection.radar_cross]\n[detection.residual]\n\
         \n[security]\n{security}\n[security.reports]\n{reports}"
    )
}

/// Follower 2, an insider, feigns braking from 20 s.
const FEIGNED_BRAKING: &str = "[[channel.attacks]]\nkind = \"feigned_braking\"\n\
    accel_mps2 = -6.0\nsenders = [2]\nstart_s = 20.0\nacts_as = \"insider\"\n";

/// A run in process: its rows, and what the authority revoked.
fn revocations(text: &str) -> (Vec<StepRow>, Vec<platoon_security::Revocation>) {
    let mut sim = platoon_sim::Simulation::new(scenario(text)).unwrap();
    let mut rows = Vec::new();
    while !sim.is_done() {
        rows.extend_from_slice(sim.step());
    }
    let revoked = sim.controller().checks().unwrap().revocations().to_vec();
    (rows, revoked)
}

/// An insider feigning braking is flagged by the followers behind it, reported by at least
/// two of them, revoked by the authority and ejected by the leader through the leave
/// protocol, without a collision; with pseudonym changes too (its later pseudonyms are as
/// revoked). Without reports nobody is revoked and it stays a member.
#[test]
fn an_insider_feigning_braking_is_reported_revoked_and_ejected() {
    for keys in ["", "pseudonym_change_s = 5.0\n"] {
        let (rows, revoked) = revocations(&reported(FEIGNED_BRAKING, keys, ""));
        assert_eq!(revoked.len(), 1, "{keys:?}: {revoked:?}");
        let r = &revoked[0];
        assert_eq!(r.vehicle, 2, "{keys:?}");
        let mut reporters = r.reporters.clone();
        reporters.sort();
        reporters.dedup();
        assert!(reporters.len() >= 2 && !reporters.contains(&2), "{r:?}");
        assert!((20_000..21_000).contains(&r.decided_ms), "{r:?}");
        // Ejected: it leaves, revoked from the step after the decision on.
        let two = of(&rows, 2);
        assert!(two.iter().any(|x| x.mode == Role::Left), "{keys:?}");
        assert!(two.iter().filter(|x| x.t > 21.0).all(|x| x.revoked));
        // The followers behind it close up to follower 1 and nobody collides.
        let lengths = 4.5;
        for k in 0..rows.len() / 6 {
            let at = &rows[k * 6..(k + 1) * 6];
            for w in [(1, 3), (3, 4), (4, 5)] {
                let gap = at[w.0].p - at[w.1].p - lengths;
                assert!(gap > 2.0, "{keys:?}: {w:?} at {}: {gap}", at[0].t);
            }
        }
        let (p1, p3) = (
            of(&rows, 1).last().unwrap().p,
            of(&rows, 3).last().unwrap().p,
        );
        assert!(
            (p1 - p3 - 20.0).abs() < 3.0,
            "follower 3 closed up: {}",
            p1 - p3
        );
    }
    // Without reports the lie goes on and follower 2 stays.
    let text = reported(FEIGNED_BRAKING, "", "");
    let cut = text.find("[security.reports]").unwrap();
    let (rows, revoked) = revocations(&text[..cut]);
    assert!(revoked.is_empty());
    assert!(of(&rows, 2)
        .iter()
        .all(|x| x.mode != Role::Left && !x.revoked));
}

/// The same revocation over iceoryx2: the controller process files the reports and applies
/// the authority's decision, and every output is the same bit for bit as in process; the
/// summary says what the reports did and whom they revoked, events.csv when.
#[test]
fn a_revocation_is_bit_identical_on_both_transports() {
    let tmp = tempfile::tempdir().unwrap();
    on_both_transports(
        tmp.path(),
        "reports.toml",
        &reported(FEIGNED_BRAKING, "", "latency_s = 0.2\n"),
        &[
            "trajectories.csv",
            "events.csv",
            "summary.json",
            "detections.csv",
        ],
    );
    let summary = common::json(&tmp.path().join("ipc/summary.json"));
    let reports = &summary["security"]["reports"];
    assert_eq!(reports["revoked"].as_array().unwrap().len(), 1, "{reports}");
    assert_eq!(reports["revoked"][0]["vehicle"], 2, "{reports}");
    // The ground truth: its own key had signed the lies the detectors flagged.
    assert_eq!(reports["revoked"][0]["signed_a_lie"], true, "{reports}");
    let lies = summary["detection"]["signed_lies"].as_array().unwrap();
    assert_eq!(lies.len(), 1, "{lies:?}");
    assert_eq!(
        (lies[0]["vehicle"].as_u64(), lies[0]["first_step"].as_u64()),
        (Some(2), Some(2000))
    );
    assert!(
        reports["outcomes"]["counted"].as_u64().unwrap() >= 2,
        "{reports}"
    );
    assert!(reports["filed"].as_u64().unwrap() >= 2, "{reports}");
    assert_eq!(summary["safety"]["collided"], false);
    // Refused as revoked from then on.
    assert!(summary["security"]["refused"]["revoked"].as_u64().unwrap() > 0);
    let events = std::fs::read_to_string(tmp.path().join("ipc/events.csv")).unwrap();
    let at = |event: &str| {
        events
            .lines()
            .find(|l| l.starts_with("0,2,") && l.contains(&format!(",{event},")))
            .map(|l| l.split(',').nth(2).unwrap().parse::<u64>().unwrap())
    };
    let (revoked, left) = (at("revoked").unwrap(), at("left").unwrap());
    assert_eq!(reports["revoked"][0]["step"], revoked);
    assert!(left > revoked, "ejected after the revocation");
}

/// One insider reporting an honest member every second, under as many pseudonyms as its
/// pseudonym changes give it, reaches no quorum: nobody is revoked and the run is the run
/// without the false reports, bit for bit. The rule is what stands in the way: with a quorum
/// of one the same campaign revokes the honest member.
#[test]
fn one_insiders_false_reports_revoke_nobody() {
    let liar = "[security.reports.false_reports]\nreporter = 3\naccused = 1\nstart_s = 5.0\n";
    let keys = "pseudonym_change_s = 5.0\n";
    let (honest, none) = revocations(&reported("", keys, ""));
    assert!(none.is_empty());
    let text = reported("", keys, liar);
    let (rows, revoked) = revocations(&text);
    assert!(revoked.is_empty(), "{revoked:?}");
    assert!(same(&rows, &honest), "the false reports changed the run");
    let mut sim = platoon_sim::Simulation::new(scenario(&text)).unwrap();
    while !sim.is_done() {
        sim.step();
    }
    let counts = sim.controller().seals().unwrap().reports;
    assert!(counts.filed >= 30, "{counts:?}");
    // Every report that arrived counted (its evidence is the accused's genuine packet); the
    // last may still be on the uplink at the end.
    let arrived: u64 = counts.outcomes.iter().sum();
    assert_eq!(counts.outcomes[0], arrived, "{counts:?}");
    assert!(arrived + 1 >= counts.filed, "{counts:?}");
    let (_, revoked) = revocations(&reported("", keys, &format!("quorum = 1\n{liar}")));
    let one = revoked.iter().find(|r| r.vehicle == 1);
    assert!(one.is_some_and(|r| r.reporters == [3]), "{revoked:?}");
    // The summary's ground truth calls every one of them a false revocation: no key signed a
    // lie in this run.
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("liar.toml"),
        reported("", keys, &format!("quorum = 1\n{liar}")),
    )
    .unwrap();
    let out = common::run_config(
        &tmp.path().join("liar.toml"),
        "out",
        &["--transport", "inproc"],
        tmp.path(),
    );
    let summary = common::json(&out.join("summary.json"));
    let judged = summary["security"]["reports"]["revoked"]
        .as_array()
        .unwrap();
    assert_eq!(judged.len(), revoked.len(), "{judged:?}");
    assert!(
        judged.iter().all(|r| r["signed_a_lie"] == false),
        "{judged:?}"
    );
    assert!(summary["detection"].get("signed_lies").is_none());
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
