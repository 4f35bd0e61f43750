//! Cooperative cancellation of long computations: a process-wide request that the fit's
//! iteration loops check, so a caller that learns of an interrupt (the Python package on
//! Ctrl-C) can stop a running calibration within one iteration.
//!
//! Process-wide like the signal it stands for: a request stops every computation running
//! in the process at its next check, and the requester clears it when its call has ended.
//! Beside it, a thread may carry its own stops: the engine abandons a speculative
//! computation whose result it will not read (a restart beyond the one that settled the
//! search) by the same checks.
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

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

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

std::thread_local! {
    /// This thread's own stops, beside the process-wide one ([`abandon_when`]).
    static ABANDON: RefCell<Option<Vec<Arc<AtomicBool>>>> = const { RefCell::new(None) };
}

/// While the returned guard lives, [`check`] on this thread also fails once `flag` is set
/// (or a flag an enclosing guard set): a speculative computation whose result will not be
/// read (a restart beyond the one that settled the search) is abandoned at its next check
/// instead of run to its end.
pub(crate) fn abandon_when(flag: Arc<AtomicBool>) -> AbandonGuard {
    let outer = ABANDON.with(|a| a.borrow_mut().replace(Vec::new()));
    let mut flags = outer.clone().unwrap_or_default();
    flags.push(flag);
    ABANDON.with(|a| *a.borrow_mut() = Some(flags));
    AbandonGuard {
        outer,
        _thread: std::marker::PhantomData,
    }
}

/// Restores the thread's previous stops when dropped ([`abandon_when`]); it stays on the
/// thread it was made on.
pub(crate) struct AbandonGuard {
    outer: Option<Vec<Arc<AtomicBool>>>,
    _thread: std::marker::PhantomData<*const ()>,
}

impl Drop for AbandonGuard {
    fn drop(&mut self) {
        let outer = self.outer.take();
        ABANDON.with(|a| *a.borrow_mut() = outer);
    }
}

/// `Err` (an [`ErrorClass::Other`](crate::error::ErrorClass::Other) error saying
/// [`CANCELLED`]) when a stop is requested, or this thread's computation abandoned.
///
/// # Errors
/// When [`request`] was called and [`clear`] not since, or when a flag this thread's
/// computation is abandoned by is set (`abandon_when`, the restarts' speculative fits).
pub fn check() -> Result<()> {
    let abandoned = || {
        ABANDON
            .try_with(|a| {
                a.borrow()
                    .iter()
                    .flatten()
                    .any(|f| f.load(Ordering::Relaxed))
            })
            .unwrap_or(false)
    };
    if requested() || abandoned() {
        Err(Error::other(CANCELLED))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An abandon flag stops this thread's checks only, and only while its guard lives.
    #[test]
    fn an_abandoned_thread_stops_at_its_next_check_alone() {
        let flag = Arc::new(AtomicBool::new(false));
        {
            let _guard = abandon_when(Arc::clone(&flag));
            assert!(check().is_ok());
            flag.store(true, Ordering::SeqCst);
            assert!(check().is_err());
            std::thread::scope(|s| {
                assert!(s.spawn(check).join().unwrap().is_ok(), "another thread");
            });
        }
        assert!(check().is_ok(), "after the guard");
    }
}
