//! SUMO as the plant: the bridge's Python environment, the road check, and plant.json.
use crate::error::{Context, OtherError};
use platoon_config::{Config, ConfigError, Num};
use platoon_output::error::OutputError;
use platoon_output::rundir::RunDir;
use platoon_runtime::Program;
use platoon_sim::{PlantSpec, Scenario};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The result of SUMO's set-up.
pub type Result<T, E = SumoError> = std::result::Result<T, E>;

/// Why SUMO could not be set up for a run (the bridge, its venv, the network and the road,
/// `plant.json`) or a run's fcd.xml written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SumoError {
    /// The config's `[sumo]` (or the road it asks for) does not fit the network: the key
    /// named (`platoon run` exits 2).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A file of the run (`plant.json`, the table fcd.xml is written from) or fcd.xml.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Anything else: the bridge and its venv, a file the bridge wrote.
    #[error(transparent)]
    Other(OtherError),
}

operation_error!(SumoError);

impl From<platoon_sim::ScenarioError> for SumoError {
    fn from(e: platoon_sim::ScenarioError) -> Self {
        Self::Other(OtherError::wrap(e))
    }
}

impl SumoError {
    /// The config error this is, if it is one.
    pub fn config(&self) -> Option<&ConfigError> {
        match self {
            Self::Config(c) => Some(c),
            _ => None,
        }
    }

    /// The output error this is, if it is one.
    pub fn output(&self) -> Option<&OutputError> {
        match self {
            Self::Output(o) => Some(o),
            _ => None,
        }
    }
}

/// The bridge directory (Python plant, injector SDK, examples; `../sumo/` beside it holds the
/// networks), found once per process in this order:
/// 1. `--bridge-dir` / `PLATOON_BRIDGE_DIR`, which must be one;
/// 2. the checkout this binary was built from, while the binary is inside it (`cargo run`);
/// 3. a `bridge/` in the current directory, or beside or above the binary (a release archive);
/// 4. the copy embedded in the binary, unpacked on first use (`crate::bundle`).
pub fn bridge_dir() -> Result<PathBuf, OtherError> {
    static FOUND: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    if let Some(dir) = FOUND.get() {
        return Ok(dir.clone());
    }
    let dir = find_bridge()?;
    Ok(FOUND.get_or_init(|| dir).clone())
}

fn find_bridge() -> Result<PathBuf, OtherError> {
    use crate::bundle::is_bridge;
    if let Some(dir) = std::env::var_os("PLATOON_BRIDGE_DIR").filter(|d| !d.is_empty()) {
        let dir = PathBuf::from(dir);
        if !is_bridge(&dir) {
            bail!(
                "--bridge-dir/PLATOON_BRIDGE_DIR = {} is not a bridge directory (it has no setup-venv.sh; give the bridge/ folder of a platoon checkout)",
                dir.display()
            );
        }
        return Ok(dir);
    }
    let exe = std::env::current_exe()
        .ok()
        .and_then(|e| e.canonicalize().ok());
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    if let (Some(exe), Ok(checkout)) = (&exe, built.canonicalize()) {
        if exe.starts_with(&checkout) && is_bridge(&checkout.join("bridge")) {
            return Ok(checkout.join("bridge"));
        }
    }
    let cwd = std::env::current_dir().ok().map(|d| d.join("bridge"));
    let beside_exe = exe.iter().flat_map(|exe| {
        exe.ancestors()
            .skip(1)
            .map(|a| a.join("bridge"))
            .collect::<Vec<_>>()
    });
    if let Some(dir) = cwd.into_iter().chain(beside_exe).find(|d| is_bridge(d)) {
        return Ok(dir);
    }
    Ok(crate::bundle::unpacked()?.join("bridge"))
}

/// Creates `bridge/.venv` with the pinned packages if it is missing (with a progress message),
/// and returns its Python.
pub fn ensure_venv() -> Result<PathBuf, OtherError> {
    let bridge = bridge_dir()?;
    let setup = bridge.join("setup-venv.sh");
    let status = Command::new(&setup)
        .status()
        .with_context(|| format!("running {}", setup.display()))?;
    if !status.success() {
        bail!(
            "could not set up the bridge's Python environment ({} exited with {status}; its message is above)",
            setup.display()
        );
    }
    Ok(bridge.join(".venv/bin/python"))
}

/// The bridge's Python running a module of the bridge's `platoon` package (`python -m
/// <module>`, e.g. `platoon.dask`), the bridge first on its `PYTHONPATH` so that the bridge's
/// own copy runs, not another one installed in the venv.
pub fn bridge_module(module: &str) -> Result<Command, OtherError> {
    let python = ensure_venv()?;
    let theirs = std::env::var_os("PYTHONPATH").unwrap_or_default();
    let path = std::iter::once(bridge_dir()?)
        .chain(std::env::split_paths(&theirs).filter(|p| !p.as_os_str().is_empty()));
    let mut cmd = Command::new(python);
    cmd.args(["-m", module]).env(
        "PYTHONPATH",
        std::env::join_paths(path).map_err(OtherError::wrap)?,
    );
    Ok(cmd)
}

