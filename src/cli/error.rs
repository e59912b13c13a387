//! Failures of a command and their exit codes: 2 bad input or usage, 1 anything else.

use crate::pipeline::executor::RunError;
use crate::pipeline::{Diagnostics, StageError};

/// A failure with its exit code.
pub(super) struct Failure {
    pub(super) code: u8,
    pub(super) error: anyhow::Error,
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        let error = e.into();
        Failure {
            code: exit_code(&error),
            error,
        }
    }
}

impl Failure {
    /// Bad input or usage (exit 2), whatever the error's type.
    pub(super) fn bad_input(e: impl Into<anyhow::Error>) -> Self {
        Failure {
            code: 2,
            error: e.into(),
        }
    }
}

/// The exit code for an error: 2 when anything in its chain says the user's input is at fault
/// (a located diagnostic, an unknown `--only` stage, a stage's bad input), 1 otherwise.
pub(super) fn exit_code(error: &anyhow::Error) -> u8 {
    let input = error.chain().any(|cause| {
        cause.downcast_ref::<Diagnostics>().is_some()
            || cause
                .downcast_ref::<StageError>()
                .is_some_and(|e| e.is_input())
            || cause
                .downcast_ref::<RunError>()
                .is_some_and(|e| e.is_input())
    });
    if input { 2 } else { 1 }
}

/// An error and its causes joined by `: `, leaving out a cause whose text the message already
/// holds (errors that print their source themselves would otherwise say it twice).
pub(super) fn error_chain(error: &anyhow::Error) -> String {
    let mut message = error.to_string();
    for cause in error.chain().skip(1) {
        let text = cause.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
    }
    message
}
