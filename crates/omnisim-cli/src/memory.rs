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
    /// Whether `bytes` is what is left after this process's present use (else the whole).
    pub left: bool,
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
            left: true,
        });
    }
    limits.extend(cgroup_limit(read));
    if let Some(meminfo) = read("/proc/meminfo")
        && let Some(ram) = kib_field(&meminfo, "MemTotal:")
    {
        limits.push(Limit {
            bytes: ram + kib_field(&meminfo, "SwapTotal:").unwrap_or(0),
            what: "the memory of this machine (RAM and swap)",
            address_space: false,
            left: false,
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

/// The memory left to this process's cgroup: v2's `memory.max` less `memory.current`, else v1's
/// `memory.limit_in_bytes` less `memory.usage_in_bytes` (hosts and older container runtimes
/// with v1 hierarchies; at the group's path, or at the hierarchy's root where a cgroup namespace
/// shows the group as the root). Either usage less the inactive file cache (`memory.stat`),
/// which the kernel reclaims before it fails an allocation, as `docker stats` counts it.
/// `read` reads a file's text.
fn cgroup_limit(read: impl Fn(&str) -> Option<String>) -> Option<Limit> {
    /// v1 writes a limit of "none" as the largest page-aligned i64.
    const UNLIMITED: u64 = 1 << 62;
    let number = |path: &str| read(path).and_then(|t| t.trim().parse::<u64>().ok());
    // A `memory.stat` field ("inactive_file 1234").
    let stat = |dir: &str, field: &str| {
        read(&format!("{dir}/memory.stat"))?
            .lines()
            .find_map(|l| l.strip_prefix(field)?.strip_prefix(' ')?.trim().parse::<u64>().ok())
    };
    let groups = read("/proc/self/cgroup")?;
    // "0::/path": this process's v2 group.
    if let Some(group) = groups.lines().find_map(|l| l.strip_prefix("0::"))
        && let Some(max) = number(&format!("/sys/fs/cgroup{group}/memory.max"))
    {
        let dir = format!("/sys/fs/cgroup{group}");
        let used = number(&format!("{dir}/memory.current"))
            .unwrap_or(0)
            .saturating_sub(stat(&dir, "inactive_file").unwrap_or(0));
        return Some(Limit {
            bytes: max.saturating_sub(used),
            what: "the memory left to its cgroup (memory.max)",
            address_space: false,
            left: true,
        });
    }
    // "4:memory:/path" (or "4:cpu,memory:/path"): its v1 memory group.
    let group = groups.lines().find_map(|l| {
        let mut parts = l.splitn(3, ':');
        let (_, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        controllers.split(',').any(|c| c == "memory").then_some(path)
    })?;
    [
        format!("/sys/fs/cgroup/memory{group}"),
        "/sys/fs/cgroup/memory".to_string(),
    ]
    .into_iter()
    .find_map(|dir| {
        let limit = number(&format!("{dir}/memory.limit_in_bytes"))?;
        let used = number(&format!("{dir}/memory.usage_in_bytes"))
            .unwrap_or(0)
            .saturating_sub(stat(&dir, "total_inactive_file").unwrap_or(0));
        Some((limit, used))
    })
    .filter(|&(limit, _)| limit < UNLIMITED)
    .map(|(limit, used)| Limit {
        bytes: limit.saturating_sub(used),
        what: "the memory left to its cgroup (memory.limit_in_bytes)",
        address_space: false,
        left: true,
    })
}

/// A "Name:   1234 kB" field of a /proc file, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    Some(line.split_whitespace().nth(1)?.parse::<u64>().ok()? * 1024)
}

/// What a render needs, for [`check`].
pub(crate) struct Need<'a> {
    /// Bytes it keeps resident, `loaded` included.
    pub resident: u64,
    /// Address space it reserves (`address_space(resident)`).
    pub address_space: u64,
    /// Of those, bytes already allocated (the scene's textures): a limit that states what is
    /// left to this process (ulimit -v, the cgroup) has counted them already.
    pub loaded: u64,
    /// What needs it, in words.
    pub what: &'a str,
    /// How to need less, in words.
    pub fix: &'a str,
}

/// Refuses a render whose `need` exceeds one of `limits`, or where allocating what it has not
/// yet allocated fails (reserved once, fallibly, and given back: what would otherwise abort the
/// render part-way).
pub(crate) fn check(need: &Need, limits: &[Limit]) -> anyhow::Result<()> {
    let Need { what, fix, loaded, .. } = *need;
    for limit in limits {
        let total = if limit.address_space {
            need.address_space
        } else {
            need.resident
        };
        let (bytes, besides) = if limit.left && loaded > 0 {
            (
                total - loaded,
                format!(" besides the {} already loaded", gigabytes(loaded)),
            )
        } else {
            (total, String::new())
        };
        if bytes > limit.bytes {
            let space = if limit.address_space {
                format!(
                    " of address space ({} of it the threads' allocator arenas, reserved and hardly used)",
                    gigabytes(need.address_space - need.resident)
                )
            } else {
                String::new()
            };
            bail!(
                "{what} needs about {}{space}{besides}, more than {} ({}): {fix}",
                gigabytes(bytes),
                limit.what,
                gigabytes(limit.bytes)
            );
        }
    }
    let mut probe: Vec<u8> = Vec::new();
    if let Err(error) = usize::try_from(need.resident - loaded)
        .map_err(|_| None)
        .and_then(|n| probe.try_reserve_exact(n).map_err(Some))
    {
        bail!(
            "{what} needs about {}, which this process cannot allocate{}: {fix}",
            gigabytes(need.resident),
            error.map(|e| format!(" ({e})")).unwrap_or_default()
        );
    }
    Ok(())
}

/// How to make a render need less memory.
pub(crate) const SMALLER_RENDER: &str = "render a smaller image, fewer outputs or fewer views";

/// Bytes in GB (10⁹), to two significant decimals for small amounts.
fn gigabytes(bytes: u64) -> String {
    format!("{:.2} GB", bytes as f64 / 1e9)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A need of `resident` bytes (`address_space` reserved, `loaded` of them allocated).
    fn need(resident: u64, address_space: u64, loaded: u64) -> Need<'static> {
        Need {
            resident,
            address_space,
            loaded,
            what: "a render",
            fix: SMALLER_RENDER,
        }
    }

    const LIMITS: [Limit; 2] = [
        Limit {
            bytes: 8_000_000_000,
            what: "the memory of this machine (RAM and swap)",
            address_space: false,
            left: false,
        },
        Limit {
            bytes: 4_000_000_000,
            what: "the address space left under ulimit -v",
            address_space: true,
            left: true,
        },
    ];

    /// The cgroup's limit from v2 files, or v1's at the group's path or the hierarchy's root,
    /// and none where v1 says unlimited or nothing is mounted.
    #[test]
    fn cgroup_limits_are_read_from_v2_or_v1() {
        let files = |files: Vec<(&'static str, &'static str)>| {
            move |path: &str| files.iter().find(|(p, _)| *p == path).map(|(_, text)| text.to_string())
        };
        let v2 = cgroup_limit(files(vec![
            ("/proc/self/cgroup", "0::/job\n"),
            ("/sys/fs/cgroup/job/memory.max", "1000000\n"),
            ("/sys/fs/cgroup/job/memory.current", "250000\n"),
            (
                "/sys/fs/cgroup/job/memory.stat",
                "anon 100000\ninactive_file 50000\nactive_file 1\n",
            ),
        ]));
        // 250,000 used less 50,000 of inactive file cache.
        assert_eq!(
            v2.map(|l| (l.bytes, l.what)),
            Some((800_000, "the memory left to its cgroup (memory.max)"))
        );
        let v1 = |limit: &'static str, at: &'static str| {
            cgroup_limit(files(vec![
                ("/proc/self/cgroup", "5:devices:/\n4:cpu,memory:/job\n0::/\n"),
                (at, limit),
                ("/sys/fs/cgroup/memory/job/memory.usage_in_bytes", "140\n"),
                (
                    "/sys/fs/cgroup/memory/job/memory.stat",
                    "inactive_file 7\ntotal_inactive_file 40\n",
                ),
                ("/sys/fs/cgroup/memory/memory.usage_in_bytes", "300\n"),
            ]))
        };
        let at_group = v1("1000\n", "/sys/fs/cgroup/memory/job/memory.limit_in_bytes");
        assert_eq!(
            at_group.map(|l| (l.bytes, l.what)),
            Some((900, "the memory left to its cgroup (memory.limit_in_bytes)"))
        );
        let at_root = v1("1000\n", "/sys/fs/cgroup/memory/memory.limit_in_bytes");
        assert_eq!(at_root.map(|l| l.bytes), Some(700));
        assert_eq!(
            v1(
                "9223372036854771712\n",
                "/sys/fs/cgroup/memory/job/memory.limit_in_bytes"
            ),
            None
        );
        assert_eq!(cgroup_limit(files(vec![("/proc/self/cgroup", "0::/\n")])), None);
    }

    #[test]
    fn a_need_over_a_limit_is_refused_naming_both() {
        let big = Need {
            what: "a 10000x10000 render",
            ..need(3_500_000_000, 4_100_000_000, 0)
        };
        let message = check(&big, &LIMITS).unwrap_err().to_string();
        assert_eq!(
            message,
            "a 10000x10000 render needs about 4.10 GB of address space (0.60 GB of it the threads' allocator \
             arenas, reserved and hardly used), more than the address space left under ulimit -v (4.00 GB): render a \
             smaller image, fewer outputs or fewer views"
        );
        let message = check(&need(9_000_000_000, 9_000_000_000, 0), &LIMITS)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("9.00 GB, more than the memory of this machine (RAM and swap) (8.00 GB)"),
            "{message}"
        );
        // Resident memory is held against resident limits, address space against address space.
        assert!(check(&need(3_000_000_000, 3_900_000_000, 0), &LIMITS).is_ok());
    }

    /// Textures already loaded count against the whole of a limit, not against what a limit
    /// says is left (which they already use).
    #[test]
    fn what_is_loaded_counts_against_whole_limits_only() {
        // 4.5 GB of address space, 1 GB of it loaded: 3.5 GB more fits the 4 GB left.
        assert!(check(&need(4_000_000_000, 4_500_000_000, 1_000_000_000), &LIMITS).is_ok());
        let message = check(&need(4_000_000_000, 5_500_000_000, 1_000_000_000), &LIMITS)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains(
                "needs about 4.50 GB of address space (1.50 GB of it the threads' allocator arenas, reserved and \
                 hardly used) besides the 1.00 GB already loaded, more than the address space left under ulimit -v \
                 (4.00 GB)"
            ),
            "{message}"
        );
        // The machine's whole memory holds the loaded bytes as well.
        let message = check(&need(8_500_000_000, 3_900_000_000, 1_000_000_000), &LIMITS)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("needs about 8.50 GB, more than the memory of this machine"),
            "{message}"
        );
    }

    /// Past every stated limit, an allocation that fails is refused up front too.
    #[test]
    fn a_need_that_cannot_be_allocated_is_refused() {
        let message = check(&need(u64::MAX / 2, u64::MAX / 2, 0), &[])
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
