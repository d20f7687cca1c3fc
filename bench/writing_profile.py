"""Where a data set's writing goes: core-ms per frame by part, from a `perf record` of
`omnisim dataset` (docs/benchmarks.md, "Data-set writing").

    perf record -o writing.data -e cpu-clock -F 1000 --call-graph dwarf,65528 \\
        target/release/omnisim dataset scenes/env1-speed-dataset.ron --out /tmp/speed --backend cpu
    python3 bench/writing_profile.py writing.data 100

A sample is writing when its stack holds the frame writer, the hashing of its files, an atomic write (entries), the batch
sync or the writing of entries; each such sample goes to the first part below that its stack names (SHA-256 first,
so the hashing of each file is not counted as its encoder's). At 1 kHz a sample is one core-ms.
"""

import collections
import subprocess
import sys

SYSTEM_CALLS = ("do_sys_open", "do_filp_open", "ksys_write", "__x64_sys_write", "vfs_write", "rename")

# (part, names any of which put a sample in it, names that keep it out)
PARTS = [
    ("SHA-256", ("sha2::", "sha256::"), ()),
    ("syncfs / fsync", ("syncfs", "make_durable", "fsync"), ()),
    ("pixel pass (ranges, hits, points)", ("PixelPass::read",), ()),
    ("range EXR encoding", ("write_range_exr", "write_ranges_exr", "write_channel_exr", "write_exr"), SYSTEM_CALLS),
    ("PLY encoding", ("point_cloud_ply", "write_point_cloud_points"), SYSTEM_CALLS),
    ("colour PNG encoding", ("write_png",), SYSTEM_CALLS),
    ("file creation (openat)", ("do_sys_open", "do_filp_open", "openat"), ()),
    ("write system calls", ("ksys_write", "__x64_sys_write", "vfs_write"), ()),
    ("rename", ("rename",), ()),
]
# `omnisim_dataset::sha256::` too: where `WrittenFrame::hashed` is inlined into the writer thread's closure, the
# hashing's stack names no other writing function.
WRITING = (
    "write_frame",
    "WrittenFrame::hashed",
    "omnisim_dataset::sha256::",
    "write_bytes_atomically",
    "Pending::write_entries",
    "make_durable",
)


def main():
    data, frames = sys.argv[1], int(sys.argv[2])
    script = subprocess.run(
        ["perf", "script", "-i", data, "-F", "comm,tid,ip,sym"], capture_output=True, text=True, check=True
    ).stdout
    counts = collections.Counter()
    for block in script.split("\n\n"):
        lines = [line.strip() for line in block.strip().split("\n") if line.strip()]
        if len(lines) < 2:
            continue
        counts["all samples"] += 1
        stack = "\n".join(line.split(None, 1)[-1] for line in lines[1:])
        if not any(name in stack for name in WRITING):
            continue
        counts["writing in all"] += 1
        part = next(
            (
                part
                for part, names, unless in PARTS
                if any(n in stack for n in names) and not any(n in stack for n in unless)
            ),
            "other writing",
        )
        counts[part] += 1
        # Across the parts: page faults, and ext4's skipping of recently deleted inodes (a file
        # system without a journal checks each free inode's deletion time before reusing it).
        for name, label in (("exc_page_fault", "(page faults, any part)"), ("recently_deleted", "(recently_deleted)")):
            if name in stack:
                counts[label] += 1
    for part, samples in counts.most_common():
        print(f"{part:34s} {samples:6d} samples {samples / frames:6.2f} core-ms/frame")


if __name__ == "__main__":
    main()
