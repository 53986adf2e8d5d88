//! `[sumo]` and the traffic around the platoon: the SUMO plant's road and options, the leader in
//! SUMO's traffic (`leader.drive`), the vehicles ahead of it and the flows.
use super::checks::{bad, finite, positive, steps_of};
use crate::error::{KeyError, Num};
use crate::schema::{Config, FcdWriter, LeaderDrive, PlantKind, Sumo, SumoStates};

/// `[sumo]`'s own keys, at a step of `dt`.
pub(crate) fn check(s: &Sumo, dt: f64) -> Result<(), KeyError> {
    finite("sumo.start_m", s.start_m)?;
    positive("sumo.tolerance_m", s.tolerance_m)?;
    let share = finite("sumo.background_truck_share", s.background_truck_share)?;
    if !(0.0..=1.0).contains(&share) {
        return bad(
            "sumo.background_truck_share",
            format!("must be in [0, 1], got {share}"),
        );
    }
    if let Some(lc) = &s.background_lane_changes {
        let key = |k: &str| format!("sumo.background_lane_changes.{k}");
        if !(0.0..=1.0).contains(&finite(&key("cooperative"), lc.cooperative)?) {
            return bad(
                &key("cooperative"),
                format!("must be in [0, 1], got {}", lc.cooperative),
            );
        }
        for (k, x) in [("speed_gain", lc.speed_gain), ("keep_right", lc.keep_right)] {
            if finite(&key(k), x)? < 0.0 {
                return bad(&key(k), format!("must be >= 0, got {x}"));
            }
        }
        positive(&key("assertive"), lc.assertive)?;
    }
    if let Some(p) = s.fcd_period_s {
        if finite("sumo.fcd_period_s", p)? != 0.0 {
            steps_of("sumo.fcd_period_s", p, dt)?;
        }
    }
    Ok(())
}

/// The leader in SUMO's traffic (`leader.drive`), the vehicles ahead of it (`[[sumo.ahead]]`),
/// the flows (`[[sumo.flows]]`) and the route through several edges (`sumo.route`).
pub(crate) fn traffic_around(c: &Config) -> Result<(), KeyError> {
    leader_drive(c)?;
    ahead(&c.sumo)?;
    flows(&c.sumo, c.simulation.duration_s, c.simulation.dt_s)?;
    route(c)
}

/// `leader.drive`: SUMO's car-following model drives the leader (SUMO as the plant, its states).
fn leader_drive(c: &Config) -> Result<(), KeyError> {
    let sumo_plant = c.simulation.plant == PlantKind::Sumo;
    if let LeaderDrive::Sumo {
        speed_mps,
        accel_mps2,
        decel_mps2,
        headway_s,
        min_gap_m,
        ..
    } = &c.leader.drive
    {
        if !sumo_plant {
            return bad(
                "leader.drive",
                "kind = \"sumo\" has SUMO's car-following model drive the leader, which needs \
                 SUMO as the plant: set simulation.plant = \"sumo\" (the native plant's leader \
                 follows leader.profile)",
            );
        }
        if c.sumo.states == SumoStates::Model {
            return bad(
                "leader.drive",
                "kind = \"sumo\": SUMO moves the leader, so the controllers must see SUMO's \
                 states (sumo.states = \"sumo\"), not the model's",
            );
        }
        positive("leader.drive.speed_mps", *speed_mps)?;
        positive("leader.drive.accel_mps2", *accel_mps2)?;
        positive("leader.drive.decel_mps2", *decel_mps2)?;
        positive("leader.drive.headway_s", *headway_s)?;
        if finite("leader.drive.min_gap_m", *min_gap_m)? < 0.0 {
            return bad(
                "leader.drive.min_gap_m",
                format!("must be >= 0, got {min_gap_m}"),
            );
        }
    }
    Ok(())
}

/// The traffic only SUMO drives, refused on the native plant (which would drop it without a
/// word): `[[sumo.flows]]`, `[[sumo.ahead]]`, `sumo.background_vehicles` and a `sumo.route` of
/// several edges. The rest of `[sumo]` says where the platoon drives on SUMO's road and means
/// nothing to the native plant, which has no road: it is ignored, as `--plant native` on a
/// SUMO config expects. Checked where the plant is known for good (`platoon run`, after
/// `--plant`), through [`crate::native_plant_check`]: a config may leave the plant native and be
/// run with `--plant sumo`.
pub(crate) fn native_plant(c: &Config) -> Result<(), KeyError> {
    let s = &c.sumo;
    let why = "is SUMO's traffic, which the native plant does not drive (it would run without \
               it): use simulation.plant = \"sumo\" (and no --plant native), or remove it";
    if !s.flows.is_empty() {
        return bad("sumo.flows[0]", format!("[[sumo.flows]] {why}"));
    }
    if !s.ahead.is_empty() {
        return bad("sumo.ahead[0]", format!("[[sumo.ahead]] {why}"));
    }
    if s.background_vehicles > 0 {
        return bad(
            "sumo.background_vehicles",
            format!("{} vehicles {why}", s.background_vehicles),
        );
    }
    if s.route.len() > 1 {
        return bad(
            "sumo.route",
            "a route of several edges is SUMO's road; the native plant drives one straight lane \
             (it would run without it): use simulation.plant = \"sumo\", or remove it",
        );
    }
    Ok(())
}

