//! The SSH server of a Power PMAC card (russh): password login (the configured user and
//! password; nothing else is accepted), session channels with an optional pseudo-terminal,
//! `shell` and `exec` requests played by [`Shell`], and one card command thread
//! ([`CardPort`]: its own addressed motor/C.S., echo mode, L/R stack, open buffer) per
//! running `gpascii`. Card requests wait for the servo thread without holding up other tasks
//! (`block_in_place`: the runtime must be multi-threaded).

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mcc_ring::linkfault::LinkFaultSlot;
use russh::keys::ssh_key::private::Ed25519Keypair;
use russh::keys::PrivateKey;
use russh::server::{Auth, ChannelOpenHandle, Config, Handler, Msg, Session};
use russh::{Channel, ChannelId, MethodKind, MethodSet, Pty};
use tokio::net::TcpListener;
use tokio::sync::{watch, Semaphore};
use tokio::task::JoinHandle;

use super::penalty::{Delays, Penalties};
use super::shell::{Shell, ShellOut, TtyModes};
use crate::host::port::{CardPort, Interpreter};
use crate::host::power_ports::accept_limited;
use crate::service::handle::CardHandle;

/// Who may log in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Credentials {
    /// User name (Power PMAC: `root`).
    pub user: String,
    /// Password (Power PMAC: `deltatau`).
    pub password: String,
}

impl Default for Credentials {
    fn default() -> Self {
        Credentials {
            user: "root".into(),
            password: "deltatau".into(),
        }
    }
}

/// Longest a session may stay idle before the server closes it.
const INACTIVITY: Duration = Duration::from_secs(3600);
/// A failed login is answered after this long at least (slows password guessing; a host's
/// failures add their own growing wait, [`Penalties`]).
const REJECTION_TIME: Duration = Duration::from_millis(300);
/// Authentication requests one connection may make; the next one is disconnected ("Too many
/// authentication attempts"), as sshd's `MaxAuthTries` (6). Every refused request counts,
/// `none` included.
pub(crate) const MAX_AUTH_TRIES: usize = 6;
/// Channels one connection may hold open.
const MAX_CHANNELS: usize = 16;

/// The russh server configuration: a fresh Ed25519 host key (hosts add it on first sight,
/// as dls_pmaclib does) and password authentication only.
fn russh_config() -> Config {
    let key = PrivateKey::from(Ed25519Keypair::from_seed(&rand::random::<[u8; 32]>()));
    Config {
        inactivity_timeout: Some(INACTIVITY),
        auth_rejection_time: REJECTION_TIME,
        auth_rejection_time_initial: Some(Duration::ZERO),
        methods: MethodSet::from(&[MethodKind::Password][..]),
        max_auth_attempts: MAX_AUTH_TRIES,
        keys: vec![key],
        nodelay: true,
        ..Config::default()
    }
}

/// A refused login: the client is told that a password may be tried again (an empty
/// list of methods makes clients give up, and a second attempt on the connection then waited
/// for the client's own timeout).
fn refused() -> Auth {
    Auth::Reject {
        proceed_with_methods: Some(MethodSet::from(&[MethodKind::Password][..])),
        partial_success: false,
    }
}

/// Accept SSH connections on `listener` until `stop`, at most `max_connections` at a time;
/// failed logins make their source host wait `delays`.
pub(crate) fn spawn_ssh(
    listener: TcpListener,
    card: CardHandle,
    creds: Credentials,
    max_connections: usize,
    delays: Delays,
    link: LinkFaultSlot,
    mut stop: watch::Receiver<bool>,
) -> JoinHandle<()> {
    let config = Arc::new(russh_config());
    let creds = Arc::new(creds);
    let penalties = Arc::new(Mutex::new(Penalties::new(delays)));
    tokio::spawn(async move {
        let slots = Arc::new(Semaphore::new(max_connections));
        while let Some((stream, peer, permit)) =
            accept_limited(&listener, &slots, &mut stop, "ssh").await
        {
            let mut conn = Conn::new(
                card.clone(),
                Arc::clone(&creds),
                Arc::clone(&penalties),
                peer,
            );
            conn.link = link.clone();
            let (config, mut stop) = (Arc::clone(&config), stop.clone());
            tokio::spawn(async move {
                match russh::server::run_stream(config, stream, conn).await {
                    Ok(session) => {
                        tokio::select! {
                            r = session => {
                                if let Err(e) = r {
                                    tracing::debug!("ssh session {peer} ended: {e}");
                                }
                            }
                            _ = stop.changed() => {}
                        }
                    }
                    Err(e) => tracing::debug!("ssh handshake with {peer} failed: {e}"),
                }
                drop(permit);
            });
        }
    })
}

