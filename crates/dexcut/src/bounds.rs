//! Bounds on everything input can make large, checked before the work:
//! input files (regular files only, size caps), memory (columns, planner
//! stations, servo samples) against what this process may really use
//! (available memory, cgroup `memory.max`, `RLIMIT_AS`/`RLIMIT_DATA`).
//!
//! The per-item costs are measured peak resident memory of the release
//! binary (`/usr/bin/time -f %M`, differences between two sizes of the same
//! job), not sizes of structs:
//! * a stock column: 63 B in `simulate`, 82 B in `optimize` (stock clones,
//!   top heights, the error map; columns.csv is streamed). Before columns.csv
//!   was streamed it was 80 and 99.5 B, and under `ulimit -v` its doubling
//!   buffer aborted runs that passed the check. After the Kienzle model
//!   78 and 96.5 B. Probed at the boundary under `prlimit --as` of
//!   512 MiB, 1 GiB and 2 GiB: every grid either ran or was refused by this
//!   check, none aborted (with [`THREAD_RESERVE_BYTES`] counted);
//! * a servo sample (one sweep step): 307 B with 20 bands in air; while
//!   cutting 996 B with 40 bands, 1116 B with 80, 2027 B with 160 (the
//!   removal record keeps every band of every step): bounded by
//!   [`bytes_per_sample`] = 600 B + 12 B per band;
//! * a planner station: 110 B in `simulate`, 320 B in `optimize` (engagement).

use std::io::Read;
use std::path::Path;

use crate::error::{fail, Error, Result};

/// Peak bytes per stock column (measured, see the module notes; rounded up).
pub const BYTES_PER_COLUMN: f64 = 104.0;
/// Peak bytes per servo sample of one run without bands (measured 307 B with 20 bands in air).
pub const BYTES_PER_SAMPLE: f64 = 320.0;

/// Peak bytes per servo sample of a run whose removal record has `bands`
/// tool bands (measured while cutting; see the module notes).
pub fn bytes_per_sample(bands: usize) -> f64 {
    600.0 + 12.0 * bands as f64
}
/// Peak bytes per planner station (measured 320 B in optimize).
pub const BYTES_PER_STATION: f64 = 336.0;
/// Peak bytes per byte of G-code text while it is parsed (about 40×, measured
/// on long programs), so the program cap also follows memory.
pub const BYTES_PER_PROGRAM_BYTE: f64 = 48.0;
/// Peak bytes per path segment while a program is read: a segment is 120 B
/// and the path's vector grows by doubling (up to 240 B a segment held
/// while it moves), rounded up. Bounds the moves a program's loops may make
/// ([`max_path_segments`]), which its text's size does not.
pub const BYTES_PER_SEGMENT: f64 = 256.0;

/// Most path segments a program may make while it is read: what the memory
/// this process may use holds at [`BYTES_PER_SEGMENT`] beside the program's
/// text (`text_bytes` × [`BYTES_PER_PROGRAM_BYTE`]), and `nc`'s own cap (5 M)
/// at most. A loop that would make more (`o1 repeat [1000000000]`) is
/// refused at its line once its first run shows it, before the moves are
/// made (issue 39).
pub fn max_path_segments(text_bytes: usize) -> usize {
    let room = usable_memory_bytes() - text_bytes as f64 * BYTES_PER_PROGRAM_BYTE;
    (room / BYTES_PER_SEGMENT).clamp(1.0, nc::Options::default().max_segments as f64) as usize
}

/// Most servo samples of one run, whatever the memory: bounds the sweep time.
pub const MAX_SAMPLES: f64 = 100_000_000.0;
/// Most planner stations (0.05 mm apart: 5 000 m of path).
pub const MAX_STATIONS: f64 = 100_000_000.0;

/// Size caps of input files, bytes.
pub const MAX_JOB_BYTES: u64 = 1 << 20;
pub const MAX_PROGRAM_BYTES: u64 = 256 << 20;
pub const MAX_MESH_BYTES: u64 = 1 << 30;
pub const MAX_CSV_BYTES: u64 = 1 << 30;
pub const MAX_SUMMARY_BYTES: u64 = 16 << 20;