/// What the orchestrator needs to run the SUMO plant.
pub struct SumoPlant {
    /// The bridge process (`python -m platoon.sumo`).
    pub program: Program,
    /// `PLATOON_PLANT_SPEC`.
    pub env: Vec<(String, String)>,
    /// Its background vehicles, whose positions it publishes every step (`traffic`).
    pub traffic: usize,
    /// Other vehicles may reach the platoons' lanes (background vehicles that start there or
    /// change lanes, flows that merge): the run records what the radars saw.
    pub near_platoon: bool,
}

/// `plant.json`: the plant spec plus the SUMO options.
#[derive(serde::Serialize)]
struct Spec<'a> {
    #[serde(flatten)]
    plant: PlantSpec,
    sumo: SumoSpec<'a>,
}

#[derive(serde::Serialize)]
struct SumoSpec<'a> {
    net: String,
    edge: &'a str,
    offset_m: f64,
    vehicle_length_m: f64,
    collision_action: platoon_config::CollisionAction,
    states: platoon_config::SumoStates,
    tolerance_m: f64,
    /// SUMO's FCD writer's period (0: SUMO writes none).
    fcd_period_s: f64,
    /// fcd.xml's period when platoon writes it from the trajectories after the run (0: not).
    recorded_fcd_period_s: f64,
    background_vehicles: usize,
    background_seed: u64,
    background_lanes: Vec<(u32, f64)>,
    /// LC2013's parameters for the background vehicles; absent: they keep their lanes.
    #[serde(skip_serializing_if = "Option::is_none")]
    background_lane_changes: Option<&'a platoon_config::LaneChanges>,
    /// `background_lanes` holds the platoons' lanes too; the bridge keeps the background
    /// vehicles out of each platoon's extent.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    background_on_platoon_lanes: bool,
    #[serde(skip_serializing_if = "is_zero")]
    background_truck_share: f64,
    /// SUMO's lane-change output (with `background_lane_changes`, or flows).
    #[serde(skip_serializing_if = "Option::is_none")]
    lanechanges: Option<String>,
    /// The lane beside each platoon's, where its leavers go and its joiners from beside start
    /// (empty: nobody changes lanes).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    side_lanes: Vec<u32>,
    /// The followers (by their number in the platoon) that start in the lane beside.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    beside: Vec<usize>,
    /// `[sumo] route`, when it has several edges.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    route: Vec<String>,
    /// Where each lane of the route starts along the platoons' lane (with `route`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    road: Vec<(String, f64)>,
    /// SUMO's car-following model drives the leaders (`leader.drive`).
    #[serde(skip_serializing_if = "Option::is_none")]
    leader: Option<&'a platoon_config::LeaderDrive>,
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    ahead: &'a [platoon_config::AheadVehicle],
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    flows: &'a [platoon_config::SumoFlow],
    /// The run's duration (s), where a flow's end is absent (with `flows`).
    #[serde(skip_serializing_if = "is_zero")]
    duration_s: f64,
    routes: String,
    fcd: String,
    report: String,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

fn config_error(file: &Path, key: &str, message: String) -> SumoError {
    // Placed at the key's line, as the config's own errors are.
    let lines = platoon_config::KeyLines::new(&std::fs::read_to_string(file).unwrap_or_default());
    ConfigError::at_key(file, &lines, key, message).into()
}

/// A checked SUMO set-up, before any file is written.
pub struct SumoPlan<'a> {
    config: &'a Config,
    scenario: &'a Scenario,
    net: PathBuf,
    offset: f64,
    length: f64,
    free_lanes: Vec<(u32, f64)>,
    /// fcd.xml's period (s; 0: none).
    fcd_period_s: f64,
    /// The road along `[sumo] route`, when it has several edges.
    road: Option<Road>,
    /// The lane beside each platoon's (leaves, joins from beside).
    side_lanes: Vec<u32>,
}

