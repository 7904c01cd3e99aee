//! Command-line interface of `mcc` (clap).

use std::ffi::OsString;
use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use mcc_contracts::config::ClockMode;

use crate::cluster::launch;

/// Default cluster name.
pub const DEFAULT_CLUSTER: &str = "mcc";

/// mcc: a cluster of software PMAC cards and MACRO stations on a zenoh ring.
#[derive(Debug, Parser)]
#[command(name = "mcc", version, about)]
pub struct Cli {
    /// Cluster name: key-expression namespace and run directory (default `mcc`).
    #[arg(long, global = true, value_name = "NAME")]
    pub cluster: Option<String>,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

impl Cli {
    /// The cluster name given, or the default.
    pub fn cluster_name(&self) -> String {
        self.cluster
            .clone()
            .unwrap_or_else(|| DEFAULT_CLUSTER.to_string())
    }
}

/// The verbs.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Start every member of a cluster and wait until the ring is locked.
    Up(UpArgs),
    /// Show the state of a running cluster.
    Status(StatusArgs),
    /// Inject a fault on a member's send path (`mcc fault MEMBER KIND`), or clear faults
    /// (`mcc fault clear [MEMBER]`).
    Fault(FaultArgs),
    /// Stop every member of a running cluster and remove its runtime files.
    Down(DownArgs),
    /// Run one command line on several cards in the servo tick of the same ring cycle.
    StartSync(StartSyncArgs),
    /// Send command lines on the daisy chain and print the replies (for scripts).
    Send(SendArgs),
    /// Interactive terminal on a running cluster's daisy chain.
    Term(TermArgs),
    /// Record motor positions with a card's data gathering; write gather.csv and gather.png.
    Gather(GatherArgs),
    /// Benchmarks.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// The EMCL bus: send a frame (`mcc emcl send 1 6 1 0 0`), set a drive's inputs.
    Emcl(EmclArgs),
    /// Internal: the detached supervisor started by `mcc up --detach`.
    #[command(hide = true)]
    Supervise(SuperviseArgs),
    /// Internal: a card member process (the `mcc-card` binary's command line), where `mcc`
    /// is installed alone (the Python wheel; `cluster::launch::member_program`).
    #[command(name = launch::CARD.subcommand, hide = true, disable_help_flag = true)]
    RunCard(RoleArgs),
    /// Internal: a station (or stand-alone drive) member process, as `mcc-station`.
    #[command(name = launch::STATION.subcommand, hide = true, disable_help_flag = true)]
    RunStation(RoleArgs),
}

/// `mcc run-card` / `mcc run-station` (hidden): the member's own arguments, passed on whole.
#[derive(Debug, Args)]
pub struct RoleArgs {
    /// The member binary's arguments.
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, num_args = 0..)]
    pub args: Vec<OsString>,
}

impl RoleArgs {
    /// The member's command line as its own binary would see it: `program` first.
    pub fn argv(&self, program: &str) -> Vec<OsString> {
        std::iter::once(OsString::from(program))
            .chain(self.args.iter().cloned())
            .collect()
    }
}

/// `mcc supervise` (hidden).
#[derive(Debug, Args)]
pub struct SuperviseArgs {
    /// Stop the cluster when this process exits (`mcc up --owner-pid`).
    #[arg(long, value_name = "PID")]
    pub owner_pid: Option<u32>,
    /// The host whose share this supervisor runs (`mcc up --host`).
    #[arg(long, value_name = "NAME")]
    pub host: Option<String>,
}

