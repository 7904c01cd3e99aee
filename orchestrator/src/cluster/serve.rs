//! What the supervisor's host servers (daisy chain, EMCL bus) share: the TCP accept loop (a
//! non-blocking listener polled until `stop`, one thread per host connection, admission by
//! [`ConnTable`]: at most `max_connections`, a new host over the limit evicts the connection
//! idle longest or is refused: with a message on a text server, by closing on a binary one),
//! idle timeouts, the raw pseudo-terminal, and the
//! endpoints record.

use std::collections::HashMap;
use std::io::Write;
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mcc_contracts::hostport::{refusal_message, Admission, ConnTable, HostLimits};

type Table = Arc<Mutex<(ConnTable, HashMap<u64, TcpStream>)>>;

/// One connection's place in its port's table: activity and idle time.
#[derive(Debug)]
pub struct Activity {
    table: Table,
    id: u64,
    origin: Instant,
    limits: HostLimits,
    last: std::cell::Cell<Instant>,
}

/// Why a connection's read loop ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// The host closed it, it failed, the server stopped, or `data` ended it.
    Closed,
    /// Closed to make room for a new host after this long idle.
    Evicted(Duration),
    /// Idle for the idle timeout.
    Idle(Duration),
}

impl Activity {
    fn lock(&self) -> std::sync::MutexGuard<'_, (ConnTable, HashMap<u64, TcpStream>)> {
        self.table.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The connection did something (`busy`: a request of it is under way).
    pub fn touch(&self, busy: bool) {
        let now = Instant::now();
        self.last.set(now);
        let t = now.duration_since(self.origin);
        self.lock().0.touch(self.id, t, busy);
    }

    fn evicted(&self) -> bool {
        !self.lock().0.contains(self.id)
    }

    fn idle_expired(&self) -> Option<Duration> {
        let limit = self.limits.idle_timeout()?;
        (self.last.get().elapsed() >= limit).then_some(limit)
    }

    /// The text a terminal-like host reads when its connection ends for `why` (`what` names
    /// the server).
    pub fn farewell(what: &str, why: Ended) -> Option<String> {
        match why {
            Ended::Closed => None,
            Ended::Evicted(idle) => Some(mcc_contracts::hostport::eviction_message(what, idle)),
            Ended::Idle(t) => Some(format!(
                "\r\nmcc: {what}: connection closed after {} s idle (host.idle_timeout_s)\r\n",
                t.as_secs()
            )),
        }
    }
}

impl Drop for Activity {
    fn drop(&mut self) {
        let mut t = self.lock();
        t.0.close(self.id);
        t.1.remove(&self.id);
    }
}

/// How a server tells a host over its connection limit that it is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// A text line naming the limit, then close (terminal-like servers: the daisy chain).
    Text,
    /// Close without writing a byte (binary protocols: the EMCL bus, whose hosts would read a
    /// text line as reply frames); the log says why.
    Close,
}

