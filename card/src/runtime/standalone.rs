//! `mcc-card --standalone`: one card with its host ports and no ring. Prints
//! `{"ascii":PORT,"pmac_eth":PORT}` (a Power card: `{"gpascii":PORT,"ssh":PORT}`) on stdout
//! once listening; runs until SIGTERM, Ctrl-C, or (with `exit_on_stdin_eof`) until stdin
//! closes.

use std::io::{self, Read, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::core::CardCore;
use crate::domain::Profile;
use crate::host::power_ports::{serve_power, PowerPortsConfig};
use crate::host::server::{serve, PortsConfig};
use crate::host::ssh::server::Credentials;
use crate::runtime::startup_card;
use crate::service::handle::channel;
use crate::service::storage::FileStorage;

/// Options of the standalone mode.
#[derive(Debug, Clone, Default)]
pub struct StandaloneOpts {
    /// Card profile.
    pub profile: Profile,
    /// ASCII port (0 = ephemeral).
    pub ascii_port: u16,
    /// Ethernet protocol port (0 = ephemeral).
    pub eth_port: u16,
    /// Where `SAVE` writes and start-up loads from (none: the card starts from factory
    /// defaults and SAVE answers an error, ERR003 or Power's `error #21`: it has nowhere to
    /// keep the state, and acknowledging it would lose it).
    pub state_file: Option<PathBuf>,
    /// Exit when stdin reaches end of file (for supervisors and tests).
    pub exit_on_stdin_eof: bool,
    /// Host-port limits.
    pub limits: mcc_contracts::hostport::HostLimits,
    /// The card's host ports are a Power PMAC's (`gpascii` and SSH) instead of the ASCII and
    /// Ethernet-protocol ports.
    pub power_host: Option<PowerHostOpts>,
}

/// A Power card's host ports.
#[derive(Debug, Clone)]
pub struct PowerHostOpts {
    /// Raw TCP `gpascii` port (0 = ephemeral).
    pub gpascii_port: u16,
    /// SSH port (0 = ephemeral).
    pub ssh_port: u16,
    /// SSH user.
    pub ssh_user: String,
    /// SSH password.
    pub ssh_password: String,
}

impl Default for PowerHostOpts {
    fn default() -> Self {
        let creds = Credentials::default();
        PowerHostOpts {
            gpascii_port: 0,
            ssh_port: 0,
            ssh_user: creds.user,
            ssh_password: creds.password,
        }
    }
}

impl PowerHostOpts {
    /// The port configuration these options give.
    pub(crate) fn ports_config(&self) -> PowerPortsConfig {
        PowerPortsConfig {
            gpascii_port: self.gpascii_port,
            ssh_port: self.ssh_port,
            creds: Credentials {
                user: self.ssh_user.clone(),
                password: self.ssh_password.clone(),
            },
            ..PowerPortsConfig::default()
        }
    }
}

/// The line printed once the ports listen.
pub(crate) fn ports_json(ascii: u16, pmac_eth: u16) -> String {
    format!("{{\"ascii\":{ascii},\"pmac_eth\":{pmac_eth}}}")
}

/// The line a Power card prints once its ports listen.
pub(crate) fn power_ports_json(gpascii: u16, ssh: u16) -> String {
    format!("{{\"gpascii\":{gpascii},\"ssh\":{ssh}}}")
}

/// Run the standalone card until asked to stop.
pub fn run_standalone(opts: StandaloneOpts) -> io::Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    // The card lives on its own thread (no ring, no servo loop); the ports reach it through
    // its channel.
    let storage = opts.state_file.as_ref().map(FileStorage::new);
    if storage.is_none() {
        tracing::info!("no --state-file: SAVE is refused (nowhere to keep the state)");
    }
    let (card, load_error) = startup_card(opts.profile, storage.as_ref());
    let mut core = CardCore::new(card);
    core.load_error = load_error;
    let (mut runner, card) = channel(core, storage);
    let stop = Arc::new(AtomicBool::new(false));
    let card_thread = {
        let stop = Arc::clone(&stop);
        std::thread::Builder::new()
            .name("mcc-card".into())
            .spawn(move || runner.run_until(&stop))?
    };
    let r = rt.block_on(async move {
        if let Some(power) = &opts.power_host {
            let cfg = PowerPortsConfig {
                max_connections: opts.limits.max_connections,
                ..power.ports_config()
            };
            let ports = serve_power(card, cfg).await?;
            print_line(&power_ports_json(ports.gpascii.port(), ports.ssh.port()))?;
            wait_for_stop(opts.exit_on_stdin_eof).await;
            ports.shutdown().await;
            return Ok(());
        }
        let cfg = PortsConfig {
            ascii_port: opts.ascii_port,
            eth_port: opts.eth_port,
            limits: opts.limits,
            ..PortsConfig::default()
        };
        let ports = serve(card, cfg).await?;
        print_line(&ports_json(ports.ascii.port(), ports.pmac_eth.port()))?;
        wait_for_stop(opts.exit_on_stdin_eof).await;
        ports.shutdown().await;
        Ok(())
    });
    stop.store(true, Ordering::Relaxed);
    let _ = card_thread.join();
    r
}

fn print_line(line: &str) -> io::Result<()> {
    let mut out = io::stdout().lock();
    writeln!(out, "{line}")?;
    out.flush()
}

async fn wait_for_stop(exit_on_stdin_eof: bool) {
    let (eof_tx, eof_rx) = tokio::sync::oneshot::channel::<()>();
    // Without the stdin watcher the sender stays here, so `eof_rx` never fires.
    let _keep = if exit_on_stdin_eof {
        // A plain thread: tokio's stdin would keep the runtime from shutting down promptly.
        std::thread::spawn(move || {
            let mut sink = [0u8; 256];
            let mut stdin = io::stdin();
            while matches!(stdin.read(&mut sink), Ok(n) if n > 0) {}
            let _ = eof_tx.send(());
        });
        None
    } else {
        Some(eof_tx)
    };
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        _ = term => {}
        _ = eof_rx => {}
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn ports_json_shape() {
        assert_eq!(super::ports_json(1025, 7), r#"{"ascii":1025,"pmac_eth":7}"#);
        assert_eq!(
            super::power_ports_json(23, 22),
            r#"{"gpascii":23,"ssh":22}"#
        );
    }
}
