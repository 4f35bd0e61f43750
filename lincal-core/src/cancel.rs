//! Cooperative cancellation of long computations: a process-wide request that the fit's
//! iteration loops check, so a caller that learns of an interrupt (the Python package on
//! Ctrl-C) can stop a running calibration within one iteration.
//!
//! Process-wide like the signal it stands for: a request stops every computation running
//! in the process at its next check, and the requester clears it when its call has ended.
//!
//! # Example
//! ```
//! use lincal_core::cancel;
//! assert!(cancel::check().is_ok());
//! cancel::request();
//! assert!(cancel::check().is_err());
//! cancel::clear();
//! assert!(cancel::check().is_ok());
//! ```

use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{Error, Result};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// The message of the error a cancelled computation returns.
pub const CANCELLED: &str = "interrupted: the computation was cancelled";

/// Asks every running computation to stop at its next check.
pub fn request() {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// Withdraws the request (after the cancelled call has returned).
pub fn clear() {
    REQUESTED.store(false, Ordering::SeqCst);
}

/// Whether a stop is requested.
#[must_use]
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// `Err` (an [`ErrorClass::Other`](crate::error::ErrorClass::Other) error saying
/// [`CANCELLED`]) when a stop is requested.
///
/// # Errors
/// When [`request`] was called and [`clear`] not since.
pub fn check() -> Result<()> {
    if requested() {
        Err(Error::other(CANCELLED))
    } else {
        Ok(())
    }
}
