//! The host ports of a Power PMAC card (tokio): the raw TCP `gpascii` ("Telnet") port, where
//! every connection is one `gpascii` command thread on the card, and the SSH server
//! ([`super::ssh`]). Both bind the configured address (127.0.0.1 unless the config says
//! otherwise); a connection that stalls or misbehaves is closed on its own (bounded lines,
//! write timeouts, a connection limit per port).

use std::io;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{watch, OwnedSemaphorePermit, Semaphore};
use tokio::task::JoinHandle;

use mcc_ring::linkfault::LinkFaultSlot;

use super::gpascii::{GpEvent, LineSplitter, BANNER};
use super::link_reply::write_reply;
use super::port::{CardPort, Interpreter};
use super::ssh::penalty::Delays;
use super::ssh::server::{spawn_ssh, Credentials};
use crate::service::handle::CardHandle;

/// Where and how a Power card's host ports listen.
#[derive(Debug, Clone)]
pub(crate) struct PowerPortsConfig {
    /// Address both ports bind (default 127.0.0.1).
    pub bind: IpAddr,
    /// Raw TCP `gpascii` port (0 = ephemeral).
    pub gpascii_port: u16,
    /// SSH port (0 = ephemeral).
    pub ssh_port: u16,
    /// SSH login.
    pub creds: Credentials,
    /// Longest wait for a reply write.
    pub io_timeout: Duration,
    /// Simultaneous connections per port; further ones are closed at once.
    pub max_connections: usize,
    /// How long a host waits after failed SSH logins.
    pub ssh_delays: Delays,
    /// The card's host-link fault (`mcc fault CARD link KIND`), shared with its ring app.
    pub link: LinkFaultSlot,
}

impl Default for PowerPortsConfig {
    fn default() -> Self {
        PowerPortsConfig {
            bind: IpAddr::V4(Ipv4Addr::LOCALHOST),
            gpascii_port: 0,
            ssh_port: 0,
            creds: Credentials::default(),
            io_timeout: Duration::from_secs(10),
            max_connections: 64,
            ssh_delays: Delays::default(),
            link: LinkFaultSlot::default(),
        }
    }
}

/// The listening ports; [`BoundPowerPorts::shutdown`] stops them (dropping this does not).
#[derive(Debug)]
pub(crate) struct BoundPowerPorts {
    /// `gpascii` port address.
    pub gpascii: SocketAddr,
    /// SSH port address.
    pub ssh: SocketAddr,
    stop: watch::Sender<bool>,
    tasks: Vec<JoinHandle<()>>,
}

impl BoundPowerPorts {
    /// Stop accepting, close every connection of these ports and wait for the listeners.
    pub(crate) async fn shutdown(self) {
        let _ = self.stop.send(true);
        for t in self.tasks {
            let _ = t.await;
        }
    }
}

/// Bind both ports and serve them on the current (multi-threaded) tokio runtime.
pub(crate) async fn serve_power(
    card: CardHandle,
    cfg: PowerPortsConfig,
) -> io::Result<BoundPowerPorts> {
    let gp = TcpListener::bind((cfg.bind, cfg.gpascii_port)).await?;
    let ssh = TcpListener::bind((cfg.bind, cfg.ssh_port)).await?;
    let (stop, stop_rx) = watch::channel(false);
    let (gp_addr, ssh_addr) = (gp.local_addr()?, ssh.local_addr()?);
    let tasks = vec![
        tokio::spawn(gpascii_accept(
            gp,
            card.clone(),
            cfg.clone(),
            stop_rx.clone(),
        )),
        spawn_ssh(
            ssh,
            card,
            cfg.creds.clone(),
            cfg.max_connections,
            cfg.ssh_delays,
            cfg.link.clone(),
            stop_rx,
        ),
    ];
    Ok(BoundPowerPorts {
        gpascii: gp_addr,
        ssh: ssh_addr,
        stop,
        tasks,
    })
}

