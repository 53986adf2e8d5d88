//! SUMO's FCD output (`fcd.xml`, which sumo-gui replays with SUMO's `tools/fcdReplay.py`) from a
//! run's recorded states instead of from SUMO during the run: SUMO writing it costs the plant's
//! step a tail (BENCHMARKS.md, "FCD"), converting the trajectories afterwards costs the run
//! nothing. Pure: the network is parsed from its text and the XML goes to any [`Write`]; the
//! caller reads and writes the files (`platoon_app::sumo::write_fcd`).
//!
//! Each vehicle is placed as SUMO places it: its lane position scaled onto the lane's shape
//! (the shape's length over the lane's `length`), x and y interpolated along the shape's
//! polyline, the angle (navigational degrees: 0 north, clockwise) from its back to its front,
//! the slope of the shape's segment; the acceleration is the one held over the step that
//! ended at the timestep (SUMO's, under the ballistic update) when the trajectories hold the
//! step before, else the vehicle's acceleration state at the timestep. Vehicles are sorted by
//! id within a timestep, and values written to SUMO's default precision, as SUMO writes them: 2
//! decimals, 3 when the step is not a whole number of 10 ms (SUMO's MSFrame raises its default
//! `--precision` then, and the bridge passes none).
use crate::error::{OutputError, Result};

/// Returns an [`OutputError::Fcd`] with the formatted message.
macro_rules! bail {
    ($($t:tt)*) => {
        return Err(OutputError::Fcd(format!($($t)*)))
    };
}
use platoon_sim::StepRow;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::io::Write;

/// The lanes of a SUMO network (`.net.xml`), by id.
#[derive(Debug, Clone)]
pub struct Network {
    name: String,
    lanes: HashMap<String, Lane>,
}

/// One lane: its length (lane positions run over it) and its shape.
#[derive(Debug, Clone)]
pub struct Lane {
    length: f64,
    /// The shape's points (x, y, z; z = 0 when the network has none).
    points: Vec<[f64; 3]>,
    /// The shape's length up to each point.
    at: Vec<f64>,
}

/// Where a vehicle is drawn: its front's x and y, its angle and the slope under it (degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    pub x: f64,
    pub y: f64,
    pub angle: f64,
    pub slope: f64,
}

impl Network {
    /// Parses the lanes of a network's XML; `name` (its file) names it in errors.
    pub fn parse(text: &str, name: &str) -> Result<Network> {
        let doc = match roxmltree::Document::parse(text) {
            Ok(doc) => doc,
            Err(e) => bail!("{name} is not a SUMO network: {e}"),
        };
        let mut lanes = HashMap::new();
        for n in doc.descendants().filter(|n| n.has_tag_name("lane")) {
            let Some(id) = n.attribute("id") else {
                bail!("{name}: a <lane> without an id");
            };
            let number = |key: &str| -> Result<f64> {
                match n.attribute(key).map(str::parse::<f64>) {
                    Some(Ok(x)) if x.is_finite() => Ok(x),
                    _ => bail!("{name}: lane {id} has no valid {key}"),
                }
            };
            let length = number("length")?;
            if length <= 0.0 {
                bail!("{name}: lane {id} has length {length}, not a positive one");
            }
            let shape = n.attribute("shape").unwrap_or("");
            let points = parse_shape(shape).filter(|p| p.len() >= 2).ok_or_else(|| {
                OutputError::Fcd(format!("{name}: lane {id} has no valid shape (`{shape}`)"))
            })?;
            lanes.insert(id.to_string(), Lane::new(length, points));
        }
        if lanes.is_empty() {
            bail!("{name} has no <lane>: not a SUMO network");
        }
        Ok(Network {
            name: name.to_string(),
            lanes,
        })
    }

    /// The lane `id`, or an error naming the network and its lane ids.
    pub fn lane(&self, id: &str) -> Result<&Lane> {
        match self.lanes.get(id) {
            Some(lane) => Ok(lane),
            None => {
                let mut ids: Vec<&str> = self
                    .lanes
                    .keys()
                    .map(String::as_str)
                    .filter(|l| !l.starts_with(':'))
                    .collect();
                ids.sort_unstable();
                bail!(
                    "{} has no lane {id} (its lanes are {})",
                    self.name,
                    ids.join(", ")
                )
            }
        }
    }
}

