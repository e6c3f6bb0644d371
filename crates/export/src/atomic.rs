//! Whole-or-nothing output.
//!
//! * A file is written to a fresh temporary file beside the target (created
//!   exclusively by the `tempfile` crate, never through an existing link),
//!   synced, then renamed over the target.
//! * A results folder is built in a private staging folder beside it
//!   ([`Staging`]) and swapped into place only when every file is complete, so
//!   after a failure, a full disk or `kill -9` the folder holds either the
//!   complete previous results or the complete new ones.
//!
//! The swap of a folder DIR that already exists (a rename cannot replace a
//! non-empty folder): DIR → `.DIR.dexcut-old`, staging → DIR, remove the old
//! one. A run killed between the two renames leaves no DIR and the old one;
//! [`recover`] (called by every [`Staging::begin`]) puts the old one back. A
//! run killed after them leaves DIR and the old one; [`recover`] removes the
//! old one. Staging folders of processes that no longer run are removed.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// The manifest a committed results folder carries: its run id and files.
pub const MANIFEST: &str = "manifest.json";

/// Write `dir`'s manifest: the run id, the command, and every file directly
/// in `dir` with its size (a folder inside a results folder that is a
/// results folder of its own, an operation's, gets one too).
pub fn write_manifest(dir: &Path, run_id: &str, command: &str) -> io::Result<()> {
    let mut files: Vec<(String, u64)> = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let meta = entry.metadata()?;
        if meta.is_file() && entry.file_name() != MANIFEST {
            files.push((entry.file_name().to_string_lossy().into_owned(), meta.len()));
        }
    }
    files.sort();
    let mut json = format!(
        "{{\n  \"run_id\": \"{}\",\n  \"command\": \"{}\",\n  \"files\": {{",
        run_id,
        json_escape(command)
    );
    for (i, (name, size)) in files.iter().enumerate() {
        json.push_str(if i == 0 { "\n" } else { ",\n" });
        json.push_str(&format!("    \"{}\": {size}", json_escape(name)));
    }
    json.push_str("\n  }\n}\n");
    write_bytes(&dir.join(MANIFEST), json.as_bytes())
}

/// Files and folders being written that are not results yet (staging
/// folders, pending files): removed by [`remove_unfinished`] when the process
/// is told to stop (SIGTERM, SIGINT), as they are when a run fails.
static UNFINISHED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// One entry of [`UNFINISHED`], listed while it lives.
struct Unfinished(PathBuf);

impl Unfinished {
    fn new(path: &Path) -> Unfinished {
        let mut list = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
        list.push(path.to_path_buf());
        Unfinished(path.to_path_buf())
    }
}

impl Drop for Unfinished {
    fn drop(&mut self) {
        let mut list = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(i) = list.iter().position(|p| *p == self.0) {
            list.swap_remove(i);
        }
    }
}

/// Remove every staging folder and pending file of this process (for a
/// handler of SIGTERM and SIGINT, which exits after it: the writers never
/// finish). Returns what was removed. The list stays locked, so nothing new
/// is started meanwhile.
pub fn remove_unfinished() -> Vec<PathBuf> {
    let list = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
    let mut removed = Vec::new();
    for p in list.iter() {
        // A writer may still add files while the tree is removed: tried again.
        for _ in 0..5 {
            match remove_any(p) {
                Ok(()) => {
                    removed.push(p.clone());
                    break;
                }
                Err(e) if e.kind() == io::ErrorKind::NotFound => break,
                Err(_) => std::thread::sleep(std::time::Duration::from_millis(20)),
            }
        }
    }
    std::mem::forget(list);
    removed
}

/// Write `path` through `write`; the file appears only if `write` succeeds.
pub fn write_file<F>(path: &Path, write: F) -> io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let mut file = PendingFile::create(path)?;
    write(&mut file)?;
    file.commit()
}

/// A file written piece by piece that appears at its path only on
/// [`PendingFile::commit`] (dropped before: nothing appears).
pub struct PendingFile {
    buf: io::BufWriter<tempfile::NamedTempFile>,
    path: PathBuf,
    /// Listed for [`remove_unfinished`] until committed or dropped.
    _unfinished: Unfinished,
}