/// Check that `path` is a regular file of at most `cap` bytes (no device,
/// FIFO or folder: `/dev/zero` would read for ever, a FIFO would block).
pub fn check_input_file(path: &Path, what: &str, cap: u64) -> Result<u64> {
    let meta =
        std::fs::metadata(path).map_err(|e| Error::io(format!("cannot read {what}"), path, e))?;
    if !meta.is_file() {
        fail!(
            limits,
            "{what} {} is not a regular file (devices, FIFOs and folders are refused)",
            path.display()
        );
    }
    if meta.len() > cap {
        fail!(
            limits,
            "{what} {} is {} bytes, more than the limit of {} bytes",
            path.display(),
            meta.len(),
            cap
        );
    }
    Ok(meta.len())
}

/// Read a regular UTF-8 text file of at most `cap` bytes. A file that is
/// not UTF-8 is refused at the line and column of its first byte that is
/// not ([`not_utf8`]), not with the decoder's "stream did not contain valid
/// UTF-8" and no place.
pub fn read_text(path: &Path, what: &str, cap: u64) -> Result<String> {
    let bytes = read_bytes(path, what, cap)?;
    String::from_utf8(bytes).map_err(|e| not_utf8(path, what, e.as_bytes(), e.utf8_error()))
}

/// The error of a `what` file at `path` that is not UTF-8: its first such
/// byte at its line and character column.
pub fn not_utf8(path: &Path, what: &str, bytes: &[u8], e: std::str::Utf8Error) -> Error {
    let at = e.valid_up_to();
    // The prefix is valid UTF-8 by the error's word.
    let prefix = std::str::from_utf8(&bytes[..at]).unwrap_or("");
    let line = prefix.matches('\n').count() as u64 + 1;
    let column = prefix.rsplit('\n').next().map_or(0, |l| l.chars().count()) as u64 + 1;
    Error::input(
        &path.display().to_string(),
        line,
        column,
        format!(
            "byte 0x{:02X} is not UTF-8: the {what} must be UTF-8 text",
            bytes[at]
        ),
    )
}

/// Read a regular file of at most `cap` bytes whole.
pub fn read_bytes(path: &Path, what: &str, cap: u64) -> Result<Vec<u8>> {
    let size = check_input_file(path, what, cap)?;
    let file =
        std::fs::File::open(path).map_err(|e| Error::io(format!("cannot read {what}"), path, e))?;
    // Read at most cap + 1 bytes: a file that grows while read is still bounded.
    // Room for the file as it was measured: a reader with a limit gives no
    // size hint, and the text grown by doubling would hold up to twice its
    // bytes through a whole run (a program's text is: 33.6 MB for 26.8);
    // where it grew meanwhile, it is fitted after.
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(format!("cannot read {what}"), path, e))?;
    if bytes.len() as u64 > cap {
        fail!(
            limits,
            "{what} {} grew past the limit of {cap} bytes while read",
            path.display()
        );
    }
    bytes.shrink_to_fit();
    Ok(bytes)
}

/// Open a regular file of at most `cap` bytes for streaming.
pub fn open(path: &Path, what: &str, cap: u64) -> Result<std::io::Take<std::fs::File>> {
    check_input_file(path, what, cap)?;
    let file =
        std::fs::File::open(path).map_err(|e| Error::io(format!("cannot read {what}"), path, e))?;
    Ok(file.take(cap))
}

fn read_u64(path: &str) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

