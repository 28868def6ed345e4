//! The basis, loaded from the cache or built on a background thread while painting works.

use crate::basis::{Basis, BasisCache, BasisSpec, BuildProgress, CacheOutcome};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// Where the basis stands, for the status bar.
#[derive(Clone, Debug)]
pub enum BasisStatus {
    /// Loading from the cache or building: stage name and fraction done.
    Working {
        stage: String,
        fraction: f32,
    },
    Ready {
        components: usize,
        outcome: CacheOutcome,
    },
    Failed(String),
}

/// A basis being obtained in the background.
pub struct BasisJob {
    spec: BasisSpec,
    shared: Arc<Mutex<JobState>>,
    thread: Option<JoinHandle<()>>,
}

struct JobState {
    status: BasisStatus,
    result: Option<Arc<Basis>>,
}

impl BasisJob {
    /// Loads `spec` from `cache` or builds it, on its own thread.
    pub fn start(spec: BasisSpec, cache: Option<BasisCache>) -> Self {
        let shared = Arc::new(Mutex::new(JobState {
            status: BasisStatus::Working {
                stage: "loading".into(),
                fraction: 0.0,
            },
            result: None,
        }));
        let job_state = shared.clone();
        let thread = std::thread::Builder::new()
            .name("burnish-basis".into())
            .spawn(move || {
                let progress_state = job_state.clone();
                let progress = move |p: BuildProgress| {
                    let fraction = p.done as f32 / p.total.max(1) as f32;
                    if let Ok(mut state) = progress_state.lock() {
                        state.status = BasisStatus::Working {
                            stage: p.stage.to_owned(),
                            fraction,
                        };
                    }
                };
                let outcome = match cache.map_or_else(BasisCache::default_location, Ok) {
                    Ok(cache) => cache.load_or_build(&spec, false, &progress),
                    // No folder to cache it in: painting still needs the basis.
                    Err(e) => Ok((
                        Arc::new(crate::basis::build_basis(&spec, &progress)),
                        CacheOutcome::NotStored {
                            reason: e.to_string(),
                        },
                    )),
                };
                let mut state = job_state.lock().unwrap_or_else(|e| e.into_inner());
                match outcome {
                    Ok((basis, outcome)) => {
                        state.status = BasisStatus::Ready {
                            components: basis.components(),
                            outcome,
                        };
                        state.result = Some(basis);
                    }
                    Err(e) => state.status = BasisStatus::Failed(e.to_string()),
                }
            })
            .expect("spawning the basis thread");
        Self {
            spec,
            shared,
            thread: Some(thread),
        }
    }

    /// A job that is already done (a basis given by the caller, as in tests).
    pub fn ready(spec: BasisSpec, basis: Arc<Basis>) -> Self {
        Self {
            spec,
            shared: Arc::new(Mutex::new(JobState {
                status: BasisStatus::Ready {
                    components: basis.components(),
                    outcome: CacheOutcome::Loaded,
                },
                result: Some(basis),
            })),
            thread: None,
        }
    }

    /// A job whose basis the caller hands over later (see `Document::set_basis`).
    pub fn awaiting_caller(spec: BasisSpec) -> Self {
        Self {
            spec,
            shared: Arc::new(Mutex::new(JobState {
                status: BasisStatus::Working {
                    stage: "waiting for the basis".into(),
                    fraction: 0.0,
                },
                result: None,
            })),
            thread: None,
        }
    }

    pub fn spec(&self) -> &BasisSpec {
        &self.spec
    }

    pub fn status(&self) -> BasisStatus {
        self.shared
            .lock()
            .map(|s| s.status.clone())
            .unwrap_or_else(|e| e.into_inner().status.clone())
    }

    /// The basis once, when it has just become ready.
    pub fn take_result(&mut self) -> Option<Arc<Basis>> {
        let basis = self.shared.lock().ok()?.result.take();
        if basis.is_some()
            && let Some(thread) = self.thread.take()
        {
            let _ = thread.join();
        }
        basis
    }

    /// Waits for the job (tests, benchmarks and the command line only).
    pub fn wait(&mut self) {
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
