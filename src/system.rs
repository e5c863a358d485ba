//! What the machine allows this process: the memory every "must fit in memory" check
//! asks for, kept out of the parsers that ask.

use std::path::{Path, PathBuf};

/// Bytes of memory this process may use: the least of the system's MemAvailable, what
/// the process's cgroups allow beyond what they hold ([`cgroup_memory`]: a SLURM job or
/// a container has its own limit, not the host's), and `WAVETRACE_MEMORY` (bytes) when
/// set; 8 GiB when none can be read. Every "must fit in memory" check asks it.
pub fn available_memory() -> u64 {
    let system = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map(|kb| kb * 1024)
    });
    let cgroup = cgroup_memory(Path::new("/"));
    let user = std::env::var("WAVETRACE_MEMORY").ok().and_then(|v| v.trim().parse::<u64>().ok());
    [system, cgroup, user].into_iter().flatten().min().unwrap_or(8 << 30)
}

/// The memory the process's cgroups leave it, read under `root` (`/` on a live system;
/// a folder with `proc/self/cgroup` and `sys/fs/cgroup/...` in tests): for each
/// hierarchy in `proc/self/cgroup` (v2 `0::PATH`: `memory.max` − `memory.current`; v1
/// `N:memory:PATH`: `memory.limit_in_bytes` − `memory.usage_in_bytes`), every level
/// from the process's cgroup up to the hierarchy's root, and the smallest room wins: a
/// limit may sit on any ancestor (SLURM puts the job's above its steps'). A limit of
/// "max" (v2) does not parse and one near 2^63 (v1's unlimited) does not bind. `None`
/// when no level has a limit.
pub fn cgroup_memory(root: &Path) -> Option<u64> {
    let read = |p: &Path| std::fs::read_to_string(p).ok();
    let num = |p: PathBuf| read(&p)?.trim().parse::<u64>().ok();
    let table = read(&root.join("proc/self/cgroup"))?;
    let mut least: Option<u64> = None;
    for line in table.lines() {
        let (mount, max, current, dir) = match line.split_once(":memory:") {
            Some((_, dir)) => ("sys/fs/cgroup/memory", "memory.limit_in_bytes", "memory.usage_in_bytes", dir),
            None => match line.strip_prefix("0::") {
                Some(dir) => ("sys/fs/cgroup", "memory.max", "memory.current", dir),
                None => continue,
            },
        };
        let top = root.join(mount);
        // `..` in a cgroup path (a process outside the reader's namespace) is not
        // followed: the walk stays inside the hierarchy.
        let parts: Vec<&str> = dir.trim().split('/').filter(|p| !p.is_empty() && *p != "." && *p != "..").collect();
        for depth in (0..=parts.len()).rev() {
            let level = parts[..depth].iter().fold(top.clone(), |p, part| p.join(part));
            if let Some(limit) = num(level.join(max)) {
                let room = limit.saturating_sub(num(level.join(current)).unwrap_or(0));
                least = Some(least.map_or(room, |l| l.min(room)));
            }
        }
    }
    least
}
