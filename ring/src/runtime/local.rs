//! Run a whole ring inside one process, one thread per member, over the in-process loopback
//! transport or over real zenoh sessions (one per member, connected over loopback TCP). Used by
//! tests and by `mcc bench ring` (whose members come from the ring builder, [`crate::builder`]).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use crossbeam_channel::{bounded, unbounded, Sender};

use super::driver::{Driver, DriverCmd, DriverConfig, DriverExit};
use crate::control::MemberStatus;
use crate::core::{CoreConfig, MemberCore, RingApp};
use crate::transport::loopback::LoopbackRing;
use crate::transport::session::{free_loopback_endpoint, open_session, SessionOptions};
use crate::transport::{zenoh_link, LinkRx, LinkTx, TransportError};

/// Which links the members use.
#[derive(Debug, Clone)]
pub enum LocalTransport {
    /// In-process channels.
    Loopback,
    /// One zenoh peer session per member; all connect to the first one's loopback endpoint.
    Zenoh {
        /// Cluster name used in the key expressions.
        cluster: String,
    },
    /// [`LocalTransport::Zenoh`], members run as member processes do ([`super::inline`]):
    /// followers forward on zenoh's receive thread.
    ZenohInline {
        /// Cluster name used in the key expressions.
        cluster: String,
        /// Ticks run on the receive thread too ([`super::inline::run_send`]), else on each
        /// member's thread ([`super::inline::run`]).
        receive_thread_ticks: bool,
    },
}

impl LocalTransport {
    fn zenoh_cluster(&self) -> Option<&str> {
        match self {
            LocalTransport::Loopback => None,
            LocalTransport::Zenoh { cluster } | LocalTransport::ZenohInline { cluster, .. } => {
                Some(cluster)
            }
        }
    }
}

/// What a member's thread leaves behind.
#[derive(Debug)]
pub struct MemberResult<A> {
    /// Why its loop ended.
    pub exit: DriverExit,
    /// Its core (status, counters).
    pub core: MemberCore,
    /// Its application.
    pub app: A,
    /// Timing samples ([`DriverConfig::record`]).
    pub records: Vec<(u64, u64)>,
    /// The synchronizing master's clock report at the end.
    pub clock: Option<crate::control::ClockReport>,
}

/// One member of a local ring.
#[derive(Debug)]
pub struct LocalMember {
    /// Member name.
    pub name: String,
    /// Requests to its loop.
    pub cmds: Sender<DriverCmd>,
}

/// A running local ring.
pub struct LocalRing<A: RingApp + Send + 'static> {
    /// The members, in ring order.
    pub members: Vec<LocalMember>,
    stop: Arc<AtomicBool>,
    handles: Vec<JoinHandle<MemberResult<A>>>,
    _sessions: Vec<zenoh::Session>,
    _guards: Vec<zenoh_link::ZenohRxGuard>,
}

impl<A: RingApp + Send + 'static> std::fmt::Debug for LocalRing<A> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LocalRing")
            .field("members", &self.members)
            .finish_non_exhaustive()
    }
}