/// `MemAvailable` from /proc/meminfo, bytes.
fn mem_available() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kb: f64 = s
        .lines()
        .find(|l| l.starts_with("MemAvailable:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(kb * 1024.0)
}

/// Room left under the cgroup v2 `memory.max` of this process and its ancestors.
fn cgroup_room() -> Option<f64> {
    let cg = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let rel = cg.lines().find_map(|l| l.strip_prefix("0::"))?.trim();
    let mut dir = std::path::PathBuf::from(format!("/sys/fs/cgroup{rel}"));
    let mut room: Option<f64> = None;
    loop {
        let d = dir.display().to_string();
        if let (Some(max), Some(cur)) = (
            read_u64(&format!("{d}/memory.max")),
            read_u64(&format!("{d}/memory.current")),
        ) {
            let r = max.saturating_sub(cur) as f64;
            room = Some(room.map_or(r, |x: f64| x.min(r)));
        }
        if !dir.pop() || dir.as_os_str() == "/sys/fs" {
            break;
        }
    }
    room
}

/// Address space each worker thread reserves beyond its data: glibc's
/// per-thread malloc arena (64 MiB reserved) and a 2 MiB stack. The sweep's
/// threads start after the checks, so their reservations are counted here.
const THREAD_RESERVE_BYTES: f64 = 66.0 * 1048576.0;

/// Room left under RLIMIT_AS and RLIMIT_DATA (from /proc/self/limits, less
/// what the process already maps and what its worker threads will reserve).
fn rlimit_room() -> Option<f64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let soft = |name: &str| -> Option<f64> {
        let l = limits.lines().find(|l| l.starts_with(name))?;
        l[name.len()..].split_whitespace().next()?.parse().ok()
    };
    let used_kb = |name: &str| -> f64 {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(0.0)
    };
    let threads = std::thread::available_parallelism().map_or(4, |n| n.get()) as f64 + 1.0;
    let as_room = soft("Max address space")
        .map(|b| b - used_kb("VmSize:") * 1024.0 - threads * THREAD_RESERVE_BYTES);
    let data_room = soft("Max data size").map(|b| b - used_kb("VmData:") * 1024.0);
    match (as_room, data_room) {
        (Some(a), Some(d)) => Some(a.min(d)),
        (a, d) => a.or(d),
    }
    .map(|r| r.max(0.0))
}

/// Bytes this process may still allocate: the least of the machine's
/// available memory, the cgroup's room and the rlimits' room (4 GiB if none
/// can be read).
pub fn memory_room_bytes() -> f64 {
    least_room([mem_available(), cgroup_room(), rlimit_room()])
}

/// The least of the rooms that could be read, 4 GiB if none could.
fn least_room(rooms: [Option<f64>; 3]) -> f64 {
    rooms
        .into_iter()
        .flatten()
        .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.min(v))))
        .unwrap_or(4.0 * (1u64 << 30) as f64)
}

/// The share of the room a run plans to use (the rest: allocator slack, threads, libraries).
const USABLE_SHARE: f64 = 0.8;

/// The bytes a run plans to use at most: a share of [`memory_room_bytes`].
pub fn usable_memory_bytes() -> f64 {
    USABLE_SHARE * memory_room_bytes()
}

/// Refuse work that would need more than the usable memory.
pub fn check_memory(bytes: f64, what: &str) -> Result<()> {
    let room = usable_memory_bytes();
    if !(bytes <= room) {
        fail!(limits,
            "{what} needs about {:.0} MB of memory, more than the {:.0} MB this process may use (available memory, cgroup memory.max and ulimit)",
            bytes / 1e6,
            room / 1e6
        );
    }
    Ok(())
}

/// What a motion plan will allocate, estimated from the path before planning.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionEstimate {
    pub stations: f64,
    /// Lower bound on the program's time, s.
    pub time_s: f64,
    pub samples: f64,
}

