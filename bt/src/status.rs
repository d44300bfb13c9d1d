//! Node statuses.
//!
//! Not here: what any node does with them ([`crate::tree`]).

use std::fmt;
use std::str::FromStr;

/// What a node returns when ticked, and the state it rests in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Status {
    /// Not started, or reset/halted.
    #[default]
    Idle,
    Running,
    Success,
    Failure,
    /// Did not execute (a precondition-style decorator decided so); parents skip it.
    Skipped,
}

impl Status {
    /// Success or Failure.
    pub fn is_completed(self) -> bool {
        matches!(self, Status::Success | Status::Failure)
    }
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Idle => "IDLE",
            Status::Running => "RUNNING",
            Status::Success => "SUCCESS",
            Status::Failure => "FAILURE",
            Status::Skipped => "SKIPPED",
        }
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Status {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "IDLE" => Ok(Status::Idle),
            "RUNNING" => Ok(Status::Running),
            "SUCCESS" => Ok(Status::Success),
            "FAILURE" => Ok(Status::Failure),
            "SKIPPED" => Ok(Status::Skipped),
            other => Err(format!(
                "'{other}' is not a status (IDLE, RUNNING, SUCCESS, FAILURE, SKIPPED)"
            )),
        }
    }
}
