//! The memory budget: how much loading one scene, or one render session's film, may take
//! before it is refused with one line instead of allocated.

/// The memory a scene, or a render session's film, may take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Bytes that loading and building one scene, or one session's film, may take at the peak.
    pub memory: u64,
}

/// The limit where the machine's memory cannot be read (4 GiB).
const FALLBACK_MEMORY: u64 = 4 << 30;

impl Limits {
    /// The tightest of what this process may still take: half the machine's physical
    /// memory (MemTotal), the memory available now (MemAvailable), three quarters of the
    /// address space left under RLIMIT_AS (thread stacks and allocator arenas take the
    /// rest) and what the cgroup's limit leaves (v2 memory.max, or v1
    /// memory.limit_in_bytes, less the usage); 4 GiB where none can be read.
    pub fn from_machine() -> Self {
        let read = |path: &str| std::fs::read_to_string(path).ok();
        let meminfo = read("/proc/meminfo");
        let total = meminfo.as_deref().and_then(|s| meminfo_field(s, "MemTotal:"));
        let available = meminfo.as_deref().and_then(|s| meminfo_field(s, "MemAvailable:"));
        let address_space = read("/proc/self/limits").as_deref().and_then(address_space_limit).and_then(|limit| {
            let used = read("/proc/self/status").as_deref().and_then(|s| meminfo_field(s, "VmSize:"))?;
            Some(limit.saturating_sub(used) / 4 * 3)
        });
        let bounds = [total.map(|t| t / 2), available, address_space, cgroup_room()];
        let memory = bounds.into_iter().flatten().min().unwrap_or(FALLBACK_MEMORY);
        Self { memory }
    }
}

/// Most bytes a settings file may have (a view file, a sidecar): a few kB in practice,
/// and a view file editing every material of a large scene stays far below.
pub const MAX_TEXT_FILE: u64 = 16 << 20;

/// The text of the file at `path` if it is a regular UTF-8 file of at most
/// `MAX_TEXT_FILE` bytes (see `regular_file_size`).
pub fn read_text(path: &std::path::Path) -> Result<String, String> {
    use std::io::Read;
    let size = regular_file_size(path, MAX_TEXT_FILE)?;
    let mut text = String::with_capacity(size as usize);
    std::fs::File::open(path).and_then(|f| f.take(size).read_to_string(&mut text)).map_err(|e| e.to_string())?;
    Ok(text)
}

/// A "Name: value kB" field of /proc/meminfo or /proc/self/status, in bytes.
fn meminfo_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The soft RLIMIT_AS from the text of /proc/self/limits, or None if unlimited.
fn address_space_limit(limits: &str) -> Option<u64> {
    let line = limits.lines().find(|l| l.starts_with("Max address space"))?;
    line.trim_start_matches("Max address space").split_whitespace().next()?.parse().ok()
}

/// A cgroup limit file's value in bytes, or None for "max" (v2) or the v1 "no limit" value
/// (the largest page-aligned i64).
fn cgroup_limit(text: &str) -> Option<u64> {
    let v: u64 = text.trim().parse().ok()?;
    (v < (i64::MAX as u64 & !0xfff)).then_some(v)
}

