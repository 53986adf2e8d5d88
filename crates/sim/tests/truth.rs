//! The ground-truth labels of every delivery match what the channel did, attack by
//! attack, in process (the paper's scenario, its two-predecessor graph and DoS, 20 s).
use platoon_attacks::channel::{Action, ChannelEvent};
use platoon_config::{parse, PAPER_TOML};
use platoon_control::fallback::RadarTruth;
use platoon_control::{Controller, Delivery, FollowerStep, Packet, RejectCounts};
use platoon_model::{State, VehicleId};
use platoon_sim::truth::{Fields, Label, LabelCounts, Labelled, TruthLabeler};
use platoon_sim::{run_until_with, tally, ControllerFactory, Scenario};
use std::ops::ControlFlow;
use std::path::Path;
use std::sync::{Arc, Mutex};

/// What the controllers saw and sent in the last step.
#[derive(Debug, Default)]
struct Seen {
    k: u64,
    states: Vec<State>,
    tx: Vec<Packet>,
    deliveries: Vec<Delivery>,
}

/// The built-in controller, recording its step and optionally lying: `lie = (v, dp)` adds `dp`
/// to the position vehicle v broadcasts (an insider lying at its source).
#[derive(Debug, Clone)]
struct Tap {
    inner: Box<dyn Controller>,
    seen: Arc<Mutex<Seen>>,
    lie: Option<(VehicleId, f64)>,
}

impl Controller for Tap {
    fn transmit(&mut self, k: u64, states: &[State], out: &mut Vec<Packet>) {
        let from = out.len();
        self.inner.transmit(k, states, out);
        if let Some((v, dp)) = self.lie {
            for p in out[from..].iter_mut().filter(|p| p.sender == v) {
                p.state[0] += dp;
            }
        }
        let mut s = self.seen.lock().unwrap();
        s.k = k;
        s.states = states.to_vec();
        s.tx = out[from..].to_vec();
    }

    fn set_radar_truth(&mut self, truth: &[Option<RadarTruth>]) {
        self.inner.set_radar_truth(truth);
    }

    fn receive(&mut self, k: u64, states: &[State], d: &[Delivery], jammed: &[bool]) -> &[f64] {
        self.seen.lock().unwrap().deliveries = d.to_vec();
        self.inner.receive(k, states, d, jammed)
    }

    fn commands(&self) -> &[f64] {
        self.inner.commands()
    }

    fn follower_step(&self, i: VehicleId) -> FollowerStep {
        self.inner.follower_step(i)
    }

    fn rejected(&self) -> RejectCounts {
        self.inner.rejected()
    }
}

fn scenario(attacks: &str) -> Scenario {
    let text = format!("{PAPER_TOML}\n{attacks}").replace("duration_s = 55.0", "duration_s = 20.0");
    parse(&text, Path::new("truth.toml")).unwrap().1
}

/// One labelled run: every labelled delivery with the broadcasts and the channel's log rows of
/// its step, and the labeler's totals.
struct Run {
    steps: Vec<(Vec<Packet>, Vec<Labelled>, Vec<ChannelEvent>)>,
    totals: LabelCounts,
}

impl Run {
    fn labels(&self) -> impl Iterator<Item = (&Labelled, &[Packet], &[ChannelEvent])> {
        self.steps
            .iter()
            .flat_map(|(tx, ls, log)| ls.iter().map(move |l| (l, &tx[..], &log[..])))
    }

    fn rows(&self, action: Action) -> impl Iterator<Item = &ChannelEvent> {
        self.steps
            .iter()
            .flat_map(|(_, _, log)| log.iter())
            .filter(move |e| e.action == action)
    }

    /// The delivery a log row is about (its step, link and seq), if delivered.
    fn delivery_of(&self, e: &ChannelEvent) -> Option<(&Labelled, &[Packet])> {
        let (tx, ls, _) = &self.steps[e.step as usize];
        ls.iter()
            .find(|l| {
                l.delivery.receiver.0 == e.receiver
                    && l.delivery.packet.sender.0 == e.sender
                    && l.delivery.packet.seq == e.seq
            })
            .map(|l| (l, &tx[..]))
    }
}

