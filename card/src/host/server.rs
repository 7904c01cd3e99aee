//! TCP servers for a card's host ports (tokio): the ASCII terminal port and the PMAC Ethernet
//! protocol port. Every connection has its own session on the card (addressed motor / C.S.)
//! and reaches it through the card's channel ([`CardHandle`]): a request waits for the servo
//! thread, which serves it between ticks; TCP_NODELAY is set; a connection that stalls or sends garbage is closed on its own
//! without affecting the others (bounded buffers, I/O timeouts, a connection limit per port).

use std::io;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{watch, Semaphore};
use tokio::task::JoinHandle;

use super::ascii::AsciiCodec;
use super::eth_codec::{EthAction, EthConn};
use super::port::{run_event, CardPort};
use crate::service::handle::CardHandle;

/// Where and how the host ports listen.
#[derive(Debug, Clone)]
pub(crate) struct PortsConfig {
    /// Address both ports bind (default 127.0.0.1).
    pub bind: IpAddr,
    /// ASCII terminal port (0 = ephemeral).
    pub ascii_port: u16,
    /// PMAC Ethernet protocol port (0 = ephemeral; Delta Tau's convention is 1025).
    pub eth_port: u16,
    /// Longest wait for a reply write, or for the rest of a started Ethernet request.
    pub io_timeout: Duration,
    /// Simultaneous connections per port; further ones are closed at once.
    pub max_connections: usize,
}

impl Default for PortsConfig {
    fn default() -> Self {
        PortsConfig {
            bind: IpAddr::V4(Ipv4Addr::LOCALHOST),
            ascii_port: 0,
            eth_port: 0,
            io_timeout: Duration::from_secs(10),
            max_connections: 64,
        }
    }
}

/// The listening ports; [`BoundPorts::shutdown`] stops them (dropping this does not).
#[derive(Debug)]
pub(crate) struct BoundPorts {
    /// ASCII terminal port address.
    pub ascii: SocketAddr,
    /// PMAC Ethernet protocol port address.
    pub pmac_eth: SocketAddr,
    stop: watch::Sender<bool>,
    tasks: Vec<JoinHandle<()>>,
}

impl BoundPorts {
    /// Stop accepting, close every connection of these ports and wait for the listeners to end.
    pub(crate) async fn shutdown(self) {
        let _ = self.stop.send(true);
        for t in self.tasks {
            let _ = t.await;
        }
    }
}

/// ASCII-port output is written once this much has accumulated within one read.
const ASCII_FLUSH_AT: usize = 64 * 1024;

#[derive(Debug, Clone, Copy)]
enum Kind {
    Ascii,
    Eth,
}

/// Bind both ports and serve them on the current tokio runtime.
pub(crate) async fn serve(card: CardHandle, cfg: PortsConfig) -> io::Result<BoundPorts> {
    let ascii = TcpListener::bind((cfg.bind, cfg.ascii_port)).await?;
    let eth = TcpListener::bind((cfg.bind, cfg.eth_port)).await?;
    let (stop, stop_rx) = watch::channel(false);
    let ports = BoundPorts {
        ascii: ascii.local_addr()?,
        pmac_eth: eth.local_addr()?,
        stop,
        tasks: Vec::new(),
    };
    let mut ports = ports;
    for (listener, kind) in [(ascii, Kind::Ascii), (eth, Kind::Eth)] {
        let t = tokio::spawn(accept_loop(
            listener,
            kind,
            card.clone(),
            cfg.clone(),
            stop_rx.clone(),
        ));
        ports.tasks.push(t);
    }
    Ok(ports)
}

