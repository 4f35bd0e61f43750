//! The basis half built ahead, on a thread of its own, from the moment a fit's model is made
//! ([`super::SymbolicModel::for_fitting_prefetching`]).
//!
//! A calibration reports `K` (`basis_size`), and the start plan may need it, but the
//! expansion that gives it does not depend on the data. Started before the identifiability
//! analysis and the data reading, it overlaps them and the fit instead of following them.
//! `K` comes first from the certificate of a basis of grid monomials ([`super::coverage`],
//! about a millisecond for the repository's 6- and 7-joint arms), exact, and then the thread
//! is done: a run that reads the basis itself (the linear method) builds it on demand, on
//! both cores, which measured no slower than a build ahead that held one of them. Where the
//! certificate claims nothing (parallel axes, whose basis functions are sums of products,
//! a shared variable, a grid beyond its bounds), a
//! sketch of the expansion ([`super::sketch`]) gives `K` in a fraction of the exact
//! expansion's time, or shows the expansion beyond its bounds (the thread then ends without
//! `K`, as the exact build would, in more time). Where the sketch gives nothing certain
//! either (rows of `E` with several terms, a spec beyond its layout, a parameter's degree
//! bound past 15), the thread builds the exact part and hands `K` over as soon as the
//! reduction knows it (from a one-pass count or from the echelon form,
//! [`super::reduce::reduce_with`]), the whole part (basis functions, `c`) when it ends. The
//! thread builds within the report's bounds ([`super::model::REPORT_MAX_TERMS`]), so a spec
//! too large to report refuses it in moments, as the report would.

use super::basis_part::{expand_and_reduce_with, BasisPart, KnownBasisSize};
use super::sketch::Sketched;
use crate::spec::Spec;
use std::sync::mpsc::{self, TryRecvError};
use std::sync::Mutex;
use std::thread::JoinHandle;

#[cfg(test)]
thread_local! {
    /// Tests only: how long a build started from this thread waits before it begins, so that
    /// a test can be sure its caller asks for `K` before the build gives it.
    pub(crate) static DELAY: std::cell::Cell<std::time::Duration> =
        const { std::cell::Cell::new(std::time::Duration::ZERO) };
}

/// Where `K` stands: still to arrive on the channel, or received (`None`: the build failed
/// before the reduction gave it).
enum SizeState {
    Waiting(mpsc::Receiver<KnownBasisSize>),
    Received(Option<KnownBasisSize>),
}

/// A basis half being built on another thread; see the [module docs](self).
pub(super) struct Prefetch {
    /// `K`, once received from the thread.
    size: Mutex<SizeState>,
    /// The thread, until its part is taken (`None` from it: no part built, the certificate's
    /// or the sketch's `K` sufficed, or the build failed).
    part: Mutex<Option<JoinHandle<Option<BasisPart>>>>,
}

impl std::fmt::Debug for Prefetch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Prefetch")
            .field("received", &self.basis_size_received())
            .finish_non_exhaustive()
    }
}

impl Prefetch {
    /// Starts building `spec`'s basis half within `max_terms` per polynomial and `max_total`
    /// terms in all. `None` when no thread can be started (the caller builds on demand).
    pub(super) fn start(spec: &Spec, max_terms: usize, max_total: usize) -> Option<Self> {
        let spec = spec.clone();
        let (tx, rx) = mpsc::sync_channel(1);
        #[cfg(test)]
        let delay = DELAY.with(std::cell::Cell::get);
        // The core is marked taken before the thread exists, so that work started right
        // after this call (the identifiability analysis) sees it held; dropped with the
        // closure if the spawn fails.
        let core = crate::cores::Taken::new();
        let (placement, placed) = crate::cores::Placement::new();
        let thread = std::thread::Builder::new()
            .name("lincal-basis".into())
            .spawn(move || {
                let _core = core;
                placement.wait_and_release();
                #[cfg(test)]
                std::thread::sleep(delay);
                super::link::SERIAL.with(|s| s.set(true));
                // The receiver may be gone (nobody asked for `K`): nothing to tell then.
                // A basis of grid monomials has its `K` proven without the expansion (in a
                // millisecond for the repository's arms, `super::coverage`); else the sketch,
                // else the exact build; beyond their bounds no `K`.
                if let Some(k) = super::coverage::grid_basis_size(&spec) {
                    let _ = tx.send(KnownBasisSize { k, terms: 0 });
                    return None;
                }
                match super::sketch::basis_size(&spec, max_terms, Some(max_total)) {
                    Sketched::Known(k) => {
                        let _ = tx.send(k);
                        return None;
                    }
                    // The exact build would fail its bounds as surely.
                    Sketched::Beyond => return None,
                    Sketched::Unknown => {}
                }
                expand_and_reduce_with(&spec, max_terms, Some(max_total), |k| {
                    let _ = tx.send(k);
                })
                .ok()
                .map(|(part, _)| part)
            })
            .ok()?;
        crate::cores::start_elsewhere(&thread);
        // The thread goes on once its half of the handshake is gone.
        drop(placed);
        Some(Prefetch {
            size: Mutex::new(SizeState::Waiting(rx)),
            part: Mutex::new(Some(thread)),
        })
    }

    /// `K` and the expansion's size, waiting for the reduction if need be; `None` when the
    /// build failed (beyond its bounds) before giving them.
    pub(super) fn basis_size(&self) -> Option<KnownBasisSize> {
        let mut state = self.size.lock().ok()?;
        if let SizeState::Waiting(rx) = &*state {
            *state = SizeState::Received(rx.recv().ok());
        }
        match *state {
            SizeState::Received(k) => k,
            SizeState::Waiting(_) => None,
        }
    }

