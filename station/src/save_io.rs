//! The station's I/O thread for `MS SAVE` ([`crate::save_effect`]): it writes each
//! [`SaveJob`] with [`persist::save`] (temporary file, fsync, rename, directory fsync: the old
//! file stays intact if anything fails) and sends the [`SaveDone`] back. The tick only hands a
//! job over and picks results up, both without waiting ([`SaveWorker::submit`],
//! [`SaveWorker::poll`]).
//!
//! Queues are bounded ([`QUEUE`]); the core has at most one save in flight, so they never fill.
//! Jobs are written in order, one at a time; a panic while writing is a failed write, not a
//! dead thread. Dropping the worker lets the thread write every job it was given (a write is
//! never cut short by the station going away) and waits for it.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::thread::JoinHandle;

use tracing::{error, info, warn};

use crate::mi::persist;
use crate::save_effect::{SaveDone, SaveJob};

/// Jobs (and results) that may wait in each direction.
pub const QUEUE: usize = 4;

/// The thread that writes the station's state file.
#[derive(Debug)]
pub struct SaveWorker {
    jobs: Option<SyncSender<SaveJob>>,
    done: Option<Receiver<SaveDone>>,
    thread: Option<JoinHandle<()>>,
}

impl SaveWorker {
    /// Start the thread (`mcc-station-save`).
    pub fn start() -> std::io::Result<Self> {
        let (jobs, rx) = sync_channel::<SaveJob>(QUEUE);
        let (tx, done) = sync_channel::<SaveDone>(QUEUE);
        let thread = std::thread::Builder::new()
            .name("mcc-station-save".into())
            .spawn(move || {
                for job in rx {
                    let done =
                        catch_unwind(AssertUnwindSafe(|| write(&job))).unwrap_or_else(|_| {
                            error!("the station's save thread panicked while writing");
                            SaveDone {
                                token: job.token,
                                result: Err("the save thread panicked".into()),
                            }
                        });
                    // Nobody takes results once the worker is dropped: write the rest anyway.
                    let _ = tx.send(done);
                }
            })?;
        Ok(SaveWorker {
            jobs: Some(jobs),
            done: Some(done),
            thread: Some(thread),
        })
    }

    /// Hand `job` to the thread without waiting; the job back if it cannot take it (queue
    /// full, thread gone).
    pub fn submit(&self, job: SaveJob) -> Result<(), SaveJob> {
        let Some(jobs) = &self.jobs else {
            return Err(job);
        };
        jobs.try_send(job).map_err(|e| match e {
            TrySendError::Full(j) | TrySendError::Disconnected(j) => j,
        })
    }

    /// A finished job's result, if one is ready (never waits).
    pub fn poll(&self) -> Option<SaveDone> {
        self.done.as_ref()?.try_recv().ok()
    }
}

impl Drop for SaveWorker {
    fn drop(&mut self) {
        // Results first (the thread never waits to hand one over), then the job queue: the
        // thread writes what it was given and ends.
        self.done = None;
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            if t.join().is_err() {
                error!("the station's save thread panicked");
            }
        }
    }
}

/// Perform one job.
pub fn write(job: &SaveJob) -> SaveDone {
    let path = job.path.display();
    let result = match persist::save(&job.path, &job.setup) {
        Ok(()) => {
            info!(path = %path, "setup saved");
            Ok(())
        }
        Err(e) => {
            warn!(path = %path, "SAVE failed: {e}");
            Err(e.to_string())
        }
    };
    SaveDone {
        token: job.token,
        result,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mi::persist::Loaded;
    use crate::mi::{Globals, Setup};
    use std::path::{Path, PathBuf};
    use std::time::{Duration, Instant};

    fn setup(n: u32) -> Setup {
        Setup {
            globals: Globals {
                config_number: n,
                ..Globals::from_check(8, 4, 4)
            },
            nodes: [(0u8, Default::default())].into(),
        }
    }

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("mcc-save-io-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    fn wait(w: &SaveWorker) -> SaveDone {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            if let Some(d) = w.poll() {
                return d;
            }
            assert!(Instant::now() < deadline, "no result from the save thread");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    fn job(token: u64, path: &Path, n: u32) -> SaveJob {
        SaveJob {
            token,
            path: path.to_path_buf(),
            setup: setup(n),
        }
    }

    #[test]
    fn writes_off_the_caller_and_reports_each_result() {
        let dir = temp_dir("ok");
        let path = dir.join("state").join("station0.state");
        let w = SaveWorker::start().unwrap();
        assert_eq!(w.poll(), None);
        w.submit(job(1, &path, 37)).unwrap();
        assert_eq!(
            wait(&w),
            SaveDone {
                token: 1,
                result: Ok(())
            }
        );
        assert_eq!(persist::load(&path), Loaded::Setup(setup(37)));
        // a second save replaces the first; no temporary is left beside it
        w.submit(job(2, &path, 38)).unwrap();
        assert_eq!(wait(&w).result, Ok(()));
        assert_eq!(persist::load(&path), Loaded::Setup(setup(38)));
        let files = std::fs::read_dir(path.parent().unwrap()).unwrap().count();
        assert_eq!(files, 1);
        drop(w);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_failing_write_reports_why_and_keeps_the_old_file() {
        let dir = temp_dir("fail");
        let good = dir.join("station0.state");
        let w = SaveWorker::start().unwrap();
        w.submit(job(1, &good, 37)).unwrap();
        assert_eq!(wait(&w).result, Ok(()));
        // a path below a regular file cannot be created
        let bad = good.join("sub").join("x.state");
        w.submit(job(2, &bad, 38)).unwrap();
        let d = wait(&w);
        assert_eq!(d.token, 2);
        assert!(d.result.is_err(), "{d:?}");
        assert_eq!(persist::load(&good), Loaded::Setup(setup(37)), "intact");
        // the thread goes on after a failure
        w.submit(job(3, &good, 39)).unwrap();
        assert_eq!(wait(&w).result, Ok(()));
        assert_eq!(persist::load(&good), Loaded::Setup(setup(39)));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn dropping_the_worker_finishes_the_queued_writes() {
        let dir = temp_dir("drop");
        let path = dir.join("station0.state");
        let w = SaveWorker::start().unwrap();
        for k in 0..QUEUE as u64 {
            w.submit(job(k, &path, 40 + k as u32)).unwrap();
        }
        drop(w);
        let last = 40 + QUEUE as u32 - 1;
        assert_eq!(persist::load(&path), Loaded::Setup(setup(last)));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
