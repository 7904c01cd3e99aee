//! The EMCL bus as the supervisor serves it: a TCP port on 127.0.0.1 (each connection is a
//! bus master; several may share the bus, their frames are served one at a time) and, with
//! `mcc up --pty`, `MCC_EMCL_PTY=1` or `[emcl] pty = true`, a pseudo-terminal in raw mode
//! whose slave the server keeps open (hosts may open and close it at will).
//!
//! Framing: bytes are cut into 9-byte frames whatever the segmentation; a partial frame
//! followed by [`SILENCE_MS`] of silence is discarded (the drive UART's inter-byte timeout),
//! which is how a host that sent garbage or half a frame gets back in step. Options:
//! `MCC_EMCL_PORT` / `[emcl] port` (TCP port, 0 = any free port), the pty as above.

use std::net::{TcpListener, TcpStream};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_station::emcl::codec::FrameAssembler;

use mcc_ring::linkfault::LinkFaultSlot;

use super::bus::Bus;
use crate::cluster::link_ctl::write_tcp;

/// Environment variable: TCP port of the bus (overrides `[emcl] port`).
pub const PORT_ENV: &str = "MCC_EMCL_PORT";
/// Environment variable: `1` = also serve a pseudo-terminal.
pub const PTY_ENV: &str = "MCC_EMCL_PTY";
/// A partial frame is dropped after this much silence, ms. Far above any TCP segment delay
/// on a loaded machine, well below the 2–5 s a TMCL client waits for a reply.
pub const SILENCE_MS: u64 = 500;
/// Host connections served at once; more are closed at once.
pub const MAX_CONNECTIONS: usize = 16;
/// A reply a host does not read within this time ends its connection.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(10);

/// Bus options.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BusOptions {
    /// TCP port (0 = any free port).
    pub port: u16,
    /// Serve a pseudo-terminal too.
    pub pty: bool,
}

impl BusOptions {
    /// From the config's `[emcl]`, overridden by [`PORT_ENV`] / [`PTY_ENV`] and `mcc up
    /// --pty` (which asks for the daisy chain's pty and the bus's).
    pub fn resolve(cfg: &ClusterConfig) -> Result<Self> {
        let port = match std::env::var(PORT_ENV) {
            Ok(v) if !v.trim().is_empty() => v
                .trim()
                .parse()
                .map_err(|_| anyhow!("{PORT_ENV}={v:?}: not a TCP port number (0-65535)"))?,
            _ => cfg.emcl.port,
        };
        let env_on = |k: &str| std::env::var(k).is_ok_and(|v| v.trim() == "1");
        let pty = cfg.emcl.pty || env_on(PTY_ENV) || env_on(crate::cluster::chain::server::PTY_ENV);
        Ok(BusOptions { port, pty })
    }
}

/// `mcc up --emcl-port P`: where the supervisor (this process or the detached one) reads it.
pub fn export_up_options(args: &crate::cli::UpArgs) {
    if let Some(p) = args.emcl_port {
        std::env::set_var(PORT_ENV, p.to_string());
    }
}

/// A running bus server (its endpoints). Dropping it stops accepting.
pub type BusServer = crate::cluster::serve::Endpoints;

/// Listen on `[emcl] bind` (default 127.0.0.1), port `opts.port` (and open a pseudo-terminal if asked).
/// Every reply goes through `link` (`mcc fault bus link KIND`).
pub fn start(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    opts: &BusOptions,
    link: &LinkFaultSlot,
) -> Result<BusServer> {
    let bus = Bus::start(session.clone(), cfg).context("EMCL bus: cannot start the line")?;
    // 127.0.0.1 unless the config opens it (`[emcl] bind`, checked by the config).
    let bind = cfg.emcl.bind.as_deref().unwrap_or("127.0.0.1");
    let listener = TcpListener::bind((bind, opts.port))
        .with_context(|| format!("EMCL bus: cannot listen on {bind}:{}", opts.port))?;
    let addr = listener.local_addr()?.to_string();
    listener.set_nonblocking(true)?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let (bus, stop) = (bus.clone(), Arc::clone(&stop));
        let stop2 = Arc::clone(&stop);
        let fault = link.clone();
        let serve = Arc::new(
            move |stream: TcpStream, activity: crate::cluster::serve::Activity| {
                serve_tcp(stream, &bus, &fault, &stop2, &activity)
            },
        );
        let limits = cfg.host.with_max(MAX_CONNECTIONS);
        std::thread::Builder::new()
            .name("mcc-emcl-accept".into())
            .spawn(move || {
                crate::cluster::serve::accept_loop(
                    listener,
                    "EMCL bus",
                    "mcc-emcl-conn",
                    limits,
                    crate::cluster::serve::Refusal::Close,
                    stop,
                    serve,
                )
            })?;
    }
    let pty = if opts.pty {
        Some(pty::start(bus.clone(), link.clone(), Arc::clone(&stop))?)
    } else {
        None
    };
    Ok(crate::cluster::serve::Endpoints::new(addr, pty, stop))
}