/// `[[sumo.ahead]]`: the vehicles ahead of the leader.
fn ahead(s: &Sumo) -> Result<(), KeyError> {
    for (i, a) in s.ahead.iter().enumerate() {
        let key = |k: &str| format!("sumo.ahead[{i}].{k}");
        positive(&key("gap_m"), a.gap_m)?;
        positive(&key("length_m"), a.length_m)?;
        if finite(&key("speed_mps"), a.speed_mps)? < 0.0 {
            return bad(
                &key("speed_mps"),
                format!("must be >= 0, got {}", a.speed_mps),
            );
        }
    }
    Ok(())
}

/// The top speed of a flow's cars (their SUMO vType's `maxSpeed`, m/s).
pub const FLOW_CAR_MAX_SPEED_MPS: f64 = 36.0;
/// The top speed of a flow's trucks (m/s).
pub const FLOW_TRUCK_MAX_SPEED_MPS: f64 = 25.0;

/// `[[sumo.flows]]`: SUMO's flows, each entering before the run's end (`duration_s`), at a
/// rate and a speed SUMO accepts at a step of `dt`.
fn flows(s: &Sumo, duration_s: f64, dt: f64) -> Result<(), KeyError> {
    for (i, f) in s.flows.iter().enumerate() {
        let key = |k: &str| format!("sumo.flows[{i}].{k}");
        for (k, edge) in [("from", &f.from), ("to", &f.to)] {
            if edge.is_empty() {
                return bad(&key(k), "must name an edge of the network");
            }
        }
        let rate = positive(&key("vehicles_per_hour"), f.vehicles_per_hour)?;
        // SUMO inserts a flow's vehicles one per step at most, and refuses a rate whose
        // period is below its resolution.
        let most = 3600.0 / dt;
        if rate > most {
            return bad(
                &key("vehicles_per_hour"),
                format!(
                    "{} is more than one vehicle per step (simulation.dt_s = {} s): SUMO inserts \
                     at most {} an hour",
                    Num(rate),
                    Num(dt),
                    Num(most)
                ),
            );
        }
        if finite(&key("begin_s"), f.begin_s)? < 0.0 {
            return bad(
                &key("begin_s"),
                format!("must be >= 0, got {}", Num(f.begin_s)),
            );
        }
        if f.begin_s >= duration_s {
            return bad(
                &key("begin_s"),
                format!(
                    "{} s is not before the run's end (simulation.duration_s = {} s): no vehicle \
                     would enter",
                    Num(f.begin_s),
                    Num(duration_s)
                ),
            );
        }
        if let Some(end) = f.end_s {
            if finite(&key("end_s"), end)? <= f.begin_s {
                return bad(
                    &key("end_s"),
                    format!("must be after begin_s = {}", f.begin_s),
                );
            }
        }
        if !(0.0..=1.0).contains(&finite(&key("truck_share"), f.truck_share)?) {
            return bad(
                &key("truck_share"),
                format!("must be in [0, 1], got {}", Num(f.truck_share)),
            );
        }
        if let Some(v) = f.speed_mps {
            if finite(&key("speed_mps"), v)? < 0.0 {
                return bad(&key("speed_mps"), format!("must be >= 0, got {}", Num(v)));
            }
            // SUMO refuses a vehicle that departs faster than its type's maxSpeed.
            let (most, who) = if f.truck_share > 0.0 {
                (FLOW_TRUCK_MAX_SPEED_MPS, "its trucks' (truck_share > 0)")
            } else {
                (FLOW_CAR_MAX_SPEED_MPS, "its cars'")
            };
            if v > most {
                return bad(
                    &key("speed_mps"),
                    format!(
                        "{} m/s is above {who} top speed of {most} m/s, which SUMO refuses as a \
                         departure speed: at most {most}",
                        Num(v)
                    ),
                );
            }
        }
    }
    Ok(())
}

/// `sumo.route`: the edges the platoon drives, from `sumo.edge` on.
fn route(c: &Config) -> Result<(), KeyError> {
    let route = &c.sumo.route;
    if let Some(first) = route.first() {
        if *first != c.sumo.edge {
            return bad(
                "sumo.route",
                format!(
                    "starts on {first:?}, but the platoon starts on sumo.edge = {:?}: the route's \
                     first edge is the one the platoon starts on",
                    c.sumo.edge
                ),
            );
        }
        if route.len() > 1 && !c.cut_ins.is_empty() {
            return bad(
                "sumo.route",
                "[[cut_ins]] on a route of several edges is not built: use one edge, or SUMO's \
                 own traffic ([[sumo.flows]], background_vehicles)",
            );
        }
        if route.len() > 1 && c.sumo.fcd == FcdWriter::Recorded {
            let period = c.sumo.fcd_period_s;
            if period != Some(0.0) {
                return bad(
                    "sumo.fcd",
                    "platoon writes fcd.xml on one edge's lanes; on a route of several edges set \
                     sumo.fcd = \"sumo\" (SUMO writes it during the run) or sumo.fcd_period_s = 0",
                );
            }
        }
    }
    Ok(())
}
