//! The maneuvers of a run (`[maneuvers]`), measured where they happened: each request on the
//! wire (the step its vehicle broadcast it), its completion in the plant (the mode the
//! vehicle drives in), the errors and gaps from the request on, and the messages about it.
//! Both runtimes feed it the same rows and broadcasts, so `summary.json` agrees bit for bit.
use crate::summary::{FormationRecord, ManeuverRecord, ManeuversSummary};
use crate::StepRow;
use platoon_control::maneuvers::Message;
use platoon_control::Role;
use platoon_maneuver::{Body, Change};
use platoon_model::VehicleId;

/// What a maneuver is, by what its vehicle's request says and how it ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Join,
    Leave,
    Merge,
    Split,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Self::Join => "join",
            Self::Leave => "leave",
            Self::Merge => "merge",
            Self::Split => "split",
        }
    }

    /// Whether `body`, sent by the maneuver's vehicle, is its request (or notice).
    fn requested_by(self, body: &Body) -> bool {
        matches!(
            (self, body),
            (Self::Join, Body::JoinRequest { .. })
                | (Self::Leave, Body::LeaveNotice)
                | (Self::Merge, Body::MergeRequest { .. })
                | (Self::Split, Body::SplitNotice)
        )
    }

    /// Whether the maneuver's vehicle, driving in `mode`, has completed it: a joiner (or a
    /// merging head) admitted to the lane's platoon, a leaver out of the lane, a splitter
    /// heading its part on its ACC.
    /// Whether it is done at a row of its vehicle: in the role it ends in and, where vehicles
    /// change lanes, on the lane that role drives in as the plant has it (a leaver waiting for
    /// a safe gap has not left yet).
    fn completed_in(self, row: &StepRow) -> bool {
        let mode = row.mode;
        let on_its_lane = row.beside.is_none_or(|b| b == mode.is_beside_the_lane());
        on_its_lane
            && match self {
                Self::Join | Self::Merge => !matches!(mode.role(), Role::Outside | Role::Beside),
                Self::Leave => mode == Role::Left,
                Self::Split => mode == Role::Outside,
            }
    }
}

/// Whether `m` is about the maneuver of `vehicle`: sent by it or to it, or naming it.
fn concerns(m: &Message, vehicle: VehicleId) -> bool {
    m.sender == vehicle
        || m.to == vehicle
        || match m.body {
            Body::OpenGap { joiner } | Body::GapReady { joiner } | Body::Abort { joiner } => {
                joiner == vehicle
            }
            Body::Update { change, .. } => match change {
                Change::Joined { vehicle: v, .. } | Change::Left { vehicle: v } => v == vehicle,
                Change::Merged { head, .. } | Change::Split { head } => head == vehicle,
            },
            _ => false,
        }
}

/// One maneuver being measured.
#[derive(Debug, Clone)]
struct Tracked {
    kind: Kind,
    vehicle: VehicleId,
    requested: Option<u64>,
    completed: Option<u64>,
    max_spacing_error: f64,
    min_gap: f64,
    messages: u64,
}

/// Accumulates a platoon's maneuvers step by step (constant memory).
#[derive(Debug, Clone)]
pub(crate) struct ManeuverTally {
    dt: f64,
    tracked: Vec<Tracked>,
    /// The broadcasts of the step whose rows come next.
    pending: Vec<Message>,
    sent: u64,
    formations: Vec<FormationRecord>,
    /// Each follower's wish for the other lane not yet granted: since which step, and which
    /// lane (`true`: beside).
    asking: Vec<Option<(u64, bool)>>,
    /// The last step pushed.
    last_step: u64,
    lane_changes: Vec<crate::summary::LaneChangeRecord>,
}

