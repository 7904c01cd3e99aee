//! The supervising process of a cluster (the foreground `mcc up`, or the detached
//! `mcc supervise` daemon): it owns the zenoh endpoint members connect to, the orchestrator's
//! liveliness token, and the member processes; it stops them in order on request.

use std::process::{Child, ExitStatus};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context, Result};
use mcc_contracts::config::{ClusterConfig, MemberRef};
use mcc_contracts::config::{Topology, LOCAL_HOST};
use mcc_contracts::control::hosts::{DrillRequest, HostProc};
use mcc_ring::control::{alive_key, ctl_key, CtlReply};
use mcc_ring::transport::cluster::{self, Role};
use mcc_ring::transport::session::{free_loopback_endpoint, SessionOptions};
use zenoh::Wait;

use crate::cluster::hosts;
use crate::cluster::hosts::share::Share;
use crate::cluster::launch;
use crate::cluster::rundir::{MemberProc, RunDir, SupervisorInfo};
use crate::cluster::sys;

/// One started member.
#[derive(Debug)]
struct Running {
    name: String,
    child: Child,
    exited: Option<ExitStatus>,
}

/// A running cluster.
pub struct Supervisor {
    rd: RunDir,
    cfg: ClusterConfig,
    session: zenoh::Session,
    token: Option<zenoh::liveliness::LivelinessToken>,
    children: Vec<Running>,
    info: SupervisorInfo,
    /// `mcc fault MEMBER restart` requests (DRILLS), served in [`Supervisor::poll`].
    restarts: Option<(
        zenoh::query::Queryable<()>,
        mpsc::Receiver<zenoh::query::Query>,
    )>,
    /// The daisy chain (TCP port, optional pty) while the cluster runs.
    chain: Option<crate::cluster::chain::server::ChainServer>,
    /// The EMCL bus (TCP port, optional pty) when the cluster has drives.
    emcl: Option<crate::cluster::emcl::server::BusServer>,
    /// The chain's and bus's host-link faults, and their queryable (`link_ctl`).
    links: crate::cluster::link_ctl::HostLinks,
    links_q: Option<zenoh::query::Queryable<()>>,
    /// This host's share on the zenoh network (token, info, down, drills).
    share: Option<Share>,
    /// The host this supervisor runs ([`LOCAL_HOST`] for a cluster on one machine).
    host: String,
}

impl std::fmt::Debug for Supervisor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Supervisor")
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