/// How far back (the rear of the last platoon) and ahead (the leader) the run reaches, each
/// as (position along the platoons' lane, t): platoon 0 runs natively (SUMO reproduces it to
/// 1e-9 m), the others are the same shifted back (to well under a millimetre); a leader SUMO
/// drives goes at most at its desired speed (then the third value is true: the farthest point
/// is that speed's).
fn reach(config: &Config, scenario: &Scenario) -> Result<Reach> {
    let back = scenario.fleet.offset(scenario.fleet.platoons - 1);
    let (mut lo, mut hi) = ((f64::INFINITY, 0.0), (f64::NEG_INFINITY, 0.0));
    let mut platoon0 = scenario.clone();
    platoon0.fleet.platoons = 1;
    platoon_sim::run(platoon0, |rows| {
        for r in rows {
            if r.p - back < lo.0 {
                lo = (r.p - back, r.t);
            }
            if r.p > hi.0 {
                hi = (r.p, r.t);
            }
        }
    })?;
    if let platoon_config::LeaderDrive::Sumo { speed_mps, .. } = &config.leader.drive {
        // SUMO drives the leader at most at its desired speed (or its initial one).
        let (p0, v0) = (scenario.initial[0][0], scenario.initial[0][1]);
        let t = scenario.steps as f64 * scenario.dt();
        let far = p0 + v0.max(*speed_mps) * t;
        if far > hi.0 {
            return Ok(Reach {
                lo,
                hi: (far, t),
                driven: *speed_mps > v0,
            });
        }
    }
    Ok(Reach {
        lo,
        hi,
        driven: false,
    })
}

/// How far back and ahead a run reaches ([`reach`]).
struct Reach {
    /// The rearmost point and when (m, s).
    lo: (f64, f64),
    /// The farthest and when (m, s).
    hi: (f64, f64),
    /// Whether the farthest is the desired speed of a leader SUMO drives.
    driven: bool,
}

/// `[[sumo.ahead]]`: every vehicle ahead of a leader starts on the platoon's first edge, whose
/// lane ends at `first_edge_m` (SUMO would put one beyond at the lane's end, nearer than
/// asked); `front` is the frontmost leader's lane position at t = 0.
fn ahead_on_edge(
    config_file: &Path,
    s: &platoon_config::Sumo,
    front: f64,
    first_edge_m: f64,
) -> Result<()> {
    for (i, a) in s.ahead.iter().enumerate() {
        let at = front + a.gap_m + a.length_m;
        if at > first_edge_m {
            return Err(config_error(
                config_file,
                &format!("sumo.ahead[{i}].gap_m"),
                format!(
                    "{} m puts its front at lane position {} m, beyond the end of edge {:?} \
                     ({} m; SUMO would put it there, nearer than asked): at most {} m",
                    Num(a.gap_m),
                    Num(at),
                    s.edge,
                    Num(first_edge_m),
                    Num(first_edge_m - front - a.length_m)
                ),
            ));
        }
    }
    Ok(())
}

/// The lane beside each platoon's (of the edge's `lanes`, index and length), where a leaver
/// changes to, a joiner from beside starts and a car that cuts in waits and drives out to: the
/// next lane to the left, else to the right; none unless the scenario changes lanes or has
/// cut-ins (on a route of `several_edges` it cannot).
fn side_lanes(
    config_file: &Path,
    scenario: &Scenario,
    s: &platoon_config::Sumo,
    lanes: &[(u32, f64)],
    several_edges: bool,
) -> Result<Vec<u32>> {
    let mut side_lanes = Vec::new();
    let cut_ins = !scenario.cut_ins.is_empty();
    if scenario.changes_lanes() || cut_ins {
        let key = if scenario.changes_lanes() {
            "maneuvers"
        } else {
            "cut_ins"
        };
        let lanes_error = |message: String| config_error(config_file, key, message);
        if several_edges {
            return Err(lanes_error(
                "on SUMO a leaver, a joiner from beside or a car that cuts in changes lanes \
                 on one edge; sumo.route has several"
                    .into(),
            ));
        }
        for &lane in &scenario.fleet.lanes {
            let beside = [lane + 1, lane.wrapping_sub(1)]
                .into_iter()
                .find(|l| lanes.iter().any(|(i, _)| i == l));
            let Some(beside) = beside else {
                return Err(lanes_error(format!(
                    "on SUMO a leaver, a joiner from beside or a car that cuts in uses the \
                     lane beside the platoon's, and edge {} has only lane {lane} (sumo.net: a \
                     network with two lanes or more, such as the default)",
                    s.edge
                )));
            };
            side_lanes.push(beside);
        }
    }
    Ok(side_lanes)
}

