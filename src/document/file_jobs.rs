//! File work that takes seconds (writing an export, reading a starting material and
//! rendering it under every view) runs on a thread of its own: the window keeps drawing and
//! painting while it runs, shows what is under way, and takes the outcome when it is done.

use crate::image_io::RgbImage;
use crate::scene::GBuffer;
use crate::session::StartMaterial;
use crate::worker::ViewId;
use crossbeam_channel::{Receiver, TryRecvError};
use std::path::PathBuf;
use std::sync::Arc;

/// What a finished job hands back to the thread that polls the document.
pub(super) enum Outcome {
    /// A file was written; the notice to show.
    Written(String),
    /// A starting material was read and rendered for the views it was asked for.
    StartLoaded {
        start: StartMaterial,
        /// Per view, the geometry the render is of and the material rendered on it.
        renders: Vec<(ViewId, Arc<GBuffer>, RgbImage)>,
    },
}

/// Which kind of work a job does: a later start supersedes an earlier one still running.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum JobKind {
    Export,
    Start { request: u64 },
}

/// One piece of work under way.
pub(super) struct FileJob {
    /// What the window shows while it runs, e.g. "exporting out.bsdf…".
    pub label: String,
    pub kind: JobKind,
    /// The file it reads or writes (named in the error should the thread die).
    pub path: PathBuf,
    outcome: Receiver<crate::Result<Outcome>>,
}

/// The jobs under way.
#[derive(Default)]
pub(super) struct FileJobs {
    jobs: Vec<FileJob>,
    next_start: u64,
}

impl FileJobs {
    /// Runs `work` on a new thread.
    pub fn spawn(
        &mut self,
        label: String,
        kind: JobKind,
        path: PathBuf,
        work: impl FnOnce() -> crate::Result<Outcome> + Send + 'static,
    ) -> std::io::Result<()> {
        let (sender, outcome) = crossbeam_channel::bounded(1);
        std::thread::Builder::new()
            .name("burnish file job".into())
            .spawn(move || {
                let _ = sender.send(work());
            })?;
        self.jobs.push(FileJob {
            label,
            kind,
            path,
            outcome,
        });
        Ok(())
    }

    /// A number for a new start job; only the newest start's outcome is taken.
    pub fn new_start_request(&mut self) -> u64 {
        self.next_start += 1;
        self.next_start
    }

    /// Whether `request` is the newest start asked for.
    pub fn is_latest_start(&self, request: u64) -> bool {
        request == self.next_start
    }

    /// The jobs that finished since the last call, with their outcomes; a job whose thread
    /// died without one gives an error naming its file.
    pub fn take_finished(&mut self) -> Vec<(FileJob, crate::Result<Outcome>)> {
        let mut finished = Vec::new();
        let mut i = 0;
        while i < self.jobs.len() {
            match self.jobs[i].outcome.try_recv() {
                Ok(outcome) => finished.push((self.jobs.remove(i), outcome)),
                Err(TryRecvError::Disconnected) => {
                    let job = self.jobs.remove(i);
                    let error = crate::Error::invalid(
                        &job.path,
                        format!("{} stopped unexpectedly", job.label.trim_end_matches('…')),
                    );
                    finished.push((job, Err(error)));
                }
                Err(TryRecvError::Empty) => i += 1,
            }
        }
        finished
    }

    pub fn is_empty(&self) -> bool {
        self.jobs.is_empty()
    }

    /// What the jobs under way are doing, oldest first.
    pub fn labels(&self) -> impl Iterator<Item = &str> {
        self.jobs.iter().map(|j| j.label.as_str())
    }
}