/// The lane's platoons at a step, from its rows (leader first): each vehicle in the platoon of
/// the leader it took, unless outside the lane's platoons (approaching, beside, left) or a head
/// of a part itself; platoons and their members in road order, each head first.
fn platoons_of(rows: &[StepRow]) -> Vec<Vec<u16>> {
    // A member heads a part of its own only on its ACC outside the leader's platoon (a split's,
    // a merging platoon's): one heading behind a car that cut in stays in the leader's.
    let head = |r: &StepRow| match r.head.unwrap_or(0) {
        0 => 0,
        h => match rows.get(usize::from(h)) {
            Some(x) if x.mode == Role::Outside => h,
            _ => 0,
        },
    };
    let member = |r: &&StepRow| r.vehicle != 0 && r.mode == Role::Member;
    let mut heads: Vec<u16> = vec![0];
    for r in rows.iter().filter(member) {
        if !heads.contains(&head(r)) {
            heads.push(head(r));
        }
    }
    let ahead = |a: u16, b: u16| {
        let p = |v: u16| rows.get(usize::from(v)).map_or(f64::NAN, |r| r.p);
        p(b).total_cmp(&p(a))
    };
    heads.sort_by(|&a, &b| ahead(a, b));
    heads
        .iter()
        .map(|&h| {
            let mut platoon: Vec<u16> = rows
                .iter()
                .filter(member)
                .filter(|r| head(r) == h && !heads.contains(&r.vehicle))
                .map(|r| r.vehicle)
                .collect();
            platoon.sort_by(|&a, &b| ahead(a, b));
            platoon.insert(0, h);
            platoon
        })
        .collect()
}

impl ManeuverTally {
    /// The maneuvers `scenario`'s config asks for; `None` without `[maneuvers]`.
    pub(crate) fn new(scenario: &crate::Scenario) -> Option<Self> {
        let m = scenario.control.maneuvers.as_ref()?;
        let mut tracked: Vec<(u64, Kind, VehicleId)> = Vec::new();
        tracked.extend(m.joins.iter().map(|j| (j.at_step, Kind::Join, j.vehicle)));
        tracked.extend(m.leaves.iter().map(|l| (l.at_step, Kind::Leave, l.vehicle)));
        tracked.extend(m.merge.iter().map(|g| (g.at_step, Kind::Merge, g.head)));
        tracked.extend(m.split.iter().map(|g| (g.at_step, Kind::Split, g.head)));
        tracked.sort_by_key(|&(at, _, v)| (at, v));
        Some(Self {
            dt: scenario.dt(),
            tracked: tracked
                .into_iter()
                .map(|(_, kind, vehicle)| Tracked {
                    kind,
                    vehicle,
                    requested: None,
                    completed: None,
                    max_spacing_error: 0.0,
                    min_gap: f64::INFINITY,
                    messages: 0,
                })
                .collect(),
            pending: Vec::new(),
            sent: 0,
            formations: Vec::new(),
            asking: vec![None; scenario.topology.followers() + 1],
            last_step: 0,
            lane_changes: Vec::new(),
        })
    }

    /// A lane change asked for (the role's lane is not the plant's) or made, per follower.
    fn lanes(&mut self, rows: &[StepRow]) {
        for r in rows.iter().skip(1) {
            let Some(beside) = r.beside else { return };
            let want = r.mode.is_beside_the_lane();
            let Some(asking) = self.asking.get_mut(usize::from(r.vehicle)) else {
                continue;
            };
            match *asking {
                None if want != beside => *asking = Some((r.step, want)),
                Some((since, to)) if want == beside || to != want => {
                    *asking = (want != beside).then_some((r.step, want));
                    self.lane_changes.push(crate::summary::LaneChangeRecord {
                        vehicle: r.vehicle,
                        to: lane_name(to).to_string(),
                        asked_t_s: since as f64 * self.dt,
                        t_s: (beside == to).then_some(r.step as f64 * self.dt),
                        waited_s: (r.step - since - 1) as f64 * self.dt,
                    });
                }
                _ => {}
            }
        }
    }

