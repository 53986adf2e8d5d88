//! A platoon's formation: its members in road order, and the graph a topology preset gives it.
use crate::Change;
use platoon_model::VehicleId;
use platoon_topology::{Preset, Topology, TopologyError};

/// Why a formation or a change of it is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FormationError {
    /// A formation has a head.
    #[error("a formation needs at least its head")]
    Empty,
    /// A vehicle stands twice.
    #[error("vehicle {0} stands twice in the formation")]
    Duplicate(u16),
    /// The vehicle is not a member.
    #[error("vehicle {0} is not a member of the formation")]
    NotMember(u16),
    /// The vehicle is a member already.
    #[error("vehicle {0} is a member of the formation already")]
    Member(u16),
    /// The head cannot leave its own formation (it dissolves it).
    #[error("the head, vehicle {0}, cannot leave its formation")]
    HeadLeaves(u16),
    /// A merge names platoons that are not numbered on from each other.
    #[error(
        "a merge of the platoon from vehicle {head} to {tail} is not at this formation's ends"
    )]
    NotConsecutive {
        /// The rear platoon's head.
        head: u16,
        /// The rear platoon's tail.
        tail: u16,
    },
}

/// The members of one platoon in road order, the head first.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Formation {
    members: Vec<VehicleId>,
}

impl Formation {
    /// A formation of `members`, the head first.
    pub fn new(members: Vec<VehicleId>) -> Result<Self, FormationError> {
        if members.is_empty() {
            return Err(FormationError::Empty);
        }
        for (i, m) in members.iter().enumerate() {
            if members[..i].contains(m) {
                return Err(FormationError::Duplicate(m.0));
            }
        }
        Ok(Self { members })
    }

    /// The leader and followers `1..=followers` in order: a platoon as a scenario starts.
    pub fn in_order(followers: usize) -> Self {
        Self {
            members: (0..=followers).map(|i| VehicleId(i as u16)).collect(),
        }
    }

    /// The members, the head first.
    pub fn members(&self) -> &[VehicleId] {
        &self.members
    }

    /// The head (the platoon's leader).
    pub fn head(&self) -> VehicleId {
        self.members[0]
    }

    /// The last member.
    pub fn tail(&self) -> VehicleId {
        self.members[self.members.len() - 1]
    }

    /// The number of followers (members behind the head).
    pub fn followers(&self) -> usize {
        self.members.len() - 1
    }

    /// Where `v` stands: 0 for the head.
    pub fn position(&self, v: VehicleId) -> Option<usize> {
        self.members.iter().position(|&m| m == v)
    }

    /// Whether `v` is a member.
    pub fn contains(&self, v: VehicleId) -> bool {
        self.position(v).is_some()
    }

    /// The member directly ahead of `v` (none for the head or a stranger).
    pub fn predecessor(&self, v: VehicleId) -> Option<VehicleId> {
        self.position(v)
            .filter(|&i| i > 0)
            .map(|i| self.members[i - 1])
    }

    /// The member directly behind `v` (none for the tail or a stranger).
    pub fn successor(&self, v: VehicleId) -> Option<VehicleId> {
        self.position(v)
            .and_then(|i| self.members.get(i + 1).copied())
    }

    /// This formation with `joiner` standing directly behind `behind`.
    pub fn joined(&self, joiner: VehicleId, behind: VehicleId) -> Result<Self, FormationError> {
        if self.contains(joiner) {
            return Err(FormationError::Member(joiner.0));
        }
        let at = self
            .position(behind)
            .ok_or(FormationError::NotMember(behind.0))?;
        let mut members = self.members.clone();
        members.insert(at + 1, joiner);
        Ok(Self { members })
    }

    /// This formation without `v`; the member behind it closes up to the one ahead.
    pub fn left(&self, v: VehicleId) -> Result<Self, FormationError> {
        match self.position(v) {
            None => Err(FormationError::NotMember(v.0)),
            Some(0) => Err(FormationError::HeadLeaves(v.0)),
            Some(i) => {
                let mut members = self.members.clone();
                members.remove(i);
                Ok(Self { members })
            }
        }
    }

    /// The formation of the merge of the platoon from `head` to `tail` behind the one from
    /// the run's leader to `head - 1` ([`Change::Merged`]), from either's copy: the front's
    /// (its tail is `head - 1`) or the rear's (headed by `head`, its tail `tail`).
    pub fn merged(&self, head: VehicleId, tail: VehicleId) -> Result<Self, FormationError> {
        let wrong = FormationError::NotConsecutive {
            head: head.0,
            tail: tail.0,
        };
        let run = |from: u16, to: u16| (from..=to).map(VehicleId);
        if head.0 == 0 || tail.0 < head.0 {
            return Err(wrong);
        }
        let members: Vec<VehicleId> = if self.tail().0 + 1 == head.0 {
            self.members
                .iter()
                .copied()
                .chain(run(head.0, tail.0))
                .collect()
        } else if self.head() == head && self.tail() == tail {
            run(0, head.0 - 1)
                .chain(self.members.iter().copied())
                .collect()
        } else {
            return Err(wrong);
        };
        Self::new(members)
    }

