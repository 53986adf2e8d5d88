//! What the LMI layer reports when it cannot answer (every module of the crate returns it).
use crate::sdp::SdpError;

/// Why a design request could not be answered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LmiError {
    /// Inputs out of range.
    #[error("{0}")]
    Bad(String),
    /// The solver failed (numerical trouble, iteration limit).
    #[error("the SDP solver stopped with status {0}")]
    Solver(String),
    /// This build has no SDP solver (the system OpenBLAS was missing when it was built).
    #[error("{}", SdpError::NoSolver)]
    NoSolver,
    /// The solver reported a solution that fails the independent re-check (at the edge of
    /// feasibility): not a certificate.
    #[error("the solver's answer fails the independent re-check (largest eigenvalue {0:.3e})")]
    NotCertified(f64),
}

/// The SDP layer's failures, as the LMI layer reports them (the same words).
impl From<SdpError> for LmiError {
    fn from(e: SdpError) -> Self {
        match e {
            SdpError::Solver(status) => Self::Solver(status),
            SdpError::NoSolver => Self::NoSolver,
        }
    }
}
