//! What the supervisor's host servers (daisy chain, EMCL bus) share: the TCP accept loop (a
//! non-blocking listener polled until `stop`, one thread per host connection, at most `max`
//! at once: a connection over the limit is closed at once), the raw pseudo-terminal, and the
//! endpoints record.

use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// Serve `listener` until `stop`: each connection runs `serve` on a thread named `thread`;
/// `what` names the server in log lines.
pub fn accept_loop(
    listener: TcpListener,
    what: &'static str,
    thread: &'static str,
    max: usize,
    stop: Arc<AtomicBool>,
    serve: Arc<dyn Fn(TcpStream) + Send + Sync>,
) {
    let live = Arc::new(AtomicUsize::new(0));
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                if live.load(Ordering::Relaxed) >= max {
                    tracing::warn!("{what}: too many connections; refusing one");
                    continue;
                }
                live.fetch_add(1, Ordering::Relaxed);
                let (serve, live) = (Arc::clone(&serve), Arc::clone(&live));
                let spawned = std::thread::Builder::new()
                    .name(thread.into())
                    .spawn(move || {
                        serve(stream);
                        live.fetch_sub(1, Ordering::Relaxed);
                    });
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

/// Read a host connection until it closes, fails or `stop` is raised: `data` gets each chunk
/// (returning false ends the connection), `idle` runs whenever a read times out.
pub fn read_loop(
    stream: &mut TcpStream,
    stop: &AtomicBool,
    buf_len: usize,
    mut data: impl FnMut(&[u8]) -> bool,
    mut idle: impl FnMut(),
) {
    use std::io::Read;
    let mut buf = vec![0u8; buf_len.max(1)];
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => {
                if !data(buf.get(..n).unwrap_or_default()) {
                    return;
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                idle()
            }
            Err(_) => return,
        }
    }
}
