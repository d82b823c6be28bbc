//! Progress reports and cancellation: how a long computation talks back to whoever started it
//! (the command line's bar or JSON lines, the benchmark, tests) without knowing who that is.

use crate::error::{Error, Result};
use std::sync::atomic::{AtomicBool, Ordering};

/// One progress report.
#[derive(Clone, Debug)]
pub struct ProgressEvent<'a> {
    pub stage: &'a str,
    /// Fraction of the stage done, in [0, 1].
    pub fraction: f32,
    pub message: String,
}

/// How the renderer talks back while it works: progress reports and the cancel flag.
pub struct Progress<'a> {
    pub cancel: &'a AtomicBool,
    pub report: &'a (dyn Fn(&ProgressEvent) + Sync),
}

impl Progress<'_> {
    pub fn check(&self) -> Result<()> {
        if self.cancel.load(Ordering::Relaxed) {
            Err(Error::Cancelled)
        } else {
            Ok(())
        }
    }
}