async fn gpascii_accept(
    listener: TcpListener,
    card: CardHandle,
    cfg: PowerPortsConfig,
    mut stop: watch::Receiver<bool>,
) {
    let slots = Arc::new(Semaphore::new(cfg.max_connections));
    while let Some((stream, peer, permit)) =
        accept_limited(&listener, &slots, &mut stop, "gpascii").await
    {
        let (card, cfg, stop) = (card.clone(), cfg.clone(), stop.clone());
        tokio::spawn(async move {
            let mut port = CardPort::new(card);
            let r = gpascii_conn(stream, &mut port, &cfg, stop).await;
            // A buffer this command thread left open is closed.
            tokio::task::block_in_place(|| port.end());
            if let Err(e) = r {
                tracing::debug!("gpascii connection {peer} closed: {e}");
            }
            drop(permit);
        });
    }
}

/// Accept the next connection of `listener` with a free slot (a connection beyond the limit is
/// closed at once); `None` once `stop` fires.
pub(crate) async fn accept_limited(
    listener: &TcpListener,
    slots: &Arc<Semaphore>,
    stop: &mut watch::Receiver<bool>,
    what: &str,
) -> Option<(TcpStream, SocketAddr, OwnedSemaphorePermit)> {
    loop {
        let accepted = tokio::select! {
            r = listener.accept() => r,
            _ = stop.changed() => return None,
        };
        let (stream, peer) = match accepted {
            Ok(s) => s,
            Err(e) => {
                tracing::warn!("{what} port accept failed: {e}");
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let Ok(permit) = slots.clone().try_acquire_owned() else {
            tracing::warn!("{what} port: connection limit reached, closing {peer}");
            continue;
        };
        let _ = stream.set_nodelay(true);
        return Some((stream, peer, permit));
    }
}

async fn write_all(stream: &mut TcpStream, bytes: &[u8], cfg: &PowerPortsConfig) -> io::Result<()> {
    match tokio::time::timeout(cfg.io_timeout, stream.write_all(bytes)).await {
        Ok(r) => r,
        Err(_) => Err(io::Error::new(
            io::ErrorKind::TimedOut,
            "host stopped reading",
        )),
    }
}

/// Output is written once this much has accumulated within one read.
const FLUSH_AT: usize = 64 * 1024;

async fn gpascii_conn(
    mut stream: TcpStream,
    port: &mut CardPort,
    cfg: &PowerPortsConfig,
    mut stop: watch::Receiver<bool>,
) -> io::Result<()> {
    write_all(&mut stream, BANNER, cfg).await?;
    let mut lines = LineSplitter::new();
    let mut buf = vec![0u8; 4096];
    loop {
        let n = tokio::select! {
            r = stream.read(&mut buf) => r?,
            _ = stop.changed() => return Ok(()),
        };
        if n == 0 {
            return Ok(());
        }
        let mut out = Vec::new();
        for ev in lines.feed(buf.get(..n).unwrap_or_default()) {
            match ev {
                // The dialect's reply is what gpascii prints, ACK included.
                GpEvent::Line(l) => {
                    let reply = tokio::task::block_in_place(|| port.line(&l));
                    if cfg.link.armed() {
                        write_all(&mut stream, &out, cfg).await?;
                        out.clear();
                        write_reply(&mut stream, &cfg.link, &reply, cfg.io_timeout).await?;
                    } else {
                        out.extend_from_slice(&reply);
                    }
                }
                GpEvent::Quit => {
                    write_all(&mut stream, &out, cfg).await?;
                    return Ok(());
                }
            }
            if out.len() >= FLUSH_AT {
                write_all(&mut stream, &out, cfg).await?;
                out.clear();
            }
        }
        if !out.is_empty() {
            write_all(&mut stream, &out, cfg).await?;
        }
    }
}

#[cfg(test)]
#[path = "tests_power_ports.rs"]
pub(crate) mod tests;
