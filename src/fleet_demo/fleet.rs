//! The fleet `frontseat demo --fleet` flies: how many vehicles it may have and their names, the
//! one list the launch file, the topside and the helms all name them by.

/// Most vehicles `--fleet` flies (one interface process each on a shared 2-core laptop).
pub const MAX_FLEET: usize = 12;
/// The leader's vehicle name; followers are `follower1`, `follower2`, …
pub const LEADER: &str = "leader";

/// The fleet's vehicle names, the leader first.
pub fn names(n: usize) -> Vec<String> {
    std::iter::once(LEADER.to_string())
        .chain((1..n).map(|k| format!("follower{k}")))
        .collect()
}
