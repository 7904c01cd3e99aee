//! The card process on a ring: the ring application ([`ring_app`]) and the process main
//! ([`run_ring_card`]) that joins the ring, serves the host ports and the zenoh command
//! queryable, and runs the cycle loop.

pub mod ring_app;

use std::sync::{Arc, Mutex};

use anyhow::{anyhow, Context};
use mcc_ring::config::MemberRef;
use mcc_ring::control::MemberKind;
use mcc_ring::runtime::process::{run_member, MemberArgs};

use crate::host::server::{serve, PortsConfig};
use crate::host::zenoh_cmd::declare_cmd_queryable;
use crate::interp::{Card, Profile};

/// Run card `args.name` of the cluster until stopped.
pub fn run_ring_card(args: MemberArgs) -> anyhow::Result<()> {
    run_member(args, MemberKind::Card, |ctx| {
        let cc = match ctx.config.member(&ctx.name) {
            Some(MemberRef::Card(c)) => c.clone(),
            _ => anyhow::bail!("'{}' is not a card in the config", ctx.name),
        };
        let profile = match cc.profile.as_str() {
            "turbo" => Profile::Turbo,
            _ => Profile::Pmac2,
        };
        let mut card = match &cc.state_file {
            Some(p) => Card::with_state_file(profile, p.clone()),
            None => Card::new(profile),
        };
        // The ring settings the config derives (I995/I996), then the user's overrides.
        if let Some(rs) = ctx.config.ring_settings(&ctx.name) {
            let mut s = crate::interp::Session::default();
            let line = format!("I995=${:X} I996=${:X}", rs.i995, rs.i996);
            let _ = card.command_line(&mut s, line.as_bytes());
        }
        apply_ivars(&mut card, &cc.ivars)?;
        let card = Arc::new(Mutex::new(card));
        // Host ports and the command queryable live on a small tokio runtime of their own.
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("mcc-card-host")
            .enable_all()
            .build()
            .context("starting the host-port runtime")?;
        let ports = rt.block_on(serve(
            Arc::clone(&card),
            PortsConfig {
                ascii_port: cc.ascii_port,
                eth_port: cc.pmac_eth_port,
                ..PortsConfig::default()
            },
        ))?;
        let queryable = rt
            .block_on(declare_cmd_queryable(
                &ctx.session,
                &ctx.config.cluster,
                u32::from(cc.number),
                Arc::clone(&card),
            ))
            .map_err(|e| anyhow!("declare card command queryable: {e}"))?;
        let mut extra = serde_json::Map::new();
        extra.insert("number".into(), serde_json::json!(cc.number));
        extra.insert("profile".into(), serde_json::json!(cc.profile));
        extra.insert("ascii".into(), serde_json::json!(ports.ascii.port()));
        extra.insert("pmac_eth".into(), serde_json::json!(ports.pmac_eth.port()));
        // The runtime, ports and queryable live as long as the process.
        std::mem::forget(queryable);
        std::mem::forget(ports);
        std::mem::forget(rt);
        Ok((ring_app::CardRingApp::new(card, &cc.nodes), extra))
    })
}

/// Apply the config's start-up I-variable overrides (`I1001 = 8`, ...) as on-line commands.
fn apply_ivars(
    card: &mut Card,
    ivars: &std::collections::BTreeMap<String, mcc_ring::config::IVarValue>,
) -> anyhow::Result<()> {
    let mut s = crate::interp::Session::default();
    for (k, v) in ivars {
        let line = format!("{k}={}", v.as_f64());
        let reply = card.command_line(&mut s, line.as_bytes());
        if reply.contains(&0x07) {
            anyhow::bail!(
                "cards.ivars: '{line}' was refused by the card: {}",
                String::from_utf8_lossy(&reply).trim()
            );
        }
    }
    Ok(())
}