/// One channel: its terminal, its shell, the command thread of its `gpascii`.
#[derive(Debug, Default)]
struct Chan {
    tty: Option<TtyModes>,
    shell: Option<Shell>,
    port: Option<CardPort>,
}

/// One SSH connection.
struct Conn {
    card: CardHandle,
    creds: Arc<Credentials>,
    penalties: Arc<Mutex<Penalties>>,
    peer: SocketAddr,
    user: String,
    chans: HashMap<ChannelId, Chan>,
    /// The card's host-link fault: applied to each `gpascii` reply.
    link: LinkFaultSlot,
}

impl Conn {
    fn new(
        card: CardHandle,
        creds: Arc<Credentials>,
        penalties: Arc<Mutex<Penalties>>,
        peer: SocketAddr,
    ) -> Self {
        Conn {
            card,
            creds,
            penalties,
            peer,
            user: String::new(),
            chans: HashMap::new(),
            link: LinkFaultSlot::default(),
        }
    }

    fn penalties(&self) -> std::sync::MutexGuard<'_, Penalties> {
        self.penalties.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Carry out what the shell of `id` asked, in order. Terminal output is sent as one data
    /// message where possible (hosts read replies with single `recv` calls).
    fn apply(
        &mut self,
        id: ChannelId,
        outs: Vec<ShellOut>,
        session: &mut Session,
    ) -> Result<(), russh::Error> {
        let card = self.card.clone();
        let Some(chan) = self.chans.get_mut(&id) else {
            return Ok(());
        };
        let mut data = Vec::new();
        for o in outs {
            match o {
                ShellOut::Bytes(b) => data.extend_from_slice(&b),
                ShellOut::Stderr(b) => {
                    flush(session, id, &mut data)?;
                    session.extended_data(id, 1, b)?;
                }
                ShellOut::Begin => {
                    if let Some(old) = chan.port.replace(CardPort::new(card.clone())) {
                        end_port(old);
                    }
                }
                ShellOut::Line(line) => {
                    let reply = match chan.port.as_mut() {
                        Some(p) => tokio::task::block_in_place(|| p.line(&line)),
                        None => Vec::new(),
                    };
                    let Some(sh) = &chan.shell else { continue };
                    let bytes = sh.reply(&reply);
                    if !self.link.armed() {
                        data.extend_from_slice(&bytes);
                        continue;
                    }
                    // A host-link fault: the reply as it says (a reset drops the session).
                    flush(session, id, &mut data)?;
                    let o = self.link.on_reply(&bytes);
                    if o.delay_ms > 0 {
                        let d = std::time::Duration::from_millis(o.delay_ms);
                        tokio::task::block_in_place(|| std::thread::sleep(d));
                    }
                    data.extend_from_slice(&o.bytes);
                    if o.reset {
                        flush(session, id, &mut data)?;
                        return Err(russh::Error::IO(crate::host::link_reply::reset_error()));
                    }
                }
                ShellOut::End => {
                    if let Some(p) = chan.port.take() {
                        end_port(p);
                    }
                }
                ShellOut::Exit(code) => {
                    flush(session, id, &mut data)?;
                    session.exit_status_request(id, code)?;
                    session.eof(id)?;
                    session.close(id)?;
                }
            }
        }
        flush(session, id, &mut data)
    }
}

fn flush(session: &mut Session, id: ChannelId, data: &mut Vec<u8>) -> Result<(), russh::Error> {
    if data.is_empty() {
        return Ok(());
    }
    session.data(id, std::mem::take(data))
}

/// Release a command thread (the card closes a buffer it left open) off the async threads.
fn end_port(mut port: CardPort) {
    if tokio::runtime::Handle::try_current().is_ok() {
        drop(tokio::task::spawn_blocking(move || port.end()));
    } else {
        port.end();
    }
}

impl Drop for Conn {
    fn drop(&mut self) {
        for (_, chan) in self.chans.drain() {
            if let Some(p) = chan.port {
                end_port(p);
            }
        }
    }
}

/// The terminal modes of a `pty-req` (Linux defaults for those not given).
fn tty_modes(modes: &[(Pty, u32)]) -> TtyModes {
    let mut t = TtyModes::default();
    for &(m, v) in modes {
        match m {
            Pty::ECHO => t.echo = v != 0,
            Pty::ICRNL => t.icrnl = v != 0,
            Pty::ONLCR => t.onlcr = v != 0,
            _ => {}
        }
    }
    t
}

impl Handler for Conn {
    type Error = russh::Error;

