//! The member side of the control plane (architecture §7): a queryable on
//! `mcc/<cluster>/ctl/<member>/*` (status, fault, shutdown, reset), the member's liveliness
//! token, and a watch on the orchestrator's token (when it disappears the member stops).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{bounded, Sender};
use tracing::{info, warn};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::{Query, Queryable};
use zenoh::sample::SampleKind;
use zenoh::Wait;

use super::driver::DriverCmd;
use crate::control::{alive_key, ctl_key, CtlReply, FaultRequest};

/// How long a control query waits for the member's loop.
const LOOP_REPLY_TIMEOUT: Duration = Duration::from_millis(1500);

/// Keeps the control plane declared; drop it to undeclare.
pub struct ControlPlane {
    _queryable: Queryable<()>,
    _token: LivelinessToken,
    _orchestrator_watch: Option<Subscriber<()>>,
}

impl std::fmt::Debug for ControlPlane {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ControlPlane").finish_non_exhaustive()
    }
}

/// Declare the control plane of `member` in `cluster`. Requests are forwarded to the member's
/// loop through `cmds`; `stop` is raised on a shutdown request or when the supervisor that
/// was seen (its liveliness token `orchestrator_key`, see [`orchestrator_key`]) goes away.
pub fn start(
    session: &zenoh::Session,
    cluster: &str,
    member: &str,
    orchestrator_key: Option<&str>,
    cmds: Sender<DriverCmd>,
    stop: Arc<AtomicBool>,
) -> Result<ControlPlane, super::DeclareError> {
    let prefix = ctl_key(cluster, member, "");
    let stop_q = Arc::clone(&stop);
    let queryable = session
        .declare_queryable(ctl_key(cluster, member, "*"))
        .callback(move |query| {
            let cmds = cmds.clone();
            let stop = Arc::clone(&stop_q);
            let prefix = prefix.clone();
            // Answer on a short-lived thread: never block zenoh's callback thread.
            let _ = std::thread::Builder::new()
                .name("mcc-ctl".into())
                .spawn(move || answer(query, &prefix, &cmds, &stop));
        })
        .wait()
        .map_err(super::DeclareError::of("control queryable"))?;
    let token = session
        .liveliness()
        .declare_token(alive_key(cluster, member))
        .wait()
        .map_err(super::DeclareError::of("liveliness token"))?;
    let Some(orch_key) = orchestrator_key.map(str::to_string) else {
        return Ok(ControlPlane {
            _queryable: queryable,
            _token: token,
            _orchestrator_watch: None,
        });
    };
    let seen = Arc::new(AtomicBool::new(false));
    let weak = session.clone();
    let watch = session
        .liveliness()
        .declare_subscriber(orch_key.clone())
        .history(true)
        .callback(move |sample| match sample.kind() {
            SampleKind::Put => seen.store(true, Ordering::Relaxed),
            SampleKind::Delete => {
                if seen.load(Ordering::Relaxed) {
                    // A member thawed after SIGSTOP sees the token vanish while its session
                    // reconnects: look again before giving up.
                    let stop = Arc::clone(&stop);
                    let session = weak.clone();
                    let key = orch_key.clone();
                    let _ = std::thread::Builder::new()
                        .name("mcc-orch-watch".into())
                        .spawn(move || {
                            if !orchestrator_alive(&session, &key) {
                                warn!("orchestrator went away: stopping");
                                stop.store(true, Ordering::Relaxed);
                            }
                        });
                }
            }
        })
        .wait()
        .map_err(super::DeclareError::of("orchestrator watch"))?;
    Ok(ControlPlane {
        _queryable: queryable,
        _token: token,
        _orchestrator_watch: Some(watch),
    })
}

/// The liveliness token of the supervisor that started `member` (its host's share,
/// `mcc/<cluster>/hosts/<host>/alive`) on one machine. On several hosts None: the token
/// travels through the network (a router), and a cut network must not stop a host's members
/// (they still leave when their supervisor dies: the parent-death signal).
pub fn orchestrator_key(
    config: &mcc_contracts::config::ClusterConfig,
    member: &str,
) -> Option<String> {
    if config.is_multi_host() {
        return None;
    }
    let host = config
        .member_host(member)
        .unwrap_or(mcc_contracts::config::LOCAL_HOST);
    Some(mcc_contracts::control::hosts::host_key(
        &config.cluster,
        host,
        "alive",
    ))
}

/// Whether the orchestrator's liveliness token is still (or again) there, asked a few times
/// over about two seconds.
fn orchestrator_alive(session: &zenoh::Session, key: &str) -> bool {
    for _ in 0..4 {
        std::thread::sleep(Duration::from_millis(500));
        let replies = match session
            .liveliness()
            .get(key)
            .timeout(Duration::from_millis(500))
            .wait()
        {
            Ok(r) => r,
            Err(_) => continue,
        };
        while let Ok(reply) = replies.recv() {
            if reply.result().is_ok() {
                return true;
            }
        }
    }
    false
}

fn answer(query: Query, prefix: &str, cmds: &Sender<DriverCmd>, stop: &AtomicBool) {
    let key = query.key_expr().as_str().to_string();
    let what = key.strip_prefix(prefix).unwrap_or("").to_string();
    let payload = query
        .payload()
        .map(|p| p.to_bytes().into_owned())
        .unwrap_or_default();
    let body: Vec<u8> = match what.as_str() {
        "status" => {
            let (tx, rx) = bounded(1);
            if cmds.send(DriverCmd::Status(tx)).is_err() {
                json(&reply(false, "member loop has stopped"))
            } else {
                match rx.recv_timeout(LOOP_REPLY_TIMEOUT) {
                    Ok(s) => serde_json::to_vec(&s).unwrap_or_default(),
                    Err(_) => json(&reply(false, "member loop did not answer")),
                }
            }
        }
        "fault" => match serde_json::from_slice::<FaultRequest>(&payload) {
            Ok(req) => loop_call(cmds, |tx| DriverCmd::Fault(req, tx)),
            Err(e) => json(&reply(false, &format!("bad fault request: {e}"))),
        },
        "reset" => loop_call(cmds, DriverCmd::ResetRingFault),
        "shutdown" => {
            info!("shutdown requested");
            stop.store(true, Ordering::Relaxed);
            let _ = cmds.send(DriverCmd::Stop);
            json(&reply(true, "stopping"))
        }
        other => json(&reply(false, &format!("unknown control request '{other}'"))),
    };
    if let Err(e) = query.reply(query.key_expr().clone(), body).wait() {
        warn!("control reply failed: {e}");
    }
}

fn loop_call(
    cmds: &Sender<DriverCmd>,
    make: impl FnOnce(Sender<CtlReply>) -> DriverCmd,
) -> Vec<u8> {
    let (tx, rx) = bounded(1);
    if cmds.send(make(tx)).is_err() {
        return json(&reply(false, "member loop has stopped"));
    }
    match rx.recv_timeout(LOOP_REPLY_TIMEOUT) {
        Ok(r) => json(&r),
        Err(_) => json(&reply(false, "member loop did not answer")),
    }
}

fn reply(ok: bool, message: &str) -> CtlReply {
    CtlReply {
        ok,
        message: message.to_string(),
    }
}

fn json(r: &CtlReply) -> Vec<u8> {
    serde_json::to_vec(r).unwrap_or_default()
}