impl Supervisor {
    /// Open the endpoint, declare `alive/orchestrator`, start every member (in ring order)
    /// and record everything in `supervisor.json`. On failure, whatever was started is
    /// stopped again.
    pub fn start(rd: RunDir, cfg: ClusterConfig) -> Result<Self> {
        let host = rd.host.clone().unwrap_or_else(|| LOCAL_HOST.to_string());
        let (session, endpoint) = open_endpoint(&cfg, &host)?;
        // Join only the same cluster: same config on every other host, this host not
        // running elsewhere, none of its members already up.
        let others = cfg.host_names().len().saturating_sub(1);
        hosts::settle(&session, &cfg, others, Duration::from_secs(1));
        hosts::admit::admit(&session, &cfg, &host)?;
        let share = Share::declare(&session, &cfg, &host, std::process::id())?;
        let token = session
            .liveliness()
            .declare_token(alive_key(&cfg.cluster, "orchestrator"))
            .wait()
            .map_err(|e| anyhow!("cannot declare the orchestrator liveliness token: {e}"))?;
        let mut info = SupervisorInfo::starting(std::process::id(), &cfg.cluster);
        info.endpoint = Some(endpoint.clone());
        info.host = rd.host.clone();
        rd.write_info(&info)?;
        let cfg_has_no_drives = cfg.drives.is_empty();
        let mut sup = Supervisor {
            rd,
            cfg,
            session,
            token: Some(token),
            children: Vec::new(),
            info,
            restarts: None,
            chain: None,
            emcl: None,
            links: crate::cluster::link_ctl::HostLinks {
                has_bus: !cfg_has_no_drives,
                ..Default::default()
            },
            links_q: None,
            share: Some(share),
            host,
        };
        let (rtx, rrx) = mpsc::sync_channel(16);
        let q = sup
            .session
            .declare_queryable(crate::cluster::drills::restart_key(&sup.cfg.cluster))
            .callback(move |query| {
                let _ = rtx.try_send(query);
            })
            .wait()
            .map_err(|e| anyhow!("cannot declare the restart queryable: {e}"))?;
        sup.restarts = Some((q, rrx));
        sup.links_q = Some(sup.links.declare(&sup.session, &sup.cfg.cluster)?);
        // This host's members (all of them on one machine), then its stand-alone EMCL drives
        // (processes of their own, not on the ring).
        let order = sup.cfg.host_processes(&sup.host);
        for name in &order {
            match launch::spawn_member(&sup.rd, &sup.cfg, name, &endpoint) {
                Ok(child) => {
                    let kind = match sup.cfg.member(name) {
                        Some(MemberRef::Card(_)) => "card",
                        None if sup.cfg.drive(name).is_some() => "drive",
                        _ => "station",
                    };
                    tracing::info!(member = %name, pid = child.id(), "started");
                    sup.info.members.push(MemberProc {
                        name: name.clone(),
                        kind: kind.into(),
                        pid: child.id(),
                    });
                    sup.children.push(Running {
                        name: name.clone(),
                        child,
                        exited: None,
                    });
                }
                Err(e) => {
                    sup.shutdown(Duration::from_secs(3));
                    return Err(e);
                }
            }
        }
        let chain = crate::cluster::chain::server::ChainOptions::from_env().and_then(|o| {
            crate::cluster::chain::server::start(&sup.session, &sup.cfg, &o, &sup.links.chain)
        });
        match chain {
            Ok(c) => {
                sup.info.daisy_chain = Some(c.addr().to_string());
                sup.info.daisy_chain_pty = c.pty_path().map(str::to_string);
                sup.chain = Some(c);
            }
            Err(e) => {
                sup.shutdown(Duration::from_secs(3));
                return Err(e);
            }
        }
        if !sup.cfg.drives.is_empty() {
            let bus = crate::cluster::emcl::server::BusOptions::resolve(&sup.cfg).and_then(|o| {
                crate::cluster::emcl::server::start(&sup.session, &sup.cfg, &o, &sup.links.bus)
            });
            match bus {
                Ok(b) => {
                    sup.info.emcl_bus = Some(b.addr().to_string());
                    sup.info.emcl_bus_pty = b.pty_path().map(str::to_string);
                    sup.emcl = Some(b);
                }
                Err(e) => {
                    sup.shutdown(Duration::from_secs(3));
                    return Err(e);
                }
            }
        }
        sup.info.phase = "running".into();
        sup.rd.write_info(&sup.info)?;
        sup.publish_share();
        Ok(sup)
    }

    /// What this share's `info` answers: phase, member pids, chain and bus.
    fn publish_share(&self) {
        let Some(share) = &self.share else { return };
        share.update(|h| {
            h.phase = self.info.phase.clone();
            h.members = self
                .info
                .members
                .iter()
                .map(|m| HostProc {
                    name: m.name.clone(),
                    pid: m.pid,
                })
                .collect();
            h.daisy_chain = self.info.daisy_chain.clone();
            h.emcl_bus = self.info.emcl_bus.clone();
        });
    }

    /// Another host asked this share to stop (`mcc down` there).
    pub fn stop_requested(&self) -> bool {
        self.share.as_ref().is_some_and(Share::down_requested)
    }

    /// Serve drill requests from other hosts (freeze, thaw, kill, restart of a member here).
    fn serve_drills(&mut self, out: &mut Vec<String>) {
        let queries = self
            .share
            .as_ref()
            .map(Share::take_drills)
            .unwrap_or_default();
        for q in queries {
            let req = q
                .payload()
                .and_then(|p| serde_json::from_slice::<DrillRequest>(&p.to_bytes()).ok());
            let reply = match req {
                None => Err(anyhow!("bad drill request")),
                Some(r) => self.drill(&r.member, &r.kind).inspect(|m| {
                    out.push(format!(
                        "member {} {}: {m} (asked by another host)",
                        r.member, r.kind
                    ))
                }),
            };
            let r = match reply {
                Ok(message) => CtlReply { ok: true, message },
                Err(e) => CtlReply {
                    ok: false,
                    message: format!("{e:#}"),
                },
            };
            let _ = q
                .reply(
                    q.key_expr().clone(),
                    serde_json::to_vec(&r).unwrap_or_default(),
                )
                .wait();
        }
    }

