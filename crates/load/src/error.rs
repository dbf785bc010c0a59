//! Errors of the grip-load kernel: bad parameters or input name the field; solver
//! failures are values the caller counts (never a panic, never a NaN force).

/// Why grip loads could not be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LoadError {
    /// A parameter is NaN, infinite or not positive.
    #[error("grip-load parameter `{field}` must be finite and > 0 (got {value})")]
    InvalidParam {
        /// Field name as in [`crate::LoadParams`].
        field: &'static str,
        /// The offending value.
        value: f64,
    },
    /// The stance given to the solver is malformed (non-finite position, zero normal, too
    /// many grips).
    #[error("grip-load input: {0}")]
    BadInput(String),
    /// The solver stopped without an optimum (iteration limit, numerical breakdown or a
    /// non-solved status of the reference solver).
    #[error("grip-load solver failed: {0}")]
    SolverFailed(String),
}
