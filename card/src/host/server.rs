//! TCP servers for a card's host ports (tokio): the ASCII terminal port and the PMAC Ethernet
//! protocol port. Every connection has its own session on the card (addressed motor / C.S.)
//! and reaches it through the card's channel ([`CardHandle`]): a request waits for the servo
//! thread, which serves it between ticks; TCP_NODELAY is set.
//!
//! Limits ([`HostLimits`], `[host]` in the cluster config): at most `max_connections` per
//! port, a new host over the limit evicts the connection idle longest or is refused
//! ([`ConnTable`]: a line on the ASCII port, a close without a byte on the binary Ethernet
//! port); a connection idle for `idle_timeout_s` is closed; a request must
//! be complete within `request_timeout_ms` of its first byte (an ASCII line within
//! [`HostLimits::line_timeout`]); a reply write must progress within the request timeout.
//! Long replies are streamed from the card part by part ([`crate::core::STREAM_CHUNK`]), so a
//! connection holds a bounded amount of memory whatever it asks for.

use std::io;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mcc_contracts::hostport::{
    eviction_message, refusal_message, Admission, ConnTable, HostLimits,
};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{watch, Notify};
use tokio::task::JoinHandle;

use mcc_ring::linkfault::LinkFaultSlot;

use super::ascii::{AsciiCodec, AsciiEvent};
use super::eth_codec::{EthAction, EthConn};
use super::link_reply::write_reply;
use super::port::{run_event, CardPort, Interpreter};
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
    /// Connection limits and timeouts.
    pub limits: HostLimits,
    /// The card's name in messages to hosts and the log.
    pub name: String,
    /// The card's host-link fault (`mcc fault CARD link KIND`), shared with its ring app.
    pub link: LinkFaultSlot,
}