/// `mcc up`.
#[derive(Debug, Args)]
pub struct UpArgs {
    /// Number of cards in the embedded default cluster (default 2).
    #[arg(long, value_name = "N", conflicts_with = "config", value_parser = clap::value_parser!(u8).range(1..=16))]
    pub cards: Option<u8>,
    /// Number of stations in the embedded default cluster (default 2).
    #[arg(long, value_name = "M", conflicts_with = "config", value_parser = clap::value_parser!(u8).range(0..=48))]
    pub stations: Option<u8>,
    /// Clock mode: paced (default: lockstep paced by the wall clock), lockstep (as fast as
    /// the ring goes) or realtime (free-running) (overrides the config).
    #[arg(long, value_name = "MODE", value_parser = parse_clock)]
    pub clock: Option<ClockMode>,
    /// Ring rate in Hz (overrides the config).
    #[arg(long, value_name = "HZ")]
    pub rate: Option<f64>,
    /// Paced clock: real-time factor, ring time per wall time (default 1; overrides the config).
    #[arg(long, value_name = "X")]
    pub rtf: Option<f64>,
    /// Cycles in flight around the ring, 1-8 (`ring.in_flight`; overrides the config): the
    /// sync master starts cycle k once k-N came back; each card's servo feedback comes N-1
    /// cycles later.
    #[arg(long, value_name = "N")]
    pub in_flight: Option<u64>,
    /// Cluster config file (TOML).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Start only host NAME's share of a cluster on several hosts (`host = "NAME"` on its
    /// members); it joins the other hosts through the configured zenoh routers or peers.
    #[arg(long, value_name = "NAME")]
    pub host: Option<String>,
    /// Leave the cluster running in the background and return once the ring is locked.
    #[arg(long)]
    pub detach: bool,
    /// Seconds to wait for the ring to lock.
    #[arg(long, value_name = "S", default_value_t = 60)]
    pub timeout: u64,
    /// Also serve the daisy chain on a pseudo-terminal (its path is printed and in status).
    #[arg(long)]
    pub pty: bool,
    /// TCP port of the daisy chain on 127.0.0.1 (default: any free port).
    #[arg(long, value_name = "PORT")]
    pub chain_port: Option<u16>,
    /// TCP port of the EMCL bus on 127.0.0.1 (default: `[emcl] port`, else any free port).
    #[arg(long, value_name = "PORT")]
    pub emcl_port: Option<u16>,
    /// Terminal: show framing characters (`<ACK>`, `<CR>`, `<LF>`, `<BELL>`) in replies.
    #[arg(long)]
    pub show_framing: bool,
    /// With --detach: print the status document (`mcc status --json`) once the ring is locked,
    /// and on failure a JSON error (`{"error": {"kind", "message", "logs"}}`) on stdout.
    #[arg(long, requires = "detach")]
    pub json: bool,
    /// Stop the cluster when process PID exits (test harnesses: a killed test runner never
    /// leaves a cluster behind).
    #[arg(long, value_name = "PID")]
    pub owner_pid: Option<u32>,
    /// Print the resolved, checked config (TOML: the file or the embedded default with the
    /// options applied) and exit without starting anything.
    #[arg(long, conflicts_with_all = ["detach", "json"])]
    pub print_config: bool,
}

/// `mcc send`.
#[derive(Debug, Args)]
pub struct SendArgs {
    /// Address card N (`@N`) before the first line.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(0..=15))]
    pub card: Option<u8>,
    /// Show framing characters (`<ACK>`, `<CR>`, `<LF>`, `<BELL>`) in replies.
    #[arg(long)]
    pub show_framing: bool,
    /// Milliseconds a card has to answer.
    #[arg(long, value_name = "MS", default_value_t = 2000)]
    pub timeout_ms: u64,
    /// Print one JSON array of `{"line", "reply", "error"}` (one per LINE) instead of text.
    #[arg(long)]
    pub json: bool,
    /// Command lines (`^K` = control character).
    #[arg(required = true, value_name = "LINE")]
    pub lines: Vec<String>,
}

/// `mcc term`.
#[derive(Debug, Args)]
pub struct TermArgs {
    /// Show framing characters (`<ACK>`, `<CR>`, `<LF>`, `<BELL>`) in replies.
    #[arg(long)]
    pub show_framing: bool,
    /// Milliseconds a card has to answer.
    #[arg(long, value_name = "MS", default_value_t = 2000)]
    pub timeout_ms: u64,
}

/// `mcc bench chain`.
#[derive(Debug, Args)]
pub struct BenchChainArgs {
    /// Cards in the benchmark cluster.
    #[arg(long, value_name = "N", default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=16))]
    pub cards: u8,
    /// Round trips to measure.
    #[arg(long, value_name = "K", default_value_t = 1000)]
    pub count: u32,
    /// Clock mode of the benchmark cluster.
    #[arg(long, value_name = "MODE", value_parser = parse_clock)]
    pub clock: Option<ClockMode>,
}

/// `mcc status`.
#[derive(Debug, Args)]
pub struct StatusArgs {
    /// Print the JSON status document instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Keep printing a status document (one compact JSON line) every MS milliseconds until
    /// the cluster stops or the reader goes away.
    #[arg(long, value_name = "MS", requires = "json", value_parser = clap::value_parser!(u64).range(10..=60_000))]
    pub watch: Option<u64>,
}