    /// A process drill on one of this share's members.
    fn drill(&mut self, member: &str, kind: &str) -> Result<String> {
        let pid = self
            .children
            .iter()
            .find(|r| r.name == member && r.exited.is_none())
            .map(|r| r.child.id());
        let sig = match kind {
            "restart" => {
                return self
                    .restart(member)
                    .map(|pid| format!("restarted (pid {pid})"))
            }
            "freeze" => libc::SIGSTOP,
            "thaw" => libc::SIGCONT,
            "kill" => libc::SIGKILL,
            other => return Err(anyhow!("unknown drill {other:?}")),
        };
        let pid = pid.ok_or_else(|| anyhow!("{member} is not running on host {}", self.host))?;
        sys::signal(pid, sig).map_err(|e| anyhow!("signal {sig} to {member} (pid {pid}): {e}"))?;
        Ok(format!("{kind}: signal {sig} sent to pid {pid}"))
    }

    /// The supervisor's session (directly connected to every member).
    pub fn session(&self) -> &zenoh::Session {
        &self.session
    }

    /// The cluster config.
    pub fn config(&self) -> &ClusterConfig {
        &self.cfg
    }

    /// The supervisor record.
    pub fn info(&self) -> &SupervisorInfo {
        &self.info
    }

    /// The run directory.
    pub fn run_dir(&self) -> &RunDir {
        &self.rd
    }

    /// Reap members that exited since the last call; one message per newly dead member.
    pub fn poll(&mut self) -> Vec<String> {
        let mut out = Vec::new();
        self.serve_drills(&mut out);
        let queries: Vec<zenoh::query::Query> = self
            .restarts
            .as_ref()
            .map(|(_, rx)| rx.try_iter().collect())
            .unwrap_or_default();
        for q in queries {
            let name = q
                .payload()
                .and_then(|p| p.try_to_string().ok().map(|s| s.trim().to_string()))
                .unwrap_or_default();
            let reply = match self.restart(&name) {
                Ok(pid) => {
                    out.push(format!("member {name} restarted (pid {pid})"));
                    mcc_ring::control::CtlReply {
                        ok: true,
                        message: format!("restarted (pid {pid})"),
                    }
                }
                Err(e) => mcc_ring::control::CtlReply {
                    ok: false,
                    message: format!("{e:#}"),
                },
            };
            let body = serde_json::to_vec(&reply).unwrap_or_default();
            let _ = q.reply(q.key_expr().clone(), body).wait();
        }
        for r in self.children.iter_mut().filter(|r| r.exited.is_none()) {
            if let Ok(Some(status)) = r.child.try_wait() {
                r.exited = Some(status);
                out.push(format!(
                    "member {} (pid {}) exited: {status}",
                    r.name,
                    r.child.id()
                ));
            }
        }
        out
    }

    /// Restart member `name` (drill): SIGKILL the old process if it still runs (thawing it
    /// first), reap it, start it again with the same config and endpoint; it rejoins the ring.
    pub fn restart(&mut self, name: &str) -> Result<u32> {
        let idx = self
            .children
            .iter()
            .position(|r| r.name == name)
            .ok_or_else(|| anyhow!("unknown member {name:?}"))?;
        let endpoint = self
            .info
            .endpoint
            .clone()
            .ok_or_else(|| anyhow!("no endpoint"))?;
        if let Some(r) = self.children.get_mut(idx) {
            if r.exited.is_none() {
                let _ = sys::signal(r.child.id(), libc::SIGCONT);
                let _ = sys::signal(r.child.id(), sys::SIGKILL);
                r.exited = r.child.wait().ok();
            }
        }
        let child = launch::spawn_member(&self.rd, &self.cfg, name, &endpoint)?;
        let pid = child.id();
        tracing::info!(member = %name, pid, "restarted");
        if let Some(r) = self.children.get_mut(idx) {
            *r = Running {
                name: name.to_string(),
                child,
                exited: None,
            };
        }
        if let Some(m) = self.info.members.iter_mut().find(|m| m.name == name) {
            m.pid = pid;
        }
        self.rd.write_info(&self.info)?;
        self.publish_share();
        Ok(pid)
    }