/// Serve `listener` until `stop`: each connection runs `serve` on a thread named `thread`;
/// `what` names the server in log lines and messages; `refusal` is how a host over the limit
/// is refused.
pub fn accept_loop(
    listener: TcpListener,
    what: &'static str,
    thread: &'static str,
    limits: HostLimits,
    refusal: Refusal,
    stop: Arc<AtomicBool>,
    serve: Arc<dyn Fn(TcpStream, Activity) + Send + Sync>,
) {
    let table: Table = Arc::new(Mutex::new((ConnTable::new(limits), HashMap::new())));
    let origin = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((mut stream, peer)) => {
                let admission = {
                    let mut t = table.lock().unwrap_or_else(|e| e.into_inner());
                    let a = t.0.admit(origin.elapsed());
                    if let Admission::Evict { evict, .. } = a {
                        // Its thread sees end of input and says why before closing.
                        if let Some(s) = t.1.remove(&evict) {
                            let _ = s.shutdown(Shutdown::Read);
                        }
                    }
                    a
                };
                let id = match admission {
                    Admission::Accept(id) => id,
                    Admission::Evict { id, evict, idle } => {
                        tracing::info!(
                            "{what}: evicting connection {evict} (idle {idle:?}) for {peer}"
                        );
                        id
                    }
                    Admission::Refuse { open } => {
                        refuse(&mut stream, what, open, peer, refusal);
                        continue;
                    }
                };
                if let Ok(c) = stream.try_clone() {
                    table
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .1
                        .insert(id, c);
                }
                let activity = Activity {
                    table: Arc::clone(&table),
                    id,
                    origin,
                    limits,
                    last: std::cell::Cell::new(Instant::now()),
                };
                let serve = Arc::clone(&serve);
                let spawned = std::thread::Builder::new()
                    .name(thread.into())
                    .spawn(move || serve(stream, activity));
                if spawned.is_err() {
                    tracing::warn!("{what}: cannot start a connection thread");
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => {
                tracing::warn!("{what} accept: {e}");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

/// Refuse `stream` (a host over the limit) as `refusal` says, logging why.
fn refuse(
    stream: &mut TcpStream,
    what: &str,
    open: usize,
    peer: std::net::SocketAddr,
    refusal: Refusal,
) {
    match refusal {
        Refusal::Text => {
            tracing::warn!("{what}: {open} connections, none idle: refusing {peer}");
            let _ = stream.set_write_timeout(Some(Duration::from_secs(1)));
            let _ = stream.write_all(refusal_message(what, open).as_bytes());
        }
        Refusal::Close => {
            tracing::warn!(
                "{what}: {open} connections, none idle: refusing {peer} by closing \
                 (a binary protocol has no place for a message; host.max_connections)"
            );
            let _ = stream.shutdown(Shutdown::Write);
        }
    }
}

/// Where a server listens (TCP, optional pty); dropping it stops accepting.
#[derive(Debug)]
pub struct Endpoints {
    addr: String,
    pty: Option<String>,
    stop: Arc<AtomicBool>,
}

impl Endpoints {
    /// A server at `addr` (and `pty`) that stops when `stop` is raised.
    pub fn new(addr: String, pty: Option<String>, stop: Arc<AtomicBool>) -> Self {
        Endpoints { addr, pty, stop }
    }

    /// `127.0.0.1:PORT`.
    pub fn addr(&self) -> &str {
        &self.addr
    }

    /// The pseudo-terminal's slave path, when serving one.
    pub fn pty_path(&self) -> Option<&str> {
        self.pty.as_deref()
    }
}

impl Drop for Endpoints {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// A pseudo-terminal in raw mode (no echo, no signals, no CR/NL or XON/XOFF handling: every
/// byte value passes): its slave (keep it open, so reads of the master do not fail while no
/// host has the path open), its master, and the slave's path. `what` names it in errors.
pub fn open_raw_pty(what: &str) -> anyhow::Result<(std::os::fd::OwnedFd, std::fs::File, String)> {
    use anyhow::anyhow;
    use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};
    let p = nix::pty::openpty(None, None).map_err(|e| anyhow!("{what}: openpty: {e}"))?;
    let mut t = tcgetattr(&p.slave).map_err(|e| anyhow!("{what} pty: {e}"))?;
    cfmakeraw(&mut t);
    tcsetattr(&p.slave, SetArg::TCSANOW, &t).map_err(|e| anyhow!("{what} pty: {e}"))?;
    let path = nix::unistd::ttyname(&p.slave)
        .map_err(|e| anyhow!("{what} pty name: {e}"))?
        .display()
        .to_string();
    Ok((p.slave, std::fs::File::from(p.master), path))
}

/// Read a host connection until it closes, fails, is evicted, stays idle too long or `stop`
/// is raised: `data` gets each chunk (returning false ends the connection), `idle` runs
/// whenever a read times out (reads must have a timeout). Says why it ended.
pub fn read_loop(
    stream: &mut TcpStream,
    stop: &AtomicBool,
    buf_len: usize,
    activity: &Activity,
    mut data: impl FnMut(&[u8]) -> bool,
    mut idle: impl FnMut(),
) -> Ended {
    use std::io::Read;
    let mut buf = vec![0u8; buf_len.max(1)];
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut buf) {
            Ok(0) => {
                if activity.evicted() {
                    return Ended::Evicted(activity.last.get().elapsed());
                }
                return Ended::Closed;
            }
            Ok(n) => {
                activity.touch(true);
                if !data(buf.get(..n).unwrap_or_default()) {
                    return Ended::Closed;
                }
                activity.touch(false);
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                if let Some(t) = activity.idle_expired() {
                    return Ended::Idle(t);
                }
                idle()
            }
            Err(_) => return Ended::Closed,
        }
    }
    Ended::Closed
}
