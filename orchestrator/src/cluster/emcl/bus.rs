//! The bus itself: frames from every host connection go through one FIFO to one worker that
//! puts each on the line (a zenoh query to every drive host at once: each drive filters by
//! address, as on RS485), waits for the answers, honours the telegram pause (GP 75) and
//! hands the reply back. One frame is on the line at a time (half duplex); connections are
//! served in arrival order, so a host that floods the bus cannot starve another.
//!
//! Answers: none → RS485 silence (no reply); one → its bytes; several (two drives with the
//! same address: a bus collision) → the wired-AND of the replies, as colliding drivers on an
//! idle-high line would leave, which no client will take for a valid reply.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{bounded, Receiver, Sender};
use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::emcl::{decode_answers, frame_key_all, FRAME_LEN};
use zenoh::query::{ConsolidationMode, QueryTarget};
use zenoh::Wait;

/// How long the line waits for the drive hosts (a setting is on disk before its reply).
pub const HOST_TIMEOUT: Duration = Duration::from_secs(3);
/// Frames waiting for the line, at most (a connection has one in flight at a time).
const QUEUE: usize = 256;

/// What came back for one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Outcome {
    /// The reply on the line (None: silence).
    pub bytes: Option<[u8; FRAME_LEN]>,
    /// More than one drive answered.
    pub collision: bool,
}

/// Counters of the bus (logged when it stops).
#[derive(Debug, Default)]
struct BusStats {
    frames: AtomicU64,
    silent: AtomicU64,
    collisions: AtomicU64,
}

struct Job {
    frame: [u8; FRAME_LEN],
    done: Sender<Outcome>,
}

/// A handle on the bus; cheap to clone.
#[derive(Clone)]
pub struct Bus {
    tx: Sender<Job>,
}

impl std::fmt::Debug for Bus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bus").finish_non_exhaustive()
    }
}

impl Bus {
    /// Start the line worker for `cfg`'s cluster on `session`. It ends when every handle is
    /// dropped.
    pub fn start(session: zenoh::Session, cfg: &ClusterConfig) -> std::io::Result<Self> {
        let (tx, rx) = bounded::<Job>(QUEUE);
        let stats = Arc::new(BusStats::default());
        let key = frame_key_all(&cfg.cluster);
        std::thread::Builder::new()
            .name("mcc-emcl-bus".into())
            .spawn(move || line(session, key, rx, stats))?;
        Ok(Bus { tx })
    }

    /// Put `frame` on the line and wait for the outcome (silence if the bus is gone).
    pub fn transact(&self, frame: [u8; FRAME_LEN]) -> Outcome {
        let (done, rx) = bounded(1);
        if self.tx.send(Job { frame, done }).is_err() {
            return Outcome::default();
        }
        rx.recv_timeout(HOST_TIMEOUT * 4).unwrap_or_default()
    }
}

fn line(session: zenoh::Session, key: String, rx: Receiver<Job>, stats: Arc<BusStats>) {
    for job in rx {
        let (out, pause) = put_on_line(&session, &key, &job.frame);
        stats.frames.fetch_add(1, Ordering::Relaxed);
        if out.bytes.is_none() {
            stats.silent.fetch_add(1, Ordering::Relaxed);
        }
        if out.collision {
            stats.collisions.fetch_add(1, Ordering::Relaxed);
        }
        if pause > 0 && out.bytes.is_some() {
            // The drive keeps the line turned around for GP 75 ms before it answers.
            std::thread::sleep(Duration::from_millis(u64::from(pause)));
        }
        let _ = job.done.send(out);
    }
    tracing::info!(
        frames = stats.frames.load(Ordering::Relaxed),
        silent = stats.silent.load(Ordering::Relaxed),
        collisions = stats.collisions.load(Ordering::Relaxed),
        "EMCL bus stopped"
    );
}

fn put_on_line(session: &zenoh::Session, key: &str, frame: &[u8; FRAME_LEN]) -> (Outcome, u8) {
    let get = session
        .get(key)
        .payload(frame.to_vec())
        .target(QueryTarget::All)
        .consolidation(ConsolidationMode::None)
        .timeout(HOST_TIMEOUT)
        .wait();
    let Ok(replies) = get else {
        return (Outcome::default(), 0);
    };
    let mut answers = Vec::new();
    while let Ok(r) = replies.recv() {
        if let Ok(s) = r.result() {
            let b = s.payload().to_bytes();
            answers.extend(decode_answers(&b));
        }
    }
    merge(&answers)
}

/// The line's content for a set of answers, and the pause before it.
pub fn merge(answers: &[mcc_contracts::control::emcl::BusAnswer]) -> (Outcome, u8) {
    let replies: Vec<&[u8; FRAME_LEN]> = answers.iter().filter_map(|a| a.bytes.as_ref()).collect();
    let pause = answers.iter().map(|a| a.pause_ms).max().unwrap_or(0);
    let bytes = match replies.as_slice() {
        [] => None,
        [one] => Some(**one),
        many => {
            let mut f = [0xFFu8; FRAME_LEN];
            for r in many {
                for (a, b) in f.iter_mut().zip(r.iter()) {
                    *a &= *b;
                }
            }
            Some(f)
        }
    };
    (
        Outcome {
            bytes,
            collision: replies.len() > 1,
        },
        pause,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcc_contracts::control::emcl::BusAnswer;

    #[test]
    fn silence_one_answer_and_collisions() {
        assert_eq!(merge(&[]).0, Outcome::default());
        let a = BusAnswer {
            pause_ms: 15,
            bytes: Some([2, 1, 100, 6, 0, 0, 0, 1, 110]),
        };
        let (o, p) = merge(&[a]);
        assert_eq!((o.bytes, o.collision, p), (a.bytes, false, 15));
        let b = BusAnswer {
            pause_ms: 0,
            bytes: Some([2, 1, 100, 6, 0, 0, 0, 2, 111]),
        };
        let (o, _) = merge(&[a, b]);
        assert!(o.collision);
        assert_eq!(o.bytes, Some([2, 1, 100, 6, 0, 0, 0, 0, 110]));
        // An executed frame without a reply (137) is silence on the line.
        let none = BusAnswer {
            pause_ms: 0,
            bytes: None,
        };
        assert_eq!(merge(&[none]).0.bytes, None);
    }
}