/// Checks the network, lane and that the platoon stays on the road for the whole run (from the
/// native run, which SUMO reproduces to 1e-9 m). Errors are config errors naming the key.
pub fn plan<'a>(
    config_file: &Path,
    config: &'a Config,
    scenario: &'a Scenario,
) -> Result<SumoPlan<'a>> {
    let s = &config.sumo;
    let net = match &s.net {
        Some(net) => config_file.parent().unwrap_or(Path::new(".")).join(net),
        None => bridge_dir()?.join("../sumo/highway/highway.net.xml"),
    };
    let net_error = |message: String| config_error(config_file, "sumo.net", message);
    let net = net
        .canonicalize()
        .map_err(|e| net_error(format!("cannot read {}: {e}", net.display())))?;
    let text = std::fs::read_to_string(&net)
        .map_err(|e| net_error(format!("cannot read {}: {e}", net.display())))?;
    let doc = roxmltree::Document::parse(&text)
        .map_err(|e| net_error(format!("{} is not a SUMO network: {e}", net.display())))?;
    // Every lane of the edge: index -> length.
    let prefix = format!("{}_", s.edge);
    let lanes: Vec<(u32, f64)> = doc
        .descendants()
        .filter(|n| n.has_tag_name("lane"))
        .filter_map(|n| {
            let index = n.attribute("id")?.strip_prefix(&prefix)?.parse().ok()?;
            Some((index, n.attribute("length")?.parse().ok()?))
        })
        .collect();
    let mut lane_length = f64::INFINITY;
    let mut lane_id = String::new();
    for &lane in &scenario.fleet.lanes {
        let Some(&(_, length)) = lanes.iter().find(|(i, _)| *i == lane) else {
            return Err(config_error(
                config_file,
                if scenario.fleet.platoons > 1 {
                    "fleet.lanes"
                } else {
                    "sumo.lane"
                },
                format!(
                    "{} has no lane {}{lane} (edge `sumo.edge`; its lanes are {:?})",
                    net.display(),
                    prefix,
                    lanes.iter().map(|(i, _)| *i).collect::<Vec<_>>()
                ),
            ));
        };
        if length < lane_length {
            (lane_length, lane_id) = (length, format!("{prefix}{lane}"));
        }
    }
    // A route of several edges: where each lane of it starts along the platoons' lane.
    let road = route_road(config_file, s, &doc, &net, &scenario.fleet.lanes)?;
    if let Some(road) = &road {
        lane_length = road.length;
        lane_id = format!("{lane_id} along sumo.route {:?}", s.route);
    }
    for (i, f) in s.flows.iter().enumerate() {
        for (key, edge) in [("from", &f.from), ("to", &f.to)] {
            if !doc
                .descendants()
                .any(|n| n.has_tag_name("edge") && n.attribute("id") == Some(edge.as_str()))
            {
                return Err(config_error(
                    config_file,
                    &format!("sumo.flows[{i}].{key}"),
                    format!("{} has no edge {edge:?}", net.display()),
                ));
            }
        }
    }
    let free_lanes: Vec<(u32, f64)> = lanes
        .iter()
        .copied()
        .filter(|(i, _)| s.background_on_platoon_lanes || !scenario.fleet.lanes.contains(i))
        .collect();
    if s.background_vehicles > 0 && free_lanes.is_empty() {
        return Err(config_error(
            config_file,
            "sumo.background_vehicles",
            format!(
                "background traffic drives on the lanes no platoon uses, and edge {} has none free \
                 (sumo.background_on_platoon_lanes = true puts it on the platoons' lanes too)",
                s.edge
            ),
        ));
    }

    // Where the platoon goes: the native run predicts SUMO's to 1e-9 m.
    let rear0 = scenario
        .initial
        .iter()
        .map(|x| x[0])
        .fold(f64::INFINITY, f64::min)
        - scenario.fleet.offset(scenario.fleet.platoons - 1);
    let offset = s.start_m - rear0;
    let length = scenario.vehicle_length.max(0.01);
    // The longest member (vehicle classes) must fit on the road too.
    let longest = scenario.lengths().into_iter().fold(length, f64::max);
    let first_edge_m = lanes
        .iter()
        .filter(|(i, _)| scenario.fleet.lanes.contains(i))
        .map(|(_, l)| *l)
        .fold(f64::INFINITY, f64::min);
    stays_on_road(
        config_file,
        config,
        scenario,
        &Lane {
            id: &lane_id,
            length: lane_length,
            first_edge_m,
            net: &net,
        },
        (offset, longest),
    )?;
    let fcd_period_s = fcd_period(config_file, config, scenario)?;
    let side_lanes = side_lanes(config_file, scenario, s, &lanes, road.is_some())?;
    Ok(SumoPlan {
        config,
        scenario,
        net,
        offset,
        length,
        free_lanes,
        fcd_period_s,
        road,
        side_lanes,
    })
}

/// The platoons' lane as the road check sees it.
struct Lane<'a> {
    /// Its id (and route), as errors name it.
    id: &'a str,
    /// Its length along the route (m).
    length: f64,
    /// Where the first edge's lane ends (m).
    first_edge_m: f64,
    /// The network.
    net: &'a Path,
}

