//! Opening the zenoh session every mcc process uses: peer mode, multicast scouting off,
//! explicit loopback endpoints (architecture §7).

use zenoh::config::Config;
use zenoh::Wait;

use super::TransportError;

/// The environment variable zenoh reads its thread-pool sizes from (RON), once, when the
/// process first uses zenoh.
pub const RUNTIME_ENV: &str = "ZENOH_RUNTIME";

/// zenoh's thread pools for a ring member process: one runtime (the receive pool) that every
/// other pool hands over to, with a single worker thread. A member receives one ring frame per
/// cycle on one link plus a trickle of control traffic: one thread owns the sockets and runs the
/// receive path, so a frame's arrival wakes exactly one thread (zenoh's default, five pools and
/// two receive workers, wakes a socket-polling thread, then a receive worker, and moves tasks
/// between them).
pub const MEMBER_RUNTIME: &str =
    "(rx: (worker_threads: 1), tx: (handover: rx), acc: (handover: rx), app: (handover: rx), net: (handover: rx))";

/// Batches in the real-time transmit queue of each zenoh link (zenoh's maximum; its default is
/// 2). A ring frame is express, so it travels as a batch of its own: on a healthy paced or
/// lockstep ring one link carries at most `ring.in_flight` frames at a time (a member forwards
/// cycle k+N only after the master saw cycle k come back, i.e. after this link's frame of cycle k
/// was written and read), and `ring.in_flight` is at most
/// [`mcc_contracts::config::MAX_IN_FLIGHT`].
pub const RING_TX_QUEUE_BATCHES: usize = 16;

const _: () = assert!(mcc_contracts::config::MAX_IN_FLIGHT as usize * 2 <= RING_TX_QUEUE_BATCHES);

