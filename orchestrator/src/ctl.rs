//! Client side of the control plane (`mcc/<cluster>/ctl/<member>/...` queryables): status,
//! fault and shutdown queries, always with timeouts, never a hang.

use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use mcc_ring::config::ClusterConfig;
use mcc_ring::control::{ctl_key, CtlReply, MemberStatus};
use mcc_ring::transport::cluster::{self, Role};
use mcc_ring::transport::session::{open_session, SessionOptions};
use zenoh::Wait;

/// Largest control reply accepted, bytes.
const MAX_REPLY: usize = 1 << 20;

/// Open a CLI session to cluster `cfg` running on this machine's `host` (its supervisor's
/// endpoint on one machine; the routers or peers on several hosts), and give gossip up to
/// `settle` to connect us directly to the `expected` other peers (peers do not route for
/// each other, so queries only reach members we are connected to).
pub fn connect(
    cfg: &ClusterConfig,
    host: Option<&str>,
    endpoint: &str,
    expected: usize,
    settle: Duration,
) -> Result<zenoh::Session> {
    if cfg.is_multi_host() {
        let host = host.unwrap_or_default();
        let session = crate::hosts::open(cfg, Role::Client { host })?;
        crate::hosts::settle(&session, cfg, expected, settle);
        return Ok(session);
    }
    let mut opts = SessionOptions {
        listen: vec!["tcp/127.0.0.1:0".into()],
        connect: vec![endpoint.to_string()],
        ..Default::default()
    };
    cluster::secure(&mut opts, cfg).map_err(|e| anyhow!("{e}"))?;
    let session =
        open_session(&opts).map_err(|e| anyhow!("cannot reach the cluster at {endpoint}: {e}"))?;
    let deadline = Instant::now() + settle;
    while Instant::now() < deadline {
        if session.info().peers_zid().wait().count() >= expected {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(session)
}

/// Send one query with an optional JSON payload; the first reply's text, or an error naming
/// the key (no reply within `timeout`, error reply, non-UTF-8).
pub fn query_text(
    session: &zenoh::Session,
    key: &str,
    payload: Option<String>,
    timeout: Duration,
) -> Result<String> {
    let mut get = session.get(key).timeout(timeout);
    if let Some(p) = payload {
        get = get.payload(p);
    }
    let replies = get.wait().map_err(|e| anyhow!("query {key}: {e}"))?;
    match replies.recv() {
        Ok(reply) => match reply.result() {
            Ok(sample) => {
                let bytes = sample.payload();
                if bytes.len() > MAX_REPLY {
                    return Err(anyhow!(
                        "query {key}: reply too large ({} bytes)",
                        bytes.len()
                    ));
                }
                let text = bytes
                    .try_to_string()
                    .map_err(|_| anyhow!("query {key}: reply is not UTF-8"))?;
                Ok(text.into_owned())
            }
            Err(e) => {
                let text = e
                    .payload()
                    .try_to_string()
                    .map(|s| s.into_owned())
                    .unwrap_or_default();
                Err(anyhow!("query {key}: error reply: {text}"))
            }
        },
        Err(_) => Err(anyhow!(
            "query {key}: no reply within {} ms",
            timeout.as_millis()
        )),
    }
}

/// Query a [`CtlReply`] endpoint (`fault`, `shutdown`).
pub fn query_ctl(
    session: &zenoh::Session,
    key: &str,
    payload: Option<String>,
    timeout: Duration,
) -> Result<CtlReply> {
    let text = query_text(session, key, payload, timeout)?;
    serde_json::from_str(&text).map_err(|e| anyhow!("query {key}: bad reply {text:?}: {e}"))
}

/// Status of every member in ring order (`None`: no valid answer). The synchronizing master is
/// asked first and the others once it answered (concurrently), so every other member's snapshot
/// is younger than the master's: a healthy member has then received at least the master's
/// cycle less the cycles in flight, and a lag against the master's cycle (`status::broken_link`)
/// is never an artefact of replies taken at different moments of a fast ring. Members that did
/// not answer are asked again until `budget` is spent (all others again when the master only
/// answers in a later round).
pub fn query_statuses(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    per_try: Duration,
    budget: Duration,
) -> Vec<Option<MemberStatus>> {
    let start = Instant::now();
    let n = cfg.ring.order.len();
    let sm = cfg.position(&cfg.ring.sync_master);
    let mut out: Vec<Option<MemberStatus>> = vec![None; n];
    loop {
        let sm_pending = sm.filter(|&i| out.get(i).is_some_and(Option::is_none));
        let mut again = false;
        if let Some(i) = sm_pending {
            ask(session, cfg, per_try, &[i], &mut out);
            // Answered only now: the others' earlier snapshots are older than its one (they are
            // asked again and kept if they do not answer).
            again = out.get(i).is_some_and(Option::is_some);
        }
        let pending: Vec<usize> = (0..n)
            .filter(|&i| Some(i) != sm && (again || out.get(i).is_some_and(Option::is_none)))
            .collect();
        ask(session, cfg, per_try, &pending, &mut out);
        if out.iter().all(Option::is_some) || start.elapsed() + per_try / 2 >= budget {
            break;
        }
        // No queryable matched yet (connections still forming): do not spin.
        std::thread::sleep(Duration::from_millis(50));
    }
    out
}

/// Ask the members at `which` (ring positions) for their status, concurrently; valid answers go
/// into `out`.
fn ask(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    per_try: Duration,
    which: &[usize],
    out: &mut [Option<MemberStatus>],
) {
    let gets: Vec<_> = which
        .iter()
        .filter_map(|&i| Some((i, ctl_key(&cfg.cluster, cfg.ring.order.get(i)?, "status"))))
        .map(|(i, key)| (i, session.get(key.as_str()).timeout(per_try).wait()))
        .collect();
    for (i, get) in gets {
        let Ok(replies) = get else { continue };
        let Ok(reply) = replies.recv() else { continue };
        let Ok(sample) = reply.result() else { continue };
        if sample.payload().len() > MAX_REPLY {
            continue;
        }
        let Ok(text) = sample.payload().try_to_string() else {
            continue;
        };
        if let (Ok(st), Some(slot)) = (serde_json::from_str::<MemberStatus>(&text), out.get_mut(i))
        {
            *slot = Some(st);
        }
    }
}
