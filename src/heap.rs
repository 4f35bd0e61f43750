//! Tuning of the C allocator for lincal's two phases (glibc on Linux; nothing elsewhere).
//!
//! The symbolic engine builds and frees many small hash-map entries and big-rational
//! coefficients. With glibc's default top pad (128 KiB) the heap is grown and trimmed again
//! and again, and every regrowth faults in fresh zeroed pages: a tenth of a small
//! calibration's run time. A 16 MiB pad keeps those pages. Once the model is built, what it
//! freed goes back to the system before the readings are loaded, so a million poses do not
//! sit on top of the engine's scratch space (BENCHMARKS.md has both measurements). Setting
//! the pad also fixes glibc's mmap threshold at its default (128 KiB) for the rest of the
//! run, instead of letting it adapt; the fitting phase was measured with that in place.

/// Heap growth step while the engine runs.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const ENGINE_TOP_PAD: libc::c_int = 16 << 20;

/// Sets the allocator up for the symbolic engine (call once, first thing).
pub fn tune_for_engine() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes a tuning parameter of the allocator; called before any
    // other thread exists.
    unsafe {
        libc::mallopt(libc::M_TOP_PAD, ENGINE_TOP_PAD);
    }
}

/// Returns the engine's freed scratch memory to the system and goes back to the default
/// growth step (call once the model is built, before the data are read).
pub fn release_engine_scratch() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: both calls only adjust and trim the allocator's own free lists; they are
    // thread-safe in glibc.
    unsafe {
        libc::mallopt(libc::M_TOP_PAD, 128 << 10);
        libc::malloc_trim(0);
    }
}
