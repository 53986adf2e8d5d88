//! The platoon's V2V communication graph (Section II-B of the paper), as a pure library.
//!
//! Convention (reading R6): `a_ij = 1` iff follower `i` **receives** from follower `j`, and
//! `h_i = 1` iff follower `i` receives from the leader. The Laplacian is `L = D - A` with
//! `d_i = sum_j a_ij`, and the information-flow matrix is `H = L + diag(h)`.
//!
//! Every constructor checks Assumption 3 (a spanning tree rooted at the leader): a graph in which
//! some follower cannot be reached from the leader is rejected with [`TopologyError::NoSpanningTree`]
//! naming the unreachable followers.
#![warn(missing_docs)]

use nalgebra::{DMatrix, DVector};
use platoon_model::VehicleId;
use serde::{Deserialize, Serialize};

/// The named topologies of the literature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// Predecessor following: i hears i-1 (follower 1 hears the leader).
    Pf,
    /// Predecessor-leader following: i hears i-1 and the leader.
    Plf,
    /// Bidirectional predecessor following: i hears i-1 and i+1 (follower 1 hears the leader).
    Bpf,
    /// Two-predecessor single following: i hears i-1 and i-2, where vehicle 0 is the leader
    /// (docs/paper-readings.md#R7: pinning diag(1, 1, 0, ...)).
    Tpsf,
}

impl Preset {
    /// Every preset.
    pub const ALL: [Preset; 4] = [Preset::Pf, Preset::Plf, Preset::Bpf, Preset::Tpsf];

    /// The preset of a config's `topology.preset` name (`pf`, `plf`, `bpf`, `tpsf`).
    pub fn from_name(name: &str) -> Option<Preset> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Its name in a config's `topology.preset`.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Pf => "pf",
            Preset::Plf => "plf",
            Preset::Bpf => "bpf",
            Preset::Tpsf => "tpsf",
        }
    }
}

/// Why a topology was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TopologyError {
    /// No followers.
    #[error("a platoon needs at least one follower")]
    Empty,
    /// The adjacency is not N x N or the pinning vector not of length N.
    #[error("adjacency must be {n} x {n} and pinning of length {n} (got {rows} rows, a row of {cols}, pinning of {pins})")]
    Shape {
        /// Number of followers.
        n: usize,
        /// Rows given.
        rows: usize,
        /// Length of the first offending row.
        cols: usize,
        /// Pinning entries given.
        pins: usize,
    },
    /// Entries must be 0 or 1.
    #[error("entry ({row}, {col}) is {value}; adjacency and pinning entries must be 0 or 1")]
    NotBinary {
        /// 1-based follower row (0 for the pinning vector).
        row: usize,
        /// 1-based follower column.
        col: usize,
        /// The value.
        value: f64,
    },
    /// a_ii must be zero.
    #[error("follower {0} lists itself as a neighbour")]
    SelfLoop(usize),
    /// Assumption 3 fails.
    #[error("no spanning tree rooted at the leader (Assumption 3): {} cannot be reached from the leader", list(.unreachable))]
    NoSpanningTree {
        /// The followers the leader's information never reaches.
        unreachable: Vec<VehicleId>,
    },
}

fn list(ids: &[VehicleId]) -> String {
    let names: Vec<String> = ids.iter().map(|id| id.0.to_string()).collect();
    format!("follower(s) {}", names.join(", "))
}

/// A validated follower graph with its pinning.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    adjacency: DMatrix<f64>,
    pinning: DVector<f64>,
    /// in_neighbours[i] for follower i+1: the vehicles it receives from (leader first if pinned).
    in_neighbours: Vec<Vec<VehicleId>>,
    /// out_neighbours[v] for vehicle v (leader at 0): who receives v's broadcasts.
    out_neighbours: Vec<Vec<VehicleId>>,
    /// Whom the leader receives from: nobody in a control graph; every follower in
    /// [`Topology::hearing_everyone`].
    leader_in: Vec<VehicleId>,
}

