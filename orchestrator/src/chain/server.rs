//! The daisy chain as the supervisor serves it: a TCP port on 127.0.0.1 (one chain connection
//! per TCP connection, each with its own addressing) and, on request, a pseudo-terminal whose
//! slave path a serial-terminal program can open (one chain connection for the life of the
//! cluster, like a serial cable whose addressing outlives the program using it).
//! Options come from the environment so that the detached supervisor gets them too:
//! `MCC_CHAIN_PORT` (TCP port, default 0 = any free port) and `MCC_CHAIN_PTY=1`.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, Context, Result};
use mcc_ring::config::ClusterConfig;
use mcc_ring::control::chain::MAX_CHUNK;

use super::link::{ChainLink, DEFAULT_TIMEOUT};

/// Environment variable: TCP port of the chain (0 or unset: any free port).
pub const PORT_ENV: &str = "MCC_CHAIN_PORT";
/// Environment variable: `1` = also serve a pseudo-terminal.
pub const PTY_ENV: &str = "MCC_CHAIN_PTY";
/// Host connections served at once; more are closed at once.
pub const MAX_CONNECTIONS: usize = 16;

/// Chain options.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ChainOptions {
    /// TCP port (0 = any free port).
    pub port: u16,
    /// Serve a pseudo-terminal too.
    pub pty: bool,
}

impl ChainOptions {
    /// From [`PORT_ENV`] / [`PTY_ENV`]; a bad port is an error naming the variable.
    pub fn from_env() -> Result<Self> {
        let port = match std::env::var(PORT_ENV) {
            Ok(v) if !v.trim().is_empty() => v
                .trim()
                .parse()
                .map_err(|_| anyhow!("{PORT_ENV}={v:?}: not a TCP port number (0-65535)"))?,
            _ => 0,
        };
        let pty = std::env::var(PTY_ENV).is_ok_and(|v| v.trim() == "1");
        Ok(ChainOptions { port, pty })
    }
}

/// A running chain server. Dropping it stops accepting; open connections end with the process.
#[derive(Debug)]
pub struct ChainServer {
    addr: String,
    pty: Option<String>,
    stop: Arc<AtomicBool>,
}

impl ChainServer {
    /// Listen on 127.0.0.1:`opts.port` (and open a pseudo-terminal if asked).
    pub fn start(
        session: &zenoh::Session,
        cfg: &ClusterConfig,
        opts: &ChainOptions,
    ) -> Result<Self> {
        let listener = TcpListener::bind(("127.0.0.1", opts.port))
            .with_context(|| format!("daisy chain: cannot listen on 127.0.0.1:{}", opts.port))?;
        let addr = listener.local_addr()?.to_string();
        listener.set_nonblocking(true)?;
        let stop = Arc::new(AtomicBool::new(false));
        let live = Arc::new(AtomicUsize::new(0));
        {
            let (session, cfg, stop) = (session.clone(), cfg.clone(), Arc::clone(&stop));
            std::thread::Builder::new()
                .name("mcc-chain-accept".into())
                .spawn(move || accept_loop(listener, session, cfg, stop, live))?;
        }
        let pty = if opts.pty {
            Some(pty::start(session.clone(), cfg.clone())?)
        } else {
            None
        };
        Ok(ChainServer { addr, pty, stop })
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

impl Drop for ChainServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

fn accept_loop(
    listener: TcpListener,
    session: zenoh::Session,
    cfg: ClusterConfig,
    stop: Arc<AtomicBool>,
    live: Arc<AtomicUsize>,
) {
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                if live.load(Ordering::Relaxed) >= MAX_CONNECTIONS {
                    tracing::warn!("daisy chain: too many connections; refusing one");
                    continue;
                }
                live.fetch_add(1, Ordering::Relaxed);
                let link = ChainLink::new(session.clone(), &cfg, DEFAULT_TIMEOUT);
                let (stop, live) = (Arc::clone(&stop), Arc::clone(&live));
                let spawned = std::thread::Builder::new()
                    .name("mcc-chain-conn".into())
                    .spawn(move || {
                        serve_tcp(stream, &link, &stop);
                        link.close();
                        live.fetch_sub(1, Ordering::Relaxed);
                    });
                if spawned.is_err() {
                    tracing::warn!("daisy chain: cannot start a connection thread");
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => {
                tracing::warn!("daisy chain accept: {e}");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

fn serve_tcp(mut stream: TcpStream, link: &ChainLink, stop: &AtomicBool) {
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_nodelay(true);
    let _ = stream.set_read_timeout(Some(Duration::from_millis(200)));
    let mut buf = vec![0u8; MAX_CHUNK];
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => {
                let reply = link.send(buf.get(..n).unwrap_or_default());
                if !reply.bytes.is_empty() && stream.write_all(&reply.bytes).is_err() {
                    return;
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) => {}
            Err(_) => return,
        }
    }
}

mod pty {
    //! The pseudo-terminal: raw mode (no echo, no CR/NL translation), the slave kept open by
    //! us so that hosts may come and go.

    use std::fs::File;
    use std::io::{Read, Write};

    use anyhow::{anyhow, Result};
    use mcc_ring::config::ClusterConfig;
    use mcc_ring::control::chain::MAX_CHUNK;
    use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};

    use super::super::link::{ChainLink, DEFAULT_TIMEOUT};

    /// Open the pty and serve it from a thread; the slave path.
    pub fn start(session: zenoh::Session, cfg: ClusterConfig) -> Result<String> {
        let p = nix::pty::openpty(None, None).map_err(|e| anyhow!("daisy chain: openpty: {e}"))?;
        let mut t = tcgetattr(&p.slave).map_err(|e| anyhow!("daisy chain pty: {e}"))?;
        cfmakeraw(&mut t);
        tcsetattr(&p.slave, SetArg::TCSANOW, &t).map_err(|e| anyhow!("daisy chain pty: {e}"))?;
        let path = nix::unistd::ttyname(&p.slave)
            .map_err(|e| anyhow!("daisy chain pty name: {e}"))?
            .display()
            .to_string();
        let slave = p.slave;
        let mut master = File::from(p.master);
        std::thread::Builder::new()
            .name("mcc-chain-pty".into())
            .spawn(move || {
                // Holding the slave open keeps reads from failing while no host has it open.
                let _slave = slave;
                let link = ChainLink::new(session, &cfg, DEFAULT_TIMEOUT);
                let mut buf = vec![0u8; MAX_CHUNK];
                loop {
                    match master.read(&mut buf) {
                        Ok(0) => break,
                        Ok(n) => {
                            let r = link.send(buf.get(..n).unwrap_or_default());
                            if !r.bytes.is_empty() && master.write_all(&r.bytes).is_err() {
                                break;
                            }
                        }
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                        Err(_) => break,
                    }
                }
                link.close();
            })?;
        Ok(path)
    }
}

/// `mcc up --pty --chain-port P`: put the chain options where the supervisor (this process,
/// or the detached one it spawns, which inherits the environment) reads them.
pub fn export_up_options(args: &crate::cli::UpArgs) {
    if args.pty {
        std::env::set_var(PTY_ENV, "1");
    }
    if let Some(p) = args.chain_port {
        std::env::set_var(PORT_ENV, p.to_string());
    }
}
