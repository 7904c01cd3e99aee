//! The drive host's side of the EMCL bus: zenoh queryables `mcc/<cluster>/emcl/<host>/frame`
//! (one frame in, the addressed drives' answers out), `…/status` (JSON rows) and `…/io` (the
//! test bench sets input lines), plus the EEPROM writer.
//!
//! Persistence: a frame that stored a setting (STAP, STGP, SGP on 64..87, SCO …,255, 133
//! after a download, 137, GP 81 erasing the program) is answered only once its image is on
//! disk (written, fsynced, renamed), on a helper thread so zenoh's callback thread never
//! waits for the disk. Slots stored during a download, and whatever a running program
//! stores, are written by the writer thread within [`WRITE_PERIOD`] (without fsync until the
//! download ends); everything still pending is written durably when the process stops.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use mcc_contracts::control::emcl::{
    encode_answers, frame_key, io_key, status_key, BusAnswer, DriveStatus, IoRequest, FRAME_LEN,
};
use mcc_ring::control::CtlReply;
use zenoh::Wait;

use crate::emcl::drive::Dirty;
use crate::emcl::DriveHost;

/// How often the writer looks for images to write.
pub const WRITE_PERIOD: Duration = Duration::from_millis(100);

/// The drives of this process and where their images go.
#[derive(Debug)]
pub struct HostState {
    /// The drives.
    pub host: DriveHost,
    /// State file of each drive.
    pub files: Vec<PathBuf>,
    /// Last write error of each drive.
    pub errors: Vec<Option<String>>,
    /// This process's member name (the host in status rows).
    pub member: String,
}

/// Shared between the ring tick (or the stand-alone clock), the queryables and the writer.
pub type Shared = Arc<Mutex<HostState>>;

fn lock(s: &Shared) -> MutexGuard<'_, HostState> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

/// Serialises image writes so that a newer image is never overwritten by an older one.
static WRITE_ORDER: Mutex<()> = Mutex::new(());

/// Write drive `k`'s image (encoded now, under the write order). Errors are recorded.
pub fn persist(shared: &Shared, k: usize, durable: bool) {
    let _order = WRITE_ORDER.lock().unwrap_or_else(|e| e.into_inner());
    let (path, bytes) = {
        let st = lock(shared);
        let (Some(d), Some(p)) = (st.host.drives.get(k), st.files.get(k)) else {
            return;
        };
        (p.clone(), d.drive.eeprom().encode())
    };
    let res = super::persist::write_atomic(&path, &bytes, durable);
    let mut st = lock(shared);
    if let Some(slot) = st.errors.get_mut(k) {
        *slot = res
            .as_ref()
            .err()
            .map(|e| format!("{}: {e}", path.display()));
    }
    if let Err(e) = res {
        tracing::warn!("EEPROM image {} not written: {e}", path.display());
    }
}

/// Write every image that has something pending (`durable`: with fsync).
pub fn flush(shared: &Shared, durable: bool) {
    let pending: Vec<(usize, Dirty)> = {
        let mut st = lock(shared);
        st.host
            .drives
            .iter_mut()
            .enumerate()
            .filter_map(|(k, d)| match d.drive.take_dirty() {
                Dirty::Clean => None,
                x => Some((k, x)),
            })
            .collect()
    };
    for (k, d) in pending {
        persist(shared, k, durable || d == Dirty::Now);
    }
}

/// Status rows of every drive of this process.
pub fn statuses(shared: &Shared) -> Vec<DriveStatus> {
    let st = lock(shared);
    (0..st.host.drives.len())
        .filter_map(|k| {
            let mut s = st.host.status(k, &st.member)?;
            s.state_file = st.files.get(k).map(|p| p.display().to_string());
            s.eeprom_error = st.errors.get(k).cloned().flatten();
            Some(s)
        })
        .collect()
}

/// Handle one bus frame: the encoded answers, and the drives whose images must be on disk
/// before the answer goes out.
pub fn handle_frame(shared: &Shared, payload: &[u8]) -> (Vec<u8>, Vec<usize>) {
    let Ok(frame) = <[u8; FRAME_LEN]>::try_from(payload) else {
        return (Vec::new(), Vec::new());
    };
    let mut st = lock(shared);
    let answers = st.host.frame(&frame);
    let mut urgent = Vec::new();
    for (k, _) in &answers {
        if let Some(d) = st.host.drives.get_mut(*k) {
            if d.drive.dirty_now() {
                let _ = d.drive.take_dirty();
                urgent.push(*k);
            }
        }
    }
    let bus: Vec<BusAnswer> = answers
        .into_iter()
        .map(|(_, a)| BusAnswer {
            pause_ms: a.pause_ms,
            bytes: a.bytes,
        })
        .collect();
    (encode_answers(&bus), urgent)
}

