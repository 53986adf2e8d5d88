//! Our implementations of the field's CACC laws (`platoon_control::laws`) equal Plexe's, the
//! `CC` car-following model inside SUMO 1.28.
//!
//! Each test runs `bridge/tools/plexe_reference.py` (libsumo) for one controller: a leader on the
//! paper's velocity profile and 4 followers, 10 m front to front at 15 m/s, first-order-lag
//! engine with tau = 0.5 s, dt = 0.01 s, ballistic update, 55 s, SUMO's default controller
//! parameters. It then drives the same followers with our laws and a loop that reproduces
//! SUMO's discretisation (below), taking the leader's trajectory from SUMO's CSV (SUMO drives
//! it with setSpeed), and checks every follower's gap against SUMO's.
//!
//! Then it runs the same platoon through `platoon` itself, from a config (`[control] law`,
//! `[plant] discretisation = "plexe"`, periodic beacons every step on an ideal channel, the
//! leader on the paper's profile in our plant) with the in-process simulator, and checks every
//! follower's gap against SUMO's again: the evidence that our laws, on our controller seam and
//! plant, are the field's laws.
//!
//! The Python is `$PLATOON_PYTHON`, else `bridge/.venv/bin/python` of the workspace; a missing
//! environment fails the test (run `bridge/setup-venv.sh`).
//!
//! SUMO's step for a CC vehicle (what [`Car::step`] reproduces), with the command `u` computed
//! from every vehicle's state before any of them moves:
//!
//! ```text
//! v_pos = min(max(0, v + u dt), v + accel_max dt)     the speed the model asks for
//! u_c   = (v_pos - v) / dt                            the command SUMO records (and sends)
//! a_e   = clamp(alpha u_c + (1 - alpha) a, -decel_max, accel_max),  alpha = dt / (tau + dt)
//! v'    = max(0, v + a_e dt)
//! a'    = (v' - v) / dt
//! p'    = p + (v + a' dt / 2) dt                      (ballistic)
//! ```
use std::path::{Path, PathBuf};
use std::process::Command;

use platoon_control::laws::{
    consensus, flatbed, path_cacc, plexe_acc, ploeg, ConsensusParams, ConsensusVehicle,
    FlatbedParams, PathCaccParams, PlexeAccParams, PloegInput, PloegParams,
};

/// The scenario's constants (the script's defaults, passed explicitly).
const DT: f64 = 0.01;
const DURATION: f64 = 55.0;
const TAU: f64 = 0.5;
const LENGTH: f64 = 4.0;
/// The followers' cruise-control set speed: above the profile's 25 m/s.
const CC_SPEED: f64 = 30.0;
/// The largest gap deviation accepted, m (the issue's bound).
const TOLERANCE: f64 = 0.05;
/// What SUMO's discretisation reproduced exactly gives through `platoon` itself (config,
/// controller seam, plant), m: rounding only (the largest deviation is about 1.4e-11 m), the
/// bound docs/controllers.md and the README publish. The issue's bound alone would not tell
/// the discretisations apart: our default (`exact`) plant stays centimetres from SUMO here.
const EXACT: f64 = 1e-10;
/// What the law functions in a loop of SUMO's own step give, m: rounding only (0 for all but
/// consensus), the bound docs/controllers.md publishes.
const LOOP_EXACT: f64 = 1e-12;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Law {
    Acc,
    Cacc,
    Ploeg,
    Consensus,
    Flatbed,
}

impl Law {
    fn name(self) -> &'static str {
        match self {
            Law::Acc => "acc",
            Law::Cacc => "cacc",
            Law::Ploeg => "ploeg",
            Law::Consensus => "consensus",
            Law::Flatbed => "flatbed",
        }
    }
}

/// The vehicles' limits: the script's vType accel and decel (m/s^2).
#[derive(Debug, Clone, Copy)]
struct Limits {
    accel: f64,
    decel: f64,
}

const UNLIMITED: Limits = Limits {
    accel: 100.0,
    decel: 100.0,
};
/// SUMO's passenger-car defaults.
const SUMO_PASSENGER: Limits = Limits {
    accel: 2.6,
    decel: 4.5,
};

/// One row of the reference CSV.
#[derive(Debug, Clone, Copy)]
struct Row {
    p: f64,
    v: f64,
    a: f64,
    gap: f64,
}