/// `mcc fault`.
#[derive(Debug, Args)]
pub struct FaultArgs {
    /// `MEMBER KIND` or `clear [MEMBER]`. Ring kinds: drop-sync, drop-packets, corrupt,
    /// byte-violation, overrun, underrun, delay, delay-us, cut; process drills: freeze
    /// (SIGSTOP), thaw (SIGCONT), kill (SIGKILL), restart (same config, rejoins the ring).
    /// Application faults: `STATION axis NODE KIND`, `STATION power-loss`,
    /// `CARD|chain|bus link KIND`, `CARD input KIND`.
    /// Axis kinds (`--cycles N`, else until cleared): amp-fault, encoder-loss,
    /// encoder-glitch (--value counts), load (--value N·m), jam, plus-limit-on,
    /// plus-limit-off, plus-limit-chatter, minus-limit-on, minus-limit-off,
    /// minus-limit-chatter, home-on, home-off, home-chatter; `STATION power-loss` faults every
    /// amplifier of the station. Input kinds: abort, feed-hold — the JPAN STOP/ and HOLD/
    /// inputs of a PMAC2/Turbo card, the global abort input of a Power card; held until
    /// cleared or for --cycles N.
    /// Host-link kinds (`CARD|chain|bus link KIND`, on replies only, never on what is stored):
    /// no-reply, late (--delay MS), short, stray-cr, stray-lf, stray-bel, stray-ctrl,
    /// corrupt, reset, bad-checksum (EMCL bus only); --probability is drawn per reply,
    /// --cycles N = the next N replies.
    #[arg(num_args = 1..=4, required = true, value_name = "MEMBER KIND | clear [MEMBER]")]
    pub words: Vec<String>,
    /// Apply for this many ring cycles (default: until cleared).
    #[arg(long, value_name = "N")]
    pub cycles: Option<u64>,
    /// Probability per cycle/packet, 0–1 (default 1).
    #[arg(long, value_name = "P")]
    pub probability: Option<f64>,
    /// Random seed for the probability.
    #[arg(long, value_name = "S")]
    pub seed: Option<u64>,
    /// Delay amount: cycles for `delay`, microseconds for `delay-us`, milliseconds for a
    /// `late` link fault.
    #[arg(long, value_name = "N")]
    pub delay: Option<u64>,
    /// Amount of an application fault (counts of an encoder glitch, a load, ...).
    #[arg(long, value_name = "V", allow_negative_numbers = true)]
    pub value: Option<f64>,
    /// `CARD input KIND` on a PMAC2/Turbo card: the C.S. the FPD select lines choose
    /// (0 = none; default 1).
    #[arg(long, value_name = "N")]
    pub cs: Option<u16>,
}

/// `mcc start-sync`.
#[derive(Debug, Args)]
pub struct StartSyncArgs {
    /// Card numbers (I0), comma-separated.
    #[arg(long, value_name = "N,N,...", required = true)]
    pub cards: String,
    /// Smallest lead, ms of ring time (doubled on every retry).
    #[arg(long, value_name = "MS", default_value_t = 10.0)]
    pub lead_ms: f64,
    /// Attempts before giving up.
    #[arg(long, value_name = "N", default_value_t = 6, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub attempts: u32,
    /// Print the outcome as JSON (an array with `--repeat`).
    #[arg(long)]
    pub json: bool,
    /// Run the start this many times, one after the other (tests, benchmarks).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub repeat: Option<u32>,
    /// The command line, e.g. "&1B1R".
    #[arg(required = true, value_name = "LINE")]
    pub line: Vec<String>,
}

/// `mcc gather`.
#[derive(Debug, Args)]
pub struct GatherArgs {
    /// Card number(s) (I0), comma-separated: gathering starts on every one in the same ring
    /// cycle.
    #[arg(long, value_name = "N[,N...]")]
    pub card: String,
    /// Motors (1-8), comma-separated: commanded and actual position of each.
    #[arg(long, value_name = "M,M,...", default_value = "1")]
    pub motors: String,
    /// Servo cycles to record.
    #[arg(long, value_name = "K", default_value_t = 1000)]
    pub cycles: u64,
    /// Servo cycles between samples (I19).
    #[arg(long, value_name = "P", default_value_t = 1)]
    pub period: u32,
    /// Command line run on each card in the ring cycle gathering starts (e.g. "#1J=2000").
    #[arg(long, value_name = "LINE")]
    pub run: Option<String>,
    /// Directory for gather.csv and gather.png (several cards: `gather-card<N>.csv/.png`);
    /// default `.`, or no files with --json.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Print the samples as JSON (ring cycle of every sample, positions per card and motor).
    #[arg(long)]
    pub json: bool,
}

