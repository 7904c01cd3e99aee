//! `mcc bench host`: the card's host interface (in-process command rate, ASCII and PMAC
//! Ethernet port round trips on loopback, `P0..1023` replies per second), measured by
//! `mcc_card::host::bench`.

use anyhow::Result;
use mcc_card::{run_host_bench, HostBenchOpts};

use crate::cli::BenchHostArgs;

/// Run the host benchmark and print its report.
pub fn run(args: &BenchHostArgs) -> Result<()> {
    let opts = HostBenchOpts {
        inproc_commands: args.commands.max(1),
        round_trips: args.round_trips.max(10),
        ..HostBenchOpts::default()
    };
    println!("mcc bench host: 1 card (pmac2), {} CPUs", num_cpus());
    let report = run_host_bench(&opts)?;
    println!("{report}");
    Ok(())
}

/// Run the card's servo-tick benchmarks (the tick alone; the tick while hosts hammer SAVE and
/// the heaviest legal lines) and print their reports.
pub fn run_servo() -> Result<()> {
    println!(
        "mcc bench servo: 1 card, 8 motors on a loopback plant, {} CPUs",
        num_cpus()
    );
    println!("{}", mcc_card::run_servo_bench());
    println!("{}", mcc_card::run_servo_load_bench()?);
    Ok(())
}

fn num_cpus() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