/// The platoon stays on the road for the whole run: it starts on it, nothing backs off its
/// start, the vehicles ahead start on the first edge and the leader does not run off its end
/// (`offset`: the platoon's coordinates onto the lane; `longest`: the longest vehicle). Each
/// error names the key that puts a vehicle off the road.
fn stays_on_road(
    config_file: &Path,
    config: &Config,
    scenario: &Scenario,
    lane: &Lane<'_>,
    (offset, longest): (f64, f64),
) -> Result<()> {
    let s = &config.sumo;
    if s.start_m < longest {
        return Err(config_error(
            config_file,
            "sumo.start_m",
            format!("must be at least the vehicle length ({longest} m) so every vehicle starts on the road"),
        ));
    }
    if s.start_m + longest > lane.length {
        return Err(config_error(
            config_file,
            "sumo.start_m",
            format!(
                "{} m is beyond the end of the road (lane {} is {} m long)",
                Num(s.start_m),
                lane.id,
                Num(lane.length)
            ),
        ));
    }
    ahead_on_edge(
        config_file,
        s,
        scenario.initial[0][0] + offset,
        lane.first_edge_m,
    )?;
    let Reach { lo, hi, driven } = reach(config, scenario)?;
    if lo.0 + offset < longest {
        return Err(config_error(
            config_file,
            "sumo.start_m",
            format!(
                "a vehicle would back off the start of the road at t = {:.2} s ({:.1} m before it); increase sumo.start_m",
                lo.1,
                longest - (lo.0 + offset)
            ),
        ));
    }
    let margin = 1.0;
    if hi.0 + offset > lane.length - margin {
        if driven {
            let speed = match &config.leader.drive {
                platoon_config::LeaderDrive::Sumo { speed_mps, .. } => *speed_mps,
                platoon_config::LeaderDrive::Profile {} => f64::NAN,
            };
            return Err(config_error(
                config_file,
                "leader.drive.speed_mps",
                format!(
                    "{} m/s would take the leader to lane position {} m by t = {:.2} s, beyond \
                     the end of lane {} of {} ({:.0} m): a slower leader, a \
                     longer network or a shorter simulation.duration_s",
                    Num(speed),
                    Num((hi.0 + offset).round()),
                    hi.1,
                    lane.id,
                    lane.net.display(),
                    lane.length
                ),
            ));
        }
        return Err(config_error(
            config_file,
            "sumo.net",
            format!(
                "road too short: the leader reaches lane position {} m at t = {:.2} s, but lane {} of {} is {:.0} m long; use a longer network or a shorter simulation.duration_s",
                Num((hi.0 + offset).round()),
                hi.1,
                lane.id,
                lane.net.display(),
                lane.length
            ),
        ));
    }
    Ok(())
}

/// The platoons' road along a route of several edges (`[sumo] route`): where each lane of the
/// route's edges, and of the junctions between them, starts along the platoons' lane, which
/// goes on from lane to lane by the network's connections.
pub struct Road {
    /// Lane id -> the road coordinate (m) of its start.
    pub lanes: Vec<(String, f64)>,
    /// From the start of the route's first edge to the end of the platoons' lane on its last.
    pub length: f64,
}

fn route_road(
    config_file: &Path,
    s: &platoon_config::Sumo,
    doc: &roxmltree::Document,
    net: &Path,
    platoon_lanes: &[u32],
) -> Result<Option<Road>> {
    if s.route.len() < 2 {
        return Ok(None);
    }
    let err = |message: String| config_error(config_file, "sumo.route", message);
    let lane_length = |id: &str| -> Option<f64> {
        doc.descendants()
            .find(|n| n.has_tag_name("lane") && n.attribute("id") == Some(id))
            .and_then(|n| n.attribute("length")?.parse().ok())
    };
    let edge_lanes = |edge: &str| -> Vec<String> {
        doc.descendants()
            .filter(|n| n.has_tag_name("edge") && n.attribute("id") == Some(edge))
            .flat_map(|n| n.children().filter(|c| c.has_tag_name("lane")))
            .filter_map(|l| l.attribute("id").map(String::from))
            .collect()
    };
    let mut road: Option<Road> = None;
    for &lane0 in platoon_lanes {
        let mut lanes = Vec::new();
        let (mut lane, mut start) = (lane0.to_string(), 0.0);
        for (i, edge) in s.route.iter().enumerate() {
            let ids = edge_lanes(edge);
            if ids.is_empty() {
                return Err(err(format!("{} has no edge {edge:?}", net.display())));
            }
            for id in &ids {
                lanes.push((id.clone(), start));
            }
            let here = format!("{edge}_{lane}");
            let length = lane_length(&here)
                .ok_or_else(|| err(format!("{} has no lane {here}", net.display())))?;
            let Some(next) = s.route.get(i + 1) else {
                start += length;
                break;
            };
            let connection = doc.descendants().find(|n| {
                n.has_tag_name("connection")
                    && n.attribute("from") == Some(edge.as_str())
                    && n.attribute("to") == Some(next.as_str())
                    && n.attribute("fromLane") == Some(lane.as_str())
            });
            let Some(c) = connection else {
                return Err(err(format!(
                    "lane {here} of {} does not lead on to edge {next:?}: the platoon keeps its lane",
                    net.display()
                )));
            };
            start += length;
            if let Some(via) = c.attribute("via") {
                let l = lane_length(via)
                    .ok_or_else(|| err(format!("{} has no lane {via}", net.display())))?;
                // Every junction lane between the two edges ends where the next edge starts.
                for other in doc.descendants().filter(|n| {
                    n.has_tag_name("connection")
                        && n.attribute("from") == Some(edge.as_str())
                        && n.attribute("to") == Some(next.as_str())
                }) {
                    if let Some(v) = other.attribute("via") {
                        let lv = lane_length(v).unwrap_or(l);
                        lanes.push((v.to_string(), start + l - lv));
                    }
                }
                start += l;
            }
            lane = c.attribute("toLane").unwrap_or("0").to_string();
        }
        // The platoons share the road coordinates of the first one's lane.
        if road.is_none() {
            road = Some(Road {
                lanes,
                length: start,
            });
        } else if let Some(r) = &mut road {
            r.length = r.length.min(start);
        }
    }
    Ok(road)
}