impl<A: RingApp + Send + 'static> LocalRing<A> {
    /// Start `members` (core config, app, driver config each) in ring order.
    pub fn start(
        members: Vec<(CoreConfig, A, DriverConfig)>,
        transport: LocalTransport,
    ) -> Result<Self, TransportError> {
        let n = members.len();
        let stop = Arc::new(AtomicBool::new(false));
        let mut links: Vec<(Box<dyn LinkTx>, LinkRx)> = Vec::with_capacity(n);
        let mut sessions = Vec::new();
        let mut guards = Vec::new();
        match &transport {
            LocalTransport::Loopback => {
                let ring = LoopbackRing::new(n);
                for k in 0..n {
                    let (tx, rx) = ring.member(k)?;
                    links.push((Box::new(tx), rx));
                }
            }
            LocalTransport::Zenoh { .. } | LocalTransport::ZenohInline { .. } => {
                let cluster = transport.zenoh_cluster().unwrap_or_default();
                let first = free_loopback_endpoint()?;
                for k in 0..n {
                    let opts = if k == 0 {
                        SessionOptions {
                            listen: vec![first.clone()],
                            connect: vec![],
                            ..Default::default()
                        }
                    } else {
                        SessionOptions {
                            listen: vec![free_loopback_endpoint()?],
                            connect: vec![first.clone()],
                            ..Default::default()
                        }
                    };
                    sessions.push(open_session(&opts)?);
                }
                // Gossip connects every peer to every other; wait for the mesh (bounded).
                let deadline = std::time::Instant::now() + Duration::from_secs(15);
                while std::time::Instant::now() < deadline
                    && sessions
                        .iter()
                        .any(|s| zenoh::Wait::wait(s.info().peers_zid()).count() + 1 < n)
                {
                    std::thread::sleep(Duration::from_millis(20));
                }
                for (k, s) in sessions.iter().enumerate() {
                    let (tx, rx, g) = zenoh_link::join(s, cluster, "0", k, n)?;
                    links.push((Box::new(tx), rx));
                    guards.push(g);
                }
                // Let every subscriber's declaration reach its publisher before frames flow.
                std::thread::sleep(Duration::from_millis(300));
            }
        }
        let mut out = Vec::with_capacity(n);
        let mut handles = Vec::with_capacity(n);
        // Start followers first so the sync master's first frame finds everyone listening.
        let mut items: Vec<_> = members.into_iter().zip(links).enumerate().collect();
        items.sort_by_key(|(_, ((c, _, _), _))| c.settings.is_sync_master());
        let mut named = Vec::with_capacity(n);
        for (k, ((core_cfg, app, dcfg), (tx, rx))) in items {
            let (ctx, crx) = unbounded();
            let name = dcfg.name.clone();
            let stop2 = Arc::clone(&stop);
            let runner = transport.clone();
            let h = std::thread::Builder::new()
                .name(format!("ring-{name}"))
                .spawn(move || {
                    let core = MemberCore::new(core_cfg);
                    let d = Driver::new(dcfg, core, app, tx, rx, crx, stop2);
                    let (exit, mut d) = match runner {
                        LocalTransport::ZenohInline {
                            receive_thread_ticks: true,
                            ..
                        } => super::inline::run_send(d),
                        LocalTransport::ZenohInline { .. } => super::inline::run(d),
                        _ => {
                            let mut d = d;
                            (d.run(), d)
                        }
                    };
                    let records = d.take_records();
                    let clock = d.clock_report();
                    let (core, app) = d.into_parts();
                    MemberResult {
                        exit,
                        core,
                        app,
                        records,
                        clock,
                    }
                })
                .map_err(|e| TransportError::Io(e.to_string()))?;
            named.push((k, LocalMember { name, cmds: ctx }, h));
        }
        named.sort_by_key(|(k, _, _)| *k);
        for (_, m, h) in named {
            out.push(m);
            handles.push(h);
        }
        Ok(LocalRing {
            members: out,
            stop,
            handles,
            _sessions: sessions,
            _guards: guards,
        })
    }

    /// Whether member `k`'s loop has ended.
    pub fn is_finished(&self, k: usize) -> bool {
        self.handles.get(k).is_none_or(JoinHandle::is_finished)
    }

    /// Wait up to `timeout` for member `k`'s loop to end (e.g. the sync master reaching its
    /// `max_cycles`), then stop everyone.
    pub fn join_member(self, k: usize, timeout: Duration) -> Vec<MemberResult<A>> {
        let deadline = std::time::Instant::now() + timeout;
        while std::time::Instant::now() < deadline && !self.is_finished(k) {
            std::thread::sleep(Duration::from_millis(2));
        }
        self.stop()
    }

    /// Status of member `k` (waits up to a second for its loop).
    pub fn status(&self, k: usize) -> Option<MemberStatus> {
        let (tx, rx) = bounded(1);
        self.members.get(k)?.cmds.send(DriverCmd::Status(tx)).ok()?;
        rx.recv_timeout(Duration::from_secs(1)).ok()
    }

    /// Wait until every member's loop has ended on its own (e.g. `max_cycles`), or stop them
    /// after `timeout`. Returns each member's exit, core and app in ring order.
    pub fn join(self, timeout: Duration) -> Vec<MemberResult<A>> {
        let deadline = std::time::Instant::now() + timeout;
        while std::time::Instant::now() < deadline && self.handles.iter().any(|h| !h.is_finished())
        {
            std::thread::sleep(Duration::from_millis(2));
        }
        self.stop.store(true, Ordering::Relaxed);
        let r = self
            .handles
            .into_iter()
            .filter_map(|h| h.join().ok())
            .collect();
        drop(self._guards);
        for s in self._sessions {
            let _ = zenoh::Wait::wait(s.close());
        }
        r
    }

    /// Stop every member now.
    pub fn stop(self) -> Vec<MemberResult<A>> {
        self.stop.store(true, Ordering::Relaxed);
        self.join(Duration::ZERO)
    }
}