impl Topology {
    /// A preset for `n` followers.
    pub fn preset(preset: Preset, n: usize) -> Result<Self, TopologyError> {
        if n == 0 {
            return Err(TopologyError::Empty);
        }
        let mut a = vec![vec![0.0; n]; n];
        let mut h = vec![0.0; n];
        for i in 0..n {
            // i is the 0-based follower index; follower i+1 in the paper.
            let mut hear = |j: isize| {
                if j == -1 {
                    h[i] = 1.0;
                } else if j >= 0 && (j as usize) < n {
                    a[i][j as usize] = 1.0;
                }
            };
            let i_ = i as isize;
            match preset {
                Preset::Pf => hear(i_ - 1),
                Preset::Plf => {
                    hear(i_ - 1);
                    hear(-1);
                }
                Preset::Bpf => {
                    hear(i_ - 1);
                    hear(i_ + 1);
                }
                Preset::Tpsf => {
                    hear(i_ - 1);
                    hear(i_ - 2);
                }
            }
        }
        Self::explicit(a, h)
    }

    /// A graph from an explicit adjacency (row i lists whom follower i+1 receives from) and
    /// pinning vector.
    pub fn explicit(adjacency: Vec<Vec<f64>>, pinning: Vec<f64>) -> Result<Self, TopologyError> {
        let n = adjacency.len();
        if n == 0 {
            return Err(TopologyError::Empty);
        }
        if let Some(row) = adjacency.iter().find(|r| r.len() != n) {
            return Err(TopologyError::Shape {
                n,
                rows: n,
                cols: row.len(),
                pins: pinning.len(),
            });
        }
        if pinning.len() != n {
            return Err(TopologyError::Shape {
                n,
                rows: n,
                cols: n,
                pins: pinning.len(),
            });
        }
        for (i, row) in adjacency.iter().enumerate() {
            for (j, &value) in row.iter().enumerate() {
                if value != 0.0 && value != 1.0 {
                    return Err(TopologyError::NotBinary {
                        row: i + 1,
                        col: j + 1,
                        value,
                    });
                }
            }
            if row[i] != 0.0 {
                return Err(TopologyError::SelfLoop(i + 1));
            }
        }
        if let Some((j, &value)) = pinning
            .iter()
            .enumerate()
            .find(|(_, &v)| v != 0.0 && v != 1.0)
        {
            return Err(TopologyError::NotBinary {
                row: 0,
                col: j + 1,
                value,
            });
        }
        let adjacency = DMatrix::from_fn(n, n, |i, j| adjacency[i][j]);
        let pinning = DVector::from_vec(pinning);

        let mut in_neighbours = vec![Vec::new(); n];
        let mut out_neighbours = vec![Vec::new(); n + 1];
        for i in 0..n {
            let me = VehicleId::follower(i + 1);
            if pinning[i] == 1.0 {
                in_neighbours[i].push(VehicleId::LEADER);
                out_neighbours[0].push(me);
            }
            for j in 0..n {
                if adjacency[(i, j)] == 1.0 {
                    in_neighbours[i].push(VehicleId::follower(j + 1));
                    out_neighbours[j + 1].push(me);
                }
            }
        }
        // Assumption 3: breadth-first search from the leader along information flow.
        let mut reached = vec![false; n + 1];
        reached[0] = true;
        let mut queue = vec![VehicleId::LEADER];
        while let Some(v) = queue.pop() {
            for &w in &out_neighbours[v.index()] {
                if !reached[w.index()] {
                    reached[w.index()] = true;
                    queue.push(w);
                }
            }
        }
        let unreachable: Vec<VehicleId> = (1..=n)
            .filter(|&i| !reached[i])
            .map(VehicleId::follower)
            .collect();
        if !unreachable.is_empty() {
            return Err(TopologyError::NoSpanningTree { unreachable });
        }
        Ok(Self {
            adjacency,
            pinning,
            in_neighbours,
            out_neighbours,
            leader_in: Vec::new(),
        })
    }

    /// Number of followers N.
    pub fn followers(&self) -> usize {
        self.pinning.len()
    }

    /// The adjacency matrix `[a_ij]` (N x N).
    pub fn adjacency(&self) -> &DMatrix<f64> {
        &self.adjacency
    }

    /// The pinning vector `h` (length N).
    pub fn pinning(&self) -> &DVector<f64> {
        &self.pinning
    }

