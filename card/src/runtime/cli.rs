//! `mcc-card`: one PMAC-style controller card process ([`run_process`]: the `mcc-card`
//! binary, and `mcc run-card` where only `mcc` is installed).
//!
//! `mcc-card --standalone [--profile pmac2|turbo|power] [--ascii-port P] [--eth-port P]
//! [--state-file PATH] [--exit-on-stdin-eof] [--max-connections N] [--idle-timeout-s S]
//! [--request-timeout-ms MS]` runs the card with its host ports and no ring,
//! printing `{"ascii":PORT,"pmac_eth":PORT}` once listening. A Power card (`--profile power`)
//! has a `gpascii` and an SSH port instead (`--gpascii-port P --ssh-port P --ssh-user U
//! --ssh-password W`) and prints `{"gpascii":PORT,"ssh":PORT}`.

#![allow(clippy::disallowed_methods, clippy::disallowed_types)] // the process

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use mcc_contracts::hostport::HostLimits;

use crate::domain::Profile;
use crate::runtime::standalone::{run_standalone, PowerHostOpts, StandaloneOpts};

#[derive(Debug, Clone, Copy, ValueEnum)]
enum ProfileArg {
    /// PMAC2 (seed manual): 8 motors, 8 C.S., variables 0-1023.
    Pmac2,
    /// Turbo host compatibility: 32 motors, 16 C.S., variables 0-8191, CID.
    Turbo,
    /// Power PMAC script language (seed 000): motors 0-31, C.S. 0-15, P0-65535.
    Power,
}

#[derive(Debug, Parser)]
#[command(name = "mcc-card", about = "A PMAC-style motion controller card")]
struct Args {
    /// Run one card with its host ports only (no ring).
    #[arg(long)]
    standalone: bool,
    /// Card profile.
    #[arg(long, value_enum, default_value = "pmac2")]
    profile: ProfileArg,
    /// ASCII terminal port on 127.0.0.1 (0 = ephemeral).
    #[arg(long, default_value_t = 0)]
    ascii_port: u16,
    /// PMAC Ethernet protocol port on 127.0.0.1 (0 = ephemeral).
    #[arg(long, default_value_t = 0)]
    eth_port: u16,
    /// Power card: raw TCP gpascii port on 127.0.0.1 (0 = ephemeral).
    #[arg(long)]
    gpascii_port: Option<u16>,
    /// Power card: SSH port on 127.0.0.1 (0 = ephemeral).
    #[arg(long)]
    ssh_port: Option<u16>,
    /// Power card: SSH user [default: root].
    #[arg(long)]
    ssh_user: Option<String>,
    /// Power card: SSH password [default: deltatau].
    #[arg(long)]
    ssh_password: Option<String>,
    /// File SAVE writes and start-up loads (without it SAVE answers an error: ERR003, on a
    /// Power card `error #21`).
    #[arg(long)]
    state_file: Option<PathBuf>,
    /// Exit when stdin is closed.
    #[arg(long)]
    exit_on_stdin_eof: bool,
    /// Connections served at once per port (a new host beyond it evicts the longest idle one).
    #[arg(long, default_value_t = HostLimits::default().max_connections)]
    max_connections: usize,
    /// Close a connection idle this long (0 = never).
    #[arg(long, default_value_t = HostLimits::default().idle_timeout_s)]
    idle_timeout_s: u64,
    /// A request must be complete this long after its first byte (ASCII lines: 6 times it).
    #[arg(long, default_value_t = HostLimits::default().request_timeout_ms)]
    request_timeout_ms: u64,
    /// Ring mode: the resolved cluster config (TOML) handed over by the orchestrator.
    #[arg(long, conflicts_with = "standalone", requires = "name")]
    config: Option<PathBuf>,
    /// Ring mode: this card's member name in the config.
    #[arg(long)]
    name: Option<String>,
    /// Ring mode: zenoh endpoint to connect to (repeatable).
    #[arg(long)]
    connect: Vec<String>,
    /// Ring mode: zenoh endpoint to listen on (repeatable; default tcp/127.0.0.1:0).
    #[arg(long)]
    listen: Vec<String>,
}

/// The card process: `args` is its command line, program name first (see the module doc).
pub fn run_process<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    mcc_ring::runtime::logging::init_logging();
    let args = Args::parse_from(args);
    if let (Some(config), Some(name)) = (args.config.clone(), args.name.clone()) {
        let r = crate::runtime::run_ring_card(mcc_ring::runtime::process::MemberArgs {
            config,
            name,
            connect: args.connect,
            listen: args.listen,
        });
        return match r {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("mcc-card: {e:#}");
                ExitCode::FAILURE
            }
        };
    }
    if !args.standalone {
        eprintln!("mcc-card: give --standalone, or --config FILE --name MEMBER for ring mode");
        return ExitCode::from(2);
    }
    let limits = HostLimits {
        max_connections: args.max_connections,
        idle_timeout_s: args.idle_timeout_s,
        request_timeout_ms: args.request_timeout_ms,
        ..HostLimits::default()
    };
    if let Some((key, problem)) = limits.problem() {
        eprintln!(
            "mcc-card: --{}: {problem}",
            key.trim_start_matches("host.").replace('_', "-")
        );
        return ExitCode::from(2);
    }
    let power_host = match power_host_opts(&args) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("mcc-card: {e}");
            return ExitCode::from(2);
        }
    };
    let opts = StandaloneOpts {
        profile: match args.profile {
            ProfileArg::Pmac2 => Profile::Pmac2,
            ProfileArg::Turbo => Profile::Turbo,
            ProfileArg::Power => Profile::Power,
        },
        ascii_port: args.ascii_port,
        eth_port: args.eth_port,
        state_file: args.state_file,
        exit_on_stdin_eof: args.exit_on_stdin_eof,
        power_host,
        limits,
    };
    match run_standalone(opts) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mcc-card: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A Power card's host-port options (`None`: not a Power card, which must not be given them).
fn power_host_opts(args: &Args) -> Result<Option<PowerHostOpts>, String> {
    if !matches!(args.profile, ProfileArg::Power) {
        let given = [
            ("--gpascii-port", args.gpascii_port.is_some()),
            ("--ssh-port", args.ssh_port.is_some()),
            ("--ssh-user", args.ssh_user.is_some()),
            ("--ssh-password", args.ssh_password.is_some()),
        ];
        return match given.iter().find(|(_, g)| *g) {
            Some((flag, _)) => Err(format!(
                "{flag} is an option of a Power card (--profile power)"
            )),
            None => Ok(None),
        };
    }
    let mut o = PowerHostOpts {
        gpascii_port: args.gpascii_port.unwrap_or(0),
        ssh_port: args.ssh_port.unwrap_or(0),
        ..PowerHostOpts::default()
    };
    if let Some(u) = &args.ssh_user {
        if u.is_empty() || u.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(format!(
                "--ssh-user {u:?}: give a non-empty name without spaces"
            ));
        }
        o.ssh_user = u.clone();
    }
    if let Some(p) = &args.ssh_password {
        if p.chars().any(char::is_control) {
            return Err("--ssh-password: control characters are not allowed".into());
        }
        o.ssh_password = p.clone();
    }
    Ok(Some(o))
}
