//! Tuning of the C allocator for lincal's two phases (glibc on Linux; nothing elsewhere).
//!
//! The symbolic engine builds and frees many small hash-map entries and big-rational
//! coefficients. With glibc's default top pad (128 KiB) the heap is grown and trimmed again
//! and again, and every regrowth faults in fresh zeroed pages: a tenth of a small
//! calibration's run time. A 16 MiB pad keeps those pages. Once the model is built, what it
//! freed goes back to the system before the readings are loaded, so a million poses do not
//! sit on top of the engine's scratch space (BENCHMARKS.md has both measurements). For the
//! fit, the mmap and trim thresholds are then raised, so that its per-iteration buffers are
//! reused instead of mapped and unmapped again ([`release_engine_scratch`]).

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

/// Allocations below this come from the heap during the fit, and freed ones are reused.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const FIT_MMAP_THRESHOLD: libc::c_int = 32 << 20;

/// Free memory at the heap's top beyond this goes back to the system during the fit.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const FIT_TRIM_THRESHOLD: libc::c_int = 64 << 20;

/// Returns the engine's freed scratch memory to the system and goes back to the default
/// growth step (call once the model is built, before the data are read). Then sets up the
/// fit: its passes over the poses allocate and free the same buffers of a few hundred
/// kilobytes to megabytes on every iteration, on several threads. Under glibc's default
/// 128 KiB mmap threshold each is a fresh `mmap` and `munmap`: page faults, and TLB shootdowns
/// across the threads (with 10 000 measured PUMA poses, 31 000 page faults and half the run
/// time). From the heap, with a trim threshold above them, they are reused: 0.10 → 0.045 s
/// there, peak memory 7.8 → 9.7 MB (BENCHMARKS.md).
pub fn release_engine_scratch() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: these calls only adjust and trim the allocator's own free lists and tuning
    // parameters; they are thread-safe in glibc.
    unsafe {
        libc::mallopt(libc::M_TOP_PAD, 128 << 10);
        libc::malloc_trim(0);
        libc::mallopt(libc::M_MMAP_THRESHOLD, FIT_MMAP_THRESHOLD);
        libc::mallopt(libc::M_TRIM_THRESHOLD, FIT_TRIM_THRESHOLD);
    }
}
