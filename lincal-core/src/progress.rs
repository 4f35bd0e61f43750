//! Progress of long runs, as a callback: the core says what it is doing and how far it got;
//! whoever calls it decides whether and how to show that (the `lincal` binary draws a bar on
//! stderr when it is a terminal, with indicatif; a library user passes [`NoProgress`]).
//!
//! Callers of a [`Progress`] report per chunk of work ([`CHUNK`] poses, or a megabyte of a
//! file), never per pose, so a progress report costs nothing measurable in a hot loop.
//!
//! # Example
//! ```
//! use std::sync::atomic::{AtomicU64, Ordering};
//! use lincal_core::progress::Progress;
//!
//! /// Counts what it is told.
//! #[derive(Default)]
//! struct Count(AtomicU64);
//! impl Progress for Count {
//!     fn inc(&self, delta: u64) {
//!         self.0.fetch_add(delta, Ordering::Relaxed);
//!     }
//! }
//!
//! let count = Count::default();
//! count.stage("reading", Some(10));
//! count.inc(4);
//! count.inc(6);
//! count.finish();
//! assert_eq!(count.0.load(Ordering::Relaxed), 10);
//! ```

/// Poses between two progress reports in a loop over poses.
pub const CHUNK: usize = 4096;

/// Bytes between two progress reports while a file is read.
pub const READ_CHUNK: u64 = 1 << 20;

/// Receives progress reports. Every method has a no-op default, so an implementation picks
/// what it shows. Implementations are shared across the threads of a computation (`Sync`),
/// so they take `&self`.
pub trait Progress: Sync {
    /// A new stage begins, named for a person (`"reading data.csv"`, `"fitting"`), with its
    /// length in units of [`Progress::inc`] when known (`None`: of unknown length).
    fn stage(&self, name: &str, len: Option<u64>) {
        let _ = (name, len);
    }

    /// `delta` more units of the current stage are done.
    fn inc(&self, delta: u64) {
        let _ = delta;
    }

    /// The whole run is done (what is shown can be cleared).
    fn finish(&self) {}
}

/// Shows nothing: the progress of a caller that does not want any.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoProgress;

impl Progress for NoProgress {}

/// A reader that reports the bytes read to a [`Progress`], every [`READ_CHUNK`] bytes and at
/// the end of the input.
pub struct ProgressRead<'a, R> {
    inner: R,
    progress: &'a dyn Progress,
    pending: u64,
}

impl<'a, R> ProgressRead<'a, R> {
    /// Wraps `inner`; the bytes read go to `progress` (the caller starts the stage).
    pub fn new(inner: R, progress: &'a dyn Progress) -> Self {
        ProgressRead {
            inner,
            progress,
            pending: 0,
        }
    }
}

impl<R: std::io::Read> std::io::Read for ProgressRead<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.pending += n as u64;
        if self.pending >= READ_CHUNK || (n == 0 && self.pending > 0) {
            self.progress.inc(self.pending);
            self.pending = 0;
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read as _;
    use std::sync::atomic::{AtomicU64, Ordering};

    #[derive(Default)]
    struct Count {
        bytes: AtomicU64,
        calls: AtomicU64,
    }
    impl Progress for Count {
        fn inc(&self, delta: u64) {
            self.bytes.fetch_add(delta, Ordering::Relaxed);
            self.calls.fetch_add(1, Ordering::Relaxed);
        }
    }

    #[test]
    fn reader_reports_every_byte_in_chunks() {
        let data = vec![7u8; 3 * READ_CHUNK as usize + 5];
        let count = Count::default();
        let mut r = ProgressRead::new(&data[..], &count);
        let mut sink = Vec::new();
        r.read_to_end(&mut sink).unwrap();
        assert_eq!(sink.len(), data.len());
        assert_eq!(count.bytes.load(Ordering::Relaxed), data.len() as u64);
        assert!(count.calls.load(Ordering::Relaxed) <= 5);
    }

    #[test]
    fn no_progress_is_silent() {
        let p = NoProgress;
        p.stage("x", None);
        p.inc(1);
        p.finish();
    }
}
