//! Progress of long operations, reported to whoever runs them (a progress bar in the `platoon`
//! binary, nothing in a library call): the library never draws.

/// Hears of an operation's progress. Every method has a default that does nothing, and `()`
/// is the progress that nobody watches.
pub trait Progress: Sync {
    /// A stage of `total` units (steps, cells) starts; `what` names it ("simulating").
    fn start(&self, what: &str, total: u64) {
        let _ = (what, total);
    }
    /// `done` units of the current stage are done.
    fn at(&self, done: u64) {
        let _ = done;
    }
    /// The current stage is over.
    fn finish(&self) {}
    /// What the current unit is (a platoon being designed, a run's parameters): a note beside
    /// the count, replaced by the next.
    fn detail(&self, text: &str) {
        let _ = text;
    }
    /// A note for the person running the operation (a run id, a warning).
    fn message(&self, text: &str) {
        let _ = text;
    }
}

/// Nobody watches.
impl Progress for () {}