/// `mcc emcl`.
#[derive(Debug, Args)]
pub struct EmclArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: EmclCommand,
}

/// `mcc emcl` verbs.
#[derive(Debug, Subcommand)]
pub enum EmclCommand {
    /// Send one frame on the bus and print the reply: `ADDR OP TYPE MOTOR VALUE` (numbers,
    /// 0x hex allowed; the checksum is added) or nine hex bytes sent as they are.
    Send {
        /// Milliseconds to wait for the reply.
        #[arg(long, value_name = "MS", default_value_t = 2000)]
        timeout_ms: u64,
        /// The frame.
        #[arg(required = true, num_args = 5..=9, allow_negative_numbers = true, value_name = "WORD")]
        words: Vec<String>,
    },
    /// Set input lines of a drive: in0..in2, analog, enable_in, reset_in; inject driver
    /// faults: overtemp, short (e.g. `mcc emcl input drive0 in1=1 analog=2048`).
    Input {
        /// Drive name.
        drive: String,
        /// NAME=VALUE settings.
        #[arg(required = true, value_name = "NAME=VALUE")]
        settings: Vec<String>,
    },
}

/// `mcc bench emcl`.
#[derive(Debug, Args)]
pub struct BenchEmclArgs {
    /// Round trips to time on one connection.
    #[arg(long, value_name = "K", default_value_t = 2000, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub count: u32,
    /// Host connections sharing the bus in the throughput run.
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub connections: u32,
    /// Clock mode of the benchmark cluster (default lockstep).
    #[arg(long, value_name = "MODE", value_parser = parse_clock)]
    pub clock: Option<ClockMode>,
}

/// `mcc down`.
#[derive(Debug, Args)]
pub struct DownArgs {
    /// Seconds to wait for an orderly stop before killing.
    #[arg(long, value_name = "S", default_value_t = 10)]
    pub timeout: u64,
}

/// `mcc bench ...`.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Daisy-chain command round trip (p50/p99) on a cluster of its own.
    Chain(BenchChainArgs),
    /// Ring throughput, hop latency and CPU of multi-process clusters against a raw UDP ring;
    /// realtime lateness against the OS timer.
    Ring(BenchRingArgs),
    /// Card host interface: in-process command rate, ASCII and Ethernet port round trips.
    Host(BenchHostArgs),
    /// Card servo tick cost per motor and the share of a core used by 8 motors.
    Servo,
    /// Synchronized-start wall-clock skew p50/p99 on a realtime cluster of its own.
    Sync(BenchSyncArgs),
    /// Ring-fault detection latency in cycles (and ms) per fault kind on a cluster of its own.
    Faults(BenchFaultsArgs),
    /// Cluster bring-up time (`mcc up --detach` until locked).
    Bringup(BenchBringupArgs),
    /// EMCL bus round trip p50/p99 and frames per second (TCP and in-process drive).
    Emcl(BenchEmclArgs),
    /// A cluster of its own for N minutes beside an OS timer probe (optionally under CPU
    /// load): ring faults, achieved real-time factor, late cycles, lag, longest stall.
    Soak(BenchSoakArgs),
    /// Card SAVE under SIGKILL at random moments: old or new state, never corrupt or mixed,
    /// no leaked file.
    SaveCrash(BenchSaveCrashArgs),
    /// One process of `bench ring`'s raw UDP ring (internal).
    #[command(hide = true)]
    UdpMember(BenchUdpMemberArgs),
    /// One process of `bench ring`'s zenoh floor (internal).
    #[command(hide = true)]
    ZenohMember(BenchZenohMemberArgs),
}