/// `x,y[,z] x,y[,z] ...`.
fn parse_shape(shape: &str) -> Option<Vec<[f64; 3]>> {
    shape
        .split_whitespace()
        .map(|p| {
            let mut c = p.split(',').map(str::parse::<f64>);
            let x = c.next()?.ok()?;
            let y = c.next()?.ok()?;
            let z = c.next().transpose().ok()?.unwrap_or(0.0);
            (c.next().is_none() && x.is_finite() && y.is_finite() && z.is_finite())
                .then_some([x, y, z])
        })
        .collect()
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
}

impl Lane {
    /// A lane of `length` (> 0) along the polyline `points` (at least two): private, so that
    /// only [`Network::parse`], which checks both, makes one.
    fn new(length: f64, points: Vec<[f64; 3]>) -> Lane {
        debug_assert!(points.len() >= 2 && length > 0.0);
        let mut at = Vec::with_capacity(points.len());
        let mut s = 0.0;
        at.push(0.0);
        for w in points.windows(2) {
            s += distance(w[0], w[1]);
            at.push(s);
        }
        Lane { length, points, at }
    }

    /// The lane's length (m).
    pub fn length(&self) -> f64 {
        self.length
    }

    fn shape_length(&self) -> f64 {
        *self.at.last().unwrap()
    }