/// fcd.xml's period: `[sumo] fcd_period_s`, else every step (SUMO's writer) or every step the
/// trajectories hold (the recorded one, which needs them at the period's steps).
fn fcd_period(config_file: &Path, config: &Config, scenario: &Scenario) -> Result<f64> {
    let (s, o) = (&config.sumo, &config.output);
    let dt = scenario.dt();
    if s.fcd == platoon_config::FcdWriter::Sumo {
        return Ok(s.fcd_period_s.unwrap_or(dt));
    }
    let period = s.fcd_period_s.unwrap_or(o.decimate as f64 * dt);
    if period == 0.0 {
        return Ok(0.0);
    }
    let hint = "or set sumo.fcd = \"sumo\" (SUMO writes it during the run) or sumo.fcd_period_s = 0 (none)";
    if !o.writes(platoon_config::OutputFile::Trajectories) {
        return Err(config_error(
            config_file,
            "sumo.fcd",
            format!("fcd.xml is written from the trajectories, which output.files leaves out: add \"trajectories\", {hint}"),
        ));
    }
    let steps = (period / dt).round() as u64;
    if !steps.is_multiple_of(o.decimate) {
        return Err(config_error(
            config_file,
            "sumo.fcd_period_s",
            format!(
                "{period} s ({steps} steps) is not a whole number of the trajectories' output.decimate = {} steps, from which fcd.xml is written: make it one, {hint}",
                o.decimate
            ),
        ));
    }
    Ok(period)
}

impl SumoPlan<'_> {
    /// Sets up the bridge's Python if needed, writes plant.json into the run directory and
    /// returns the bridge to start.
    pub fn launch(&self, dir: &RunDir) -> Result<SumoPlant> {
        let s = &self.config.sumo;
        let path = |name: &str| -> Result<String> {
            Ok(std::path::absolute(dir.path(name))?.display().to_string())
        };
        let near_platoon = !s.flows.is_empty()
            || s.background_vehicles > 0
                && (s.background_on_platoon_lanes || s.background_lane_changes.is_some());
        let mut plant = PlantSpec::new(self.scenario);
        // Traffic that can reach the platoon: the radars read SUMO's road whether or not a
        // controller uses them, so the outputs say what they saw as the native plant's do.
        if near_platoon {
            plant
                .radar_range_m
                .get_or_insert(self.scenario.control.fallback.radar.range_m);
        }
        let spec = Spec {
            plant,
            sumo: SumoSpec {
                net: self.net.display().to_string(),
                edge: &s.edge,
                offset_m: self.offset,
                vehicle_length_m: self.length,
                collision_action: s.collision_action,
                states: s.states,
                tolerance_m: s.tolerance_m,
                fcd_period_s: match s.fcd {
                    platoon_config::FcdWriter::Sumo => self.fcd_period_s,
                    platoon_config::FcdWriter::Recorded => 0.0,
                },
                recorded_fcd_period_s: match s.fcd {
                    platoon_config::FcdWriter::Sumo => 0.0,
                    platoon_config::FcdWriter::Recorded => self.fcd_period_s,
                },
                background_vehicles: s.background_vehicles,
                background_seed: s.background_seed,
                background_lanes: self.free_lanes.clone(),
                background_lane_changes: s.background_lane_changes.as_ref(),
                background_on_platoon_lanes: s.background_on_platoon_lanes,
                background_truck_share: s.background_truck_share,
                lanechanges: match s.background_lane_changes {
                    Some(_) if s.background_vehicles > 0 => Some(path("lanechanges.xml")?),
                    _ if !s.flows.is_empty() => Some(path("lanechanges.xml")?),
                    _ => None,
                },
                side_lanes: self.side_lanes.clone(),
                beside: (1..self.scenario.vehicles_per_platoon())
                    .filter(|&i| self.scenario.starts_beside(i))
                    .collect(),
                route: match &self.road {
                    Some(_) => s.route.clone(),
                    None => Vec::new(),
                },
                road: self
                    .road
                    .as_ref()
                    .map(|r| r.lanes.clone())
                    .unwrap_or_default(),
                leader: Some(&self.config.leader.drive).filter(|d| !d.is_profile()),
                ahead: &s.ahead,
                flows: &s.flows,
                duration_s: match s.flows.is_empty() {
                    true => 0.0,
                    false => self.scenario.steps as f64 * self.scenario.dt(),
                },
                routes: path("routes.rou.xml")?,
                fcd: path("fcd.xml")?,
                report: path("sumo.json")?,
            },
        };
        dir.write(
            "plant.json",
            (serde_json::to_string_pretty(&spec)? + "\n").as_bytes(),
        )?;
        let python = ensure_venv()?;
        Ok(SumoPlant {
            // The plant is `platoon.sumo`; the orchestrator puts the bridge first on the
            // PYTHONPATH of every process that is not a built-in node.
            program: Program::Exec {
                program: python,
                args: vec!["-m".into(), "platoon.sumo".into()],
            },
            env: vec![("PLATOON_PLANT_SPEC".into(), path("plant.json")?)],
            traffic: self.config.sumo.background_vehicles,
            near_platoon,
        })
    }
}

