//! Cores taken by work that runs in the background of a computation (the basis built ahead,
//! [`crate::symbolic`]), so that speculative parallel work does not compete with it, and
//! where a computation's helper threads start.
//!
//! The fit from the nominals runs its starts on two threads when a core is free, a start
//! beyond the one that settles the search speculatively (it is abandoned unread). While the
//! basis is being built on the other core of a two-core machine, a second thread would take
//! that core from the build, whose `K` the same run is about to wait for: the starts then
//! run one at a time. The results do not depend on it (the two threads give the sequential
//! search bit for bit), only the time does.
//!
//! Where a helper thread starts matters as much on this kind of machine (2 vCPUs): a thread
//! just spawned is queued beside its parent and may wait for the other CPU's next balancing
//! tick, or for its parent to block, before it runs (the build ahead was measured starting
//! 0.6 to 4.8 ms after its spawn; a scoped helper beside a busy parent, a median 1.6 ms).
//! `start_elsewhere` moves the build ahead off the caller's CPU at once, and
//! `spawn_elsewhere` and `map_parts` start a computation's scoped helpers elsewhere.
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

/// Moves a thread just spawned off the calling thread's CPU, so that it starts at once on
/// another (Linux, two CPUs or more; elsewhere nothing). A new thread is queued beside its
/// parent, and an idle CPU may pull it only at its next balancing tick: measured here, the
/// build ahead started 0.6 to 4.8 ms after its spawn, while the run it serves takes 10 ms.
/// Where the kernel has already put it on another CPU, narrowing it to the others changes
/// nothing.
///
/// The thread must not have started its work yet, nor ended: it waits at a [`Placement`]
/// until the caller has placed it (and dropped its half of [`Placement::new`]), then calls
/// [`Placement::wait_and_release`], which gives it back the caller's CPU set, so that the
/// scheduler may move it again.
pub(crate) fn start_elsewhere<T>(thread: &std::thread::JoinHandle<T>) {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::thread::JoinHandleExt;
        let others = here()
            .zip(AffinityMask::current())
            .and_then(|(h, m)| m.without(h));
        if let Some(others) = others {
            // SAFETY: the set is plain data, passed with its size; the handle's thread is
            // alive: it waits at its `Placement` until the caller has called this function.
            unsafe {
                libc::pthread_setaffinity_np(
                    thread.as_pthread_t(),
                    std::mem::size_of::<libc::cpu_set_t>(),
                    &others.0,
                );
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = thread;
}

/// The calling thread's CPU now, when known.
#[cfg(target_os = "linux")]
fn here() -> Option<usize> {
    // SAFETY: `sched_getcpu` reads the calling thread's CPU.
    usize::try_from(unsafe { libc::sched_getcpu() }).ok()
}

/// The handshake of [`start_elsewhere`]: made by the caller before the spawn, its
/// [`Placement::wait_and_release`] half moved into the thread.
pub(crate) struct Placement {
    mask: Option<AffinityMask>,
    placed: std::sync::mpsc::Receiver<()>,
}

impl Placement {
    /// A handshake for a thread about to be spawned from the calling thread, and the
    /// caller's half: dropping it (after [`start_elsewhere`], or when giving up) lets the
    /// thread go on.
    pub(crate) fn new() -> (Placement, std::sync::mpsc::Sender<()>) {
        let (tx, rx) = std::sync::mpsc::channel();
        let placement = Placement {
            mask: AffinityMask::current(),
            placed: rx,
        };
        (placement, tx)
    }

    /// In the new thread, first: waits until the caller has placed it (or given up: the
    /// caller's half dropped either way), then allows it every CPU its caller had.
    pub(crate) fn wait_and_release(self) {
        let _ = self.placed.recv();
        #[cfg(target_os = "linux")]
        if let Some(mask) = self.mask {
            mask.apply();
        }
    }
}

/// A thread's CPU set: the caller's, read before [`start_elsewhere`] narrows a new thread's
/// (for [`Placement::wait_and_release`]), and the sets [`spawn_elsewhere`]'s handshake moves
/// threads with.
#[derive(Clone, Copy)]
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
pub(crate) struct AffinityMask(#[cfg(target_os = "linux")] libc::cpu_set_t);

impl AffinityMask {
    /// The calling thread's CPU set (`None` where it cannot be read).
    pub(crate) fn current() -> Option<AffinityMask> {
        #[cfg(target_os = "linux")]
        {
            // SAFETY: as in `start_elsewhere`.
            unsafe {
                let mut set: libc::cpu_set_t = std::mem::zeroed();
                (libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) == 0)
                    .then_some(AffinityMask(set))
            }
        }
        #[cfg(not(target_os = "linux"))]
        None
    }

    /// This set without CPU `cpu`, when that leaves another.
    #[cfg(target_os = "linux")]
    fn without(&self, cpu: usize) -> Option<AffinityMask> {
        let mut set = self.0;
        if cpu >= 8 * std::mem::size_of::<libc::cpu_set_t>() {
            return None;
        }
        // SAFETY: plain data; the index is checked against the set's size.
        unsafe {
            libc::CPU_CLR(cpu, &mut set);
            (libc::CPU_COUNT(&set) > 0).then_some(AffinityMask(set))
        }
    }

    /// The set of CPU `cpu` alone.
    #[cfg(target_os = "linux")]
    fn only(cpu: usize) -> Option<AffinityMask> {
        if cpu >= 8 * std::mem::size_of::<libc::cpu_set_t>() {
            return None;
        }
        // SAFETY: as in `without`.
        unsafe {
            let mut set: libc::cpu_set_t = std::mem::zeroed();
            libc::CPU_SET(cpu, &mut set);
            Some(AffinityMask(set))
        }
    }

    /// Makes this the calling thread's CPU set (a failure leaves it as it was).
    #[cfg(target_os = "linux")]
    fn apply(&self) {
        // SAFETY: the set is plain data, passed with its size.
        unsafe {
            libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &self.0);
        }
    }
}

/// Spawns `f` on `scope` so that it starts at once on another CPU (Linux, two CPUs or
/// more; elsewhere a plain spawn): for the scoped helpers of a computation, which a new
/// thread queued beside its parent would otherwise start only when the parent blocks or the
/// other CPU balances (measured on this 2-vCPU machine: a median 1.6 ms after the spawn, so
/// that two fits of a millisecond each ran one after the other).
///
/// The handshake: the new thread, when it first runs, moves itself off the caller's CPU
/// (its own affinity, which migrates it at once), tells the caller, and takes back every CPU
/// the caller had. The caller waits for that, pinned to its own CPU meanwhile so that the
/// wake-up does not pull it onto the helper's; then it has its CPU set back. About 0.1-0.3 ms
/// in all, against the milliseconds of a fit.
pub(crate) fn spawn_elsewhere<'scope, T, F>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    f: F,
) -> std::thread::ScopedJoinHandle<'scope, T>
where
    F: FnOnce() -> T + Send + 'scope,
    T: Send + 'scope,
{
    #[cfg(target_os = "linux")]
    if let (Some(here), Some(mask)) = (here(), AffinityMask::current()) {
        if let Some(others) = mask.without(here) {
            let (started, on_its_way) = std::sync::mpsc::channel::<()>();
            let handle = scope.spawn(move || {
                others.apply();
                let _ = started.send(());
                mask.apply();
                f()
            });
            // A helper that panicked before telling drops its sender (no wait then); one
            // that a busy CPU holds back is not waited for beyond the handshake's usual time.
            let wait = std::time::Duration::from_micros(500);
            match AffinityMask::only(here) {
                Some(only_here) => {
                    only_here.apply();
                    let _ = on_its_way.recv_timeout(wait);
                    mask.apply();
                }
                None => {
                    let _ = on_its_way.recv_timeout(wait);
                }
            }
            return handle;
        }
    }
    scope.spawn(f)
}