    async fn auth_password(&mut self, user: &str, password: &str) -> Result<Auth, Self::Error> {
        // The source host's turn first (after its failed logins' wait), right or wrong.
        let ip = self.peer.ip();
        let turn = self.penalties().admit(ip, Instant::now());
        tokio::time::sleep_until(tokio::time::Instant::from_std(turn)).await;
        // Compare without an early exit on the first differing byte.
        let same = |a: &str, b: &str| {
            a.len() == b.len() && a.bytes().zip(b.bytes()).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
        };
        let user_ok = same(user, &self.creds.user);
        let password_ok = same(password, &self.creds.password);
        if user_ok && password_ok {
            self.penalties().succeeded(ip);
            self.user = user.to_string();
            tracing::info!("ssh: {user} logged in from {}", self.peer);
            return Ok(Auth::Accept);
        }
        self.penalties().failed(ip, Instant::now());
        tracing::warn!("ssh: login refused for {user:?} from {}", self.peer);
        Ok(refused())
    }

    async fn auth_publickey_offered(
        &mut self,
        _user: &str,
        _offer: russh::server::PublicKeyOffer<'_>,
    ) -> Result<Auth, Self::Error> {
        Ok(refused())
    }

    async fn channel_open_session(
        &mut self,
        channel: Channel<Msg>,
        reply: ChannelOpenHandle,
        _session: &mut Session,
    ) -> Result<(), Self::Error> {
        if self.chans.len() >= MAX_CHANNELS {
            drop(reply);
            return Ok(());
        }
        self.chans.insert(channel.id(), Chan::default());
        reply.accept().await;
        Ok(())
    }

    #[allow(clippy::too_many_arguments)] // russh's signature
    async fn pty_request(
        &mut self,
        channel: ChannelId,
        _term: &str,
        _col_width: u32,
        _row_height: u32,
        _pix_width: u32,
        _pix_height: u32,
        modes: &[(Pty, u32)],
        session: &mut Session,
    ) -> Result<(), Self::Error> {
        match self.chans.get_mut(&channel) {
            Some(c) if c.shell.is_none() => {
                c.tty = Some(tty_modes(modes));
                session.channel_success(channel)
            }
            _ => session.channel_failure(channel),
        }
    }

    async fn shell_request(
        &mut self,
        channel: ChannelId,
        session: &mut Session,
    ) -> Result<(), Self::Error> {
        let user = self.user.clone();
        let outs = match self.chans.get_mut(&channel) {
            Some(c) if c.shell.is_none() => {
                let (sh, outs) = Shell::interactive(&user, c.tty);
                c.shell = Some(sh);
                outs
            }
            _ => return session.channel_failure(channel),
        };
        session.channel_success(channel)?;
        self.apply(channel, outs, session)
    }

    async fn exec_request(
        &mut self,
        channel: ChannelId,
        data: &[u8],
        session: &mut Session,
    ) -> Result<(), Self::Error> {
        let outs = match self.chans.get_mut(&channel) {
            Some(c) if c.shell.is_none() => {
                tracing::debug!("ssh exec {:?}", String::from_utf8_lossy(data));
                let (sh, outs) = Shell::exec(data, c.tty);
                c.shell = Some(sh);
                outs
            }
            _ => return session.channel_failure(channel),
        };
        session.channel_success(channel)?;
        self.apply(channel, outs, session)
    }

    async fn subsystem_request(
        &mut self,
        channel: ChannelId,
        name: &str,
        session: &mut Session,
    ) -> Result<(), Self::Error> {
        tracing::debug!("ssh subsystem {name:?} refused (not provided)");
        session.channel_failure(channel)
    }

    async fn data(
        &mut self,
        channel: ChannelId,
        data: &[u8],
        session: &mut Session,
    ) -> Result<(), Self::Error> {
        let outs = match self.chans.get_mut(&channel).and_then(|c| c.shell.as_mut()) {
            Some(sh) => sh.feed(data),
            None => return Ok(()),
        };
        self.apply(channel, outs, session)
    }

    async fn channel_eof(
        &mut self,
        channel: ChannelId,
        session: &mut Session,
    ) -> Result<(), Self::Error> {
        let outs = match self.chans.get_mut(&channel).and_then(|c| c.shell.as_mut()) {
            Some(sh) => sh.eof(),
            None => return Ok(()),
        };
        self.apply(channel, outs, session)
    }

    async fn channel_close(
        &mut self,
        channel: ChannelId,
        _session: &mut Session,
    ) -> Result<(), Self::Error> {
        if let Some(p) = self.chans.remove(&channel).and_then(|c| c.port) {
            end_port(p);
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "tests_server.rs"]
mod tests;
