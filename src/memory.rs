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
    /// Half the machine's physical memory (MemTotal in /proc/meminfo), or 4 GiB without it.
    pub fn from_machine() -> Self {
        let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| mem_total(&s));
        Self { memory: total.map_or(FALLBACK_MEMORY, |t| t / 2) }
    }
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

/// MemTotal from the text of /proc/meminfo, in bytes.
fn mem_total(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
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