fn now_ms(t0: Instant) -> u64 {
    u64::try_from(t0.elapsed().as_millis()).unwrap_or(u64::MAX)
}

/// Serve frames arriving in `data` at `now`; `write` each reply (false: the host is gone,
/// and so is this connection).
fn serve_bytes(
    asm: &mut FrameAssembler,
    data: &[u8],
    now: u64,
    bus: &Bus,
    write: &mut dyn FnMut(&[u8]) -> bool,
) -> bool {
    for f in asm.push(data, now) {
        if let Some(r) = bus.transact(f).bytes {
            if !write(&r) {
                return false;
            }
        }
    }
    true
}

fn serve_tcp(
    mut stream: TcpStream,
    bus: &Bus,
    fault: &LinkFaultSlot,
    stop: &AtomicBool,
    activity: &crate::cluster::serve::Activity,
) {
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_nodelay(true);
    let _ = stream.set_read_timeout(Some(Duration::from_millis(200)));
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let Ok(mut out) = stream.try_clone() else {
        return;
    };
    let t0 = Instant::now();
    let asm = std::cell::RefCell::new(FrameAssembler::new(SILENCE_MS));
    let mut write = |r: &[u8]| write_tcp(fault, &mut out, r);
    let data =
        |chunk: &[u8]| serve_bytes(&mut asm.borrow_mut(), chunk, now_ms(t0), bus, &mut write);
    let idle = || {
        asm.borrow_mut().expire(now_ms(t0));
    };
    // A binary bus has no place for a farewell text: the host sees the connection close.
    let why = crate::cluster::serve::read_loop(&mut stream, stop, 4096, activity, data, idle);
    if why != crate::cluster::serve::Ended::Closed {
        tracing::info!("EMCL bus connection closed: {why:?}");
    }
}

mod pty {
    //! The pseudo-terminal: raw mode (no echo, no signals, no CR/NL or XON/XOFF handling, so
    //! every byte value passes), the slave kept open by us so that hosts may come and go.

    use std::io::Read;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::time::Instant;

    use anyhow::Result;
    use mcc_station::emcl::codec::FrameAssembler;

    use mcc_ring::linkfault::LinkFaultSlot;

    use super::super::bus::Bus;
    use super::{now_ms, serve_bytes, SILENCE_MS};
    use crate::cluster::link_ctl::write_pty;

    /// Open the pty and serve it from a thread; the slave path.
    pub fn start(bus: Bus, fault: LinkFaultSlot, stop: Arc<AtomicBool>) -> Result<String> {
        let (slave, mut master, path) = crate::cluster::serve::open_raw_pty("EMCL bus")?;
        let mut out = master.try_clone()?;
        std::thread::Builder::new()
            .name("mcc-emcl-pty".into())
            .spawn(move || {
                // Holding the slave open keeps reads from failing while no host has it open.
                let _slave = slave;
                let t0 = Instant::now();
                let mut asm = FrameAssembler::new(SILENCE_MS);
                let mut buf = [0u8; 4096];
                while !stop.load(Ordering::Relaxed) {
                    match master.read(&mut buf) {
                        Ok(0) => break,
                        Ok(n) => {
                            let data = buf.get(..n).unwrap_or_default();
                            let mut write = |r: &[u8]| write_pty(&fault, &mut out, r);
                            if !serve_bytes(&mut asm, data, now_ms(t0), &bus, &mut write) {
                                break;
                            }
                        }
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                        Err(_) => break,
                    }
                }
            })?;
        Ok(path)
    }
}
