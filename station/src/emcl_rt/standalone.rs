//! A drive standing alone as its own process (`[[drives]]` without `station`): an RS485
//! device is not on the MACRO ring, so it runs on its own 1 kHz clock (the monotonic clock:
//! the drive's model still takes its ticks as arguments). It serves the same queryables as a
//! hosting station, holds the liveliness token `mcc/<cluster>/alive/<name>`, answers
//! `ctl/<name>/shutdown`, and stops on SIGTERM/SIGINT/SIGHUP, when the orchestrator's token
//! goes away, or when its parent dies — writing its pending EEPROM image first.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_ring::control::{alive_key, ctl_key, CtlReply};
use mcc_ring::transport::cluster::{self, Role};
use mcc_ring::transport::session::{open_session, SessionOptions};
use zenoh::sample::SampleKind;
use zenoh::Wait;

use super::service::{EmclService, HostState};

/// How long the orchestrator's token may stay away before the drive process leaves.
const ORPHAN_GRACE: Duration = Duration::from_secs(2);

/// Run stand-alone drive `name` of the config at `config_path` until stopped.
pub fn run(config_path: &Path, name: &str, connect: &[String], listen: &[String]) -> Result<()> {
    let cfg = ClusterConfig::from_file(config_path)
        .with_context(|| format!("loading {}", config_path.display()))?;
    let span = tracing::info_span!("drive", cluster = %cfg.cluster, name = %name);
    let _enter = span.enter();
    let d = cfg
        .drive(name)
        .ok_or_else(|| anyhow!("'{name}' is not a drive in the config"))?;
    if d.station.is_some() {
        anyhow::bail!("drive '{name}' is hosted by a station, not a process of its own");
    }
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [
        signal_hook::consts::SIGTERM,
        signal_hook::consts::SIGINT,
        signal_hook::consts::SIGHUP,
    ] {
        signal_hook::flag::register(sig, Arc::clone(&stop)).context("signal handler")?;
    }
    #[cfg(target_os = "linux")]
    let _ = nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGTERM);

    let run_dir = config_path.parent().unwrap_or(Path::new("."));
    let (host, files, notes) = super::build_host(&cfg, name, run_dir).map_err(|e| anyhow!(e))?;
    for n in &notes {
        tracing::warn!("{n}");
        eprintln!("mcc-drive {name}: {n}");
    }
    let mut conn = cfg.zenoh.connect.clone();
    conn.extend(connect.iter().cloned());
    let listen = if listen.is_empty() {
        cfg.zenoh.listen.clone()
    } else {
        listen.to_vec()
    };
    let opts = match cluster::host_options(&cfg, Role::Member { name })? {
        Some(o) => o,
        None => {
            let mut o = SessionOptions {
                listen,
                connect: conn,
                ..Default::default()
            };
            cluster::secure(&mut o, &cfg)?;
            o
        }
    };
    let session = open_session(&opts)?;
    mcc_ring::runtime::join::check(&session, &cfg)?;
    let n = files.len();
    let shared = Arc::new(Mutex::new(HostState {
        host,
        files,
        errors: vec![None; n],
        member: name.to_string(),
    }));
    let service = EmclService::start(&session, &cfg.cluster, name, Arc::clone(&shared))
        .map_err(|e| anyhow!("declaring the EMCL queryables: {e}"))?;
    let _token = session
        .liveliness()
        .declare_token(alive_key(&cfg.cluster, name))
        .wait()
        .map_err(|e| anyhow!("liveliness token: {e}"))?;
    let stop_q = Arc::clone(&stop);
    let _shutdown = session
        .declare_queryable(ctl_key(&cfg.cluster, name, "shutdown"))
        .callback(move |q| {
            let body = serde_json::to_vec(&CtlReply {
                ok: true,
                message: "stopping".into(),
            })
            .unwrap_or_default();
            let _ = q.reply(q.key_expr().clone(), body).wait();
            stop_q.store(true, Ordering::Relaxed);
        })
        .wait()
        .map_err(|e| anyhow!("shutdown queryable: {e}"))?;
    let orch_seen = Arc::new(AtomicBool::new(false));
    let orch_gone: Arc<Mutex<Option<Instant>>> = Arc::new(Mutex::new(None));
    let (seen, gone) = (Arc::clone(&orch_seen), Arc::clone(&orch_gone));
    // On several hosts no watch (a cut network must not stop the drive; the parent-death
    // signal still does when its supervisor dies).
    let key = mcc_ring::runtime::control_plane::orchestrator_key(&cfg, name)
        .unwrap_or_else(|| format!("mcc/{}/never/{name}", cfg.cluster));
    let _watch = session
        .liveliness()
        .declare_subscriber(key)
        .history(true)
        .callback(move |s| {
            let mut g = gone.lock().unwrap_or_else(|e| e.into_inner());
            match s.kind() {
                SampleKind::Put => {
                    seen.store(true, Ordering::Relaxed);
                    *g = None;
                }
                SampleKind::Delete => *g = Some(Instant::now()),
            }
        })
        .wait()
        .map_err(|e| anyhow!("orchestrator watch: {e}"))?;
    tracing::info!("drive {name} running stand-alone");

    // The 1 kHz clock: the drive's time is the monotonic time since start.
    let t0 = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(1));
        let now_ns = u64::try_from(t0.elapsed().as_nanos()).unwrap_or(u64::MAX);
        shared
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .host
            .advance(now_ns, None);
        let gone_for = orch_gone
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .map(|t| t.elapsed());
        if orch_seen.load(Ordering::Relaxed) && gone_for.is_some_and(|d| d > ORPHAN_GRACE) {
            tracing::warn!("the orchestrator is gone: stopping");
            break;
        }
    }
    drop(service);
    let _ = session.close().wait();
    Ok(())
}

/// If `name` is a stand-alone drive of the config at `config_path`, run it (the process is
/// a drive, not a station) and return its outcome; otherwise `None`.
pub fn maybe_run(
    config_path: &Path,
    name: &str,
    connect: &[String],
    listen: &[String],
) -> Option<Result<()>> {
    let cfg = ClusterConfig::from_file(config_path).ok()?;
    cfg.drive(name)?;
    Some(run(config_path, name, connect, listen))
}
