//! How much memory this process may still take, so that work too large for it is refused
//! with a message before it starts, not ended by the allocator's abort or the kernel's OOM
//! killer with nothing said.
//!
//! Three limits count, the least wins: the machine's `MemAvailable` (`/proc/meminfo`), in a
//! container what its cgroup (v2) leaves (`memory.max − memory.current`), and under an
//! address-space limit (`ulimit -v`, `prlimit --as`) what the limit leaves of the process's
//! virtual size (`/proc/self/limits`, `VmSize`). Where none can be read (not Linux), nothing
//! is known.

/// What the process may still allocate: the least of the three limits (module docs), `None`
/// where none can be read.
#[must_use]
pub fn available() -> Option<u64> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let machine = read("/proc/meminfo").and_then(|text| {
        text.lines()
            .find_map(|l| l.strip_prefix("MemAvailable:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            .map(|kb| kb.saturating_mul(1024))
    });
    // "max" (no limit) does not parse: the machine's figure stands alone.
    let cgroup = read("/sys/fs/cgroup/memory.max")
        .and_then(|m| m.trim().parse::<u64>().ok())
        .map(|max| {
            let used = read("/sys/fs/cgroup/memory.current")
                .and_then(|c| c.trim().parse::<u64>().ok())
                .unwrap_or(0);
            max.saturating_sub(used)
        });
    [machine, cgroup, address_space_left()]
        .into_iter()
        .flatten()
        .min()
}

/// The memory a large piece of work may plan on: 80 % of [`available`] (the rest for what
/// the estimate leaves out), 8 GB where nothing can be read.
#[must_use]
pub fn budget() -> u64 {
    available().map_or(8_000_000_000, |b| b / 5 * 4)
}

/// What an address-space limit leaves this process: the soft limit of `/proc/self/limits`
/// ("Max address space") less the process's virtual size (`VmSize` of `/proc/self/status`);
/// `None` when unlimited or unreadable.
#[must_use]
pub fn address_space_left() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let soft = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?
        .strip_prefix("Max address space")?
        .split_whitespace()
        .next()?
        .parse::<u64>()
        .ok()?;
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let size = status
        .lines()
        .find_map(|l| l.strip_prefix("VmSize:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .map_or(0, |kb| kb.saturating_mul(1024));
    Some(soft.saturating_sub(size))
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_budget_is_positive_and_below_what_is_available() {
        let b = super::budget();
        assert!(b > 0);
        if let Some(a) = super::available() {
            assert!(b <= a);
        }
    }
}
