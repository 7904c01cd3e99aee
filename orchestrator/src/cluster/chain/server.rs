//! The daisy chain as the supervisor serves it: a TCP port on 127.0.0.1 (one chain connection
//! per TCP connection, each with its own addressing) and, on request, a pseudo-terminal whose
//! slave path a serial-terminal program can open (one chain connection for the life of the
//! cluster, like a serial cable whose addressing outlives the program using it).
//! Options come from the environment so that the detached supervisor gets them too:
//! `MCC_CHAIN_PORT` (TCP port, default 0 = any free port) and `MCC_CHAIN_PTY=1`.

use std::io::Write;
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, Context, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::chain::MAX_CHUNK;

use mcc_ring::linkfault::LinkFaultSlot;

use super::link::{ChainLink, DEFAULT_TIMEOUT};
use crate::cluster::link_ctl::write_tcp;
use crate::cluster::serve::Activity;

/// Environment variable: TCP port of the chain (0 or unset: any free port).
pub const PORT_ENV: &str = "MCC_CHAIN_PORT";
/// Environment variable: `1` = also serve a pseudo-terminal.
pub const PTY_ENV: &str = "MCC_CHAIN_PTY";
/// Host connections served at once (at most; `host.max_connections` may lower it): a new one
/// over the limit evicts the longest idle connection or is refused with a message.
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

/// A running chain server (its endpoints). Dropping it stops accepting; open connections end
/// with the process.
pub type ChainServer = crate::cluster::serve::Endpoints;

/// Listen on `[chain] bind` (default 127.0.0.1), port `opts.port` (and open a pseudo-terminal if asked).
/// Every reply goes through `link` (`mcc fault chain link KIND`).
pub fn start(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    opts: &ChainOptions,
    link: &LinkFaultSlot,
) -> Result<ChainServer> {
    // 127.0.0.1 unless the config opens it (`[chain] bind`, checked by the config).
    let bind = cfg.chain.bind.as_deref().unwrap_or("127.0.0.1");
    let listener = TcpListener::bind((bind, opts.port))
        .with_context(|| format!("daisy chain: cannot listen on {bind}:{}", opts.port))?;
    let addr = listener.local_addr()?.to_string();
    listener.set_nonblocking(true)?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let limits = cfg.host.with_max(MAX_CONNECTIONS);
        let (session, cfg, stop) = (session.clone(), cfg.clone(), Arc::clone(&stop));
        let stop2 = Arc::clone(&stop);
        let fault = link.clone();
        let serve = Arc::new(move |stream: TcpStream, activity: Activity| {
            let link = ChainLink::new(session.clone(), &cfg, DEFAULT_TIMEOUT);
            serve_tcp(stream, &link, &fault, &stop2, &activity);
            link.close();
        });

        std::thread::Builder::new()
            .name("mcc-chain-accept".into())
            .spawn(move || {
                crate::cluster::serve::accept_loop(
                    listener,
                    "daisy chain",
                    "mcc-chain-conn",
                    limits,
                    crate::cluster::serve::Refusal::Text,
                    stop,
                    serve,
                )
            })?;
    }
    let pty = if opts.pty {
        Some(pty::start(session.clone(), cfg.clone(), link.clone())?)
    } else {
        None
    };
    Ok(crate::cluster::serve::Endpoints::new(addr, pty, stop))
}

fn serve_tcp(
    mut stream: TcpStream,
    link: &ChainLink,
    fault: &LinkFaultSlot,
    stop: &AtomicBool,
    activity: &Activity,
) {
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_nodelay(true);
    let _ = stream.set_read_timeout(Some(Duration::from_millis(200)));
    let Ok(mut out) = stream.try_clone() else {
        return;
    };
    let data = |chunk: &[u8]| {
        let reply = link.send(chunk);
        reply.bytes.is_empty() || write_tcp(fault, &mut out, &reply.bytes)
    };
    let why = crate::cluster::serve::read_loop(&mut stream, stop, MAX_CHUNK, activity, data, || {});
    if let Some(text) = Activity::farewell("daisy chain", why) {
        let _ = stream.set_write_timeout(Some(Duration::from_secs(1)));
        let _ = stream.write_all(text.as_bytes());
    }
}

mod pty {
    //! The pseudo-terminal: raw mode (no echo, no CR/NL translation), the slave kept open by
    //! us so that hosts may come and go.

    use std::io::Read;

    use anyhow::Result;
    use mcc_contracts::config::ClusterConfig;
    use mcc_contracts::control::chain::MAX_CHUNK;

    use mcc_ring::linkfault::LinkFaultSlot;

    use super::super::link::{ChainLink, DEFAULT_TIMEOUT};
    use crate::cluster::link_ctl::write_pty;

    /// Open the pty and serve it from a thread; the slave path.
    pub fn start(
        session: zenoh::Session,
        cfg: ClusterConfig,
        fault: LinkFaultSlot,
    ) -> Result<String> {
        let (slave, mut master, path) = crate::cluster::serve::open_raw_pty("daisy chain")?;
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
                            if !r.bytes.is_empty() && !write_pty(&fault, &mut master, &r.bytes) {
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