    /// The segment holding shape offset `s` (the first for s <= 0, the last past the end) and
    /// the point there, clamped to the shape (as SUMO's `positionAtOffset`).
    fn at_offset(&self, s: f64) -> (usize, [f64; 3]) {
        let last = self.points.len() - 2;
        let i = self.at[1..].partition_point(|&end| end <= s).min(last);
        let (a, b) = (self.points[i], self.points[i + 1]);
        let seg = self.at[i + 1] - self.at[i];
        let f = if seg > 0.0 {
            ((s - self.at[i]) / seg).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (i, std::array::from_fn(|c| a[c] + f * (b[c] - a[c])))
    }

    /// A vehicle of `length` whose front is at lane position `pos`.
    pub fn place(&self, pos: f64, length: f64) -> Placement {
        // SUMO's interpolateLanePosToGeometryPos: lane positions scaled onto the shape.
        let factor = self.shape_length().max(1e-6) / self.length;
        let (i, front) = self.at_offset(pos * factor);
        let (_, back) = self.at_offset((pos - length).max(0.0) * factor);
        let (a, b) = (self.points[i], self.points[i + 1]);
        // MSVehicle::computeAngle: from the back to the front, else the segment's direction.
        let (dx, dy) = if front[..2] != back[..2] {
            (front[0] - back[0], front[1] - back[1])
        } else {
            (b[0] - a[0], b[1] - a[1])
        };
        let flat = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        Placement {
            x: front[0],
            y: front[1],
            angle: (90.0 - dy.atan2(dx).to_degrees()).rem_euclid(360.0),
            slope: (b[2] - a[2]).atan2(flat).to_degrees(),
        }
    }
}

/// SUMO's name of vehicle `vehicle` of platoon `platoon` (the bridge's `vehicle_id`): leader,
/// follower1, ...; in a fleet of several platoons p3.leader, p3.follower1, ...
pub fn vehicle_id(platoon: usize, vehicle: usize, platoons: usize) -> String {
    let name = match vehicle {
        0 => "leader".to_string(),
        i => format!("follower{i}"),
    };
    if platoons == 1 {
        name
    } else {
        format!("p{platoon}.{name}")
    }
}

/// Where a run's platoons drove (from its plant.json): the edge, each platoon's lane index,
/// the vehicles per platoon, the shift from the platoon's coordinates to lane positions.
#[derive(Debug, Clone)]
pub struct Layout {
    pub edge: String,
    /// Platoon j's lane index.
    pub lanes: Vec<u32>,
    /// The lane beside platoon j's (empty: nobody changes lanes): a vehicle is on it from the
    /// step after its mode was `left` or `beside` (the lane change takes that step), or from
    /// its first row if that is `beside`.
    pub side_lanes: Vec<u32>,
    pub vehicles_per_platoon: usize,
    /// Lane position = p + offset_m.
    pub offset_m: f64,
    pub vehicle_length_m: f64,
    /// The run's step (s): the times are written with as many decimals as it needs (2 at
    /// least, as SUMO).
    pub dt: f64,
    /// The vehicle type's id in SUMO's routes.
    pub vtype: String,
}

/// Streams trajectory rows (step by step) into fcd.xml: one `<timestep>` per step that is a
/// multiple of `period_steps`, one `<vehicle>` per row of it.
pub struct FcdWriter<'a, W: Write> {
    out: W,
    layout: Layout,
    /// Per platoon: the lane's id and the lane.
    lanes: Vec<(String, &'a Lane)>,
    /// Per platoon: the lane beside (empty: nobody changes lanes).
    side_lanes: Vec<(String, &'a Lane)>,
    /// Each vehicle's lane for its next row: beside the platoon's (its last row's mode was
    /// `left` or `beside`); `None` before its first row.
    beside: Vec<Option<bool>>,
    ids: Vec<Vec<String>>,
    /// Each vehicle's (platoon * N + vehicle) line of the open timestep (a repeated row
    /// replaces it), and the order the lines are written in (by id).
    lines: Vec<String>,
    order: Vec<usize>,
    /// Each vehicle's last row: (step, acceleration).
    last: Vec<Option<(u64, f64)>>,
    period_steps: u64,
    time_decimals: usize,
    /// The values' decimals ([`precision`]).
    precision: usize,
    current: Option<u64>,
    timesteps: u64,
    vehicles: u64,
}

/// What an [`FcdWriter`] wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FcdCount {
    pub timesteps: u64,
    /// The `<vehicle>` lines: distinct vehicles per timestep, over all timesteps.
    pub vehicles: u64,
}

/// SUMO's default output precision for a step of `dt` s: 2 decimals, 3 when the step is not a
/// whole number of 10 ms (MSFrame::checkOptions: `step-length % 10 ms != 0`).
pub fn precision(dt: f64) -> usize {
    let scaled = dt * 100.0;
    if (scaled - scaled.round()).abs() < 1e-6 * scaled.max(1.0) {
        2
    } else {
        3
    }
}

fn decimals(dt: f64) -> usize {
    (2..=9)
        .find(|&d| {
            let scaled = dt * 10f64.powi(d as i32);
            (scaled - scaled.round()).abs() < 1e-6 * scaled.max(1.0)
        })
        .unwrap_or(9)
}

impl<'a, W: Write> FcdWriter<'a, W> {
    /// Writes the header; errors if a platoon's lane is not in `net`.
    pub fn new(
        net: &'a Network,
        layout: Layout,
        period_steps: u64,
        mut out: W,
        comment: &str,
    ) -> Result<Self> {
        let lanes_of = |indices: &[u32]| {
            indices
                .iter()
                .map(|l| {
                    let id = format!("{}_{l}", layout.edge);
                    let lane = net.lane(&id)?;
                    Ok((escape(&id), lane))
                })
                .collect::<Result<Vec<_>>>()
        };
        let lanes = lanes_of(&layout.lanes)?;
        let side_lanes = lanes_of(&layout.side_lanes)?;
        let platoons = layout.lanes.len();
        let ids: Vec<Vec<String>> = (0..platoons)
            .map(|j| {
                (0..layout.vehicles_per_platoon)
                    .map(|i| escape(&vehicle_id(j, i, platoons)))
                    .collect()
            })
            .collect();
        let flat: Vec<&String> = ids.iter().flatten().collect();
        let mut order: Vec<usize> = (0..flat.len()).collect();
        order.sort_by_key(|&v| flat[v]);
        writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
        writeln!(out)?;
        writeln!(out, "<!-- {} -->", comment.replace("--", "- -"))?;
        writeln!(out)?;
        writeln!(
            out,
            r#"<fcd-export xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://sumo.dlr.de/xsd/fcd_file.xsd">"#
        )?;
        let time_decimals = decimals(layout.dt);
        let precision = precision(layout.dt);
        Ok(Self {
            out,
            layout,
            lanes,
            side_lanes,
            beside: vec![None; order.len()],
            lines: vec![String::new(); order.len()],
            last: vec![None; order.len()],
            order,
            ids,
            period_steps: period_steps.max(1),
            time_decimals,
            precision,
            current: None,
            timesteps: 0,
            vehicles: 0,
        })
    }