/// `mcc bench save-crash`.
#[derive(Debug, Args)]
pub struct BenchSaveCrashArgs {
    /// Trials (one SIGKILL each).
    #[arg(long, value_name = "N", default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub trials: u32,
    /// Seed of the kill moments.
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub seed: u64,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `mcc bench soak`.
#[derive(Debug, Args)]
pub struct BenchSoakArgs {
    /// Duration, minutes.
    #[arg(long, value_name = "N", default_value_t = 10.0)]
    pub minutes: f64,
    /// Duration in seconds (overrides --minutes; short runs in tests).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// Clock mode: paced (default), lockstep or realtime.
    #[arg(long, value_name = "MODE", value_parser = parse_clock)]
    pub clock: Option<ClockMode>,
    /// Paced clock: real-time factor.
    #[arg(long, value_name = "X")]
    pub rtf: Option<f64>,
    /// Cards (embedded default cluster; default 2).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=16))]
    pub cards: Option<u8>,
    /// Stations (embedded default cluster; default 2).
    #[arg(long, value_name = "M", value_parser = clap::value_parser!(u8).range(0..=48))]
    pub stations: Option<u8>,
    /// Cluster config file instead of the embedded default (e.g. to try ring-check settings;
    /// `--clock` and `--rtf` still override it).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["cards", "stations"])]
    pub config: Option<std::path::PathBuf>,
    /// CPU-bound threads to run beside the cluster (load), e.g. 4 on a 2-core machine.
    #[arg(long, value_name = "K", default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub load: u32,
}

/// `mcc bench sync`.
#[derive(Debug, Args)]
pub struct BenchSyncArgs {
    /// Cards (each with one station).
    #[arg(long, value_name = "N", default_value_t = 2, value_parser = clap::value_parser!(u8).range(2..=16))]
    pub cards: u8,
    /// Synchronized starts to measure.
    #[arg(long, value_name = "K", default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub count: u32,
    /// Realtime ring rate, Hz (modest: the machine is shared).
    #[arg(long, value_name = "HZ", default_value_t = 1000.0)]
    pub rate: f64,
}

/// `mcc bench faults`.
#[derive(Debug, Args)]
pub struct BenchFaultsArgs {
    /// Clock mode of the benchmark cluster: paced (default), lockstep or realtime (the
    /// campaign refuses realtime: there a scheduling delay is a ring error by design).
    #[arg(long, value_name = "MODE", value_parser = parse_clock)]
    pub clock: Option<ClockMode>,
    /// Only these drills (comma-separated labels or fault words, e.g. `cut,freeze`).
    #[arg(long, value_name = "LIST")]
    pub only: Option<String>,
    /// Seconds to wait for detection per drill.
    #[arg(long, value_name = "S", default_value_t = 15)]
    pub timeout: u64,
    /// Instead of the drills: a campaign of N random faults of every kind at random members
    /// and times while programs run on every card, each held to the ring-check rules.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub campaign: Option<u64>,
    /// Campaign: seed of the plan (same seed, same faults).
    #[arg(long, value_name = "S", default_value_t = 1)]
    pub seed: u64,
    /// Campaign: only these kinds (comma-separated: drop-sync, drop-packets, corrupt,
    /// byte-violation, overrun, underrun, delay, delay-us, cut, freeze, kill, restart, input
    /// (a card's abort input), axis (an amplifier fault at a station), link (a host-link
    /// fault on a card's port)).
    #[arg(long, value_name = "LIST")]
    pub kinds: Option<String>,
    /// Campaign: cards (each followed by its stations in the ring).
    #[arg(long, value_name = "N", default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=8))]
    pub cards: u8,
    /// Card profiles, comma-separated, given to the cards in turn (`pmac2,turbo,power`
    /// with `--cards 3`: a ring mixing all three; default every card pmac2).
    #[arg(long, value_name = "LIST")]
    pub profiles: Option<String>,
    /// Campaign: stations.
    #[arg(long, value_name = "M", default_value_t = 2, value_parser = clap::value_parser!(u8).range(0..=16))]
    pub stations: u8,
    /// Campaign: start no new fault after this many minutes (the report covers the faults
    /// run and says how many were planned).
    #[arg(long, value_name = "M", value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub minutes: Option<u64>,
    /// Campaign: print the report as JSON on stdout (progress goes to stderr).
    #[arg(long)]
    pub json: bool,
}

/// `mcc bench bringup`.
#[derive(Debug, Args)]
pub struct BenchBringupArgs {
    /// Cards.
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u8).range(1..=16))]
    pub cards: u8,
    /// Stations.
    #[arg(long, value_name = "M", default_value_t = 8, value_parser = clap::value_parser!(u8).range(0..=48))]
    pub stations: u8,
    /// Bring-ups to time.
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// Clock mode of the clusters (default: realtime).
    #[arg(long, value_name = "MODE", value_parser = parse_clock, default_value = "realtime")]
    pub clock: ClockMode,
    /// Ring rate, Hz (default 500: a rate this shared 2-core machine sustains in realtime).
    #[arg(long, value_name = "HZ", default_value_t = 500.0)]
    pub rate: f64,
}

