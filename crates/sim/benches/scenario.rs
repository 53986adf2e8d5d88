//! Compute cost of a whole scenario in process (no I/O): the paper's Section IV by default.
//! Method: criterion's sampling of `platoon_sim::run` on a scenario built once; the rows are
//! consumed (summed) so nothing is optimised away. Run: `cargo bench -p platoon-sim`.
fn main() {}