impl PendingFile {
    /// Start writing `path` (a fresh temporary file beside it).
    pub fn create(path: &Path) -> io::Result<PendingFile> {
        let dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let name = path.file_name().ok_or_else(|| {
            io::Error::new(io::ErrorKind::InvalidInput, "output path has no file name")
        })?;
        // O_EXCL with a random name: a planted file or link is never written through.
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".{}.", name.to_string_lossy()))
            .suffix(".tmp")
            .tempfile_in(dir)?;
        Ok(PendingFile {
            _unfinished: Unfinished::new(tmp.path()),
            buf: io::BufWriter::new(tmp),
            path: path.to_path_buf(),
        })
    }

    /// Sync the file and rename it over its path.
    pub fn commit(self) -> io::Result<()> {
        let tmp = self.buf.into_inner().map_err(|e| e.into_error())?;
        tmp.as_file().sync_all()?;
        // On error the temporary file is removed when dropped.
        tmp.persist(&self.path).map_err(|e| e.error)?;
        Ok(())
    }
}

impl Write for PendingFile {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        self.buf.write(bytes)
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.buf.write_all(bytes)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.buf.flush()
    }
}

/// Write `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_file(path, |w| w.write_all(bytes))
}

fn parent_and_name(target: &Path) -> io::Result<(PathBuf, String)> {
    let name = target
        .file_name()
        .ok_or_else(|| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("output folder {} has no name", target.display()),
            )
        })?
        .to_string_lossy()
        .into_owned();
    let parent = target
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
    Ok((parent, name))
}

fn old_path(parent: &Path, name: &str) -> PathBuf {
    parent.join(format!(".{name}.dexcut-old"))
}

fn stage_prefix(name: &str) -> String {
    format!(".{name}.dexcut-stage-")
}

fn sync_dir(dir: &Path) -> io::Result<()> {
    std::fs::File::open(dir)?.sync_all()
}

fn process_alive(pid: u32) -> bool {
    // Without /proc (not Linux), assume alive: never remove another run's staging.
    !Path::new("/proc/self").exists() || Path::new(&format!("/proc/{pid}")).exists()
}

/// Finish or undo a swap a killed run left half done, and remove staging
/// folders of processes that no longer run. Returns what was done, for messages.
pub fn recover(target: &Path) -> io::Result<Vec<String>> {
    let (parent, name) = parent_and_name(target)?;
    let mut done = Vec::new();
    if !parent.is_dir() {
        return Ok(done);
    }
    let old = old_path(&parent, &name);
    if std::fs::symlink_metadata(&old).is_ok() {
        if std::fs::symlink_metadata(target).is_ok() {
            remove_any(&old)?;
            done.push(format!("removed {} left by a killed run", old.display()));
        } else {
            std::fs::rename(&old, target)?;
            done.push(format!(
                "restored the previous results in {} (a run was killed while replacing them)",
                target.display()
            ));
        }
    }
    let prefix = stage_prefix(&name);
    for entry in std::fs::read_dir(&parent)? {
        let entry = entry?;
        let file_name = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = file_name.strip_prefix(&prefix) else {
            continue;
        };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|pid| pid != std::process::id() && !process_alive(pid)) {
            remove_any(&entry.path())?;
            done.push(format!(
                "removed the unfinished staging folder {}",
                entry.path().display()
            ));
        }
    }
    Ok(done)
}

/// Remove a folder tree, or a file or link (a link is removed, never followed).
fn remove_any(p: &Path) -> io::Result<()> {
    if std::fs::symlink_metadata(p)?.is_dir() {
        std::fs::remove_dir_all(p)
    } else {
        std::fs::remove_file(p)
    }
}