/// Where a process listens and whom it connects to.
#[derive(Debug, Clone, Default)]
pub struct SessionOptions {
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:0`. Empty: `tcp/127.0.0.1:0`.
    pub listen: Vec<String>,
    /// Endpoints to connect to (the orchestrator's, a router, ...).
    pub connect: Vec<String>,
    /// zenoh client mode: every message goes through the routers in `connect` (clusters on
    /// several hosts through `zenohd`); no listener, no gossip.
    pub client: bool,
    /// User/password authentication of every link (`transport/auth/usrpwd`).
    pub auth: Option<SessionAuth>,
    /// zenoh's `access_control` (JSON).
    pub access_control: Option<serde_json::Value>,
    /// zenoh's `transport/link/tls` (JSON).
    pub tls: Option<serde_json::Value>,
}

/// User/password authentication (zenoh's `usrpwd`).
#[derive(Clone, Default, PartialEq, Eq)]
pub struct SessionAuth {
    /// The user this process authenticates as.
    pub user: String,
    /// Its password.
    pub password: String,
    /// `user:password` lines of the users this process accepts on its listeners.
    pub dictionary_file: Option<String>,
}

impl std::fmt::Debug for SessionAuth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SessionAuth")
            .field("user", &self.user)
            .field("dictionary_file", &self.dictionary_file)
            .finish_non_exhaustive()
    }
}

/// Build the zenoh configuration for `opts`.
pub fn zenoh_config(opts: &SessionOptions) -> Result<Config, TransportError> {
    let mut c = Config::default();
    let set = |c: &mut Config, k: &str, v: String| {
        c.insert_json5(k, &v)
            .map_err(|e| TransportError::Io(format!("zenoh config {k}: {e}")))
    };
    let mode = if opts.client {
        "\"client\""
    } else {
        "\"peer\""
    };
    set(&mut c, "mode", mode.into())?;
    set(&mut c, "scouting/multicast/enabled", "false".into())?;
    // Peers learn each other's locators from the peer they connect to and open direct links, so
    // ring frames travel member to member in one hop.
    set(&mut c, "scouting/gossip/enabled", "true".into())?;
    // Only one of two peers opens the link between them (the one with the greater id), so two
    // peers discovering each other at once never race two half-open links.
    set(
        &mut c,
        "scouting/gossip/autoconnect_strategy",
        "{ peer: { to_router: \"always\", to_peer: \"greater-zid\" } }".into(),
    )?;
    let listen = if opts.client {
        opts.listen.clone()
    } else if opts.listen.is_empty() {
        vec!["tcp/127.0.0.1:0".to_string()]
    } else {
        opts.listen.clone()
    };
    set(&mut c, "listen/endpoints", json_list(&listen))?;
    set(&mut c, "connect/endpoints", json_list(&opts.connect))?;
    // The real-time queue of every link (ring frames only use that priority) holds more frames
    // than can ever be in flight on a healthy ring, so a ring frame's put never waits for room
    // (see `zenoh_link`: the put may run on zenoh's single receive thread).
    set(
        &mut c,
        "transport/link/tx/queue/size/real_time",
        RING_TX_QUEUE_BATCHES.to_string(),
    )?;
    set(
        &mut c,
        "timestamping/enabled",
        "{ router: false, peer: false, client: false }".into(),
    )?;
    if let Some(a) = &opts.auth {
        set(&mut c, "transport/auth/usrpwd/user", json_str(&a.user))?;
        set(
            &mut c,
            "transport/auth/usrpwd/password",
            json_str(&a.password),
        )?;
        if let Some(d) = &a.dictionary_file {
            set(&mut c, "transport/auth/usrpwd/dictionary_file", json_str(d))?;
        }
    }
    if let Some(acl) = &opts.access_control {
        set(&mut c, "access_control", acl.to_string())?;
    }
    if let Some(tls) = &opts.tls {
        set(&mut c, "transport/link/tls", tls.to_string())?;
    }
    Ok(c)
}

fn json_str(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

fn json_list(items: &[String]) -> String {
    serde_json::to_string(items).unwrap_or_else(|_| "[]".into())
}

/// Open a zenoh session for `opts` (blocking).
pub fn open_session(opts: &SessionOptions) -> Result<zenoh::Session, TransportError> {
    let config = zenoh_config(opts)?;
    zenoh::open(config)
        .wait()
        .map_err(|e| TransportError::Io(format!("zenoh open: {e}")))
}

/// A loopback TCP endpoint on a port that was free a moment ago (`tcp/127.0.0.1:PORT`).
///
/// zenoh's stable API does not report the port it bound for `:0`, so processes that must tell
/// others where they listen pick the port first.
pub fn free_loopback_endpoint() -> Result<String, TransportError> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")
        .map_err(|e| TransportError::Io(format!("no free port: {e}")))?;
    let port = l
        .local_addr()
        .map_err(|e| TransportError::Io(e.to_string()))?
        .port();
    Ok(format!("tcp/127.0.0.1:{port}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_is_peer_without_multicast() {
        let c = zenoh_config(&SessionOptions {
            listen: vec![],
            connect: vec!["tcp/127.0.0.1:7447".into()],
            ..Default::default()
        })
        .unwrap();
        let s = format!("{c}");
        assert!(s.contains("\"mode\":\"peer\""), "{s}");
        assert!(s.contains("127.0.0.1:7447"), "{s}");
        assert!(s.contains("\"real_time\":16"), "{s}");
    }

    #[test]
    fn free_endpoint_is_loopback_with_a_port() {
        let e = free_loopback_endpoint().unwrap();
        let port: u16 = e.strip_prefix("tcp/127.0.0.1:").unwrap().parse().unwrap();
        assert!(port > 0);
    }

    #[test]
    fn bad_endpoint_is_a_clear_error() {
        let e = zenoh_config(&SessionOptions {
            listen: vec!["not-an-endpoint".into()],
            connect: vec![],
            ..Default::default()
        });
        assert!(e.is_err());
    }
}
