//! The common `main` of a ring member process (`mcc-card`, `mcc-station`): load the cluster
//! config, open the zenoh session, join the ring link, declare the control plane, install
//! signal handling and parent-death notification, then run the member's cycle loop on the
//! calling thread until stopped.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{anyhow, Context};
use crossbeam_channel::unbounded;
use tracing::{info, info_span};

use super::control_plane;
use super::driver::{Driver, DriverConfig, DriverExit};
pub use crate::check::{card_check, card_config_check};
use crate::control::MemberKind;
use crate::core::{CoreConfig, MemberCore, RingApp};
use crate::transport::cluster::{self, Role};
use crate::transport::session::{open_session, SessionOptions};
use crate::transport::zenoh_link;
use mcc_contracts::config::ClusterConfig;

/// Realtime: consecutive silent or packet-less cycles tolerated before a data underrun.
pub const REALTIME_TIMING_SLACK: u32 = 8;

/// Command-line arguments every member process takes.
#[derive(Debug, Clone)]
pub struct MemberArgs {
    /// The resolved cluster config (TOML).
    pub config: PathBuf,
    /// This member's name in the config.
    pub name: String,
    /// zenoh endpoints to connect to (overrides/extends the config's).
    pub connect: Vec<String>,
    /// zenoh endpoints to listen on (default `tcp/127.0.0.1:0`).
    pub listen: Vec<String>,
}

/// What the application factory gets to build a member's logic.
pub struct MemberContext {
    /// The cluster config.
    pub config: ClusterConfig,
    /// This member's name.
    pub name: String,
    /// Position in the ring order.
    pub position: usize,
    /// The process's zenoh session (for extra queryables).
    pub session: zenoh::Session,
    /// Raised when the process must stop.
    pub stop: Arc<AtomicBool>,
}

impl std::fmt::Debug for MemberContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MemberContext")
            .field("name", &self.name)
            .field("position", &self.position)
            .finish_non_exhaustive()
    }
}

/// The clock-dependent parts of a member core's set-up: holdover period and grace, timing
/// slack.
pub fn apply_clock(core_cfg: &mut CoreConfig, config: &ClusterConfig) {
    if config.clock.is_stepped() {
        // The ring waits: a gap is a real break, and a member runs on its own clock only once
        // its upstream stopped answering (the frozen-member wait) or is known dead.
        core_cfg.period_ns = config.wall_period_ns().max(1);
        core_cfg.holdover_grace_ns = Some(config.member_timeout_ms.max(1) * 1_000_000);
        core_cfg.timing_slack = 1;
    } else {
        core_cfg.period_ns = config.period_ns().max(1) * 3 / 2;
        core_cfg.holdover_grace_ns = None;
        // ≈ 3.5 ms at the PMAC servo rate before silence counts as a broken link.
        core_cfg.timing_slack = REALTIME_TIMING_SLACK;
    }
}

/// Run member `args.name` until it is stopped. `make_app` builds the card or station logic and
/// returns extra status fields (ports, nodes, ...). The application's ticks run on the member's
/// own thread (see [`super::inline`]).
pub fn run_member<A, F>(args: MemberArgs, kind: MemberKind, make_app: F) -> anyhow::Result<()>
where
    A: RingApp,
    F: FnOnce(&MemberContext) -> anyhow::Result<(A, serde_json::Map<String, serde_json::Value>)>,
{
    run_member_with(args, kind, make_app, super::inline::run)
}

/// [`run_member`] for an application whose tick is computation only and never waits (a
/// station): in the paced and lockstep clocks its ticks run on zenoh's receive thread right
/// after the frame is forwarded, which saves a thread wake-up per ring cycle.
pub fn run_member_send<A, F>(args: MemberArgs, kind: MemberKind, make_app: F) -> anyhow::Result<()>
where
    A: RingApp + Send + 'static,
    F: FnOnce(&MemberContext) -> anyhow::Result<(A, serde_json::Map<String, serde_json::Value>)>,
{
    run_member_with(args, kind, make_app, super::inline::run_send)
}

