//! The host share a supervisor runs: its liveliness token `mcc/<cluster>/hosts/<host>/alive`
//! (its members leave when it goes away) and the queryables `info` (what it runs), `down`
//! (stop this share) and `drill` (freeze, thaw, kill, restart one of its members).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};

use anyhow::{anyhow, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::hosts::{host_key, HostInfo};
use mcc_ring::control::CtlReply;
use zenoh::liveliness::LivelinessToken;
use zenoh::query::{Query, Queryable};
use zenoh::Wait;

/// A declared share; dropping it withdraws it.
pub struct Share {
    info: Arc<Mutex<HostInfo>>,
    down: Arc<AtomicBool>,
    drills: mpsc::Receiver<Query>,
    _queryables: Vec<Queryable<()>>,
    token: Option<LivelinessToken>,
}

impl std::fmt::Debug for Share {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Share").finish_non_exhaustive()
    }
}

impl Share {
    /// Declare `host`'s share of `cfg` run by process `pid`.
    pub fn declare(
        session: &zenoh::Session,
        cfg: &ClusterConfig,
        host: &str,
        pid: u32,
    ) -> Result<Self> {
        let info = Arc::new(Mutex::new(HostInfo {
            cluster: cfg.cluster.clone(),
            host: host.to_string(),
            machine: super::machine_name(),
            pid,
            digest: cfg.digest(),
            config: cfg.to_toml_string()?,
            phase: "starting".into(),
            members: Vec::new(),
            daisy_chain: None,
            emcl_bus: None,
        }));
        let key = |what: &str| host_key(&cfg.cluster, host, what);
        let i2 = Arc::clone(&info);
        let info_q = session
            .declare_queryable(key("info"))
            .callback(move |q| {
                let body = {
                    let g = i2.lock().unwrap_or_else(|e| e.into_inner());
                    serde_json::to_vec(&*g).unwrap_or_default()
                };
                let _ = q.reply(q.key_expr().clone(), body).wait();
            })
            .wait()
            .map_err(|e| anyhow!("cannot declare the share's info queryable: {e}"))?;
        let down = Arc::new(AtomicBool::new(false));
        let d2 = Arc::clone(&down);
        let down_q = session
            .declare_queryable(key("down"))
            .callback(move |q| {
                d2.store(true, Ordering::Relaxed);
                let r = CtlReply {
                    ok: true,
                    message: "stopping".into(),
                };
                let _ = q
                    .reply(
                        q.key_expr().clone(),
                        serde_json::to_vec(&r).unwrap_or_default(),
                    )
                    .wait();
            })
            .wait()
            .map_err(|e| anyhow!("cannot declare the share's down queryable: {e}"))?;
        let (tx, drills) = mpsc::sync_channel(16);
        let drill_q = session
            .declare_queryable(key("drill"))
            .callback(move |q| {
                let _ = tx.try_send(q);
            })
            .wait()
            .map_err(|e| anyhow!("cannot declare the share's drill queryable: {e}"))?;
        let token = session
            .liveliness()
            .declare_token(key("alive"))
            .wait()
            .map_err(|e| anyhow!("cannot declare the share's liveliness token: {e}"))?;
        Ok(Share {
            info,
            down,
            drills,
            _queryables: vec![info_q, down_q, drill_q],
            token: Some(token),
        })
    }

    /// Change what `info` answers.
    pub fn update(&self, f: impl FnOnce(&mut HostInfo)) {
        f(&mut self.info.lock().unwrap_or_else(|e| e.into_inner()));
    }

    /// Another host asked this share to stop.
    pub fn down_requested(&self) -> bool {
        self.down.load(Ordering::Relaxed)
    }

    /// Drill requests received since the last call.
    pub fn take_drills(&self) -> Vec<Query> {
        self.drills.try_iter().collect()
    }

    /// Withdraw the liveliness token (the share's members then leave).
    pub fn withdraw(&mut self) {
        if let Some(t) = self.token.take() {
            let _ = t.undeclare().wait();
        }
    }
}
