//! Autosave and crash recovery.
//!
//! While the app runs, an [`Autosaver`] writes the session to the recovery file at most once
//! per [`AUTOSAVE_INTERVAL`], on a background thread so that the UI never waits for the disk.
//! On a clean exit (and after the user saves) the app calls [`Autosaver::discard`]; a
//! recovery file found at the next start ([`pending_recovery`]) means the app did not exit
//! cleanly, and the app offers to reopen it.

use super::Session;
use super::file::{read_session, read_summary, write_session};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

/// The least time between the starts of two autosaves.
pub const AUTOSAVE_INTERVAL: Duration = Duration::from_secs(30);

const RECOVERY_FILE: &str = "recovery.burnish";

/// `$BURNISH_DATA_DIR/recovery.burnish` if that variable is set, else `recovery.burnish` in
/// the user's data folder for Burnish (e.g. ~/.local/share/burnish); `None` where the
/// user has no home folder.
pub fn recovery_path() -> Option<PathBuf> {
    let dir = match std::env::var_os("BURNISH_DATA_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => directories::ProjectDirs::from("", "", "burnish")?
            .data_dir()
            .to_path_buf(),
    };
    Some(dir.join(RECOVERY_FILE))
}

/// A recovery file left by a session that did not end cleanly.
#[derive(Clone, Debug, PartialEq)]
pub struct RecoveryInfo {
    pub path: PathBuf,
    /// When it was last written.
    pub modified: SystemTime,
    /// How many views it holds.
    pub views: usize,
    /// The user's own session file the recovered session belonged to, if it had been saved.
    pub session_path: Option<PathBuf>,
}

impl RecoveryInfo {
    /// Opens the recovered session (validated as [`Session::open`] does).
    pub fn open(&self) -> Result<Session> {
        read_session(&self.path, &super::file::object_cache_dir).map(|(session, _)| session)
    }
}

/// The recovery file at [`recovery_path`], if a session left one.
pub fn pending_recovery() -> Option<RecoveryInfo> {
    pending_recovery_at(&recovery_path()?)
}

/// The recovery file at `path`, if there is one whose manifest can be read. A file that
/// can't be read can't be recovered either; the next autosave replaces it.
pub fn pending_recovery_at(path: &Path) -> Option<RecoveryInfo> {
    let modified = std::fs::metadata(path).ok()?.modified().ok()?;
    let summary = read_summary(path).ok()?;
    Some(RecoveryInfo {
        path: path.to_path_buf(),
        modified,
        views: summary.views,
        session_path: summary.session_path,
    })
}

/// Writes the session to a recovery file now and then, off the calling thread.
///
/// The caller drives it from its frame loop with [`Autosaver::maybe_save`], passing the
/// time, so that it needs no timer of its own (and tests control time).
#[derive(Debug)]
pub struct Autosaver {
    path: PathBuf,
    session_path: Option<PathBuf>,
    /// When the last write started.
    last_write: Option<Instant>,
    /// The session changed since the last snapshot was taken.
    unsaved: bool,
    writer: Option<JoinHandle<Result<()>>>,
    error: Option<Error>,
}

impl Autosaver {
    /// An autosaver writing to `path`.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            session_path: None,
            last_write: None,
            unsaved: false,
            writer: None,
            error: None,
        }
    }

    /// An autosaver writing to [`recovery_path`].
    pub fn at_default_location() -> Option<Self> {
        recovery_path().map(Self::new)
    }

    /// The recovery file it writes.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Records the user's own file for the session (after Open or Save As), so that a
    /// recovery can say which file it was. Takes effect from the next write.
    pub fn set_session_path(&mut self, session_path: Option<PathBuf>) {
        self.session_path = session_path;
    }

    /// Call once per frame. `dirty`: the session changed since the previous call. Starts
    /// a background write of `snapshot()` when there are changes not yet written, no write
    /// is under way and [`AUTOSAVE_INTERVAL`] has passed since the previous write started
    /// (the first write happens at once). Returns whether it started one.
    pub fn maybe_save(
        &mut self,
        now: Instant,
        dirty: bool,
        snapshot: impl FnOnce() -> Session,
    ) -> bool {
        self.unsaved |= dirty;
        if self.writer.as_ref().is_some_and(|w| w.is_finished()) {
            self.collect();
        }
        let due = self
            .last_write
            .is_none_or(|last| now.saturating_duration_since(last) >= AUTOSAVE_INTERVAL);
        if !self.unsaved || self.writer.is_some() || !due {
            return false;
        }
        let session = snapshot();
        let path = self.path.clone();
        let session_path = self.session_path.clone();
        self.writer = Some(std::thread::spawn(move || {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
            }
            write_session(&session, &path, session_path.as_deref())
        }));
        self.last_write = Some(now);
        self.unsaved = false;
        true
    }

    /// Whether a write is under way.
    pub fn is_writing(&self) -> bool {
        self.writer.as_ref().is_some_and(|w| !w.is_finished())
    }

    /// The error of the last write that failed, once; the changes it held are written again
    /// at the next due [`Autosaver::maybe_save`].
    pub fn take_error(&mut self) -> Option<Error> {
        if self.writer.as_ref().is_some_and(|w| w.is_finished()) {
            self.collect();
        }
        self.error.take()
    }

    /// Waits for the write under way, if any, and returns its outcome (or that of an earlier
    /// failed write not yet taken).
    pub fn flush(&mut self) -> Result<()> {
        self.collect();
        self.error.take().map_or(Ok(()), Err)
    }

    /// Waits for any write under way, then deletes the recovery file: call it on a clean
    /// exit and after the user's own file has been saved.
    pub fn discard(&mut self) -> Result<()> {
        self.collect();
        self.error = None;
        self.unsaved = false;
        match std::fs::remove_file(&self.path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::io(&self.path, e)),
            _ => Ok(()),
        }
    }

    /// Joins the writer thread, keeping a failure and marking its changes as unwritten.
    fn collect(&mut self) {
        let Some(writer) = self.writer.take() else {
            return;
        };
        let outcome = writer
            .join()
            .unwrap_or_else(|_| Err(Error::invalid(&self.path, "the autosave thread panicked")));
        if let Err(e) = outcome {
            self.error = Some(e);
            self.unsaved = true;
        }
    }
}

impl Drop for Autosaver {
    /// Lets a write under way finish, so that it never leaves a temporary file behind.
    fn drop(&mut self) {
        self.collect();
    }
}