    /// Stop every member: shutdown query, then SIGTERM, then SIGKILL after `timeout`; reap
    /// them, withdraw the liveliness token, close the session, remove the runtime files.
    pub fn shutdown(mut self, timeout: Duration) {
        self.info.phase = "stopping".into();
        let _ = self.rd.write_info(&self.info);
        self.publish_share();
        let _ = self.poll();
        let gets: Vec<_> = self
            .children
            .iter()
            .filter(|r| r.exited.is_none())
            .map(|r| {
                let key = ctl_key(&self.cfg.cluster, &r.name, "shutdown");
                self.session
                    .get(key)
                    .timeout(Duration::from_millis(500))
                    .wait()
            })
            .collect();
        for replies in gets.into_iter().flatten() {
            let _ = replies.recv();
        }
        // Members also leave when these tokens disappear.
        if let Some(t) = self.token.take() {
            let _ = t.undeclare().wait();
        }
        if let Some(s) = self.share.as_mut() {
            s.withdraw();
        }
        let half = timeout / 2;
        self.wait_all(half);
        for sig in [sys::SIGTERM, sys::SIGKILL] {
            let live: Vec<u32> = self
                .children
                .iter()
                .filter(|r| r.exited.is_none())
                .map(|r| r.child.id())
                .collect();
            if live.is_empty() {
                break;
            }
            for pid in live {
                tracing::warn!(pid, sig, "member did not stop; signalling");
                let _ = sys::signal(pid, sig);
            }
            self.wait_all(half.max(Duration::from_secs(1)));
        }
        for r in self.children.iter_mut().filter(|r| r.exited.is_none()) {
            r.exited = r.child.wait().ok();
        }
        let _ = self.session.close().wait();
        if let Err(e) = self.rd.cleanup() {
            tracing::warn!("cleanup: {e:#}");
        }
    }

    fn wait_all(&mut self, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        loop {
            let _ = self.poll();
            if self.children.iter().all(|r| r.exited.is_some()) || Instant::now() >= deadline {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// Open the supervisor's session and name the endpoint members and CLI verbs reach it by.
/// On one machine: a fresh loopback port (zenoh does not report a port bound as `:0`, so a
/// free port is picked first; if another process grabs it in between, another one is tried).
/// On several hosts: the routers, or this host's supervisor endpoint (peer to peer).
fn open_endpoint(cfg: &ClusterConfig, host: &str) -> Result<(zenoh::Session, String)> {
    match cfg.topology() {
        Topology::Routers(r) => {
            let s = hosts::open(cfg, Role::Supervisor { host })?;
            return Ok((s, r.first().cloned().unwrap_or_default()));
        }
        Topology::PeerToPeer => {
            let ep = cfg.host_endpoint(host).unwrap_or_default();
            let s = hosts::open(cfg, Role::Supervisor { host })
                .map_err(|e| anyhow!("cannot open host {host}'s zenoh endpoint {ep}: {e:#}"))?;
            return Ok((s, ep));
        }
        Topology::Single => {}
    }
    let mut last = String::new();
    for _ in 0..5 {
        let endpoint = free_loopback_endpoint().map_err(|e| anyhow!("{e}"))?;
        let mut listen = vec![endpoint.clone()];
        listen.extend(cfg.zenoh.listen.iter().cloned());
        let mut opts = SessionOptions {
            listen,
            connect: cfg.zenoh.connect.clone(),
            ..Default::default()
        };
        cluster::secure(&mut opts, cfg).map_err(|e| anyhow!("{e}"))?;
        match hosts::open_with(cfg, &opts) {
            Ok(s) => return Ok((s, endpoint)),
            Err(e) => last = e.to_string(),
        }
    }
    Err(anyhow!("cannot open the cluster's zenoh endpoint: {last}"))
}

/// Termination requests (SIGINT, SIGTERM, SIGHUP) as messages. The returned runtime must be
/// kept alive as long as the receiver is used.
pub fn stop_signals() -> Result<(tokio::runtime::Runtime, mpsc::Receiver<String>)> {
    use tokio::signal::unix::{signal, SignalKind};
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .context("cannot start the signal runtime")?;
    let (tx, rx) = mpsc::channel();
    let _g = rt.enter();
    let mut int = signal(SignalKind::interrupt()).context("SIGINT handler")?;
    let mut term = signal(SignalKind::terminate()).context("SIGTERM handler")?;
    let mut hup = signal(SignalKind::hangup()).context("SIGHUP handler")?;
    rt.spawn(async move {
        loop {
            let which = tokio::select! {
                _ = int.recv() => "SIGINT",
                _ = term.recv() => "SIGTERM",
                _ = hup.recv() => "SIGHUP",
            };
            if tx.send(which.to_string()).is_err() {
                break;
            }
        }
    });
    Ok((rt, rx))
}
