//! Client side of the control plane (`mcc/<cluster>/ctl/<member>/...` queryables): status,
//! fault and shutdown queries, always with timeouts, never a hang.

use std::time::{Duration, Instant};

use anyhow::{anyhow, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::CardRefusal;
use mcc_ring::control::{alive_key, ctl_key, CtlReply, MemberStatus};
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
        let session = crate::cluster::hosts::open(cfg, Role::Client { host })?;
        crate::cluster::hosts::settle(&session, cfg, expected, settle);
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

/// Send one query (optional payload); the first reply's sample, or an error naming the key
/// (no reply within `timeout`, an error reply, a reply over `max_reply` bytes).
fn query_sample(
    session: &zenoh::Session,
    key: &str,
    payload: Option<Vec<u8>>,
    timeout: Duration,
    max_reply: usize,
) -> Result<zenoh::sample::Sample> {
    let mut get = session.get(key).timeout(timeout);
    if let Some(p) = payload {
        get = get.payload(p);
    }
    let replies = get.wait().map_err(|e| anyhow!("query {key}: {e}"))?;
    let Ok(reply) = replies.recv() else {
        return Err(anyhow!(
            "query {key}: no reply within {} ms",
            timeout.as_millis()
        ));
    };
    match reply.into_result() {
        Ok(sample) if sample.payload().len() > max_reply => Err(anyhow!(
            "query {key}: reply too large ({} bytes)",
            sample.payload().len()
        )),
        Ok(sample) => Ok(sample),
        Err(e) => {
            let text = e
                .payload()
                .try_to_string()
                .map(|s| s.into_owned())
                .unwrap_or_default();
            Err(anyhow!("query {key}: error reply: {text}"))
        }
    }
}

/// Send one query with an optional JSON payload; the first reply's text, or an error naming
/// the key (no reply within `timeout`, error reply, non-UTF-8).
pub fn query_text(
    session: &zenoh::Session,
    key: &str,
    payload: Option<String>,
    timeout: Duration,
) -> Result<String> {
    let sample = query_sample(
        session,
        key,
        payload.map(String::into_bytes),
        timeout,
        MAX_REPLY,
    )?;
    let text = sample
        .payload()
        .try_to_string()
        .map_err(|_| anyhow!("query {key}: reply is not UTF-8"))?;
    Ok(text.into_owned())
}

/// A card's answer on its command queryable `mcc/<cluster>/card/<n>/cmd`: the reply bytes as
/// its framing made them and the refusal of its line, from the reply attachment
/// (`mcc_contracts::control::refusal`) — set whether or not I6 printed it in the bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CardAnswer {
    /// The framed reply.
    pub bytes: Vec<u8>,
    /// The line's first refusal (`None`: not refused).
    pub refusal: Option<CardRefusal>,
}

