//! Autosave and crash recovery.
//!
//! While the app runs, an [`Autosaver`] writes the session to the recovery file, on a
//! background thread so that the UI never waits for the disk. A finished edit (a stroke
//! released) is written at once, and an edit still under way (a long stroke) at most
//! [`AUTOSAVE_DELAY`] after its first change; two writes start at least
//! [`AUTOSAVE_MIN_GAP`] apart. So a crash at any moment loses at most the last few seconds of
//! painting. The caller asks [`Autosaver::wake_in`] when to look again, so that a due write
//! happens even when nothing else would wake it (an idle window draws no frames).
//!
//! On a clean exit (and after the user saves) the app calls [`Autosaver::discard`]; a
//! recovery file found at the next start ([`pending_recovery`]) means the app did not exit
//! cleanly, and the app offers to reopen it.

use super::Session;
use super::file::{read_session, read_summary, write_session};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

/// The longest a change waits for its write to start while the edit it belongs to goes on.
pub const AUTOSAVE_DELAY: Duration = Duration::from_secs(2);
/// The least time between the starts of two writes, so that quick strokes in a row don't
/// keep the disk and a core busy.
pub const AUTOSAVE_MIN_GAP: Duration = Duration::from_secs(1);
/// How long a failed write waits before it is tried again.
pub const AUTOSAVE_RETRY: Duration = Duration::from_secs(5);

const RECOVERY_FILE: &str = "recovery.burnish";
const UNREADABLE_RECOVERY_FILE: &str = "recovery-unreadable.burnish";

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

/// The recovery file at [`recovery_path`], if a session left one (see
/// [`pending_recovery_at`]).
pub fn pending_recovery() -> Result<Option<RecoveryInfo>> {
    match recovery_path() {
        Some(path) => pending_recovery_at(&path),
        None => Ok(None),
    }
}

/// The recovery file at `path`, if there is one. `Ok(None)` when there is none; an error
/// naming the file and the problem when its manifest can't be read. Such a file is moved
/// aside to `recovery-unreadable.burnish` in the same folder (replacing an older one), so
/// that the next autosave does not overwrite what may still be salvaged from it.
pub fn pending_recovery_at(path: &Path) -> Result<Option<RecoveryInfo>> {
    let metadata = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(Error::io(path, e)),
    };
    let summary = match read_summary(path) {
        Ok(summary) => summary,
        Err(e) => {
            let aside = path.with_file_name(UNREADABLE_RECOVERY_FILE);
            let kept = match std::fs::rename(path, &aside) {
                Ok(()) => format!("; it was moved to {}", aside.display()),
                Err(_) => String::new(),
            };
            return Err(Error::invalid(
                path,
                format!("the recovery file can't be recovered ({e}){kept}"),
            ));
        }
    };
    Ok(Some(RecoveryInfo {
        path: path.to_path_buf(),
        modified: metadata.modified().map_err(|e| Error::io(path, e))?,
        views: summary.views,
        session_path: summary.session_path,
    }))
}

/// A callback that wakes whoever drives the autosaver (the UI asks for a frame).
type Waker = Arc<dyn Fn() + Send + Sync>;

/// Writes the session to a recovery file now and then, off the calling thread.
///
/// The caller drives it with [`Autosaver::maybe_save`], passing the time (so that tests
/// control it), and schedules its next call with [`Autosaver::wake_in`].
pub struct Autosaver {
    path: PathBuf,
    session_path: Option<PathBuf>,
    /// When the oldest change not yet in a started write was made.
    first_unwritten: Option<Instant>,
    /// An edit is under way (the pointer is down on the canvas): more changes will follow.
    editing: bool,
    /// When the last write started.
    last_start: Option<Instant>,
    /// After a failed write, when the next one may start.
    retry_at: Option<Instant>,
    writer: Option<Writer>,
    /// The last failure, until taken.
    error: Option<Error>,
    /// The last write failed (and none has succeeded since).
    failing: bool,
    waker: Option<Waker>,
}

struct Writer {
    thread: JoinHandle<Result<()>>,
    /// `first_unwritten` of the changes it writes.
    first_change: Instant,
}

impl std::fmt::Debug for Autosaver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Autosaver")
            .field("path", &self.path)
            .field("first_unwritten", &self.first_unwritten)
            .field("writing", &self.writer.is_some())
            .field("failing", &self.failing)
            .finish_non_exhaustive()
    }
}

impl Autosaver {
    /// An autosaver writing to `path`.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            session_path: None,
            first_unwritten: None,
            editing: false,
            last_start: None,
            retry_at: None,
            writer: None,
            error: None,
            failing: false,
            waker: None,
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

    /// `wake` is called from the writing thread when a write ends, so that the caller
    /// collects its outcome (and starts the next write) without polling.
    pub fn set_waker(&mut self, wake: impl Fn() + Send + Sync + 'static) {
        self.waker = Some(Arc::new(wake));
    }

