//! `mcc-station`: one MACRO station process on a ring ([`run_process`]: the `mcc-station`
//! binary, and `mcc run-station` where only `mcc` is installed).

use std::ffi::OsString;
use std::path::PathBuf;

use clap::Parser;
use mcc_contracts::config::MemberRef;
use mcc_ring::control::MemberKind;
use mcc_ring::runtime::process::{run_member, MemberArgs};

use crate::config::PlantConfig;
use crate::mi::Globals;
use crate::station_app::StationApp;

/// A MACRO station joining a ring from the cluster config the orchestrator hands it.
#[derive(Debug, Parser)]
#[command(name = "mcc-station", version)]
struct Cli {
    /// Resolved cluster config (TOML).
    #[arg(long)]
    config: PathBuf,
    /// This station's name in the config.
    #[arg(long)]
    name: String,
    /// zenoh endpoint to connect to (repeatable).
    #[arg(long)]
    connect: Vec<String>,
    /// zenoh endpoint to listen on (repeatable; default tcp/127.0.0.1:0).
    #[arg(long)]
    listen: Vec<String>,
}

/// The station process: `args` is its command line, program name first (see the module doc).
pub fn run_process<I, T>(args: I) -> std::process::ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    mcc_ring::runtime::logging::init_logging();
    let cli = Cli::parse_from(args);
    // A `[[drives]]` entry without a station runs as a process of its own (not on the ring).
    if let Some(r) =
        crate::emcl_rt::standalone::maybe_run(&cli.config, &cli.name, &cli.connect, &cli.listen)
    {
        return exit_code(r);
    }
    let run_dir = cli.config.parent().map(PathBuf::from).unwrap_or_default();
    let args = MemberArgs {
        config: cli.config,
        name: cli.name,
        connect: cli.connect,
        listen: cli.listen,
    };
    let r = run_member(args, MemberKind::Station, |ctx| {
        let st = match ctx.config.member(&ctx.name) {
            Some(MemberRef::Station(s)) => s.clone(),
            _ => anyhow::bail!("'{}' is not a station in the config", ctx.name),
        };
        let plant = PlantConfig::from_table(&st.plant)
            .map_err(|e| anyhow::anyhow!("stations.{}: {e}", st.name))?;
        // Nodes bound to EMCL drives are served by the drives, not by a plant.
        let bound = crate::emcl_rt::app::bound_nodes(&ctx.config, &st.name);
        let servo: Vec<u8> = st
            .nodes
            .iter()
            .copied()
            .filter(|n| !bound.contains(n))
            .collect();
        // The run directory holds the resolved config; station state lives beside it in
        // state/, which `mcc down` leaves alone.
        let state_file = st
            .state_file
            .clone()
            .unwrap_or_else(|| run_dir.join("state").join(format!("{}.state", st.name)));
        let globals = Globals::from_check(st.check.period, st.check.min_syncs, st.check.max_errors);
        let app = StationApp::new(&servo, &[], &plant)
            .map_err(anyhow::Error::msg)?
            .with_setup(globals, Some(state_file));
        if let Some(e) = app.mi().config_error() {
            tracing::error!("{e}: the station runs on its config values (MI4 bit 2)");
        }
        let mut extra = serde_json::Map::new();
        extra.insert("nodes".into(), serde_json::json!(st.nodes));
        let app = crate::emcl_rt::app::with_drives(ctx, app, &mut extra, &run_dir)?;
        Ok((app, extra))
    });
    exit_code(r)
}

fn exit_code(r: anyhow::Result<()>) -> std::process::ExitCode {
    match r {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mcc-station: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