impl Default for PortsConfig {
    fn default() -> Self {
        PortsConfig {
            bind: IpAddr::V4(Ipv4Addr::LOCALHOST),
            ascii_port: 0,
            eth_port: 0,
            limits: HostLimits::default(),
            name: "card".into(),
            link: LinkFaultSlot::default(),
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

/// ASCII-port output is written once this much has accumulated.
const ASCII_FLUSH_AT: usize = 64 * 1024;

#[derive(Debug, Clone, Copy)]
enum Kind {
    Ascii,
    Eth,
}

impl Kind {
    fn port_name(self) -> &'static str {
        match self {
            Kind::Ascii => "ASCII port",
            Kind::Eth => "Ethernet port",
        }
    }
}

/// Bind both ports and serve them on the current tokio runtime.
pub(crate) async fn serve(card: CardHandle, cfg: PortsConfig) -> io::Result<BoundPorts> {
    let ascii = TcpListener::bind((cfg.bind, cfg.ascii_port)).await?;
    let eth = TcpListener::bind((cfg.bind, cfg.eth_port)).await?;
    let (stop, stop_rx) = watch::channel(false);
    let mut ports = BoundPorts {
        ascii: ascii.local_addr()?,
        pmac_eth: eth.local_addr()?,
        stop,
        tasks: Vec::new(),
    };
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

/// One port's connections: the admission table and each connection's eviction signal.
struct Conns {
    origin: Instant,
    table: Mutex<(ConnTable, std::collections::HashMap<u64, Arc<Notify>>)>,
}

impl Conns {
    fn now(&self) -> Duration {
        self.origin.elapsed()
    }

    fn lock(
        &self,
    ) -> std::sync::MutexGuard<'_, (ConnTable, std::collections::HashMap<u64, Arc<Notify>>)> {
        self.table.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Connection `id` did something; `busy` = a request of it is under way.
    fn touch(&self, id: u64, busy: bool) {
        let now = self.now();
        self.lock().0.touch(id, now, busy);
    }

    fn close(&self, id: u64) {
        let mut t = self.lock();
        t.0.close(id);
        t.1.remove(&id);
    }
}

/// Why a connection ended (for its host and the log).
enum End {
    Evicted(Duration),
    Idle(Duration),
    Stalled(Duration),
}

async fn accept_loop(
    listener: TcpListener,
    kind: Kind,
    card: CardHandle,
    cfg: PortsConfig,
    mut stop: watch::Receiver<bool>,
) {
    let conns = Arc::new(Conns {
        origin: Instant::now(),
        table: Mutex::new((ConnTable::new(cfg.limits), Default::default())),
    });
    let what = format!("{} {}", cfg.name, kind.port_name());
    loop {
        let accepted = tokio::select! {
            r = listener.accept() => r,
            _ = stop.changed() => return,
        };
        let (mut stream, peer) = match accepted {
            Ok(s) => s,
            Err(e) => {
                // Out of descriptors and the like: back off a little, keep serving.
                tracing::warn!("host port accept failed: {e}");
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let _ = stream.set_nodelay(true);
        let admission = {
            let now = conns.now();
            conns.lock().0.admit(now)
        };
        let id = match admission {
            Admission::Accept(id) => id,
            Admission::Evict { id, evict, idle } => {
                tracing::info!("{what}: evicting connection {evict} (idle {idle:?}) for {peer}");
                if let Some(n) = conns.lock().1.remove(&evict) {
                    n.notify_one();
                }
                id
            }
            Admission::Refuse { open } if matches!(kind, Kind::Eth) => {
                // A PMAC Ethernet host would read text as a reply packet: close, log why.
                tracing::warn!(
                    "{what}: {open} connections, none idle: refusing {peer} by closing \
                     (a binary protocol has no place for a message; host.max_connections)"
                );
                let _ = stream.shutdown().await;
                continue;
            }
            Admission::Refuse { open } => {
                tracing::warn!("{what}: {open} connections, none idle: refusing {peer}");
                let msg = refusal_message(&what, open);
                tokio::spawn(async move {
                    let _ = tokio::time::timeout(
                        Duration::from_secs(1),
                        stream.write_all(msg.as_bytes()),
                    )
                    .await;
                });
                continue;
            }
        };
        let evicted = Arc::new(Notify::new());
        conns.lock().1.insert(id, Arc::clone(&evicted));
        let (card, cfg, stop, conns, what) = (
            card.clone(),
            cfg.clone(),
            stop.clone(),
            Arc::clone(&conns),
            what.clone(),
        );
        tokio::spawn(async move {
            let mut port = CardPort::new(card);
            let mut c = Conn {
                stream,
                id,
                conns: &conns,
                limits: cfg.limits,
                link: cfg.link.clone(),
                evicted,
                stop,
            };
            let r = match kind {
                Kind::Ascii => ascii_conn(&mut c, &mut port).await,
                Kind::Eth => eth_conn(&mut c, &mut port).await,
            };
            // A buffer this connection left open is closed (other hosts can open one).
            tokio::task::block_in_place(|| port.end());
            conns.close(id);
            match r {
                Ok(Some(end)) => {
                    let msg = match end {
                        End::Evicted(idle) => eviction_message(&what, idle),
                        End::Idle(t) => format!(
                            "\r\nmcc: {what}: connection closed after {} s idle (host.idle_timeout_s)\r\n",
                            t.as_secs()
                        ),
                        End::Stalled(t) => format!(
                            "\r\nmcc: {what}: request not completed within {} ms (host.request_timeout_ms)\r\n",
                            t.as_millis()
                        ),
                    };
                    tracing::info!("{what} connection {peer}: {}", msg.trim());
                    // Only the terminal port has a place for text the host did not ask for.
                    if matches!(kind, Kind::Ascii) {
                        let _ = tokio::time::timeout(
                            Duration::from_secs(1),
                            c.stream.write_all(msg.as_bytes()),
                        )
                        .await;
                    }
                }
                Ok(None) => {}
                Err(e) => tracing::debug!("{what} connection {peer} closed: {e}"),
            }
        });
    }
}

/// One connection and what bounds it.
struct Conn<'a> {
    stream: TcpStream,
    id: u64,
    conns: &'a Conns,
    limits: HostLimits,
    link: LinkFaultSlot,
    evicted: Arc<Notify>,
    stop: watch::Receiver<bool>,
}

impl Conn<'_> {
    async fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        match tokio::time::timeout(self.limits.request_timeout(), self.stream.write_all(bytes))
            .await
        {
            Ok(r) => r,
            Err(_) => Err(io::Error::new(
                io::ErrorKind::TimedOut,
                "host stopped reading",
            )),
        }
    }

    /// Write what is pending in `out`, then `reply` through the link fault.
    async fn write_faulted(&mut self, out: &mut Vec<u8>, reply: &[u8]) -> io::Result<()> {
        if !out.is_empty() {
            self.write(out).await?;
            out.clear();
        }
        let timeout = self.limits.request_timeout();
        write_reply(&mut self.stream, &self.link, reply, timeout).await
    }
}

/// The whole reply to `ev` (a long one gathered from all its parts): under a link fault a
/// reply is faulted as one.
fn whole_reply(ev: AsciiEvent, port: &mut CardPort) -> Vec<u8> {
    let mut r = Vec::new();
    match ev {
        AsciiEvent::Line(l) => {
            let mut part = port.line_start(&l);
            loop {
                r.extend_from_slice(&part.bytes);
                if !part.more {
                    break;
                }
                part = port.line_more();
            }
        }
        other => run_event(other, port, &mut r),
    }
    r
}

/// What one wait on a connection gave.
enum Wake {
    Data(usize),
    Eof,
    Ended(End),
    Tick,
}

/// Wait for bytes, the end of the connection, a limit, or (`poll`) the next poll tick.
async fn wait(
    c: &mut Conn<'_>,
    buf: &mut [u8],
    last: Instant,
    partial_since: Option<(Instant, Duration)>,
    poll: Option<&mut tokio::time::Interval>,
) -> io::Result<Wake> {
    let far = Duration::from_secs(86_400 * 365);
    let idle = c.limits.idle_timeout();
    let idle_at = last + idle.unwrap_or(far);
    let stall_at = partial_since.map_or(last + far, |(t, d)| t + d);
    let tick = async {
        match poll {
            Some(p) => {
                p.tick().await;
            }
            None => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        r = c.stream.read(buf) => Ok(match r? { 0 => Wake::Eof, n => Wake::Data(n) }),
        _ = c.stop.changed() => Ok(Wake::Eof),
        _ = c.evicted.notified() => Ok(Wake::Ended(End::Evicted(last.elapsed()))),
        _ = tokio::time::sleep_until(idle_at.into()) => {
            Ok(Wake::Ended(End::Idle(idle.unwrap_or(far))))
        }
        _ = tokio::time::sleep_until(stall_at.into()) => {
            Ok(Wake::Ended(End::Stalled(partial_since.map_or(far, |(_, d)| d))))
        }
        _ = tick => Ok(Wake::Tick),
    }
}

/// How often a terminal connection looks for unsolicited output.
const UNSOLICITED_POLL: Duration = Duration::from_millis(10);

async fn ascii_conn(c: &mut Conn<'_>, port: &mut CardPort) -> io::Result<Option<End>> {
    let mut codec = AsciiCodec::new();
    let mut buf = vec![0u8; 4096];
    // Unsolicited output (program SEND / CMD replies) is written as it appears.
    let mut seen = port.card().unsolicited_position();
    let mut poll = tokio::time::interval(UNSOLICITED_POLL);
    poll.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last = Instant::now();
    let mut partial: Option<Instant> = None;
    let line_timeout = c.limits.line_timeout();
    loop {
        let since = partial.map(|t| (t, line_timeout));
        let n = match wait(c, &mut buf, last, since, Some(&mut poll)).await? {
            Wake::Data(n) => n,
            Wake::Eof => return Ok(None),
            Wake::Ended(e) => return Ok(Some(e)),
            Wake::Tick => {
                let (out, pos) = port.card().unsolicited_since(seen);
                seen = pos;
                if !out.is_empty() {
                    c.write(&out).await?;
                }
                continue;
            }
        };
        last = Instant::now();
        c.conns.touch(c.id, true);
        codec.set_echo(port.echo());
        let events = codec.feed(buf.get(..n).unwrap_or_default());
        let mut out = Vec::new();
        for ev in events {
            if c.link.armed() {
                let reply = tokio::task::block_in_place(|| whole_reply(ev, port));
                c.write_faulted(&mut out, &reply).await?;
                continue;
            }
            match ev {
                // A long reply comes from the card in parts, written as they come.
                AsciiEvent::Line(l) => {
                    let mut part = tokio::task::block_in_place(|| port.line_start(&l));
                    loop {
                        out.extend_from_slice(&part.bytes);
                        if out.len() >= ASCII_FLUSH_AT {
                            c.write(&out).await?;
                            out.clear();
                        }
                        if !part.more {
                            break;
                        }
                        part = tokio::task::block_in_place(|| port.line_more());
                    }
                }
                // The card answers from its servo thread: wait without holding up other tasks.
                other => tokio::task::block_in_place(|| run_event(other, port, &mut out)),
            }
            if out.len() >= ASCII_FLUSH_AT {
                c.write(&out).await?;
                out.clear();
            }
        }
        if !out.is_empty() {
            c.write(&out).await?;
        }
        partial = match (codec.has_partial(), partial) {
            (true, Some(t)) => Some(t),
            (true, None) => Some(last),
            (false, _) => None,
        };
        last = Instant::now();
        c.conns.touch(c.id, partial.is_some());
    }
}

async fn eth_conn(c: &mut Conn<'_>, port: &mut CardPort) -> io::Result<Option<End>> {
    let mut conn = EthConn::new();
    let mut buf = vec![0u8; 4096];
    let mut last = Instant::now();
    let mut partial: Option<Instant> = None;
    let timeout = c.limits.request_timeout();
    loop {
        let since = partial.map(|t| (t, timeout));
        let n = match wait(c, &mut buf, last, since, None).await? {
            Wake::Data(n) => n,
            Wake::Eof | Wake::Tick => return Ok(None),
            Wake::Ended(e) => return Ok(Some(e)),
        };
        last = Instant::now();
        c.conns.touch(c.id, true);
        let actions =
            tokio::task::block_in_place(|| conn.feed(buf.get(..n).unwrap_or_default(), port));
        for a in actions {
            match a {
                EthAction::Send(packet) if c.link.armed() => {
                    c.write_faulted(&mut Vec::new(), &packet).await?;
                }
                EthAction::Send(packet) => c.write(&packet).await?,
                EthAction::Close(reason) => {
                    return Err(io::Error::new(
                        io::ErrorKind::InvalidData,
                        reason.to_string(),
                    ));
                }
            }
        }
        // A request's clock starts at its first byte, not at its latest one.
        partial = match (conn.has_partial_request(), partial) {
            (true, Some(t)) => Some(t),
            (true, None) => Some(last),
            (false, _) => None,
        };
        last = Instant::now();
        c.conns.touch(c.id, partial.is_some());
    }
}

#[cfg(test)]
#[path = "tests_server.rs"]
mod tests;
