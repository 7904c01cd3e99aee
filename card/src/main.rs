//! `mcc-card`: one PMAC-style controller card process (its options: `mcc_card::run_process`).

fn main() -> std::process::ExitCode {
    mcc_card::run_process(std::env::args_os())
}