/// Why an existing folder may not be replaced by [`Staging::commit`] (absent,
/// empty, or an earlier results folder are).
pub fn check_replaceable(target: &Path) -> io::Result<()> {
    let meta = match std::fs::symlink_metadata(target) {
        Ok(m) => m,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e),
    };
    if meta.file_type().is_symlink() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "output folder {} is a symbolic link; give the real folder",
                target.display()
            ),
        ));
    }
    if !meta.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("output folder {} is not a folder", target.display()),
        ));
    }
    let empty = std::fs::read_dir(target)?.next().is_none();
    if !empty && !target.join(MANIFEST).is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "output folder {} holds files but no {MANIFEST}: it is not a dexcut results folder, so it is not replaced (choose another --out or empty it)",
                target.display()
            ),
        ));
    }
    Ok(())
}

/// A results folder being built. Files go into [`Staging::path`]; nothing is
/// visible at the target until [`Staging::commit`]. Dropped uncommitted, the
/// staging folder is removed.
pub struct Staging {
    /// Listed for [`remove_unfinished`] until committed or dropped (first:
    /// dropped before the folder is removed).
    _unfinished: Unfinished,
    dir: tempfile::TempDir,
    target: PathBuf,
    run_id: String,
}

impl Staging {
    /// Start a run that will replace `target`: recover a killed run's swap,
    /// check `target` may be replaced (absent, empty, or an earlier results
    /// folder), and create a private staging folder beside it.
    pub fn begin(target: &Path) -> io::Result<Staging> {
        let (parent, name) = parent_and_name(target)?;
        std::fs::create_dir_all(&parent).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!("cannot create its parent folder {}: {e}", parent.display()),
            )
        })?;
        recover(target)?;
        check_replaceable(target)?;
        let dir = tempfile::Builder::new()
            .prefix(&format!("{}{}-", stage_prefix(&name), std::process::id()))
            .tempdir_in(&parent)?;
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        let tag = dir
            .path()
            .file_name()
            .map(|n| {
                n.to_string_lossy()
                    .rsplit('-')
                    .next()
                    .unwrap_or("")
                    .to_string()
            })
            .unwrap_or_default();
        let run_id = format!("{nanos:x}-{}-{tag}", std::process::id());
        Ok(Staging {
            _unfinished: Unfinished::new(dir.path()),
            dir,
            target: target.to_path_buf(),
            run_id,
        })
    }

    /// The staging folder to write into.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    /// The folder the results will have once committed.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// This run's id, recorded in the manifest (and by callers in their files).
    pub fn run_id(&self) -> &str {
        &self.run_id
    }

    /// Write the manifest (run id, command, every file with its size), sync,
    /// and swap the staging folder into place.
    pub fn commit(self, command: &str) -> io::Result<PathBuf> {
        write_manifest(self.path(), &self.run_id, command)?;
        sync_dir(self.path())?;
        let (parent, name) = parent_and_name(&self.target)?;
        // The target may have appeared or changed while the run worked.
        recover(&self.target)?;
        check_replaceable(&self.target)?;
        let stage = self.dir.keep();
        let result = (|| {
            if std::fs::symlink_metadata(&self.target).is_ok() {
                let old = old_path(&parent, &name);
                std::fs::rename(&self.target, &old)?;
                std::fs::rename(&stage, &self.target)?;
                sync_dir(&parent)?;
                remove_any(&old)
            } else {
                std::fs::rename(&stage, &self.target)
            }
        })();
        if let Err(e) = result {
            let _ = recover(&self.target);
            if std::fs::symlink_metadata(&stage).is_ok() {
                let _ = std::fs::remove_dir_all(&stage);
            }
            return Err(e);
        }
        sync_dir(&parent)?;
        Ok(self.target)
    }
}