    /// The Laplacian `L = D - A`.
    pub fn laplacian(&self) -> DMatrix<f64> {
        let degrees = self.adjacency.column_sum(); // row sums as a column vector
        DMatrix::from_diagonal(&degrees) - &self.adjacency
    }

    /// The information-flow matrix `H = L + diag(h)`.
    pub fn h_matrix(&self) -> DMatrix<f64> {
        self.laplacian() + DMatrix::from_diagonal(&self.pinning)
    }

    /// Whom vehicle `i` receives from (the leader first if pinned); for the leader, whom it
    /// hears (nobody in a control graph).
    pub fn in_neighbours(&self, i: VehicleId) -> &[VehicleId] {
        match i.index() {
            0 => &self.leader_in,
            i => &self.in_neighbours[i - 1],
        }
    }

    /// Who receives vehicle `v`'s broadcasts (the leader included).
    pub fn out_neighbours(&self, v: VehicleId) -> &[VehicleId] {
        &self.out_neighbours[v.index()]
    }

    /// This graph with every follower also hearing every follower ahead of it: who can hear
    /// whom on the road when a platoon may split behind a car that cut in (the followers behind
    /// then take the member that heads them as their leader, so they must hear it). The control
    /// laws keep their own graph; this one only carries packets.
    pub fn hearing_all_ahead(&self) -> Self {
        let n = self.followers();
        let adjacency = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| if j < i { 1.0 } else { self.adjacency[(i, j)] })
                    .collect()
            })
            .collect();
        Self::explicit(adjacency, self.pinning.iter().copied().collect())
            .expect("more links than a valid graph keep it valid")
    }

    /// Every vehicle hearing every other, the leader included (it hears every follower): who
    /// hears whom when the platoon negotiates maneuvers (`[[maneuvers]]`: a joiner asks the
    /// leader, the leader announces to everyone). Like [`Topology::hearing_all_ahead`], a graph
    /// that only carries packets; its adjacency and pinning are all ones.
    pub fn hearing_everyone(&self) -> Self {
        let n = self.followers();
        let adjacency = (0..n)
            .map(|i| (0..n).map(|j| if i == j { 0.0 } else { 1.0 }).collect())
            .collect();
        let mut all =
            Self::explicit(adjacency, vec![1.0; n]).expect("a complete graph is a valid graph");
        for f in 1..=n {
            all.out_neighbours[f].push(VehicleId::LEADER);
        }
        all.leader_in = (1..=n).map(VehicleId::follower).collect();
        all
    }

    /// Every directed link `(sender, receiver)`, leader links first, in a fixed order.
    pub fn links(&self) -> impl Iterator<Item = (VehicleId, VehicleId)> + '_ {
        self.out_neighbours
            .iter()
            .enumerate()
            .flat_map(|(s, rs)| rs.iter().map(move |&r| (VehicleId(s as u16), r)))
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn hearing_everyone_links_every_pair_the_leader_included() {
        let t = Topology::preset(Preset::Pf, 3).unwrap().hearing_everyone();
        let links: Vec<_> = t.links().collect();
        assert_eq!(links.len(), 4 * 3, "every ordered pair of 4 vehicles");
        assert_eq!(t.in_neighbours(VehicleId::LEADER).len(), 3);
        assert!(t.out_neighbours(VehicleId(2)).contains(&VehicleId::LEADER));
        assert!(Topology::preset(Preset::Pf, 3)
            .unwrap()
            .in_neighbours(VehicleId::LEADER)
            .is_empty());
    }

    use super::*;

    fn m(rows: &[&[f64]]) -> DMatrix<f64> {
        DMatrix::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
    }

    #[test]
    fn hearing_all_ahead_adds_the_links_from_every_member_ahead() {
        let t = Topology::preset(Preset::Plf, 4).unwrap();
        let r = t.hearing_all_ahead();
        assert_eq!(r.pinning(), t.pinning());
        assert_eq!(
            r.in_neighbours(VehicleId(4)),
            [VehicleId(0), VehicleId(1), VehicleId(2), VehicleId(3)]
        );
        assert_eq!(
            r.out_neighbours(VehicleId(1)),
            [VehicleId(2), VehicleId(3), VehicleId(4)]
        );
        // Backward links stay as they were.
        let b = Topology::preset(Preset::Bpf, 3)
            .unwrap()
            .hearing_all_ahead();
        assert_eq!(b.in_neighbours(VehicleId(1)), [VehicleId(0), VehicleId(2)]);
        assert_eq!(r.links().count(), 4 + 6);
    }

    #[test]
    fn tpsf_four_followers_matches_errata_item_7() {
        let t = Topology::preset(Preset::Tpsf, 4).unwrap();
        #[rustfmt::skip]
        let h = m(&[
            &[ 1.0,  0.0,  0.0, 0.0],
            &[-1.0,  2.0,  0.0, 0.0],
            &[-1.0, -1.0,  2.0, 0.0],
            &[ 0.0, -1.0, -1.0, 2.0],
        ]);
        assert_eq!(t.h_matrix(), h);
        assert_eq!(t.pinning().as_slice(), &[1.0, 1.0, 0.0, 0.0]);
        assert_eq!(
            t.in_neighbours(VehicleId(2)),
            &[VehicleId::LEADER, VehicleId(1)]
        );
        assert_eq!(
            t.out_neighbours(VehicleId(2)),
            &[VehicleId(3), VehicleId(4)]
        );
    }

    #[test]
    fn pf_plf_bpf_matrices() {
        #[rustfmt::skip]
        let pf = m(&[
            &[ 1.0,  0.0, 0.0],
            &[-1.0,  1.0, 0.0],
            &[ 0.0, -1.0, 1.0],
        ]);
        assert_eq!(Topology::preset(Preset::Pf, 3).unwrap().h_matrix(), pf);
        #[rustfmt::skip]
        let plf = m(&[
            &[ 1.0,  0.0, 0.0],
            &[-1.0,  2.0, 0.0],
            &[ 0.0, -1.0, 2.0],
        ]);
        assert_eq!(Topology::preset(Preset::Plf, 3).unwrap().h_matrix(), plf);
        #[rustfmt::skip]
        let bpf = m(&[
            &[ 2.0, -1.0,  0.0],
            &[-1.0,  2.0, -1.0],
            &[ 0.0, -1.0,  1.0],
        ]);
        let t = Topology::preset(Preset::Bpf, 3).unwrap();
        assert_eq!(t.h_matrix(), bpf);
        #[rustfmt::skip]
        let lap = m(&[
            &[ 1.0, -1.0,  0.0],
            &[-1.0,  2.0, -1.0],
            &[ 0.0, -1.0,  1.0],
        ]);
        assert_eq!(t.laplacian(), lap);
    }

    #[test]
    fn explicit_graph_without_spanning_tree_names_unreachable_followers() {
        // 1 hears the leader; 2 and 3 only hear each other.
        let a = vec![
            vec![0.0, 0.0, 0.0],
            vec![0.0, 0.0, 1.0],
            vec![0.0, 1.0, 0.0],
        ];
        let err = Topology::explicit(a, vec![1.0, 0.0, 0.0]).unwrap_err();
        assert_eq!(
            err,
            TopologyError::NoSpanningTree {
                unreachable: vec![VehicleId(2), VehicleId(3)]
            }
        );
        assert!(err.to_string().contains("follower(s) 2, 3"), "{err}");
    }

    #[test]
    fn explicit_graph_shape_and_values_are_checked() {
        assert!(matches!(
            Topology::explicit(vec![vec![0.0, 1.0]], vec![1.0]),
            Err(TopologyError::Shape { .. })
        ));
        assert!(matches!(
            Topology::explicit(vec![vec![0.0, 0.5], vec![0.0, 0.0]], vec![1.0, 1.0]),
            Err(TopologyError::NotBinary { row: 1, col: 2, .. })
        ));
        assert_eq!(
            Topology::explicit(vec![vec![1.0]], vec![1.0]),
            Err(TopologyError::SelfLoop(1))
        );
    }

    #[test]
    fn links_cover_every_edge_once() {
        let t = Topology::preset(Preset::Tpsf, 4).unwrap();
        let links: Vec<_> = t.links().collect();
        let edges = t.adjacency().sum() as usize + t.pinning().sum() as usize;
        assert_eq!(links.len(), edges);
        assert_eq!(links[0], (VehicleId::LEADER, VehicleId(1)));
    }
}