impl SumoPlan<'_> {
    /// After the run: writes fcd.xml from the recorded trajectories into the run's (staging)
    /// directory, if the config asks for it (`[sumo] fcd = "recorded"`, a period > 0).
    pub fn write_recorded_fcd(&self, dir: &RunDir) -> Result<Option<FcdWritten>> {
        if self.config.sumo.fcd != platoon_config::FcdWriter::Recorded || self.fcd_period_s == 0.0 {
            return Ok(None);
        }
        let run = dir.path("plant.json");
        let run = run.parent().unwrap_or(Path::new("."));
        write_fcd(run, &FcdOptions::default()).map(Some)
    }
}

/// What `write_fcd` is asked for: all defaults convert a run directory as its run would have.
#[derive(Debug, Clone, Default)]
pub struct FcdOptions {
    /// The period (s), a whole number of the steps the trajectories hold (`output.decimate` in
    /// the run's config.toml); absent: the period of the run's own fcd.xml (plant.json's
    /// `recorded_fcd_period_s`, or `fcd_period_s` when SUMO wrote it), else (0: it wrote none)
    /// every step the trajectories hold.
    pub period_s: Option<f64>,
    /// The network; absent: the one the run drove on (plant.json's `sumo.net`).
    pub net: Option<PathBuf>,
    /// Where to write; absent: `fcd.xml` in the run directory.
    pub out: Option<PathBuf>,
}

/// What `write_fcd` wrote.
#[derive(Debug, Clone)]
pub struct FcdWritten {
    /// The file.
    pub path: PathBuf,
    /// The period written (s).
    pub period_s: f64,
    /// Its `<timestep>`s.
    pub timesteps: u64,
    /// Its `<vehicle>` lines, over all timesteps.
    pub vehicles: u64,
}

/// The parts of a run's plant.json that place its vehicles.
#[derive(serde::Deserialize)]
struct RunPlant {
    dt: f64,
    vehicles_per_platoon: usize,
    lanes: Vec<u32>,
    sumo: RunSumo,
}

#[derive(serde::Deserialize)]
struct RunSumo {
    net: PathBuf,
    edge: String,
    offset_m: f64,
    vehicle_length_m: f64,
    /// Absent in run directories from before platoon wrote fcd.xml itself.
    #[serde(default)]
    recorded_fcd_period_s: f64,
    /// SUMO's FCD writer's period (0: it wrote none).
    #[serde(default)]
    fcd_period_s: f64,
    /// The lane beside each platoon's (empty: nobody changed lanes).
    #[serde(default)]
    side_lanes: Vec<u32>,
}

/// The run's `output.decimate` (every how many steps the trajectories hold a row), from the
/// config.toml its run directory holds; 1 when it has none.
fn run_decimate(run: &Path) -> Result<u64> {
    let path = run.join("config.toml");
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(1),
        Err(e) => return Err(OtherError::context(format!("reading {}", path.display()), e).into()),
    };
    let value: toml::Value =
        toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    match value.get("output").and_then(|o| o.get("decimate")) {
        None => Ok(1),
        Some(d) => match d.as_integer().and_then(|d| u64::try_from(d).ok()) {
            Some(d) if d >= 1 => Ok(d),
            _ => bail!(
                "{}: output.decimate = {d} is not a step count",
                path.display()
            ),
        },
    }
}