fn run(attacks: &str, lie: Option<(VehicleId, f64)>) -> Run {
    let sc = scenario(attacks);
    let seen = Arc::new(Mutex::new(Seen::default()));
    let tap = seen.clone();
    let factory = ControllerFactory::new(move |sc| {
        let tap = Tap {
            inner: ControllerFactory::builtin().make(sc)?,
            seen: tap.clone(),
            lie,
        };
        Ok(Box::new(tap) as Box<dyn Controller>)
    });
    let mut labeler = TruthLabeler::for_seconds(10.0, sc.dt());
    let mut steps = Vec::new();
    let topology = sc.topology.clone();
    run_until_with(&sc, &factory, |sim| {
        let s = seen.lock().unwrap();
        let mut out = Vec::new();
        labeler.label(
            s.k,
            &s.states,
            tally::links(&topology, &s.tx),
            &s.deliveries,
            &mut out,
        );
        assert_eq!(s.k as usize, steps.len());
        steps.push((s.tx.clone(), out, sim.channel_log().to_vec()));
        ControlFlow::Continue(())
    })
    .unwrap();
    Run {
        steps,
        totals: *labeler.totals(),
    }
}

/// The log row of `action` behind a labelled delivery.
fn has_row(log: &[ChannelEvent], l: &Labelled, action: Action) -> bool {
    let d = &l.delivery;
    log.iter().any(|e| {
        e.step == l.step
            && e.action == action
            && e.sender == d.packet.sender.0
            && e.receiver == d.receiver.0
            && e.seq == d.packet.seq
    })
}

/// Every label other than genuine has the channel's log row behind it, and nothing is forged
/// or a lie (the built-in controllers broadcast true states).
fn labels_match_the_log(r: &Run) {
    assert!(r.totals.total() > 1000, "{:?}", r.totals);
    assert_eq!((r.totals.forged, r.totals.lied), (0, 0), "{:?}", r.totals);
    for (l, _, log) in r.labels() {
        let ok = match l.label {
            Label::Genuine => true,
            Label::Altered { .. } => has_row(log, l, Action::Altered),
            Label::Replayed => has_row(log, l, Action::Replayed),
            Label::Delayed => {
                has_row(log, l, Action::DeliveredLate) || has_row(log, l, Action::Replayed)
            }
            Label::Lied { .. } | Label::Forged => false,
        };
        assert!(ok, "{l:?} without its log row in {log:?}");
        // Whatever the channel did, the sender's true state at the claimed step is known.
        assert!(l.truth.is_some(), "{l:?}");
    }
}

/// Every `altered` row of a delivered packet is labelled altered, unless the alteration
/// changed nothing (a scaled zero acceleration); returns how many were.
fn altered_rows_are_labelled_altered(r: &Run) -> usize {
    let mut n = 0;
    for e in r.rows(Action::Altered) {
        let Some((l, tx)) = r.delivery_of(e) else {
            continue; // altered, then dropped by a later attack
        };
        let sent = tx
            .iter()
            .find(|p| p.sender.0 == e.sender && p.seq == e.seq)
            .unwrap();
        if let Label::Altered { .. } = l.label {
            n += 1;
        } else {
            assert_eq!(l.label, Label::Genuine, "{e:?}");
            assert_eq!(
                l.delivery.packet, *sent,
                "{e:?}: changed but not labelled so"
            );
        }
    }
    n
}

#[test]
fn a_clean_run_labels_every_delivery_genuine() {
    // The paper's DoS drops packets; what gets through is genuine.
    let r = run("", None);
    assert_eq!(r.totals.genuine, r.totals.total());
    assert!(r.totals.genuine > 1000);
    for (l, _, _) in r.labels() {
        assert_eq!(
            l.truth,
            Some(l.delivery.packet.state),
            "true states, bit for bit"
        );
    }
    // And losses change nothing in what arrives.
    let r = run(
        "[[channel.attacks]]\nkind = \"bernoulli\"\nloss = 0.3\n",
        None,
    );
    assert_eq!(r.totals.genuine, r.totals.total());
}