    /// One trajectory row (rows come step by step); rows of other steps than the period's are
    /// skipped.
    pub fn row(&mut self, r: &StepRow) -> Result<()> {
        let (j, i) = (usize::from(r.platoon), usize::from(r.vehicle));
        if self.ids.get(j).and_then(|p| p.get(i)).is_none() {
            bail!(
                "a row of platoon {j}, vehicle {i} at step {}, but the run has {} platoon(s) of {} vehicles",
                r.step,
                self.lanes.len(),
                self.layout.vehicles_per_platoon
            );
        }
        let v = j * self.layout.vehicles_per_platoon + i;
        let held = match self.last[v] {
            Some((k, a)) if k + 1 == r.step => a,
            _ => r.a,
        };
        self.last[v] = Some((r.step, r.a));
        // Where it is at this row: its lane as the plant had it, or in rows without it
        // (written before the lane column), where its last row's mode sent it (a lane change
        // takes the step), at its first row where its mode says.
        let beside = r
            .beside
            .or(self.beside[v])
            .unwrap_or(r.mode == platoon_control::Role::Beside);
        self.beside[v] = Some(r.mode.is_beside_the_lane());
        if !r.step.is_multiple_of(self.period_steps) {
            return Ok(());
        }
        if self.current != Some(r.step) {
            if let Some(prev) = self.current {
                if r.step < prev {
                    bail!("rows out of order: step {} after step {prev}", r.step);
                }
                self.close_timestep()?;
            }
            writeln!(
                self.out,
                r#"    <timestep time="{:.*}">"#,
                self.time_decimals, r.t
            )?;
            self.current = Some(r.step);
            self.timesteps += 1;
        }
        let (lane_id, lane) = match self.side_lanes.get(j) {
            Some(side) if beside => side,
            _ => &self.lanes[j],
        };
        let id = &self.ids[j][i];
        let pos = r.p + self.layout.offset_m;
        let at = lane.place(pos, self.layout.vehicle_length_m);
        let d = self.precision;
        let line = &mut self.lines[v];
        line.clear();
        // `+ 0.0` turns -0.0 into 0.0, which SUMO never writes.
        write!(
            line,
            r#"        <vehicle id="{id}" x="{:.d$}" y="{:.d$}" angle="{:.d$}" type="{}" speed="{:.d$}" pos="{:.d$}" lane="{lane_id}" slope="{:.d$}" acceleration="{:.d$}"/>"#,
            at.x + 0.0,
            at.y + 0.0,
            at.angle + 0.0,
            self.layout.vtype,
            r.v + 0.0,
            pos + 0.0,
            at.slope + 0.0,
            held + 0.0,
        )
        .expect("formatting into a String does not fail");
        Ok(())
    }

    /// Writes the open timestep's lines in id order.
    fn close_timestep(&mut self) -> Result<()> {
        for &v in &self.order {
            let line = &mut self.lines[v];
            if !line.is_empty() {
                writeln!(self.out, "{line}")?;
                line.clear();
                self.vehicles += 1;
            }
        }
        writeln!(self.out, "    </timestep>")?;
        Ok(())
    }