/// `a()` on the calling thread and `b()` beside it on a thread started elsewhere
/// ([`spawn_elsewhere`]); both results. A panic in either is resumed here.
pub(crate) fn join<A, B, FA, FB>(a: FA, b: FB) -> (A, B)
where
    FA: FnOnce() -> A,
    FB: FnOnce() -> B + Send,
    B: Send,
{
    std::thread::scope(|s| {
        let other = spawn_elsewhere(s, b);
        let a = a();
        let b = other
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        (a, b)
    })
}

/// `work` on every one of `parts`, results in order: the first part on the calling thread,
/// the second on a scoped thread started elsewhere ([`spawn_elsewhere`]), any others on plain
/// scoped threads. Spawned threads that the caller only joined would all start beside it,
/// the first when it blocks and the rest when the other CPUs next balance; one handshake
/// serves the two-CPU machine, and the caller does not wait for one per part where there
/// are many CPUs (a pass of 10 000 poses splits into as many parts as cores, at every
/// linearisation).
pub(crate) fn map_parts<I, T, F>(parts: Vec<I>, work: F) -> Vec<T>
where
    I: Send,
    T: Send,
    F: Fn(I) -> T + Sync,
{
    let mut parts = parts.into_iter();
    let Some(first) = parts.next() else {
        return Vec::new();
    };
    std::thread::scope(|s| {
        let work = &work;
        let others: Vec<_> = parts
            .enumerate()
            .map(|(i, part)| {
                if i == 0 {
                    spawn_elsewhere(s, move || work(part))
                } else {
                    s.spawn(move || work(part))
                }
            })
            .collect();
        let mut out = Vec::with_capacity(others.len() + 1);
        out.push(work(first));
        out.extend(
            others
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))),
        );
        out
    })
}

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