/// Each state-altering kind, outsider and insider: labelled altered exactly where the channel
/// says it altered, with the fields the kind changes.
#[test]
fn altering_attacks_are_labelled_altered_with_their_fields() {
    let cases: [(&str, Fields); 5] = [
        ("kind = \"false_data\"\noffset = [2.0, 0.0, 0.0]", Fields::P),
        ("kind = \"random_offset\"\nstd = [0.5, 0.2, 0.0]", Fields(3)),
        ("kind = \"drift\"\nrate = [0.0, 0.1, 0.0]", Fields::V),
        ("kind = \"feigned_braking\"\naccel_mps2 = -6.0", Fields::A),
        ("kind = \"accel_scale\"\nfactor = 2.0", Fields::A),
    ];
    for (kind, fields) in cases {
        for insider in [false, true] {
            // Followers 1 and 2 from 5.005 s (off the step grid: the drift is never zero).
            let attack = format!(
                "[[channel.attacks]]\n{kind}\nsenders = [1, 2]\nstart_s = 5.005\ninsider = {insider}\n"
            );
            let r = run(&attack, None);
            labels_match_the_log(&r);
            let altered = altered_rows_are_labelled_altered(&r);
            assert!(altered > 100, "{kind}: {altered} altered");
            assert_eq!(r.totals.altered as usize, altered, "{kind}");
            for (l, _, _) in r.labels() {
                if let Label::Altered { fields: f } = l.label {
                    assert!(fields.contains(f) && !f.is_empty(), "{kind}: {f:?}");
                    assert!([1, 2].contains(&l.delivery.packet.sender.0));
                    assert!(l.step >= 501);
                }
            }
            // An insider's receivers all get the same lie; an outsider's noise differs.
            let mut same = true;
            for (_, ls, _) in &r.steps {
                for a in ls {
                    for b in ls {
                        let p = (&a.delivery.packet, &b.delivery.packet);
                        if p.0.sender == p.1.sender && p.0.seq == p.1.seq {
                            same &= p.0.state == p.1.state;
                        }
                    }
                }
            }
            if insider || !kind.contains("random") {
                assert!(same, "{kind} insider = {insider}");
            } else {
                assert!(!same, "an outsider's noise is drawn per link");
            }
        }
    }
}

#[test]
fn replayed_packets_are_labelled_replayed_or_delayed() {
    let r = run(
        "[[channel.attacks]]\nkind = \"replay\"\nsenders = [0]\nstart_s = 3.0\nlag_s = 0.5\n",
        None,
    );
    labels_match_the_log(&r);
    // The leader broadcasts every step and from 3 s on each of its packets is replaced by the
    // one of 0.5 s before, which its receivers (followers 1 and 2) never got: only the 50 steps'
    // worth they had got before 3 s are replays to them, the rest arrive 0.5 s late.
    let rows = r.rows(Action::Replayed).count() as u64;
    assert_eq!(r.totals.replayed, 2 * 50, "{:?}", r.totals);
    assert_eq!(r.totals.delayed, rows - 2 * 50, "{:?}", r.totals);
    for e in r.rows(Action::Replayed) {
        let (l, _) = r.delivery_of(e).expect("a replay is delivered");
        assert!(
            matches!(l.label, Label::Replayed | Label::Delayed),
            "{e:?}: {l:?}"
        );
        assert_eq!(l.truth, Some(l.delivery.packet.state), "a true old state");
    }
}

#[test]
fn delayed_packets_are_labelled_delayed() {
    let r = run(
        "[[channel.attacks]]\nkind = \"delay\"\nsenders = [1]\ndelay_s = 0.1\n",
        None,
    );
    labels_match_the_log(&r);
    let late = r.rows(Action::DeliveredLate).count();
    assert!(late > 100);
    assert_eq!(r.totals.delayed as usize, late);
    for e in r.rows(Action::DeliveredLate) {
        assert_eq!(r.delivery_of(e).unwrap().0.label, Label::Delayed);
    }
}

#[test]
fn a_sender_broadcasting_a_false_state_is_labelled_lied() {
    let r = run("", Some((VehicleId(1), 0.5)));
    assert!(r.totals.lied > 100, "{:?}", r.totals);
    assert_eq!(r.totals.lied + r.totals.genuine, r.totals.total());
    for (l, _, _) in r.labels() {
        let liar = l.delivery.packet.sender == VehicleId(1);
        assert_eq!(
            l.label == (Label::Lied { fields: Fields::P }),
            liar,
            "{l:?}"
        );
        if liar {
            let truth = l.truth.unwrap();
            assert_eq!(l.delivery.packet.state[0], truth[0] + 0.5);
        }
    }
}