/// `mcc bench host`.
#[derive(Debug, Args)]
pub struct BenchHostArgs {
    /// In-process command lines to execute.
    #[arg(long, value_name = "N", default_value_t = 1_000_000)]
    pub commands: usize,
    /// Round trips per host port.
    #[arg(long, value_name = "N", default_value_t = 5_000)]
    pub round_trips: usize,
}

/// `mcc bench ring`.
#[derive(Debug, Args)]
pub struct BenchRingArgs {
    /// Clusters to measure, as CARDS+STATIONS (lockstep and real-time factor 1).
    #[arg(long, value_name = "LIST", default_value = "1+1,2+2,4+8")]
    pub sizes: String,
    /// Lockstep: seconds measured per cluster (and per UDP ring).
    #[arg(long, value_name = "S", default_value_t = 5.0)]
    pub seconds: f64,
    /// Real-time factor 1: seconds measured per cluster.
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    pub rtf_seconds: f64,
    /// Lockstep: `ring.in_flight` settings measured for each size (1-8, comma-separated; the
    /// UDP ring is run beside the first).
    #[arg(long, value_name = "LIST", default_value = "1,4")]
    pub in_flight: String,
    /// Real-time factor 1: `ring.in_flight` settings measured for each size (1-8,
    /// comma-separated).
    #[arg(long, value_name = "LIST", default_value = "1,2")]
    pub rtf_in_flight: String,
    /// Only these sections (comma-separated): floor, lockstep, rtf1, realtime, hosts, netns.
    #[arg(long, value_name = "LIST")]
    pub only: Option<String>,
    /// Hosts and netns sections: the zenoh router to start (default `$MCC_ZENOHD`, else
    /// `zenohd` on the PATH, else `target/zenohd-*/bin/zenohd` of the target directory this
    /// `mcc` is in; without one the router rows are skipped, saying so).
    #[arg(long, value_name = "PATH")]
    pub zenohd: Option<std::path::PathBuf>,
    /// Realtime section: ring members in one process (default 12: 4 cards + 8 stations).
    #[arg(long, value_name = "N", default_value_t = 12, value_parser = clap::value_parser!(u32).range(2..=64))]
    pub members: u32,
    /// Realtime section: measurement duration, seconds.
    #[arg(long, value_name = "S", default_value_t = 5.0)]
    pub duration: f64,
    /// Realtime section: rate, Hz.
    #[arg(long, value_name = "HZ", default_value_t = mcc_contracts::config::DEFAULT_RATE_HZ)]
    pub rate: f64,
}

/// `mcc bench zenoh-member` (internal: one process of `bench ring`'s zenoh floor).
#[derive(Debug, Args)]
pub struct BenchZenohMemberArgs {
    /// 0 pings, 1 answers.
    #[arg(long, value_name = "K")]
    pub index: u32,
    /// Directory of the two processes' unix sockets.
    #[arg(long, value_name = "DIR")]
    pub dir: std::path::PathBuf,
    /// Process 0: the answering process's pid (its CPU is counted too).
    #[arg(long, value_name = "PID")]
    pub peer_pid: Option<u32>,
    /// Process 0: back-to-back round trips measured.
    #[arg(long, value_name = "N", default_value_t = 20_000)]
    pub msgs: u64,
    /// Process 0: the pace of the paced run, Hz.
    #[arg(long, value_name = "HZ", default_value_t = mcc_contracts::config::DEFAULT_RATE_HZ)]
    pub rate: f64,
    /// Process 0: ms of the paced run.
    #[arg(long, value_name = "MS", default_value_t = 5000)]
    pub window_ms: u64,
}

/// `mcc bench udp-member` (internal: one process of `bench ring`'s raw UDP ring).
#[derive(Debug, Args)]
pub struct BenchUdpMemberArgs {
    /// Position in the ring (0 starts the cycles).
    #[arg(long, value_name = "K")]
    pub index: u32,
    /// Position 0: ms before the measurement window.
    #[arg(long, value_name = "MS", default_value_t = 1000)]
    pub warmup_ms: u64,
    /// Position 0: ms measured.
    #[arg(long, value_name = "MS", default_value_t = 5000)]
    pub window_ms: u64,
}