/// The reference: rows[k][i] is vehicle i at step k.
struct Reference {
    rows: Vec<Vec<Row>>,
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("PLATOON_PYTHON") {
        return PathBuf::from(p);
    }
    let p = workspace_root().join("bridge/.venv/bin/python");
    assert!(
        p.exists(),
        "{} is missing: run bridge/setup-venv.sh (or set PLATOON_PYTHON to a Python with libsumo 1.28)",
        p.display()
    );
    p
}

fn run_sumo(law: Law, limits: Limits) -> Reference {
    let dir = std::env::temp_dir().join(format!(
        "plexe_agreement.{}.{}.{}",
        std::process::id(),
        law.name(),
        limits.accel
    ));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let out = dir.join("reference.csv");
    let script = workspace_root().join("bridge/tools/plexe_reference.py");
    let result = Command::new(python())
        .arg(&script)
        .args(["--law", law.name()])
        .arg("--out")
        .arg(&out)
        .args(["--duration", &DURATION.to_string()])
        .args(["--dt", &DT.to_string()])
        .args(["--tau", &TAU.to_string()])
        .args(["--length", &LENGTH.to_string()])
        .args(["--cc-desired-speed", &CC_SPEED.to_string()])
        .args(["--max-accel", &limits.accel.to_string()])
        .args(["--max-decel", &limits.decel.to_string()])
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", python().display()));
    assert!(
        result.status.success(),
        "{} --law {} failed ({}):\n{}",
        script.display(),
        law.name(),
        result.status,
        String::from_utf8_lossy(&result.stderr)
    );
    let text = std::fs::read_to_string(&out).expect("the reference CSV");
    let _ = std::fs::remove_dir_all(&dir);
    parse(&text)
}

fn parse(text: &str) -> Reference {
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,vehicle,p,v,a,u,gap"), "CSV header");
    let mut rows: Vec<Vec<Row>> = Vec::new();
    let mut last_t = f64::NAN;
    for (n, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 7, "CSV line {}: {line}", n + 2);
        let num = |s: &str| -> f64 {
            s.parse()
                .unwrap_or_else(|_| panic!("CSV line {}: not a number: {s}", n + 2))
        };
        let (t, i) = (num(f[0]), f[1].parse::<usize>().expect("vehicle index"));
        if i == 0 {
            assert!(
                rows.is_empty() || t > last_t,
                "CSV line {}: time goes back",
                n + 2
            );
            rows.push(Vec::new());
            last_t = t;
        }
        let step = rows.last_mut().expect("a leader row first");
        assert_eq!(step.len(), i, "CSV line {}: vehicles out of order", n + 2);
        step.push(Row {
            p: num(f[2]),
            v: num(f[3]),
            a: num(f[4]),
            gap: num(f[6]),
        });
    }
    Reference { rows }
}

/// A follower as SUMO holds it: position, speed, SUMO's acceleration, and the controller
/// acceleration it recorded at its last step.
#[derive(Debug, Clone, Copy)]
struct Car {
    p: f64,
    v: f64,
    a: f64,
    u: f64,
}

impl Car {
    /// SUMO's step of a CC vehicle under the command `u` (module documentation).
    fn step(&mut self, u: f64, limits: Limits) {
        let alpha = DT / (TAU + DT);
        let one_minus_alpha = 1.0 - alpha;
        let v_pos = (self.v + u * DT).max(0.0).min(self.v + limits.accel * DT);
        let u_c = ((v_pos - self.v) / DT).clamp(-1e6, 1e6);
        let a_e = (alpha * u_c + one_minus_alpha * self.a).clamp(-limits.decel, limits.accel);
        let v_next = (self.v + a_e * DT).max(0.0);
        let a_next = (v_next - self.v) / DT;
        self.p += (self.v + 0.5 * (a_next * DT)) * DT;
        self.v = v_next;
        self.a = a_next;
        self.u = u_c;
    }
}

