//! `mcc`: the cluster orchestrator (architecture §6): `up`, `status`, `fault`, `down`,
//! `bench ring`.

use std::process::ExitCode;

use clap::Parser;

mod cli;
mod cluster;
mod verbs;

use cli::{BenchCommand, Cli, Command};
use cluster::{chain, emcl, failure, launch};
use verbs::{bench, down, fault, gather, send, start_sync, status, term, up};

fn main() -> ExitCode {
    let cli = Cli::parse();
    // A member role run by `mcc` itself sets up its own logging.
    match &cli.command {
        Command::RunCard(a) => return mcc_card::run_process(a.argv(launch::CARD.binary)),
        Command::RunStation(a) => {
            return mcc_station::process::run_process(a.argv(launch::STATION.binary))
        }
        _ => {}
    }
    // zenoh's own transport chatter (links opened and closed while a CLI verb attaches) is
    // not for the user; MCC_LOG=debug shows it.
    mcc_ring::runtime::logging::init_logging_with("warn,zenoh=error,zenoh_transport=off");
    let cluster = cli.cluster_name();
    let res = match &cli.command {
        Command::Up(a) => {
            chain::server::export_up_options(a);
            emcl::server::export_up_options(a);
            up::cmd_up(cli.cluster.as_deref(), a)
        }
        Command::Send(a) => send::cmd_send(&cluster, a),
        Command::Term(a) => term::cmd_term(&cluster, a),
        Command::Bench(BenchCommand::Chain(a)) => bench::chain::run(a),
        Command::Status(a) => status::cmd_status(&cluster, a),
        Command::Fault(a) => fault::cmd_fault(&cluster, a),
        Command::Down(a) => down::cmd_down(&cluster, a),
        Command::StartSync(a) => start_sync::cmd_start_sync(&cluster, a),
        Command::Gather(a) => gather::cmd_gather(&cluster, a),
        Command::Bench(BenchCommand::Ring(a)) => bench::ring::run(a),
        Command::Bench(BenchCommand::Host(a)) => bench::host::run(a),
        Command::Bench(BenchCommand::Servo) => bench::host::run_servo(),
        Command::Bench(BenchCommand::Sync(a)) => bench::syncstart::run(a),
        Command::Bench(BenchCommand::Faults(a)) => bench::faults::run(a),
        Command::Bench(BenchCommand::Bringup(a)) => bench::bringup::run(a),
        Command::Bench(BenchCommand::UdpMember(a)) => bench::udp::member(a),
        Command::Bench(BenchCommand::ZenohMember(a)) => bench::floor::member(a),
        Command::Bench(BenchCommand::Soak(a)) => bench::soak::run(a),
        Command::Bench(BenchCommand::SaveCrash(a)) => bench::crash::run(a),
        Command::Supervise(a) => up::cmd_supervise(&cluster, a),
        Command::Emcl(a) => verbs::emcl::cmd_emcl(&cluster, a),
        Command::Bench(BenchCommand::Emcl(a)) => bench::emcl::run(a),
        // Run above, before logging.
        Command::RunCard(_) | Command::RunStation(_) => Ok(()),
    };
    if let Err(e) = res {
        if wants_json(&cli.command) {
            println!("{}", failure::error_json(&e));
        }
        eprintln!("mcc: error: {e:#}");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}

/// Verbs asked for JSON output print their errors as JSON too (`failure::error_json`).
fn wants_json(c: &Command) -> bool {
    match c {
        Command::Up(a) => a.json,
        Command::Status(a) => a.json,
        Command::Send(a) => a.json,
        Command::StartSync(a) => a.json,
        Command::Gather(a) => a.json,
        _ => false,
    }
}