#[cfg(test)]
mod tests {
    use super::*;

    /// Parts mapped on threads started elsewhere come back in order, each helper with the
    /// caller's CPUs, and the caller's own CPU set is as it was.
    #[test]
    fn parts_mapped_elsewhere_come_back_in_order() {
        let before = AffinityMask::current();
        let out = map_parts((0..5).collect(), |i: usize| {
            (i * i, AffinityMask::current())
        });
        assert_eq!(
            out.iter().map(|o| o.0).collect::<Vec<_>>(),
            [0, 1, 4, 9, 16]
        );
        let after = AffinityMask::current();
        #[cfg(target_os = "linux")]
        if let (Some(b), Some(a)) = (before, after) {
            // SAFETY: plain data sets.
            assert!(unsafe { libc::CPU_EQUAL(&b.0, &a.0) });
            for (_, inside) in &out {
                let i = inside.expect("a helper's CPU set");
                // SAFETY: as above.
                assert!(unsafe { libc::CPU_EQUAL(&b.0, &i.0) });
            }
        }
        #[cfg(not(target_os = "linux"))]
        assert!(before.is_none() && after.is_none() && out.iter().all(|o| o.1.is_none()));
        assert!(map_parts(Vec::<usize>::new(), |i| i).is_empty());
    }

    /// A thread placed elsewhere waits for its placement, then has its caller's CPUs again;
    /// the caller's own CPU set is untouched.
    #[test]
    fn a_placed_thread_gets_the_callers_cpus_back() {
        let before = AffinityMask::current();
        let (placement, placed) = Placement::new();
        let thread = std::thread::spawn(move || {
            placement.wait_and_release();
            AffinityMask::current()
        });
        start_elsewhere(&thread);
        drop(placed);
        let inside = thread.join().expect("thread");
        let after = AffinityMask::current();
        #[cfg(target_os = "linux")]
        if let (Some(b), Some(i), Some(a)) = (before, inside, after) {
            // SAFETY: plain data sets.
            assert!(unsafe { libc::CPU_EQUAL(&b.0, &i.0) && libc::CPU_EQUAL(&b.0, &a.0) });
        }
        #[cfg(not(target_os = "linux"))]
        assert!(before.is_none() && inside.is_none() && after.is_none());
    }
}