    /// Call whenever the session may have changed, and when [`Autosaver::wake_in`] asked.
    /// `changed`: the session changed since the previous call; `editing`: an edit is under
    /// way that will change it more (a stroke being painted).
    ///
    /// Starts a background write of `snapshot()` when there are unwritten changes, no write
    /// is under way, and either the edit is finished or the oldest unwritten change is
    /// [`AUTOSAVE_DELAY`] old; never sooner than [`AUTOSAVE_MIN_GAP`] after the previous
    /// write started, nor [`AUTOSAVE_RETRY`] after a failed one. Returns whether it started.
    pub fn maybe_save(
        &mut self,
        now: Instant,
        changed: bool,
        editing: bool,
        snapshot: impl FnOnce() -> Session,
    ) -> bool {
        if changed {
            self.first_unwritten.get_or_insert(now);
        }
        self.editing = editing;
        self.collect_if_finished(now);
        if self.writer.is_some() || self.due_at().is_none_or(|due| now < due) {
            return false;
        }
        let Some(first_change) = self.first_unwritten.take() else {
            return false;
        };
        let session = snapshot();
        let path = self.path.clone();
        let session_path = self.session_path.clone();
        let waker = self.waker.clone();
        let thread = std::thread::Builder::new()
            .name("burnish-autosave".into())
            .spawn(move || {
                let outcome = (|| {
                    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
                    }
                    write_session(&session, &path, session_path.as_deref())
                })();
                if let Some(wake) = waker {
                    wake();
                }
                outcome
            });
        match thread {
            Ok(thread) => {
                self.writer = Some(Writer {
                    thread,
                    first_change,
                });
                self.last_start = Some(now);
                true
            }
            Err(e) => {
                self.fail(now, first_change, Error::io(&self.path, e));
                false
            }
        }
    }

    /// How long until [`Autosaver::maybe_save`] has a write to start, if it has any; zero
    /// when one is due now. `None` while a write is under way and a waker is set (the
    /// waker calls back), or when nothing is unwritten.
    pub fn wake_in(&self, now: Instant) -> Option<Duration> {
        if self.writer.is_some() {
            // Without a waker, look again shortly for the write's outcome.
            return self.waker.is_none().then_some(Duration::from_millis(100));
        }
        self.due_at().map(|due| due.saturating_duration_since(now))
    }

    /// When the unwritten changes are due, ignoring a write under way.
    fn due_at(&self) -> Option<Instant> {
        let first = self.first_unwritten?;
        let mut due = if self.editing {
            first + AUTOSAVE_DELAY
        } else {
            first
        };
        if let Some(last) = self.last_start {
            due = due.max(last + AUTOSAVE_MIN_GAP);
        }
        if let Some(retry) = self.retry_at {
            due = due.max(retry);
        }
        Some(due)
    }

    /// Whether changes are waiting to be written (or being written).
    pub fn has_unwritten(&self) -> bool {
        self.first_unwritten.is_some() || self.writer.is_some()
    }

    /// Whether a write is under way.
    pub fn is_writing(&self) -> bool {
        self.writer
            .as_ref()
            .is_some_and(|w| !w.thread.is_finished())
    }

    /// Whether the last write failed and none has succeeded since.
    pub fn is_failing(&self) -> bool {
        self.failing
    }

    /// The error of the last write that failed, once; the changes it held are written again
    /// at the next due [`Autosaver::maybe_save`].
    pub fn take_error(&mut self) -> Option<Error> {
        self.collect_if_finished(Instant::now());
        self.error.take()
    }

    /// Waits for the write under way, if any, and returns its outcome (or that of an earlier
    /// failed write not yet taken).
    pub fn flush(&mut self) -> Result<()> {
        self.collect(Instant::now());
        self.error.take().map_or(Ok(()), Err)
    }

    /// Waits for any write under way, then deletes the recovery file: call it on a clean
    /// exit and after the user's own file has been saved.
    pub fn discard(&mut self) -> Result<()> {
        self.collect(Instant::now());
        self.error = None;
        self.failing = false;
        self.retry_at = None;
        self.first_unwritten = None;
        match std::fs::remove_file(&self.path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::io(&self.path, e)),
            _ => Ok(()),
        }
    }

    fn collect_if_finished(&mut self, now: Instant) {
        if self.writer.as_ref().is_some_and(|w| w.thread.is_finished()) {
            self.collect(now);
        }
    }

    /// Joins the writer thread, keeping a failure and marking its changes as unwritten.
    fn collect(&mut self, now: Instant) {
        let Some(writer) = self.writer.take() else {
            return;
        };
        let outcome = writer
            .thread
            .join()
            .unwrap_or_else(|_| Err(Error::invalid(&self.path, "the autosave thread panicked")));
        match outcome {
            Ok(()) => {
                self.failing = false;
                self.retry_at = None;
            }
            Err(e) => self.fail(now, writer.first_change, e),
        }
    }

    fn fail(&mut self, now: Instant, first_change: Instant, error: Error) {
        self.error = Some(error);
        self.failing = true;
        self.retry_at = Some(now + AUTOSAVE_RETRY);
        // The failed write's changes are unwritten again, and as old as they were.
        self.first_unwritten = Some(
            self.first_unwritten
                .map_or(first_change, |t| t.min(first_change)),
        );
    }
}

impl Drop for Autosaver {
    /// Lets a write under way finish, so that it never leaves a temporary file behind.
    fn drop(&mut self) {
        self.collect(Instant::now());
    }
}