fn json_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn failed_write_leaves_nothing() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let target = dir.join("out.csv");
        let err = write_file(&target, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("boom"))
        });
        assert!(err.is_err());
        assert!(!target.exists());
        assert_eq!(
            std::fs::read_dir(dir).unwrap().count(),
            0,
            "temporary file left behind"
        );
        write_bytes(&target, b"whole").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"whole");
        // A failed rewrite keeps the previous content.
        assert!(write_file(&target, |_| Err(io::Error::other("boom"))).is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"whole");
        assert_eq!(
            std::fs::read_dir(dir).unwrap().count(),
            1,
            "only the target remains"
        );
    }

    #[test]
    fn planted_links_are_never_written_through() {
        let tmp = tempfile::tempdir().unwrap();
        let victim = tmp.path().join("victim");
        std::fs::write(&victim, b"keep").unwrap();
        let target = tmp.path().join("summary.json");
        // The old predictable temporary name, planted as a link to the victim.
        let planted = tmp
            .path()
            .join(format!(".summary.json.{}.tmp", std::process::id()));
        std::os::unix::fs::symlink(&victim, &planted).unwrap();
        write_bytes(&target, b"new").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        // A link at the target itself is replaced, not followed.
        std::fs::remove_file(&target).unwrap();
        std::os::unix::fs::symlink(&victim, &target).unwrap();
        write_bytes(&target, b"newer").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
        assert!(!std::fs::symlink_metadata(&target)
            .unwrap()
            .file_type()
            .is_symlink());
    }

    #[test]
    fn staging_replaces_the_whole_folder_or_nothing() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        // First run: a, b.
        let s = Staging::begin(&out).unwrap();
        write_bytes(&s.path().join("a.csv"), b"1").unwrap();
        write_bytes(&s.path().join("b.csv"), b"1").unwrap();
        let first_id = s.run_id().to_string();
        s.commit("test").unwrap();
        assert_eq!(names(&out), ["a.csv", "b.csv", MANIFEST]);
        let manifest = std::fs::read_to_string(out.join(MANIFEST)).unwrap();
        assert!(manifest.contains(&first_id), "{manifest}");
        // A failed second run (dropped before commit) changes nothing.
        {
            let s = Staging::begin(&out).unwrap();
            write_bytes(&s.path().join("a.csv"), b"2").unwrap();
        }
        assert_eq!(std::fs::read(out.join("a.csv")).unwrap(), b"1");
        assert_eq!(names(tmp.path()), ["out"], "staging left behind");
        // A committed second run replaces every file.
        let s = Staging::begin(&out).unwrap();
        write_bytes(&s.path().join("a.csv"), b"2").unwrap();
        s.commit("test").unwrap();
        assert_eq!(names(&out), ["a.csv", MANIFEST]);
        assert_eq!(names(tmp.path()), ["out"]);
    }

    #[test]
    fn a_swap_killed_halfway_is_recovered() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        let s = Staging::begin(&out).unwrap();
        write_bytes(&s.path().join("a.csv"), b"old").unwrap();
        s.commit("test").unwrap();
        // Killed after DIR → old, before staging → DIR.
        std::fs::rename(&out, old_path(tmp.path(), "out")).unwrap();
        // ... with its staging folder left by a process that no longer runs.
        let dead = tmp
            .path()
            .join(format!("{}999999999-abc", stage_prefix("out")));
        std::fs::create_dir(&dead).unwrap();
        let done = recover(&out).unwrap();
        assert_eq!(done.len(), 2, "{done:?}");
        assert_eq!(std::fs::read(out.join("a.csv")).unwrap(), b"old");
        assert_eq!(names(tmp.path()), ["out"]);
        // Killed after both renames: the old folder is removed.
        std::fs::create_dir(old_path(tmp.path(), "out")).unwrap();
        recover(&out).unwrap();
        assert_eq!(names(tmp.path()), ["out"]);
    }

    #[test]
    fn foreign_folders_and_links_are_not_replaced() {
        let tmp = tempfile::tempdir().unwrap();
        let mine = tmp.path().join("mine");
        std::fs::create_dir(&mine).unwrap();
        std::fs::write(mine.join("thesis.tex"), b"x").unwrap();
        let err = Staging::begin(&mine).err().unwrap().to_string();
        assert!(err.contains("not a dexcut results folder"), "{err}");
        let link = tmp.path().join("link");
        std::os::unix::fs::symlink(&mine, &link).unwrap();
        let err = Staging::begin(&link).err().unwrap().to_string();
        assert!(err.contains("symbolic link"), "{err}");
        assert_eq!(std::fs::read(mine.join("thesis.tex")).unwrap(), b"x");
    }
}
