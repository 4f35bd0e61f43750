//! Cores taken by work that runs in the background of a computation (the basis built ahead,
//! [`crate::symbolic`]), so that speculative parallel work does not compete with it.
//!
//! The fit from the nominals runs two starts at a time when a core is free, the second one
//! speculatively (it may be dropped unread). While the basis is being built on the other
//! core of a two-core machine, a second start would take that core from the build, whose
//! `K` the same run is about to wait for: the starts then run one at a time. The results do
//! not depend on it (the pairing is bit-for-bit the sequential search), only the time does.
//! Likewise the identifiability analysis evaluates its two sample points side by side only
//! when a core is free, and one after the other while the build holds it.
//!
//! # Example
//! ```
//! use lincal_core::cores;
//! let before = cores::busy();
//! {
//!     let _taken = cores::Taken::new();
//!     assert_eq!(cores::busy(), before + 1);
//! }
//! assert_eq!(cores::busy(), before);
//! ```

use std::sync::atomic::{AtomicUsize, Ordering};

static BUSY: AtomicUsize = AtomicUsize::new(0);

/// How many background threads hold a core now.
#[must_use]
pub fn busy() -> usize {
    BUSY.load(Ordering::Relaxed)
}

/// The machine's cores (1 to 8: the fit splits no finer), as `available_parallelism` gives
/// them once.
#[must_use]
pub fn available() -> usize {
    static COUNT: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *COUNT.get_or_init(|| {
        std::thread::available_parallelism()
            .map_or(1, std::num::NonZeroUsize::get)
            .clamp(1, 8)
    })
}

/// Cores no background work holds (at least 1: the caller's own).
#[must_use]
pub fn free() -> usize {
    available().saturating_sub(busy()).max(1)
}

/// A core held by a background thread, from [`Taken::new`] until dropped.
#[derive(Debug)]
pub struct Taken(());

impl Taken {
    /// Marks one core as taken.
    #[must_use]
    pub fn new() -> Self {
        BUSY.fetch_add(1, Ordering::Relaxed);
        Taken(())
    }
}

impl Default for Taken {
    fn default() -> Self {
        Self::new()
    }
}

impl Drop for Taken {
    fn drop(&mut self) {
        BUSY.fetch_sub(1, Ordering::Relaxed);
    }
}
