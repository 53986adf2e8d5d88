//! `[topology]`: who hears whom.
use super::checks::bad;
use crate::error::KeyError;
use crate::schema::TopologyConfig;
use platoon_topology::Topology;

/// The graph of `[topology]` for `n` followers.
pub(crate) fn topology(t: &TopologyConfig, n: usize) -> Result<Topology, KeyError> {
    let topology = match (t, t.preset()) {
        (TopologyConfig::Explicit { adjacency, pinning }, _) => {
            Topology::explicit(adjacency.clone(), pinning.clone())
        }
        (_, Some(preset)) => Topology::preset(preset, n),
        (_, None) => unreachable!("every topology but an explicit one is a preset"),
    }
    .or_else(|e| bad("topology", e.to_string()))?;
    if topology.followers() != n {
        return bad(
            "topology.adjacency",
            format!(
                "describes {} followers, platoon.followers = {n}",
                topology.followers()
            ),
        );
    }
    Ok(topology)
}
