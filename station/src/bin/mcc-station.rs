//! `mcc-station`: one MACRO station process on a ring.

use std::path::PathBuf;

use clap::Parser;
use mcc_ring::config::MemberRef;
use mcc_ring::control::MemberKind;
use mcc_ring::runtime::process::{run_member, MemberArgs};
use mcc_station::config::PlantConfig;
use mcc_station::mi::Globals;
use mcc_station::station_app::StationApp;

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

fn main() -> std::process::ExitCode {
    mcc_ring::runtime::logging::init_logging();
    let cli = Cli::parse();
    let cli_config = cli.config.clone();
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
        // The run directory holds the resolved config; station state lives beside it in
        // state/, which `mcc down` leaves alone.
        let state_file = st.state_file.clone().unwrap_or_else(|| {
            let run_dir = cli_config
                .parent()
                .map(std::path::Path::to_path_buf)
                .unwrap_or_default();
            run_dir.join("state").join(format!("{}.state", st.name))
        });
        let globals = Globals::from_check(st.check.period, st.check.min_syncs, st.check.max_errors);
        let app = StationApp::new(&st.nodes, &[], &plant)
            .map_err(anyhow::Error::msg)?
            .with_setup(globals, Some(state_file));
        if let Some(e) = app.mi().config_error() {
            tracing::error!("{e}: the station runs on its config values (MI4 bit 2)");
        }
        let mut extra = serde_json::Map::new();
        extra.insert("nodes".into(), serde_json::json!(st.nodes));
        Ok((app, extra))
    });
    match r {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mcc-station: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
