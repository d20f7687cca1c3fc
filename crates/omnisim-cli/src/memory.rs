//! Whether a render fits the memory this process may use, decided before anything is traced:
//! a 100-megapixel render needs gigabytes, and one killed for memory half-way (or aborted by a
//! failed allocation) has spent its time for nothing.

use anyhow::bail;

/// What a render keeps besides its per-pixel planes: the program, scene and BVH, encoder
/// state, thread stacks (a 100×100 render peaks at 105 MB resident).
pub(crate) const FIXED_BYTES: u64 = 64 << 20;

/// Address space glibc reserves for each thread's allocator arena (64 MiB on 64-bit systems),
/// taken by the worker threads that allocate; it counts against `ulimit -v`, though little of
/// it is ever resident. Under such a limit a render of 1 megapixel on 2 threads failed up to
/// 276 MiB, where its planes take 55 MB.
const ARENA_BYTES: u64 = 64 << 20;

/// A ceiling on the memory this process may still take, and where it comes from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Limit {
    pub bytes: u64,
    pub what: &'static str,
    /// Whether it bounds address space (reserved, not only resident memory).
    pub address_space: bool,
}

/// The ceilings Linux sets: the address space left under `ulimit -v`, the cgroup's
/// `memory.max` less what the cgroup uses, and RAM + swap. None elsewhere.
pub(crate) fn limits() -> Vec<Limit> {
    let mut limits = Vec::new();
    let read = |path: &str| std::fs::read_to_string(path).ok();
    // "Max address space   <soft> <hard> bytes": the soft limit is the one enforced.
    let address_space = read("/proc/self/limits").and_then(|text| {
        let line = text.lines().find(|l| l.starts_with("Max address space"))?;
        line.split_whitespace().nth(3)?.parse::<u64>().ok()
    });
    if let Some(limit) = address_space {
        let used = read("/proc/self/status")
            .and_then(|text| kib_field(&text, "VmSize:"))
            .unwrap_or(0);
        limits.push(Limit {
            bytes: limit.saturating_sub(used),
            what: "the address space left under ulimit -v",
            address_space: true,
        });
    }
    // cgroup v2: "0::/path" names this process's group.
    let group =
        read("/proc/self/cgroup").and_then(|text| text.lines().find_map(|l| l.strip_prefix("0::").map(str::to_string)));
    if let Some(group) = group {
        let file =
            |name: &str| read(&format!("/sys/fs/cgroup{group}/{name}")).and_then(|t| t.trim().parse::<u64>().ok());
        if let Some(max) = file("memory.max") {
            limits.push(Limit {
                bytes: max.saturating_sub(file("memory.current").unwrap_or(0)),
                what: "the memory left to its cgroup (memory.max)",
                address_space: false,
            });
        }
    }
    if let Some(meminfo) = read("/proc/meminfo")
        && let Some(ram) = kib_field(&meminfo, "MemTotal:")
    {
        limits.push(Limit {
            bytes: ram + kib_field(&meminfo, "SwapTotal:").unwrap_or(0),
            what: "the memory of this machine (RAM and swap)",
            address_space: false,
        });
    }
    limits
}

/// Address space a render needing `resident` bytes reserves: that, and an allocator arena for
/// each worker thread and one more.
pub(crate) fn address_space(resident: u64) -> u64 {
    let threads = std::thread::available_parallelism().map_or(1, std::num::NonZero::get) as u64;
    resident + (threads + 1) * ARENA_BYTES
}

/// A "Name:   1234 kB" field of a /proc file, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    Some(line.split_whitespace().nth(1)?.parse::<u64>().ok()? * 1024)
}

/// Refuses a render that keeps `resident` bytes (and reserves `address_space(resident)`)
/// where that exceeds one of `limits`, or where allocating it fails (reserved once, fallibly,
/// and given back: what would otherwise abort the render part-way). `what` says what needs it.
pub(crate) fn check(resident: u64, address_space: u64, what: &str, limits: &[Limit]) -> anyhow::Result<()> {
    for limit in limits {
        let need = if limit.address_space { address_space } else { resident };
        if need > limit.bytes {
            bail!(
                "{what} needs about {}{}, more than {} ({}): render a smaller image, fewer outputs or fewer views",
                gigabytes(need),
                if limit.address_space { " of address space" } else { "" },
                limit.what,
                gigabytes(limit.bytes)
            );
        }
    }
    let mut probe: Vec<u8> = Vec::new();
    if let Err(error) = usize::try_from(resident)
        .map_err(|_| None)
        .and_then(|n| probe.try_reserve_exact(n).map_err(Some))
    {
        bail!(
            "{what} needs about {}, which this process cannot allocate{}: render a smaller image, fewer outputs \
             or fewer views",
            gigabytes(resident),
            error.map(|e| format!(" ({e})")).unwrap_or_default()
        );
    }
    Ok(())
}

/// Bytes in GB (10⁹), to two significant decimals for small amounts.
fn gigabytes(bytes: u64) -> String {
    format!("{:.2} GB", bytes as f64 / 1e9)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_need_over_a_limit_is_refused_naming_both() {
        let limits = [
            Limit {
                bytes: 8_000_000_000,
                what: "the memory of this machine (RAM and swap)",
                address_space: false,
            },
            Limit {
                bytes: 4_000_000_000,
                what: "the address space left under ulimit -v",
                address_space: true,
            },
        ];
        let message = check(3_500_000_000, 4_100_000_000, "a 10000x10000 render", &limits)
            .unwrap_err()
            .to_string();
        assert_eq!(
            message,
            "a 10000x10000 render needs about 4.10 GB of address space, more than the address space left under \
             ulimit -v (4.00 GB): render a smaller image, fewer outputs or fewer views"
        );
        let message = check(9_000_000_000, 9_000_000_000, "a render", &limits)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("9.00 GB, more than the memory of this machine (RAM and swap) (8.00 GB)"),
            "{message}"
        );
        // Resident memory is held against resident limits, address space against address space.
        assert!(check(3_000_000_000, 3_900_000_000, "a render", &limits).is_ok());
    }

    /// Past every stated limit, an allocation that fails is refused up front too.
    #[test]
    fn a_need_that_cannot_be_allocated_is_refused() {
        let message = check(u64::MAX / 2, u64::MAX / 2, "a render", &[])
            .unwrap_err()
            .to_string();
        assert!(message.contains("cannot allocate"), "{message}");
    }

    #[test]
    fn proc_fields_read_in_bytes() {
        assert_eq!(
            kib_field("MemTotal:   2048 kB\nSwapTotal: 0 kB\n", "MemTotal:"),
            Some(2 << 20)
        );
        assert_eq!(kib_field("VmSize: x kB", "VmSize:"), None);
    }

    /// Where Linux states limits, they are found: this machine's RAM at least.
    #[cfg(target_os = "linux")]
    #[test]
    fn this_machine_states_its_memory() {
        let limits = limits();
        assert!(
            limits.iter().any(|l| l.what.contains("RAM") && l.bytes > 100 << 20),
            "{limits:?}"
        );
        assert!(address_space(1) > ARENA_BYTES);
    }
}
