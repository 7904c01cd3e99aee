//! Logging set-up shared by the cluster's processes: `tracing` to stderr (the supervisor
//! redirects member stderr into `logs/<member>.log`), filtered by `MCC_LOG`.

/// Environment variable holding the log filter (`tracing_subscriber::EnvFilter` syntax).
pub const LOG_ENV: &str = "MCC_LOG";

/// Default filter of a member process (card or station). zenoh's unix-socket link warns about
/// every link it opens (a client socket has no path of its own): that one is silenced.
pub const MEMBER_DEFAULT_FILTER: &str = "info,zenoh=warn,zenoh_link_unixsock_stream=error";

/// Log to stderr with the filter from `MCC_LOG`, else `default_filter`; ANSI colours only
/// when stderr is a terminal. Does nothing if a global subscriber is already installed.
pub fn init_logging_with(default_filter: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_env(LOG_ENV)
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_filter));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
}

/// Logging of a member process (`mcc-card`, `mcc-station`): [`MEMBER_DEFAULT_FILTER`].
pub fn init_logging() {
    init_logging_with(MEMBER_DEFAULT_FILTER);
}