    /// Closes the document; returns the output and what was written.
    pub fn finish(mut self) -> Result<(W, FcdCount)> {
        if self.current.is_some() {
            self.close_timestep()?;
        }
        writeln!(self.out, "</fcd-export>")?;
        self.out.flush()?;
        Ok((
            self.out,
            FcdCount {
                timesteps: self.timesteps,
                vehicles: self.vehicles,
            },
        ))
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    const NET: &str = r#"<net>
        <edge id="road">
            <lane id="road_0" index="0" length="10.00" shape="0.00,0.00 10.00,0.00"/>
            <lane id="road_1" index="1" length="20.00" shape="0.00,0.00 10.00,0.00 10.00,10.00"/>
            <lane id="road_2" index="2" length="10.00" shape="0.00,0.00,0.00 8.00,0.00,6.00"/>
        </edge>
    </net>"#;

    fn close(a: Placement, b: Placement) -> bool {
        [
            (a.x, b.x),
            (a.y, b.y),
            (a.angle, b.angle),
            (a.slope, b.slope),
        ]
        .iter()
        .all(|(p, q)| (p - q).abs() < 1e-9)
    }

    #[test]
    fn vehicles_are_placed_along_the_lane_shape() {
        let net = Network::parse(NET, "net.xml").unwrap();
        let straight = net.lane("road_0").unwrap();
        let p = straight.place(7.5, 4.0);
        assert!(close(
            p,
            Placement {
                x: 7.5,
                y: 0.0,
                angle: 90.0,
                slope: 0.0
            }
        ));
        // Around the corner: the front on the second segment (north), the back on the first.
        let bent = net.lane("road_1").unwrap();
        let p = bent.place(13.0, 6.0);
        assert!((p.x - 10.0).abs() < 1e-12 && (p.y - 3.0).abs() < 1e-12);
        let expected = 90.0 - (3.0f64).atan2(3.0).to_degrees();
        assert!((p.angle - expected).abs() < 1e-9, "{}", p.angle);
        // Wholly on the second segment: heading north.
        assert!((bent.place(18.0, 4.0).angle - 0.0).abs() < 1e-9);
        // A shape longer than the lane: positions scaled (shape 10 m, lane 10 m, but 3D).
        let ramp = net.lane("road_2").unwrap();
        let p = ramp.place(5.0, 0.0);
        assert!((p.x - 4.0).abs() < 1e-12, "{}", p.x);
        assert!((p.slope - (6.0f64).atan2(8.0).to_degrees()).abs() < 1e-9);
        // Past the end: the shape's last point.
        let p = straight.place(12.0, 4.0);
        assert!((p.x - 10.0).abs() < 1e-12);
    }

    #[test]
    fn the_lengths_differ_and_positions_scale() {
        let lane = Lane::new(5.0, vec![[0.0, 0.0, 0.0], [0.0, -10.0, 0.0]]);
        let p = lane.place(2.5, 1.0);
        assert!((p.y + 5.0).abs() < 1e-12);
        assert!((p.angle - 180.0).abs() < 1e-9, "{}", p.angle);
    }

    #[test]
    fn bad_networks_and_lanes_are_named() {
        let e = Network::parse("<net", "roads/x.net.xml").unwrap_err();
        assert!(
            e.to_string()
                .contains("roads/x.net.xml is not a SUMO network"),
            "{e}"
        );
        let e = Network::parse("<net/>", "x.net.xml").unwrap_err();
        assert!(e.to_string().contains("x.net.xml has no <lane>"), "{e}");
        let e = Network::parse(r#"<net><lane id="a_0" length="1" shape="0,0"/></net>"#, "n")
            .unwrap_err();
        assert!(e.to_string().contains("lane a_0 has no valid shape"), "{e}");
        let net = Network::parse(NET, "net.xml").unwrap();
        let e = net.lane("road_7").unwrap_err();
        assert_eq!(
            e.to_string(),
            "net.xml has no lane road_7 (its lanes are road_0, road_1, road_2)"
        );
        let layout = layout(vec![0, 9], 0.0);
        let e = FcdWriter::new(&net, layout, 1, Vec::new(), "test")
            .err()
            .unwrap();
        assert!(e.to_string().contains("no lane road_9"), "{e}");
    }

    /// Two vehicles a platoon on edge `road`'s `lanes`, `offset_m` from its start.
    fn layout(lanes: Vec<u32>, offset_m: f64) -> Layout {
        Layout {
            edge: "road".into(),
            lanes,
            side_lanes: Vec::new(),
            vehicles_per_platoon: 2,
            offset_m,
            vehicle_length_m: 4.0,
            dt: 0.01,
            vtype: "platoon".into(),
        }
    }

    fn row(step: u64, platoon: u16, vehicle: u16, p: f64) -> StepRow {
        StepRow {
            step,
            t: step as f64 * 0.01,
            platoon,
            vehicle,
            p,
            v: 15.0,
            a: 0.004,
            u: 0.0,
            theta: f64::NAN,
            spacing_error: 0.0,
            velocity_error: 0.0,
            triggered: false,
            under_attack: false,
            affected: false,
            mode: platoon_control::Status::default(),
            guard: false,
            saturated: false,
            revoked: false,
            intruder: None,
            radar_target: None,
            radar_gap_m: None,
            radar_closing_mps: None,
            head: None,
            beside: None,
        }
    }

    #[test]
    fn rows_become_timesteps_at_the_period_with_sumos_ids() {
        let net = Network::parse(NET, "net.xml").unwrap();
        let layout = layout(vec![0, 1], 5.0);
        let mut w = FcdWriter::new(&net, layout, 2, Vec::new(), "from a test").unwrap();
        for k in 0..3 {
            for (j, i) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                w.row(&row(k, j, i, 1.0 - f64::from(i))).unwrap();
            }
        }
        let (out, count) = w.finish().unwrap();
        assert_eq!(
            count,
            FcdCount {
                timesteps: 2,
                vehicles: 8
            }
        );
        let text = String::from_utf8(out).unwrap();
        let doc = roxmltree::Document::parse(&text).unwrap();
        let times: Vec<&str> = doc
            .descendants()
            .filter(|n| n.has_tag_name("timestep"))
            .map(|n| n.attribute("time").unwrap())
            .collect();
        assert_eq!(times, ["0.00", "0.02"]);
        assert!(text.contains(
            r#"<vehicle id="p1.follower1" x="5.00" y="0.00" angle="90.00" type="platoon" speed="15.00" pos="5.00" lane="road_1" slope="0.00" acceleration="0.00"/>"#
        ), "{text}");
        assert!(text.contains(r#"id="p0.leader" x="6.00""#), "{text}");
        let mut w = FcdWriter::new(
            &net,
            Layout {
                edge: "road".into(),
                lanes: vec![0],
                side_lanes: Vec::new(),
                vehicles_per_platoon: 1,
                offset_m: 0.0,
                vehicle_length_m: 4.0,
                dt: 0.01,
                vtype: "platoon".into(),
            },
            1,
            Vec::new(),
            "",
        )
        .unwrap();
        let e = w.row(&row(0, 0, 1, 0.0)).unwrap_err();
        assert!(e.to_string().contains("platoon 0, vehicle 1"), "{e}");
    }

    /// SUMO writes 3 decimals when the step is not a whole number of 10 ms, else 2.
    #[test]
    fn values_have_sumos_precision_for_the_step() {
        for (dt, d) in [
            (0.01, 2),
            (0.1, 2),
            (1.0, 2),
            (0.05, 2),
            (0.005, 3),
            (0.001, 3),
        ] {
            assert_eq!(precision(dt), d, "dt = {dt}");
        }
        let net = Network::parse(NET, "net.xml").unwrap();
        let layout = |dt: f64| Layout {
            edge: "road".into(),
            lanes: vec![0],
            side_lanes: Vec::new(),
            vehicles_per_platoon: 1,
            offset_m: 5.0,
            vehicle_length_m: 4.0,
            dt,
            vtype: "platoon".into(),
        };
        let mut w = FcdWriter::new(&net, layout(0.005), 1, Vec::new(), "").unwrap();
        let mut r = row(1, 0, 0, 1.25);
        r.t = 0.005;
        w.row(&r).unwrap();
        let text = String::from_utf8(w.finish().unwrap().0).unwrap();
        assert!(text.contains(r#"<timestep time="0.005">"#), "{text}");
        assert!(
            text.contains(r#"x="6.250" y="0.000" angle="90.000" type="platoon" speed="15.000" pos="6.250" lane="road_0" slope="0.000" acceleration="0.004"/>"#),
            "{text}"
        );
        let mut w = FcdWriter::new(&net, layout(0.02), 1, Vec::new(), "").unwrap();
        w.row(&row(1, 0, 0, 1.25)).unwrap();
        let text = String::from_utf8(w.finish().unwrap().0).unwrap();
        assert!(text.contains(r#"x="6.25" y="0.00""#), "{text}");
    }

    /// A row repeated within a step is one vehicle: its line replaced, counted once.
    #[test]
    fn a_repeated_row_is_one_vehicle() {
        let net = Network::parse(NET, "net.xml").unwrap();
        let layout = layout(vec![0], 0.0);
        let mut w = FcdWriter::new(&net, layout, 1, Vec::new(), "").unwrap();
        for (step, vehicle) in [(0, 0), (0, 0), (0, 1), (1, 0), (1, 0)] {
            w.row(&row(step, 0, vehicle, 1.0)).unwrap();
        }
        let (out, count) = w.finish().unwrap();
        assert_eq!(
            count,
            FcdCount {
                timesteps: 2,
                vehicles: 3
            }
        );
        let text = String::from_utf8(out).unwrap();
        assert_eq!(text.matches("<vehicle ").count(), 3, "{text}");
    }

    #[test]
    fn a_lane_of_no_length_is_named() {
        let e = Network::parse(
            r#"<net><lane id="a_0" length="0" shape="0,0 1,0"/></net>"#,
            "n.net.xml",
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("n.net.xml: lane a_0 has length 0"),
            "{e}"
        );
    }

    #[test]
    fn times_have_the_decimals_the_step_needs() {
        assert_eq!(decimals(0.01), 2);
        assert_eq!(decimals(0.1), 2);
        assert_eq!(decimals(0.001), 3);
        assert_eq!(decimals(0.0025), 4);
    }
}
