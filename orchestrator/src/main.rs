//! `mcc`: the cluster orchestrator (architecture §6): `up`, `status`, `fault`, `down`,
//! `bench ring`.

use clap::Parser;

mod bench;
mod cli;
mod client;
mod ctl;
mod down;
mod fault;
mod launch;
mod rundir;
mod status;
mod supervisor;
mod sys;
mod up;

use cli::{BenchCommand, Cli, Command};

fn main() {
    let cli = Cli::parse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .with_writer(std::io::stderr)
        .init();
    let cluster = cli.cluster_name();
    let res = match &cli.command {
        Command::Up(a) => up::cmd_up(cli.cluster.as_deref(), a),
        Command::Status(a) => client::cmd_status(&cluster, a),
        Command::Fault(a) => fault::cmd_fault(&cluster, a),
        Command::Down(a) => down::cmd_down(&cluster, a),
        Command::Bench(BenchCommand::Ring(a)) => bench::ring::run(a),
        Command::Bench(BenchCommand::Host(a)) => bench::host::run(a),
        Command::Supervise => up::cmd_supervise(&cluster),
    };
    if let Err(e) = res {
        eprintln!("mcc: error: {e:#}");
        std::process::exit(1);
    }
}