/// Estimate stations and servo samples of `path` on `machine` before planning:
/// stations as [`schedule::station_count`] counts them at the programmed feeds (every
/// `ds_mm`, two or three a segment at least, and the ramp stations beside its ends that
/// may come to rest; re-timing at `feed_max` has about as many or fewer); the time is at least each
/// segment's length at its feed (capped by feed_max / rapid) plus dwells, at
/// least the rest-to-rest time of the whole length under the largest
/// acceleration (2·√(L/a)) and jerk ((32·L/j)^⅓), and at least one block
/// time per segment.
pub fn estimate_motion(path: &nc::Path, machine: &schedule::Machine, ds_mm: f64) -> MotionEstimate {
    let mut length_mm = 0.0;
    let mut feed_time_s = 0.0;
    for seg in &path.segments {
        let l = seg.length_mm();
        length_mm += l;
        feed_time_s += match seg.motion {
            nc::Motion::Rapid => l / machine.rapid_mm_min * 60.0,
            nc::Motion::Feed { feed_mm_min, .. } => {
                l / feed_mm_min.min(machine.feed_max_mm_min) * 60.0
            }
            nc::Motion::Dwell { seconds } => seconds,
        };
    }
    let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let accel_time_s = 2.0 * (length_mm / norm(machine.accel_mm_s2)).sqrt();
    let jerk_time_s = machine
        .jerk_mm_s3
        .map_or(0.0, |j| (32.0 * length_mm / norm(j)).cbrt());
    let block_time_s = machine.block_time_ms.unwrap_or(0.0) * 1e-3 * path.segments.len() as f64;
    let time_s = feed_time_s
        .max(accel_time_s)
        .max(jerk_time_s)
        .max(block_time_s);
    MotionEstimate {
        stations: schedule::station_count(path, machine, ds_mm, schedule::FeedPolicy::Programmed)
            as f64,
        time_s,
        samples: time_s / (machine.period_ms * 1e-3) + 2.0,
    }
}

/// Refuse a motion whose stations or samples exceed the caps or the memory.
/// `runs`: how many sample sets the command keeps (2 for optimize's before and after).
pub fn check_motion(
    e: &MotionEstimate,
    file: &str,
    period_ms: f64,
    runs: f64,
    bytes_per_sample: f64,
) -> Result<()> {
    if !(e.stations <= MAX_STATIONS) {
        fail!(limits,
            "{file}: the path needs {:.3e} planner stations (one per 0.05 mm), more than the limit of {MAX_STATIONS:.0e}: the program is too long",
            e.stations
        );
    }
    if !(e.samples <= MAX_SAMPLES) {
        fail!(limits,
            "{file}: the program takes at least {:.3e} s, {:.3e} servo samples at period_ms = {period_ms}, more than the limit of {MAX_SAMPLES:.0e} (check the feeds, dwells and [machine] limits)",
            e.time_s,
            e.samples
        );
    }
    check_memory(
        e.stations * BYTES_PER_STATION + runs * e.samples * bytes_per_sample,
        &format!(
            "{file}: {:.0} planner stations and {:.0} servo samples",
            e.stations, e.samples
        ),
    )
}

/// Refuse a planned motion of `time_s` whose servo samples exceed the cap or
/// the memory (the plan can be slower than [`estimate_motion`]'s bound).
pub fn check_samples(time_s: f64, period_ms: f64, what: &str) -> Result<()> {
    let samples = time_s / (period_ms * 1e-3) + 2.0;
    if !(samples <= MAX_SAMPLES) {
        fail!(limits,
            "{what}: the planned motion takes {time_s:.3e} s, {samples:.3e} servo samples at period_ms = {period_ms}, more than the limit of {MAX_SAMPLES:.0e}"
        );
    }
    check_memory(
        samples * BYTES_PER_SAMPLE,
        &format!("{what}: {samples:.0} servo samples"),
    )
}

/// Bytes free to an unprivileged writer on the file system holding `dir`
/// (statvfs); `None` where it cannot be told.
#[cfg(unix)]
pub fn disk_room_bytes(dir: &Path) -> Option<f64> {
    let s = rustix::fs::statvfs(dir).ok()?;
    Some(s.f_bavail as f64 * s.f_frsize as f64)
}

#[cfg(not(unix))]
pub fn disk_room_bytes(_dir: &Path) -> Option<f64> {
    None
}

/// Refuse outputs of at least `bytes` where the disk holding `dir` (the
/// results folder `shown`'s staging folder) has less room, before any work
/// (`what`: what needs them).
pub fn check_disk(dir: &Path, shown: &Path, bytes: f64, what: &str) -> Result<()> {
    match disk_room_bytes(dir) {
        Some(room) if bytes > room => fail!(limits,
            "{what} needs at least {:.3} GB on disk, and the file system of {} has {:.3} GB free: free some space, write elsewhere (--out) or use a coarser grid (--grid)",
            bytes / 1e9,
            shown.display(),
            room / 1e9
        ),
        _ => Ok(()),
    }
}