/// Our followers' gaps against SUMO's: the largest |difference| per follower.
fn max_gap_deviation(law: Law, reference: &Reference, limits: Limits) -> Vec<f64> {
    let rows = &reference.rows;
    let n = rows[0].len();
    let steps = (DURATION / DT).round() as usize;
    assert_eq!(rows.len(), steps + 1, "SUMO wrote {} steps", rows.len());
    // Initial state: SUMO's (inserted at rest acceleration, no command yet).
    let mut cars: Vec<Car> = rows[0]
        .iter()
        .map(|r| Car {
            p: r.p,
            v: r.v,
            a: r.a,
            u: 0.0,
        })
        .collect();
    let acc = PlexeAccParams {
        desired_speed_mps: CC_SPEED,
        ..Default::default()
    };
    let path = PathCaccParams::default();
    let ploeg_p = PloegParams::default();
    let cons = ConsensusParams::default();
    cons.check(n).expect("consensus parameters");
    let flat = FlatbedParams::default();
    let mut worst = vec![0.0_f64; n];
    for k in 0..steps {
        // The leader as SUMO moved it (setSpeed). The controller acceleration SUMO recorded
        // for it at its last step is the speed change it was commanded (its cruise control never
        // limits), i.e. its acceleration now.
        let lead = rows[k][0];
        cars[0] = Car {
            p: lead.p,
            v: lead.v,
            a: lead.a,
            u: lead.a,
        };
        // Every command from the states before anyone moves (SUMO plans all, then moves all).
        let before = cars.clone();
        let predicted: Vec<ConsensusVehicle> = before
            .iter()
            .map(|c| ConsensusVehicle {
                position: c.p + c.v * DT,
                speed: c.v,
                length: LENGTH,
            })
            .collect();
        for i in 1..n {
            let (me, pred, leader) = (before[i], before[i - 1], before[0]);
            let gap = pred.p - LENGTH - me.p;
            let u = match law {
                Law::Acc => plexe_acc(&acc, me.v, gap, pred.v),
                Law::Cacc => path_cacc(&path, me.v, gap, pred.v, pred.u, leader.v, leader.u),
                Law::Ploeg => {
                    let x = PloegInput {
                        u_prev: me.u,
                        v: me.v,
                        a: me.a,
                        gap,
                        v_pred: pred.v,
                        u_pred: pred.u,
                    };
                    ploeg(&ploeg_p, DT, &x)
                }
                Law::Consensus => consensus(&cons, i, &predicted),
                Law::Flatbed => flatbed(&flat, me.v, me.a, gap, pred.v, leader.v),
            };
            cars[i].step(u, limits);
        }
        let next = &rows[k + 1];
        for i in 1..n {
            let ahead = if i == 1 { next[0].p } else { cars[i - 1].p };
            let gap = ahead - LENGTH - cars[i].p;
            let d = (gap - next[i].gap).abs();
            assert!(
                d.is_finite(),
                "{}: follower {i} at step {}: gap {gap} vs {}",
                law.name(),
                k + 1,
                next[i].gap
            );
            worst[i] = worst[i].max(d);
        }
    }
    worst
}

/// The same platoon as a `platoon` config: law `law`, the plant discretised as SUMO's CC model,
/// SUMO's initial states.
fn config(law: Law, reference: &Reference) -> String {
    let (name, table) = match law {
        Law::Acc => ("acc", format!("desired_speed_mps = {CC_SPEED}\n")),
        Law::Cacc => ("path_cacc", String::new()),
        Law::Ploeg => ("ploeg", String::new()),
        Law::Consensus => ("consensus", String::new()),
        Law::Flatbed => ("flatbed", String::new()),
    };
    // The platoon's spacing policy is the one the law keeps (SUMO's defaults + the length).
    let (spacing, headway) = match law {
        Law::Acc => (2.0 + LENGTH, 1.5),
        Law::Cacc => (5.0 + LENGTH, 0.0),
        Law::Ploeg => (2.0 + LENGTH, 0.5),
        Law::Consensus => (15.0 + LENGTH, 0.8),
        Law::Flatbed => (5.0 + LENGTH, 0.0),
    };
    let policy = if headway > 0.0 {
        format!("spacing_policy = \"time_headway\"\ntime_headway_s = {headway}\n")
    } else {
        String::new()
    };
    let initial: Vec<String> = reference.rows[0]
        .iter()
        .map(|r| format!("[{:?}, {:?}, {:?}]", r.p, r.v, r.a))
        .collect();
    format!(
        "name = \"plexe-{name}\"\n\
         [simulation]\nduration_s = {DURATION}\ndt_s = {DT}\n\
         [platoon]\nfollowers = {}\nspacing_m = {spacing}\n{policy}vehicle_length_m = {LENGTH}\n\
         initial_states = [{}]\n\
         [leader]\nprofile = {{ kind = \"paper\" }}\n\
         [topology]\npreset = \"plf\"\n\
         [plant]\ntau_nominal_s = {TAU}\ntau = {{ kind = \"constant\", value_s = {TAU} }}\n\
         discretisation = \"plexe\"\n\
         [control]\nlaw = \"{name}\"\n{table}\
         [trigger]\nrule = \"periodic\"\nperiod_s = {DT}\nh_s = {DT}\n",
        reference.rows[0].len() - 1,
        initial.join(", "),
    )
}