/// Send `line` to a card's command queryable `key`; its [`CardAnswer`], or an error naming
/// the problem (no reply within `timeout`, error reply, a reply over `max_reply` bytes, an
/// attachment that is not a refusal).
pub fn query_card(
    session: &zenoh::Session,
    key: &str,
    line: &str,
    timeout: Duration,
    max_reply: usize,
) -> Result<CardAnswer> {
    let sample = query_sample(
        session,
        key,
        Some(line.as_bytes().to_vec()),
        timeout,
        max_reply,
    )?;
    let refusal = sample
        .attachment()
        .map(|a| CardRefusal::from_bytes(&a.to_bytes()))
        .transpose()
        .map_err(|e| anyhow!("query {key}: {e}"))?;
    Ok(CardAnswer {
        bytes: sample.payload().to_bytes().into_owned(),
        refusal,
    })
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

/// [`query_statuses`], and which members that did not answer still hold their zenoh
/// liveliness token (`mcc/<cluster>/alive/<member>`): alive but slow to answer (a busy
/// machine), never counted as gone (see `status::broken_link`). When the liveliness query
/// itself fails, a member that did not answer counts as gone, as before.
pub fn query_round(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    per_try: Duration,
    budget: Duration,
) -> (Vec<Option<MemberStatus>>, Vec<bool>) {
    let st = query_statuses(session, cfg, per_try, budget);
    let mut slow = vec![false; st.len()];
    if st.iter().any(Option::is_none) {
        if let Some(live) = live_members(session, cfg, per_try) {
            for ((s, l), slow) in st.iter().zip(live).zip(slow.iter_mut()) {
                *slow = s.is_none() && l;
            }
        }
    }
    (st, slow)
}

/// Which members (ring order) hold their liveliness token; None when the query failed.
pub fn live_members(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    timeout: Duration,
) -> Option<Vec<bool>> {
    let replies = session
        .liveliness()
        .get(alive_key(&cfg.cluster, "*"))
        .timeout(timeout)
        .wait()
        .ok()?;
    let mut live = vec![false; cfg.ring.order.len()];
    while let Ok(reply) = replies.recv() {
        let Ok(sample) = reply.result() else { continue };
        let key = sample.key_expr().as_str();
        if let Some(i) = cfg
            .ring
            .order
            .iter()
            .position(|m| alive_key(&cfg.cluster, m) == key)
        {
            live[i] = true;
        }
    }
    Some(live)
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

#[cfg(test)]
mod tests {
    use super::*;
    use mcc_ring::transport::session::free_loopback_endpoint;

    #[test]
    fn a_member_slow_to_answer_is_slow_not_gone() {
        // A member session holding card1's liveliness token whose status answer takes 1.5 s
        // (its thread busy); station0's token is there and it answers at once; the other
        // members are not there at all.
        let cfg = ClusterConfig::default_cluster(2, 2);
        let endpoint = free_loopback_endpoint().unwrap();
        let member = open_session(&SessionOptions {
            listen: vec![endpoint.clone()],
            ..Default::default()
        })
        .unwrap();
        let _tokens: Vec<_> = ["card1", "station0"]
            .iter()
            .map(|m| {
                member
                    .liveliness()
                    .declare_token(alive_key(&cfg.cluster, m))
                    .wait()
                    .unwrap()
            })
            .collect();
        let status = |name: &str| {
            serde_json::to_string(&MemberStatus {
                name: name.into(),
                ..Default::default()
            })
            .unwrap()
        };
        let slow_reply = status("card1");
        let _slow = member
            .declare_queryable(ctl_key(&cfg.cluster, "card1", "status"))
            .callback(move |q| {
                let body = slow_reply.clone();
                std::thread::spawn(move || {
                    std::thread::sleep(Duration::from_millis(1500));
                    let _ = q.reply(q.key_expr().clone(), body).wait();
                });
            })
            .wait()
            .unwrap();
        let quick_reply = status("station0");
        let _quick = member
            .declare_queryable(ctl_key(&cfg.cluster, "station0", "status"))
            .callback(move |q| {
                let _ = q.reply(q.key_expr().clone(), quick_reply.clone()).wait();
            })
            .wait()
            .unwrap();
        let cli = connect(&cfg, None, &endpoint, 1, Duration::from_secs(5)).unwrap();
        let (st, slow) = query_round(
            &cli,
            &cfg,
            Duration::from_millis(300),
            Duration::from_millis(600),
        );
        let answered: Vec<bool> = st.iter().map(Option::is_some).collect();
        assert_eq!(answered, [false, true, false, false]);
        assert_eq!(slow, [false, false, true, false]);
        let doc = crate::cluster::status::build(
            &cfg,
            &crate::cluster::rundir::SupervisorInfo::starting(1, "mcc"),
            "/run/x",
            &st,
            &slow,
        );
        // The walk from the sync master passes slow card1 by and stops at station1, gone.
        assert_eq!(doc.ring.broken_link.as_deref(), Some("station1 → card0"));
        assert!(doc.members[2].slow && !doc.members[2].alive);
        assert!(!doc.members[0].slow);
    }
}