/// What the memory cgroup of this process still allows (limit less usage), from the
/// unified hierarchy (memory.max, memory.current) or the v1 controller
/// (memory.limit_in_bytes, memory.usage_in_bytes), under its path in /proc/self/cgroup or
/// at the mount's root (where a container sees its own cgroup). The usage leaves out the
/// inactive page cache (memory.stat's inactive_file, or total_inactive_file in v1), which
/// the kernel reclaims before it runs out: after a build it can fill most of the limit.
fn cgroup_room() -> Option<u64> {
    let membership = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path_of = |prefix: &str| {
        membership.lines().find_map(|l| {
            let (_, rest) = l.split_once(':')?;
            let (controllers, path) = rest.split_once(':')?;
            (controllers == prefix || controllers.split(',').any(|c| c == prefix)).then(|| path.to_string())
        })
    };
    let v2 = ("memory.max", "memory.current", "inactive_file");
    let v1 = ("memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file");
    let candidates = [
        path_of("").map(|p| (format!("/sys/fs/cgroup{p}"), v2)),
        Some(("/sys/fs/cgroup".to_string(), v2)),
        path_of("memory").map(|p| (format!("/sys/fs/cgroup/memory{p}"), v1)),
        Some(("/sys/fs/cgroup/memory".to_string(), v1)),
    ];
    candidates.into_iter().flatten().find_map(|(dir, (max, current, inactive))| {
        let read = |name: &str| std::fs::read_to_string(format!("{dir}/{name}")).ok();
        let limit = cgroup_limit(&read(max)?)?;
        let used = read(current)?.trim().parse::<u64>().ok()?;
        let cache = read("memory.stat").as_deref().and_then(|s| stat_field(s, inactive)).unwrap_or(0);
        Some(limit.saturating_sub(used.saturating_sub(cache)))
    })
}

/// A "name value" line of a cgroup's memory.stat.
fn stat_field(stat: &str, name: &str) -> Option<u64> {
    stat.lines().find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.trim().parse().ok())
}

impl Default for Limits {
    /// `Limits::from_machine()`.
    fn default() -> Self {
        Self::from_machine()
    }
}

/// The size of the file at `path` (symbolic links followed) if it is a regular file of at
/// most `max` bytes: what every file a scene names must be before it is read, so that a FIFO
/// or a device (/dev/zero) is refused in one line instead of blocking or reading without end.
pub fn regular_file_size(path: &std::path::Path, max: u64) -> Result<u64, String> {
    let meta = std::fs::metadata(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        _ => e.to_string(),
    })?;
    if !meta.is_file() {
        return Err("not a regular file".into());
    }
    if meta.len() > max {
        return Err(format!("{} is over the limit of {}", format_bytes(meta.len()), format_bytes(max)));
    }
    Ok(meta.len())
}

/// A byte count as people say it, in powers of 1000: "641 B", "3.2 MB", "12.0 GB".
pub fn format_bytes(n: u64) -> String {
    const UNITS: [&str; 6] = ["kB", "MB", "GB", "TB", "PB", "EB"];
    if n < 1000 {
        return format!("{n} B");
    }
    let mut value = n as f64 / 1000.0;
    let mut unit = 0;
    while value >= 999.95 && unit + 1 < UNITS.len() {
        value /= 1000.0;
        unit += 1;
    }
    format!("{value:.1} {}", UNITS[unit])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fields_the_budget_is_taken_from_are_read_in_bytes() {
        let meminfo = "MemTotal:       24560816 kB\nMemFree:        21000000 kB\nMemAvailable:   23000000 kB\n";
        assert_eq!(meminfo_field(meminfo, "MemTotal:"), Some(24_560_816 * 1024));
        assert_eq!(meminfo_field(meminfo, "MemAvailable:"), Some(23_000_000 * 1024));
        let limits = "Max cpu time              unlimited            unlimited            seconds\n\
                      Max address space         2048000000           unlimited            bytes\n";
        assert_eq!(address_space_limit(limits), Some(2_048_000_000));
        assert_eq!(address_space_limit(&limits.replace("2048000000", "unlimited")), None);
        assert_eq!(cgroup_limit("max\n"), None);
        assert_eq!(cgroup_limit("9223372036854771712\n"), None);
        assert_eq!(cgroup_limit("2147483648\n"), Some(2 << 30));
        let stat = "active_file 100\ninactive_file 5000\ntotal_inactive_file 7000\n";
        assert_eq!(stat_field(stat, "inactive_file"), Some(5000));
        assert_eq!(stat_field(stat, "total_inactive_file"), Some(7000));
    }

    #[test]
    fn the_budget_is_within_the_machines_memory() {
        let total = meminfo_field(&std::fs::read_to_string("/proc/meminfo").unwrap(), "MemTotal:").unwrap();
        let budget = Limits::from_machine().memory;
        assert!(budget > 0 && budget <= total / 2, "budget {budget} of {total}");
    }
}