fn set_io(shared: &Shared, payload: &[u8]) -> CtlReply {
    let req: IoRequest = match serde_json::from_slice(payload) {
        Ok(r) => r,
        Err(e) => {
            return CtlReply {
                ok: false,
                message: format!("bad io request: {e}"),
            }
        }
    };
    let mut st = lock(shared);
    let Some(d) = st.host.drives.iter_mut().find(|d| d.name == req.drive) else {
        return CtlReply {
            ok: false,
            message: format!("no drive {:?} here", req.drive),
        };
    };
    match d.drive.set_input(&req.input, req.value) {
        Ok(()) => CtlReply {
            ok: true,
            message: format!("{} {} = {}", req.drive, req.input, req.value),
        },
        Err(e) => CtlReply {
            ok: false,
            message: e.to_string(),
        },
    }
}

/// The queryables and the writer; dropping it undeclares them and writes what is pending.
pub struct EmclService {
    _frame: zenoh::query::Queryable<()>,
    _status: zenoh::query::Queryable<()>,
    _io: zenoh::query::Queryable<()>,
    stop: Arc<AtomicBool>,
    writer: Option<std::thread::JoinHandle<()>>,
    shared: Shared,
}

impl std::fmt::Debug for EmclService {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EmclService").finish_non_exhaustive()
    }
}

fn reply(query: &zenoh::query::Query, body: Vec<u8>) {
    if let Err(e) = query.reply(query.key_expr().clone(), body).wait() {
        tracing::warn!("emcl reply failed: {e}");
    }
}

fn payload(query: &zenoh::query::Query) -> Vec<u8> {
    query
        .payload()
        .map(|p| p.to_bytes().into_owned())
        .unwrap_or_default()
}

impl EmclService {
    /// Declare the queryables of `member` in `cluster` and start the writer.
    pub fn start(
        session: &zenoh::Session,
        cluster: &str,
        member: &str,
        shared: Shared,
    ) -> zenoh::Result<Self> {
        let s = Arc::clone(&shared);
        let frame = session
            .declare_queryable(frame_key(cluster, member))
            .callback(move |query| {
                let (body, urgent) = handle_frame(&s, &payload(&query));
                if urgent.is_empty() {
                    reply(&query, body);
                    return;
                }
                // The setting goes to disk before the drive answers.
                let s = Arc::clone(&s);
                let spawned = std::thread::Builder::new()
                    .name("mcc-emcl-eeprom".into())
                    .spawn(move || {
                        for k in urgent {
                            persist(&s, k, true);
                        }
                        reply(&query, body);
                    });
                if let Err(e) = spawned {
                    tracing::warn!("cannot start an EEPROM write thread: {e}");
                }
            })
            .wait()?;
        let s = Arc::clone(&shared);
        let status = session
            .declare_queryable(status_key(cluster, member))
            .callback(move |query| {
                let body = serde_json::to_vec(&statuses(&s)).unwrap_or_default();
                reply(&query, body);
            })
            .wait()?;
        let s = Arc::clone(&shared);
        let io = session
            .declare_queryable(io_key(cluster, member))
            .callback(move |query| {
                let r = set_io(&s, &payload(&query));
                reply(&query, serde_json::to_vec(&r).unwrap_or_default());
            })
            .wait()?;
        let stop = Arc::new(AtomicBool::new(false));
        let writer = {
            let (s, stop) = (Arc::clone(&shared), Arc::clone(&stop));
            std::thread::Builder::new()
                .name("mcc-emcl-writer".into())
                .spawn(move || {
                    while !stop.load(Ordering::Relaxed) {
                        std::thread::sleep(WRITE_PERIOD);
                        flush(&s, false);
                    }
                })
                .ok()
        };
        Ok(EmclService {
            _frame: frame,
            _status: status,
            _io: io,
            stop,
            writer,
            shared,
        })
    }
}

impl Drop for EmclService {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(w) = self.writer.take() {
            let _ = w.join();
        }
        // Whatever is pending, durably (a download in progress included).
        let n = lock(&self.shared).host.drives.len();
        flush(&self.shared, true);
        for k in 0..n {
            let downloading = lock(&self.shared)
                .host
                .drives
                .get(k)
                .is_some_and(|d| d.drive.downloading());
            if downloading {
                persist(&self.shared, k, true);
            }
        }
    }
}