async fn accept_loop(
    listener: TcpListener,
    kind: Kind,
    card: CardHandle,
    cfg: PortsConfig,
    mut stop: watch::Receiver<bool>,
) {
    let slots = Arc::new(Semaphore::new(cfg.max_connections));
    loop {
        let accepted = tokio::select! {
            r = listener.accept() => r,
            _ = stop.changed() => return,
        };
        let (stream, peer) = match accepted {
            Ok(s) => s,
            Err(e) => {
                // Out of descriptors and the like: back off a little, keep serving.
                tracing::warn!("host port accept failed: {e}");
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let Ok(permit) = slots.clone().try_acquire_owned() else {
            tracing::warn!("{kind:?} port: connection limit reached, closing {peer}");
            drop(stream);
            continue;
        };
        let _ = stream.set_nodelay(true);
        let (card, cfg, stop) = (card.clone(), cfg.clone(), stop.clone());
        tokio::spawn(async move {
            let mut port = CardPort::new(card);
            let r = match kind {
                Kind::Ascii => ascii_conn(stream, &mut port, &cfg, stop).await,
                Kind::Eth => eth_conn(stream, &mut port, &cfg, stop).await,
            };
            // A buffer this connection left open is closed (other hosts can open one).
            tokio::task::block_in_place(|| port.end());
            if let Err(e) = r {
                tracing::debug!("{kind:?} connection {peer} closed: {e}");
            }
            drop(permit);
        });
    }
}

async fn write_reply(stream: &mut TcpStream, bytes: &[u8], cfg: &PortsConfig) -> io::Result<()> {
    match tokio::time::timeout(cfg.io_timeout, stream.write_all(bytes)).await {
        Ok(r) => r,
        Err(_) => Err(io::Error::new(
            io::ErrorKind::TimedOut,
            "host stopped reading",
        )),
    }
}

/// How often a terminal connection looks for unsolicited output.
const UNSOLICITED_POLL: Duration = Duration::from_millis(10);

async fn ascii_conn(
    mut stream: TcpStream,
    port: &mut CardPort,
    cfg: &PortsConfig,
    mut stop: watch::Receiver<bool>,
) -> io::Result<()> {
    let mut codec = AsciiCodec::new();
    let mut buf = vec![0u8; 4096];
    // Unsolicited output (program SEND / CMD replies) is written as it appears.
    let mut seen = port.card().unsolicited_position();
    let mut poll = tokio::time::interval(UNSOLICITED_POLL);
    poll.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        let n = tokio::select! {
            r = stream.read(&mut buf) => r?,
            _ = stop.changed() => return Ok(()),
            _ = poll.tick() => {
                let (out, pos) = port.card().unsolicited_since(seen);
                seen = pos;
                if !out.is_empty() {
                    write_reply(&mut stream, &out, cfg).await?;
                }
                continue;
            }
        };
        if n == 0 {
            return Ok(());
        }
        codec.set_echo(port.echo());
        let events = codec.feed(buf.get(..n).unwrap_or_default());
        let mut out = Vec::new();
        for ev in events {
            // The card answers from its servo thread: wait without holding up other tasks.
            tokio::task::block_in_place(|| run_event(ev, port, &mut out));
            // Bounded memory when a host pipelines many long replies without reading them.
            if out.len() >= ASCII_FLUSH_AT {
                write_reply(&mut stream, &out, cfg).await?;
                out.clear();
            }
        }
        if !out.is_empty() {
            write_reply(&mut stream, &out, cfg).await?;
        }
    }
}

async fn eth_conn(
    mut stream: TcpStream,
    port: &mut CardPort,
    cfg: &PortsConfig,
    mut stop: watch::Receiver<bool>,
) -> io::Result<()> {
    let mut conn = EthConn::new();
    let mut buf = vec![0u8; 4096];
    loop {
        let read = async {
            if conn.has_partial_request() {
                match tokio::time::timeout(cfg.io_timeout, stream.read(&mut buf)).await {
                    Ok(r) => r,
                    Err(_) => Err(io::Error::new(io::ErrorKind::TimedOut, "request stalled")),
                }
            } else {
                stream.read(&mut buf).await
            }
        };
        let n = tokio::select! {
            r = read => r?,
            _ = stop.changed() => return Ok(()),
        };
        if n == 0 {
            return Ok(());
        }
        let actions =
            tokio::task::block_in_place(|| conn.feed(buf.get(..n).unwrap_or_default(), port));
        for a in actions {
            match a {
                EthAction::Send(packet) => write_reply(&mut stream, &packet, cfg).await?,
                EthAction::Close(reason) => {
                    return Err(io::Error::new(
                        io::ErrorKind::InvalidData,
                        reason.to_string(),
                    ));
                }
            }
        }
    }
}

#[cfg(test)]
#[path = "tests_server.rs"]
mod tests;