fn run_member_with<A, F>(
    args: MemberArgs,
    kind: MemberKind,
    make_app: F,
    runner: fn(Driver<A>) -> (DriverExit, Driver<A>),
) -> anyhow::Result<()>
where
    A: RingApp,
    F: FnOnce(&MemberContext) -> anyhow::Result<(A, serde_json::Map<String, serde_json::Value>)>,
{
    let config = ClusterConfig::from_file(&args.config)
        .with_context(|| format!("loading {}", args.config.display()))?;
    let span = info_span!("member", cluster = %config.cluster, name = %args.name);
    let _enter = span.enter();
    // Set up as every ring of member cores is (crate::builder): settings, check, upstream.
    let mut core_cfg = crate::builder::core_config(&config, &args.name)?;
    let position = usize::from(core_cfg.position);
    let n = config.ring.order.len();

    let stop = Arc::new(AtomicBool::new(false));
    for sig in [
        signal_hook::consts::SIGTERM,
        signal_hook::consts::SIGINT,
        signal_hook::consts::SIGHUP,
    ] {
        signal_hook::flag::register(sig, Arc::clone(&stop)).context("installing signal handler")?;
    }
    // Die with the process that started us (the orchestrator), whatever happens to it.
    #[cfg(target_os = "linux")]
    let _ = nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGTERM);

    let mut connect = config.zenoh.connect.clone();
    connect.extend(args.connect.iter().cloned());
    let listen = if args.listen.is_empty() {
        config.zenoh.listen.clone()
    } else {
        args.listen.clone()
    };
    let opts = match cluster::host_options(&config, Role::Member { name: &args.name })? {
        Some(o) => o,
        None => {
            let mut o = SessionOptions {
                listen,
                connect,
                ..Default::default()
            };
            cluster::secure(&mut o, &config)?;
            o
        }
    };
    let session = open_session(&opts)?;
    // Never join a ring run with another config under this cluster's name.
    super::join::check(&session, &config)?;
    let (tx, rx, _rx_guard) =
        zenoh_link::join(&session, &config.cluster, &config.ring.name, position, n)?;

    let ctx = MemberContext {
        config: config.clone(),
        name: args.name.clone(),
        position,
        session: session.clone(),
        stop: Arc::clone(&stop),
    };
    let (app, extra) = make_app(&ctx)?;

    // A restarted member must not look stale to its downstream neighbour.
    core_cfg.seq_base = super::driver::monotonic_ns();
    // The links of a starting cluster come up in any order: check once locked.
    core_cfg.check_after_lock = true;
    apply_clock(&mut core_cfg, &config);
    let core = MemberCore::new(core_cfg);
    let (cmd_tx, cmd_rx) = unbounded();
    let _plane = control_plane::start(
        &session,
        &config.cluster,
        &args.name,
        control_plane::orchestrator_key(&config, &args.name).as_deref(),
        cmd_tx,
        Arc::clone(&stop),
    )
    .map_err(|e| anyhow!(e))?;
    info!(position, members = n, "joined ring {}", config.ring.name);
    // Loss of light when the upstream process dies (its liveliness token goes away).
    let upstream = config
        .upstream(&args.name)
        .unwrap_or(&args.name)
        .to_string();
    let watch = if upstream != args.name {
        let w =
            super::light::watch_upstream(&session, &config.cluster, &upstream, Arc::clone(&stop))
                .map_err(|e| anyhow!(e))?;
        Some(w)
    } else {
        None
    };
    // The sync master: members that come back (their new links lose frames until they are up).
    let rejoins = if config.ring.sync_master == args.name && config.clock.is_stepped() {
        Some(
            super::light::watch_rejoins(
                &session,
                &config.cluster,
                &args.name,
                &config.ring.order,
                Arc::clone(&stop),
            )
            .map_err(|e| anyhow!(e))?,
        )
    } else {
        None
    };

    let dcfg = DriverConfig {
        name: args.name.clone(),
        clock: config.clock,
        rate_hz: config.rate_hz,
        rtf: config.rtf,
        member_timeout: config.member_timeout(),
        upstream_dead: watch.as_ref().map(|w| Arc::clone(&w.dead)),
        rejoins: rejoins.as_ref().map(|w| Arc::clone(&w.rejoins)),
        members_present: rejoins.as_ref().map(|w| Arc::clone(&w.present)),
        links_matched: rejoins.as_ref().map(|w| Arc::clone(&w.matched_for)),
        in_flight: config.ring.in_flight,
        // The process probe only for an upstream on this member's host: a member the config
        // puts on another host is on another machine, even when it shares this kernel (network
        // namespaces, containers: the same boot id), and a cut network must be loss of light.
        upstream_probe: watch
            .as_ref()
            .filter(|_| config.member_host(&upstream) == config.member_host(&args.name))
            .map(|w| w.probe.clone()),
        harden: true,
        max_cycles: None,
        kind,
        position,
        extra,
        record: 0,
        // Cards act on the cycle (programs start, motors move): they tick phase-aligned.
        // Stations' plants integrate real elapsed time, so they tick on arrival.
        phase_delay_ns: match kind {
            MemberKind::Card => config.phase_delay_ns(),
            MemberKind::Station => 0,
        },
    };
    let driver = Driver::new(dcfg, core, app, Box::new(tx), rx, cmd_rx, Arc::clone(&stop));
    let (exit, _driver) = runner(driver);
    stop.store(true, Ordering::Relaxed);
    drop(_plane);
    drop(watch);
    drop(rejoins);
    let _ = zenoh::Wait::wait(session.close());
    match exit {
        DriverExit::Stopped | DriverExit::Done => Ok(()),
        DriverExit::Transport(e) => Err(anyhow!("ring transport failed: {e}")),
    }
}