/// Writes SUMO's FCD output for sumo-gui (`tools/fcdReplay.py`) from a SUMO run directory's
/// recorded trajectories (trajectories.csv or .parquet) and its plant.json (the network, the
/// edge and lanes, the shift onto the road), atomically (a `.partial` file renamed). The
/// platoons' vehicles only: background traffic is not in the trajectories.
pub fn write_fcd(run: &Path, opts: &FcdOptions) -> Result<FcdWritten> {
    let spec_path = run.join("plant.json");
    let text = std::fs::read_to_string(&spec_path).with_context(|| {
        format!(
            "reading {} (a SUMO run directory has one)",
            spec_path.display()
        )
    })?;
    let spec: RunPlant = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a SUMO plant spec", spec_path.display()))?;
    let net_path = opts.net.clone().unwrap_or(spec.sumo.net.clone());
    let net_text = std::fs::read_to_string(&net_path).with_context(|| {
        format!(
            "reading the network {} ({}sumo.net of {})",
            net_path.display(),
            if opts.net.is_some() {
                "given instead of "
            } else {
                ""
            },
            spec_path.display()
        )
    })?;
    let net = platoon_output::fcd::Network::parse(&net_text, &net_path.display().to_string())?;
    let table = ["trajectories.parquet", "trajectories.csv"]
        .iter()
        .map(|f| run.join(f))
        .find(|p| p.exists())
        .ok_or_else(|| {
            failure!(
                "{} has no trajectories.csv or trajectories.parquet to write fcd.xml from (`[output] files` must include trajectories)",
                run.display()
            )
        })?;
    let decimate = run_decimate(run)?;
    let held = decimate as f64 * spec.dt;
    let (period_s, key) = match opts.period_s {
        Some(p) => (p, "--period"),
        None if spec.sumo.recorded_fcd_period_s > 0.0 => (
            spec.sumo.recorded_fcd_period_s,
            "the run's sumo.fcd_period_s",
        ),
        None => (spec.sumo.fcd_period_s, "the run's sumo.fcd_period_s"),
    };
    if !(period_s.is_finite() && period_s >= 0.0) {
        bail!("{key}: the FCD period must be a number of seconds >= 0, not {period_s}");
    }
    // 0: every step the trajectories hold.
    let period_s = if period_s == 0.0 { held } else { period_s };
    let period_steps = ((period_s / spec.dt).round() as u64).max(1);
    if ((period_steps as f64) * spec.dt - period_s).abs() > 1e-9 * period_s.max(1.0)
        || !period_steps.is_multiple_of(decimate)
    {
        bail!(
            "{key} = {period_s} s is not a whole multiple of the {held} s between the trajectories' rows (steps of {} s, output.decimate = {decimate} in {}): give --period as one",
            spec.dt,
            run.join("config.toml").display()
        );
    }
    let layout = platoon_output::fcd::Layout {
        edge: spec.sumo.edge,
        lanes: spec.lanes,
        side_lanes: spec.sumo.side_lanes,
        vehicles_per_platoon: spec.vehicles_per_platoon,
        offset_m: spec.sumo.offset_m,
        vehicle_length_m: spec.sumo.vehicle_length_m,
        dt: spec.dt,
        vtype: "platoon".into(),
    };
    let out = opts.out.clone().unwrap_or_else(|| run.join("fcd.xml"));
    let mut partial = out.clone().into_os_string();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    let file = std::fs::File::create(&partial)
        .with_context(|| format!("creating {}", partial.display()))?;
    let comment = format!(
        "written by platoon {} from {} (the states the plant reported) on {}; the platoons' vehicles only",
        env!("CARGO_PKG_VERSION"),
        table.file_name().unwrap_or_default().to_string_lossy(),
        net_path.display()
    );
    let written = (|| {
        let mut w = platoon_output::fcd::FcdWriter::new(
            &net,
            layout,
            period_steps,
            std::io::BufWriter::with_capacity(1 << 20, file),
            &comment,
        )?;
        let mut rows = 0u64;
        platoon_output::tables::read_rows(&table, |r: platoon_sim::StepRow| {
            rows += 1;
            w.row(&r)
        })?;
        let (out, count) = w.finish()?;
        out.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        if rows == 0 {
            bail!(
                "{} is empty: the run recorded no step to write fcd.xml from",
                table.display()
            );
        }
        if count.timesteps == 0 {
            bail!(
                "{} has no step that is a multiple of the FCD period ({period_steps} steps)",
                table.display()
            );
        }
        Ok::<_, SumoError>(count)
    })()
    .with_context(|| format!("writing {}", out.display()));
    let count = match written {
        Ok(count) => count,
        Err(e) => {
            let _ = std::fs::remove_file(&partial);
            return Err(e.into());
        }
    };
    std::fs::rename(&partial, &out)
        .with_context(|| format!("renaming {} to {}", partial.display(), out.display()))?;
    Ok(FcdWritten {
        path: out,
        period_s,
        timesteps: count.timesteps,
        vehicles: count.vehicles,
    })
}

/// The bridge's sumo.json (SUMO version, per-step costs, collisions), if it wrote one.
pub fn report(dir: &RunDir) -> Result<Option<serde_json::Value>> {
    let path = dir.path("sumo.json");
    if !path.exists() {
        return Ok(None);
    }
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    Ok(Some(
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?,
    ))
}