/// Refuse a stock grid that does not fit the memory.
pub fn check_columns(nx: usize, ny: usize, spacing_mm: f64, what: &str) -> Result<()> {
    let columns = nx as f64 * ny as f64;
    check_memory(
        columns * BYTES_PER_COLUMN,
        &format!("{what}: {nx}×{ny} columns at grid {spacing_mm} mm"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_larger_than_the_disk_are_refused_before_the_work() {
        let dir = tempfile::tempdir().unwrap();
        let room = disk_room_bytes(dir.path()).expect("statvfs of a temporary folder");
        assert!(room > 0.0);
        check_disk(dir.path(), dir.path(), 1.0, "one byte").unwrap();
        let e = check_disk(dir.path(), Path::new("out"), 2.0 * room + 1e12, "the grid")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("the grid needs at least"), "{e}");
        assert!(e.contains("the file system of out has"), "{e}");
    }

    #[test]
    fn devices_fifos_and_large_files_are_refused() {
        let err = read_text(Path::new("/dev/zero"), "program", 100).unwrap_err();
        assert!(err.to_string().contains("not a regular file"), "{err}");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.nc");
        std::fs::write(&p, vec![b'G'; 101]).unwrap();
        let err = read_text(&p, "program", 100).unwrap_err().to_string();
        assert!(
            err.contains("101 bytes, more than the limit of 100"),
            "{err}"
        );
        assert_eq!(read_text(&p, "program", 101).unwrap().len(), 101);
    }

    /// A text is held at its length, not at the doubled capacity a reader
    /// without a size hint grows to (a program's text is held through a run).
    #[test]
    fn a_text_is_read_without_spare_capacity() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("program.nc");
        let body: String = (0..20_000).map(|i| format!("G1 X{i} F100\n")).collect();
        std::fs::write(&p, &body).unwrap();
        let text = read_text(&p, "program", 1 << 20).unwrap();
        assert_eq!(text, body);
        assert_eq!(text.capacity(), text.len());
    }

    #[test]
    fn memory_room_is_positive_and_bounded_by_the_machine() {
        // The machine's available memory moves while other tests run, so
        // the bound is checked on the rule with fixed readings.
        assert!(memory_room_bytes() > 0.0);
        let gib = (1u64 << 30) as f64;
        assert_eq!(least_room([Some(3e9), Some(2e9), Some(5e9)]), 2e9);
        assert_eq!(least_room([Some(3e9), None, None]), 3e9);
        assert_eq!(least_room([None, None, Some(1e9)]), 1e9);
        assert_eq!(least_room([None, None, None]), 4.0 * gib);
    }

    #[test]
    fn motion_estimate_of_a_slow_line_counts_its_samples() {
        let text = "G0 X0 Y0 Z1\nG1 X10 F60\nM2\n";
        let parsed = nc::parse(text, "p.nc", &nc::Options::default());
        let machine = schedule::Machine {
            period_ms: 10.0,
            feed_max_mm_min: 3000.0,
            rapid_mm_min: 6000.0,
            accel_mm_s2: [1000.0; 3],
            jerk_mm_s3: None,
            block_time_ms: None,
        };
        let e = estimate_motion(&parsed.path, &machine, 0.05);
        // 1 mm rapid (0.01 s) + 10 mm at 1 mm/s.
        assert!((e.time_s - 10.01).abs() < 1e-9, "{e:?}");
        assert!((e.samples - (1001.0 + 2.0)).abs() < 1e-6, "{e:?}");
        // From rest: the rapid's 20 intervals, the line's 200 and, before its end at rest,
        // 7 ramp stations (it reaches 1 mm/s in 0.0005 mm: 0.05/2^7 ≤ 0.0005).
        assert_eq!(e.stations, (1 + 20 + 200 + 7) as f64, "{e:?}");
    }
}
