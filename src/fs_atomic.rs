//! Atomic file writes: write beside the target, flush and sync, rename over it, then sync
//! the folder, so that a failed or interrupted write (a full disk, a killed process, a
//! power cut) never leaves a half-written file: the target holds either the old contents
//! or the new ones, complete.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `path` through `write`, atomically. On any error the target is untouched
/// and the temporary file is removed.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| Error::invalid(path, "not a file path"))?
        .to_string_lossy()
        .into_owned();
    // The process id and a counter: two writes of the same file (an autosave and a save)
    // never share a temporary file.
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let tmp = dir.join(format!(
        ".{file_name}.{}.{}.tmp",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let file = File::create(&tmp)?;
        let mut writer = BufWriter::with_capacity(1 << 20, file);
        write(&mut writer)?;
        writer.flush()?;
        let file = writer.into_inner().map_err(|e| e.into_error())?;
        simulated_full_disk(dir, file.metadata()?.len())?;
        // The data reaches the disk before the name does: after a crash the target is never
        // a complete-looking file with missing contents.
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)?;
        // And the rename itself is made durable.
        sync_folder(dir)
    })();
    if let Err(source) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, source));
    }
    Ok(())
}

/// Syncs a folder's entries (a rename in it) to the disk. Where the platform can't open a
/// folder as a file (Windows), the rename is as durable as that platform makes it.
fn sync_folder(dir: &Path) -> std::io::Result<()> {
    match File::open(dir) {
        Ok(folder) => folder.sync_all().or_else(|e| {
            // Some file systems can't sync a folder; the write itself succeeded.
            if e.kind() == std::io::ErrorKind::InvalidInput {
                Ok(())
            } else {
                Err(e)
            }
        }),
        Err(_) if cfg!(windows) => Ok(()),
        Err(e) => Err(e),
    }
}

/// Folders whose disk is pretended full, with the bytes still free on each.
static FULL_DISKS: Mutex<Vec<(PathBuf, u64)>> = Mutex::new(Vec::new());

/// Fails like a full disk (`ENOSPC`, "No space left on device") when a file larger than the
/// free space pretended for `dir` is written into it.
fn simulated_full_disk(dir: &Path, len: u64) -> std::io::Result<()> {
    let disks = FULL_DISKS.lock().unwrap_or_else(|e| e.into_inner());
    match disks.iter().find(|(d, _)| dir.starts_with(d)) {
        Some((_, free)) if len > *free => Err(full_disk_error()),
        _ => Ok(()),
    }
}

/// The error a full disk gives: ENOSPC, "No space left on device", where the platform has it.
fn full_disk_error() -> std::io::Error {
    if cfg!(unix) {
        std::io::Error::from_raw_os_error(28)
    } else {
        std::io::ErrorKind::StorageFull.into()
    }
}

/// Fault injection for tests of what callers do when the disk fills up: while the guard
/// lives, every atomic write into `dir` (or a folder inside it) that holds more than
/// `free_bytes` fails with [`std::io::ErrorKind::StorageFull`] after its data was written and
/// before the rename, as a real full disk makes it fail. A full disk can't be made for real
/// without privileges to mount a small file system, which test machines may lack.
pub fn simulate_full_disk(dir: &Path, free_bytes: u64) -> FullDiskGuard {
    let dir = dir.to_path_buf();
    FULL_DISKS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((dir.clone(), free_bytes));
    FullDiskGuard { dir }
}

/// Ends a [`simulate_full_disk`] when dropped.
#[must_use = "the disk is full only while the guard lives"]
pub struct FullDiskGuard {
    dir: PathBuf,
}

impl Drop for FullDiskGuard {
    fn drop(&mut self) {
        let mut disks = FULL_DISKS.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(i) = disks.iter().position(|(d, _)| *d == self.dir) {
            disks.remove(i);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failure_leaves_target_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.bin");
        std::fs::write(&path, b"before").unwrap();
        let err = write_atomically(&path, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk full"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"before");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        write_atomically(&path, |w| w.write_all(b"after")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"after");
    }

    #[test]
    fn unwritable_directory_names_the_file() {
        let err = write_atomically(Path::new("/nonexistent-dir/x.exr"), |_| Ok(())).unwrap_err();
        assert!(err.to_string().contains("/nonexistent-dir/x.exr"), "{err}");
    }

    #[test]
    fn a_full_disk_fails_the_write_and_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub").join("t.bin");
        std::fs::create_dir(path.parent().unwrap()).unwrap();
        std::fs::write(&path, b"before").unwrap();
        let full = simulate_full_disk(dir.path(), 10);
        write_atomically(&path, |w| w.write_all(b"fits")).unwrap();
        let err = write_atomically(&path, |w| w.write_all(&[7; 11])).unwrap_err();
        assert!(
            matches!(&err, Error::Io { cause, .. } if cause.kind() == std::io::ErrorKind::StorageFull),
            "{err}"
        );
        assert!(err.to_string().contains("t.bin"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"fits");
        assert_eq!(
            std::fs::read_dir(path.parent().unwrap()).unwrap().count(),
            1
        );
        drop(full);
        write_atomically(&path, |w| w.write_all(&[7; 11])).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), [7; 11]);
    }
}