    /// `K` if the thread has sent it already, read from the channel if need be; never waits
    /// (`None` too while another caller waits in [`Prefetch::basis_size`]).
    pub(super) fn basis_size_received(&self) -> Option<KnownBasisSize> {
        let mut state = self.size.try_lock().ok()?;
        if let SizeState::Waiting(rx) = &*state {
            match rx.try_recv() {
                Ok(k) => *state = SizeState::Received(Some(k)),
                Err(TryRecvError::Disconnected) => *state = SizeState::Received(None),
                Err(TryRecvError::Empty) => return None,
            }
        }
        match *state {
            SizeState::Received(k) => k,
            SizeState::Waiting(_) => None,
        }
    }

    /// Whether `K` may still come: not yet received, and the thread still running (never
    /// waits; `true` while another caller waits in [`Prefetch::basis_size`]).
    pub(super) fn size_pending(&self) -> bool {
        let Ok(mut state) = self.size.try_lock() else {
            return true;
        };
        if let SizeState::Waiting(rx) = &*state {
            match rx.try_recv() {
                Ok(k) => *state = SizeState::Received(Some(k)),
                Err(TryRecvError::Disconnected) => *state = SizeState::Received(None),
                Err(TryRecvError::Empty) => return true,
            }
        }
        false
    }

    /// The built part, waiting for the thread; `None` once taken, or when the thread built
    /// none (the certificate or the sketch gave `K`, or the build failed): the caller builds it. A panic on the
    /// thread is resumed here, as if the build had run on the caller's.
    pub(super) fn take_part(&self) -> Option<BasisPart> {
        let thread = self.part.lock().ok()?.take()?;
        thread
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e))
    }
}

#[cfg(test)]
mod tests {
    use crate::model::CalibModel;
    use crate::spec::from_yaml_file;
    use crate::symbolic::{SymbolicModel, DEFAULT_MAX_TERMS, REPORT_MAX_TERMS};

    /// For every spec of the test set (and the bench's PUMA with measured tips, whose `K`
    /// is beyond the sampled bound's reach): a model whose basis half is built ahead answers
    /// every question about `K` and the basis as the model that builds it on demand, and its
    /// facts for the cache are the same.
    #[test]
    fn prefetched_model_answers_as_the_lazy_one() {
        let mut paths = crate::symbolic::testutil::repo_spec_paths(&["tests/specs"]);
        paths.push("bench/specs/puma560_mdh_measured.yaml".into());
        let mut checked = 0;
        for name in paths {
            let spec = crate::symbolic::testutil::repo_spec(&name);
            let lazy = SymbolicModel::for_fitting(&spec, DEFAULT_MAX_TERMS).expect("model");
            let ahead = SymbolicModel::for_fitting_prefetching(&spec, DEFAULT_MAX_TERMS, None)
                .expect("model");
            let k_report = lazy.basis_size_for_report();
            assert_eq!(ahead.basis_size_for_report(), k_report, "{name}");
            let k = k_report.expect("a test spec's K is reported");
            for t in [0, k / 2, k.saturating_sub(1), k, k + 1] {
                if let Some(lazy_says) = lazy.basis_exceeds(t) {
                    assert_eq!(ahead.basis_exceeds(t), Some(lazy_says), "{name}: t = {t}");
                }
                // The prefetched `K` decides where the sampled bound cannot.
                assert_eq!(ahead.basis_exceeds(t), Some(t < k), "{name}: t = {t}");
            }
            assert_eq!(ahead.facts(), lazy.facts(), "{name}");
            assert!(
                ahead.basis_ready().is_ok() && lazy.basis_ready().is_ok(),
                "{name}"
            );
            assert_eq!(ahead.basis_size(), k, "{name}");
            let names = |m: &SymbolicModel| {
                (0..k)
                    .map(|i| m.basis_name(i).to_string())
                    .collect::<Vec<_>>()
            };
            assert_eq!(names(&ahead), names(&lazy), "{name}");
            checked += 1;
        }
        assert!(checked > 5, "only {checked} specs checked");
    }

    /// Where the certificate of grid monomials or the sketch gives `K` (a chain whose
    /// parameters are all unknown) the thread tells it and builds no part; where neither does
    /// (a known length makes rows of two terms), the thread builds the exact part, and tells
    /// the same `K` as the reduction.
    #[test]
    fn the_thread_builds_the_part_only_where_no_k_comes_without_it() {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
        let read =
            |p: &str| from_yaml_file(std::path::Path::new(&format!("{root}/{p}"))).expect("spec");
        let puma = read("bench/specs/puma560_mdh_measured.yaml");
        let p = super::Prefetch::start(&puma, DEFAULT_MAX_TERMS, REPORT_MAX_TERMS).expect("thread");
        assert_eq!(p.basis_size().map(|b| b.k), Some(729));
        assert!(p.take_part().is_none());
        let mut built = 0;
        for name in [
            "plane_spatial",
            "sphere_mdh",
            "circle_planar3",
            "measured_spatial",
        ] {
            let spec = read(&format!("tests/specs/{name}.yaml"));
            let p =
                super::Prefetch::start(&spec, DEFAULT_MAX_TERMS, REPORT_MAX_TERMS).expect("thread");
            let k = p.basis_size().expect("K").k;
            if let Some(part) = p.take_part() {
                assert_eq!(part.reduction.basis.len(), k, "{name}");
                built += 1;
            }
        }
        assert!(built > 0, "every spec's K came without the expansion");
    }
}
