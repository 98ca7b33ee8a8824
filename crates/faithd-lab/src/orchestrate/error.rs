//! How a lab run did not succeed: refused (its input or set-up cannot be used) or
//! failed (the job itself went wrong). The command line maps the two to its exit
//! statuses.

/// Why a run did not give its result.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The input cannot be used: a recording that cannot be read.
    #[error("{0}")]
    Refused(String),
    /// The job went wrong: a flight that could not be flown, a figure not written.
    #[error("{0}")]
    Failed(String),
}