    /// The maneuver messages broadcast at the step whose rows come next (one a broadcast,
    /// whatever its receivers).
    pub(crate) fn broadcast(&mut self, m: Message) {
        self.pending.push(m);
    }

    /// One step: its rows (leader first), and each follower's gap to the vehicle ahead on
    /// its lane (`NaN` for a vehicle beside the lane), as the metrics measure it.
    pub(crate) fn push(&mut self, rows: &[StepRow], gaps: &[f64]) {
        let Some(k) = rows.first().map(|r| r.step) else {
            return;
        };
        self.sent += self.pending.len() as u64;
        self.last_step = k;
        self.lanes(rows);
        let platoons = platoons_of(rows);
        if self
            .formations
            .last()
            .is_none_or(|f| f.platoons != platoons)
        {
            self.formations.push(FormationRecord {
                t_s: k as f64 * self.dt,
                speed_mps: rows[0].v,
                platoons,
                stability: None,
            });
        }
        // The step's largest spacing error in the lane's platoon and smallest gap on the lane,
        // once for every maneuver under way.
        let worst = rows
            .iter()
            .skip(1)
            .filter(|r| r.mode == Role::Member)
            .map(|r| r.spacing_error.abs())
            .fold(0.0, f64::max);
        let smallest = gaps
            .iter()
            .filter(|g| !g.is_nan())
            .fold(f64::INFINITY, |a, &g| a.min(g));
        for t in &mut self.tracked {
            for m in &self.pending {
                if t.requested.is_none() && m.sender == t.vehicle && t.kind.requested_by(&m.body) {
                    t.requested = Some(k);
                }
                if t.requested.is_some() && t.completed.is_none() && concerns(m, t.vehicle) {
                    t.messages += 1;
                }
            }
            if t.requested.is_none() {
                continue;
            }
            let Some(own) = rows.get(t.vehicle.index()) else {
                continue;
            };
            if t.completed.is_none() && t.kind.completed_in(own) {
                t.completed = Some(k);
            }
            t.max_spacing_error = t.max_spacing_error.max(worst);
            t.min_gap = t.min_gap.min(smallest);
        }
        self.pending.clear();
    }

    /// What was measured.
    pub(crate) fn finish(&self) -> ManeuversSummary {
        let seconds = |steps: u64| steps as f64 * self.dt;
        // A wish still not granted: asked, never made.
        let last = self.last_step;
        let open = self.asking.iter().enumerate().filter_map(|(v, a)| {
            let (since, to) = (*a)?;
            Some(crate::summary::LaneChangeRecord {
                vehicle: v as u16,
                to: lane_name(to).to_string(),
                asked_t_s: seconds(since),
                t_s: None,
                waited_s: seconds(last.saturating_sub(since)),
            })
        });
        let mut lane_changes = self.lane_changes.clone();
        lane_changes.extend(open);
        ManeuversSummary {
            messages_sent: self.sent,
            lane_changes,
            formations: self.formations.clone(),
            maneuvers: self
                .tracked
                .iter()
                .map(|t| ManeuverRecord {
                    maneuver: t.kind.name().to_string(),
                    vehicle: t.vehicle.0,
                    outcome: match (t.requested, t.completed) {
                        (None, _) => "not_requested",
                        (Some(_), Some(_)) => "completed",
                        (Some(_), None) => "failed",
                    }
                    .to_string(),
                    requested_t_s: t.requested.map(seconds),
                    completion_s: t
                        .requested
                        .zip(t.completed)
                        .map(|(a, b)| seconds(b.saturating_sub(a))),
                    max_spacing_error_m: t.requested.map(|_| t.max_spacing_error),
                    min_gap_m: t.min_gap.is_finite().then_some(t.min_gap),
                    messages: t.messages,
                })
                .collect(),
        }
    }
}

/// The name of a lane in the summary: `beside` or `platoon`.
fn lane_name(beside: bool) -> &'static str {
    match beside {
        true => "beside",
        false => "platoon",
    }
}