fn parse_clock(s: &str) -> Result<ClockMode, String> {
    s.parse()
        .map_err(|e: mcc_contracts::config::UnknownClockMode| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn up_parses_options() {
        let cli = Cli::try_parse_from([
            "mcc",
            "up",
            "--cluster",
            "t1",
            "--cards",
            "3",
            "--stations",
            "5",
            "--clock",
            "lockstep",
            "--rate",
            "1000",
            "--detach",
        ])
        .unwrap();
        assert_eq!(cli.cluster_name(), "t1");
        let Command::Up(up) = cli.command else {
            panic!()
        };
        assert_eq!((up.cards, up.stations), (Some(3), Some(5)));
        assert_eq!(up.clock, Some(ClockMode::Lockstep));
        assert_eq!(up.rate, Some(1000.0));
        assert!(up.detach);
    }

    #[test]
    fn harness_options_parse_and_combine_only_where_they_mean_something() {
        let cli =
            Cli::try_parse_from(["mcc", "up", "--detach", "--json", "--owner-pid", "42"]).unwrap();
        let Command::Up(up) = cli.command else {
            panic!()
        };
        assert!(up.json && up.detach);
        assert_eq!(up.owner_pid, Some(42));
        // --json needs --detach (the foreground `up` is a terminal); --print-config starts
        // nothing, so it takes neither.
        assert!(Cli::try_parse_from(["mcc", "up", "--json"]).is_err());
        assert!(Cli::try_parse_from(["mcc", "up", "--print-config", "--detach"]).is_err());
        assert!(Cli::try_parse_from(["mcc", "up", "--print-config", "--cards", "3"]).is_ok());
        let st = Cli::try_parse_from(["mcc", "status", "--json", "--watch", "50"]).unwrap();
        let Command::Status(st) = st.command else {
            panic!()
        };
        assert_eq!(st.watch, Some(50));
        assert!(Cli::try_parse_from(["mcc", "status", "--watch", "50"]).is_err());
        assert!(Cli::try_parse_from(["mcc", "status", "--json", "--watch", "5"]).is_err());
        let g = Cli::try_parse_from(["mcc", "gather", "--card", "0,1", "--json"]).unwrap();
        let Command::Gather(g) = g.command else {
            panic!()
        };
        assert_eq!((g.card.as_str(), g.json, g.out), ("0,1", true, None));
    }

    #[test]
    fn bad_arguments_are_rejected_with_a_message() {
        let e = Cli::try_parse_from(["mcc", "up", "--clock", "sometimes"]).unwrap_err();
        assert!(e.to_string().contains("sometimes"), "{e}");
        let e = Cli::try_parse_from(["mcc", "up", "--cards", "0"]).unwrap_err();
        assert!(e.to_string().contains("--cards"), "{e}");
        let e = Cli::try_parse_from(["mcc", "up", "--config", "x.toml", "--cards", "2"]);
        assert!(e.is_err());
        assert!(Cli::try_parse_from(["mcc", "fault"]).is_err());
        let ok = Cli::try_parse_from(["mcc", "fault", "clear"]).unwrap();
        assert_eq!(ok.cluster_name(), DEFAULT_CLUSTER);
    }
}

#[cfg(test)]
mod role_tests {
    use super::*;

    #[test]
    fn a_member_role_gets_its_whole_command_line() {
        let cli = Cli::try_parse_from([
            "mcc",
            "run-card",
            "--config",
            "/r/config.toml",
            "--name",
            "card0",
            "--help",
        ])
        .unwrap();
        let Command::RunCard(a) = cli.command else {
            panic!("not run-card: {:?}", cli.command);
        };
        let argv: Vec<String> = a
            .argv("mcc-card")
            .into_iter()
            .map(|s| s.into_string().unwrap())
            .collect();
        assert_eq!(
            argv,
            [
                "mcc-card",
                "--config",
                "/r/config.toml",
                "--name",
                "card0",
                "--help"
            ]
        );
    }

    #[test]
    fn the_member_roles_are_hidden_from_help() {
        use clap::CommandFactory;
        let help = Cli::command().render_help().to_string();
        assert!(help.contains("status"), "{help}");
        assert!(
            !help.contains("run-card") && !help.contains("run-station"),
            "{help}"
        );
    }
}
