//! `mcc-station`: one MACRO station process on a ring (its options: `mcc_station::process`).

fn main() -> std::process::ExitCode {
    mcc_station::process::run_process(std::env::args_os())
}