/// Our simulator's followers' gaps against SUMO's: the largest |difference| per follower.
fn platoon_gap_deviation(law: Law, reference: &Reference) -> Vec<f64> {
    let text = config(law, reference);
    let (_, scenario) = platoon_config::parse(&text, Path::new("plexe.toml"))
        .unwrap_or_else(|e| panic!("{}: the config is refused: {e}\n{text}", law.name()));
    let mut sim = platoon_sim::Simulation::new(scenario).expect("the scenario runs");
    let mut worst = vec![0.0_f64; reference.rows[0].len()];
    for (k, sumo) in reference.rows.iter().enumerate() {
        let rows = sim.step();
        assert_eq!(rows.len(), sumo.len());
        for i in 1..sumo.len() {
            let gap = rows[i - 1].p - LENGTH - rows[i].p;
            let d = (gap - sumo[i].gap).abs();
            assert!(
                d.is_finite(),
                "{}: follower {i} at step {k}: gap {gap} vs {}",
                law.name(),
                sumo[i].gap
            );
            worst[i] = worst[i].max(d);
        }
    }
    worst
}

fn check(law: Law, limits: Limits) {
    let reference = run_sumo(law, limits);
    if limits.accel == UNLIMITED.accel {
        // Our plant has no acceleration limits: only the unlimited runs are its to match.
        let worst = platoon_gap_deviation(law, &reference);
        let max = worst.iter().cloned().fold(0.0, f64::max);
        println!(
            "{}: platoon (config, controller seam, plant) against SUMO: max gap deviation \
             {max:.3e} m (followers 1..: {:?})",
            law.name(),
            &worst[1..]
        );
        assert!(
            max <= TOLERANCE,
            "{}: platoon's gaps differ from SUMO's by up to {max} m (> {TOLERANCE} m); per \
             follower {:?}",
            law.name(),
            &worst[1..]
        );
        assert!(
            max <= EXACT,
            "{}: platoon's gaps differ from SUMO's by up to {max} m: within the issue's \
             {TOLERANCE} m but more than rounding ({EXACT} m): the law, the data timing or the \
             plexe discretisation drifted from SUMO's",
            law.name()
        );
    }
    let worst = max_gap_deviation(law, &reference, limits);
    let max = worst.iter().cloned().fold(0.0, f64::max);
    println!(
        "{} (accel {} / decel {} m/s^2): max gap deviation from SUMO {max:.3e} m (followers 1..: {:?})",
        law.name(),
        limits.accel,
        limits.decel,
        &worst[1..]
    );
    assert!(
        max <= TOLERANCE,
        "{}: our gaps differ from SUMO's by up to {max} m (> {TOLERANCE} m); per follower {:?}",
        law.name(),
        &worst[1..]
    );
    assert!(
        max <= LOOP_EXACT,
        "{}: our gaps differ from SUMO's by up to {max} m: within the issue's {TOLERANCE} m, but \
         more than rounding ({LOOP_EXACT} m), so the loop no longer reproduces SUMO's step",
        law.name()
    );
}

#[test]
fn acc_equals_plexe() {
    check(Law::Acc, UNLIMITED);
}

#[test]
fn path_cacc_equals_plexe() {
    check(Law::Cacc, UNLIMITED);
}

#[test]
fn ploeg_equals_plexe() {
    check(Law::Ploeg, UNLIMITED);
}

#[test]
fn consensus_equals_plexe() {
    check(Law::Consensus, UNLIMITED);
}

#[test]
fn flatbed_equals_plexe() {
    check(Law::Flatbed, UNLIMITED);
}

/// With SUMO's passenger-car limits (2.6 / 4.5 m/s^2) the flatbed (commands up to 12 m/s^2)
/// and consensus (down to -12 m/s^2) controllers saturate; the limits of `Car::step` are
/// SUMO's.
#[test]
fn saturated_laws_equal_plexe() {
    check(Law::Flatbed, SUMO_PASSENGER);
    check(Law::Consensus, SUMO_PASSENGER);
}