    /// The two platoons of a split at `head` ([`Change::Split`]): the members ahead of it, and
    /// those from it on, headed by it.
    pub fn split(&self, head: VehicleId) -> Result<(Self, Self), FormationError> {
        match self.position(head) {
            None => Err(FormationError::NotMember(head.0)),
            Some(0) => Err(FormationError::HeadLeaves(head.0)),
            Some(i) => Ok((
                Self {
                    members: self.members[..i].to_vec(),
                },
                Self {
                    members: self.members[i..].to_vec(),
                },
            )),
        }
    }

    /// This formation after `change`, as `me` keeps it (a split leaves it the part it is in).
    pub fn apply(&self, change: Change, me: VehicleId) -> Result<Self, FormationError> {
        match change {
            Change::Joined { vehicle, behind } => self.joined(vehicle, behind),
            Change::Left { vehicle } => self.left(vehicle),
            Change::Merged { head, tail } => self.merged(head, tail),
            Change::Split { head } => {
                let (front, rear) = self.split(head)?;
                Ok(if rear.contains(me) { rear } else { front })
            }
        }
    }

    /// The graph `preset` gives this formation, by position, as in the paper: follower `i` of
    /// the graph is the member at position `i`. [`Formation::vehicle`] maps a graph id back.
    pub fn topology(&self, preset: Preset) -> Result<Topology, TopologyError> {
        Topology::preset(preset, self.followers())
    }

    /// The member at graph id `id` (position: 0 is the head).
    pub fn vehicle(&self, id: VehicleId) -> Option<VehicleId> {
        self.members.get(id.index()).copied()
    }

    /// Every directed link `(sender, receiver)` of `preset` on this formation, in vehicle ids.
    pub fn links(&self, preset: Preset) -> Result<Vec<(VehicleId, VehicleId)>, TopologyError> {
        let graph = self.topology(preset)?;
        Ok(graph
            .links()
            .map(|(s, r)| (self.members[s.index()], self.members[r.index()]))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(i: u16) -> VehicleId {
        VehicleId(i)
    }

    #[test]
    fn a_join_in_the_middle_puts_the_joiner_between_its_neighbours() {
        let f = Formation::in_order(3).joined(v(9), v(1)).unwrap();
        assert_eq!(f.members(), &[v(0), v(1), v(9), v(2), v(3)]);
        assert_eq!(f.predecessor(v(2)), Some(v(9)));
        assert_eq!(f.successor(v(1)), Some(v(9)));
        assert_eq!(f.tail(), v(3));
        let back = f.left(v(9)).unwrap();
        assert_eq!(back, Formation::in_order(3));
    }

    #[test]
    fn the_links_follow_the_members_not_their_ids() {
        let f = Formation::in_order(2).joined(v(7), v(0)).unwrap();
        let links = f.links(Preset::Pf).unwrap();
        assert_eq!(links, vec![(v(0), v(7)), (v(7), v(1)), (v(1), v(2))]);
        let plf = f.links(Preset::Plf).unwrap();
        assert!(plf.contains(&(v(0), v(2))) && plf.contains(&(v(1), v(2))));
    }

    #[test]
    fn a_merge_makes_either_copy_the_whole_formation() {
        let front = Formation::in_order(2);
        let rear = Formation::new(vec![v(3), v(4), v(5)]).unwrap();
        let whole = Formation::in_order(5);
        assert_eq!(front.merged(v(3), v(5)), Ok(whole.clone()));
        assert_eq!(rear.merged(v(3), v(5)), Ok(whole));
        let wrong = Err(FormationError::NotConsecutive { head: 4, tail: 5 });
        assert_eq!(front.merged(v(4), v(5)), wrong, "a gap in the numbers");
        assert_eq!(rear.merged(v(4), v(5)), wrong, "not this platoon's head");
    }

    #[test]
    fn a_split_leaves_each_member_its_part() {
        let f = Formation::in_order(5);
        let split = Change::Split { head: v(3) };
        assert_eq!(f.apply(split, v(1)), Ok(Formation::in_order(2)));
        let rear = Formation::new(vec![v(3), v(4), v(5)]).unwrap();
        assert_eq!(f.apply(split, v(3)), Ok(rear.clone()));
        assert_eq!(f.apply(split, v(5)), Ok(rear));
        assert_eq!(f.split(v(0)), Err(FormationError::HeadLeaves(0)));
        assert_eq!(f.split(v(7)), Err(FormationError::NotMember(7)));
    }

    #[test]
    fn impossible_changes_are_refused() {
        let f = Formation::in_order(2);
        assert_eq!(f.joined(v(1), v(0)), Err(FormationError::Member(1)));
        assert_eq!(f.joined(v(5), v(4)), Err(FormationError::NotMember(4)));
        assert_eq!(f.left(v(0)), Err(FormationError::HeadLeaves(0)));
        assert_eq!(f.left(v(3)), Err(FormationError::NotMember(3)));
        assert_eq!(
            Formation::new(vec![v(0), v(1), v(0)]),
            Err(FormationError::Duplicate(0))
        );
        assert_eq!(Formation::new(vec![]), Err(FormationError::Empty));
    }
}
