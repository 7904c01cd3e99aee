//! `mcc-station`: one MACRO station process on a ring.

use std::path::PathBuf;

use clap::Parser;
use mcc_ring::config::MemberRef;
use mcc_ring::control::MemberKind;
use mcc_ring::runtime::process::{run_member, MemberArgs};
use mcc_station::config::PlantConfig;
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
        let app = StationApp::new(&st.nodes, &[], &plant).map_err(anyhow::Error::msg)?;
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
