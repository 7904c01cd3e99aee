//! The card process on a ring: the ring application ([`ring_app`]) and the process main
//! ([`run_ring_card`]) that joins the ring, serves the host ports and the zenoh command
//! queryable, and runs the cycle loop.

#![allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge: threads, clocks, files, sockets

pub(crate) mod app_faults;
pub(crate) mod bench_servo;
pub(crate) mod cli;
pub(crate) mod input_fault;
pub(crate) mod ring_app;
pub(crate) mod standalone;
pub(crate) mod startup;

use std::path::PathBuf;

use anyhow::{anyhow, Context};
use mcc_contracts::config::MemberRef;
use mcc_ring::control::MemberKind;
use mcc_ring::runtime::process::{run_member, MemberArgs};

use crate::core::CardCore;
use crate::domain::Profile;
use crate::host::power_ports::{serve_power, PowerPortsConfig};
use crate::host::server::{serve, PortsConfig};
use crate::host::ssh::server::Credentials;
use crate::host::zenoh_cmd::declare_cmd_queryable;
use crate::lang::Card;
use crate::service::storage::{self, FileStorage};
use crate::service::{chain, handle, sync_start};

/// Where a card of a cluster keeps what SAVE writes: its `state_file`, else
/// `<run dir>/state/<name>.state` (the run directory is the folder of the resolved config;
/// `mcc down` leaves `state/` alone, as for stations).
pub(crate) fn state_file(
    cc: &mcc_contracts::config::CardConfig,
    run_dir: &std::path::Path,
) -> PathBuf {
    cc.state_file
        .clone()
        .unwrap_or_else(|| run_dir.join("state").join(format!("{}.state", cc.name)))
}

/// Run card `args.name` of the cluster until stopped.
pub fn run_ring_card(args: MemberArgs) -> anyhow::Result<()> {
    let run_dir = args.config.parent().map(PathBuf::from).unwrap_or_default();
    run_member(args, MemberKind::Card, |ctx| {
        let cc = match ctx.config.member(&ctx.name) {
            Some(MemberRef::Card(c)) => c.clone(),
            _ => anyhow::bail!("'{}' is not a card in the config", ctx.name),
        };
        let profile = profile_of(&cc);
        let state_path = state_file(&cc, &run_dir);
        let storage = Some(FileStorage::new(&state_path));
        let (mut card, load_error) = startup_card(profile, storage.as_ref());
        // The start-up layer (in the profile's numbering, every reply checked: a refused line
        // stops the card): the ring settings the config derives (I995/I996; Turbo
        // I6840/I6841), the motors on their MACRO nodes (Ix00, I1000, I1002; Turbo Ixx00,
        // I70, I71, I20: unless a saved image says how), the chain
        // address (I0, I1), then the config's own I-variables, which win. Re-applied after
        // every reset: the cluster config is the card's hardware setup.
        let wire = !state_path.exists();
        let ring = ctx
            .config
            .ring_settings(&ctx.name)
            .map(|rs| (u32::from(rs.i995), rs.i996));
        let layer = {
            let (nodes, number, ivars) = (cc.nodes.clone(), cc.number, cc.ivars.clone());
            move |card: &mut Card| -> anyhow::Result<()> {
                startup::ring_startup(card, ring, &nodes, wire)?;
                crate::core::chain::apply_chain_defaults(card, number);
                apply_ivars(card, &ivars)
            }
        };
        layer(&mut card)?;
        let mut core = CardCore::new(card);
        core.load_error = load_error.clone();
        let (runner, handle) = handle::channel(core, storage);
        // Host ports and the command queryable live on a small tokio runtime of their own.
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("mcc-card-host")
            .enable_all()
            .build()
            .context("starting the host-port runtime")?;
        let bind: Option<std::net::IpAddr> = cc.bind.as_deref().and_then(|b| b.parse().ok());
        let mut extra = serde_json::Map::new();
        // The host-link fault every port of the card consults (installed by the ring app).
        let link = mcc_ring::linkfault::LinkFaultSlot::default();
        // A Power card is reached as Power PMAC users connect (gpascii, SSH); the others
        // have the ASCII and PMAC Ethernet-protocol ports.
        let ports: Box<dyn std::any::Any> = if cc.profile == "power" {
            let ports = rt.block_on(serve_power(
                handle.clone(),
                PowerPortsConfig {
                    gpascii_port: cc.gpascii_port,
                    ssh_port: cc.ssh_port,
                    creds: Credentials {
                        user: cc.ssh_user.clone(),
                        password: cc.ssh_password.clone(),
                    },
                    max_connections: ctx.config.host.max_connections,
                    // 127.0.0.1 unless the config opens them (`bind`, checked by the config).
                    bind: bind.unwrap_or(PowerPortsConfig::default().bind),
                    link: link.clone(),
                    ..PowerPortsConfig::default()
                },
            ))?;
            extra.insert("gpascii".into(), serde_json::json!(ports.gpascii.port()));
            extra.insert("ssh".into(), serde_json::json!(ports.ssh.port()));
            Box::new(ports)
        } else {
            let ports = rt.block_on(serve(
                handle.clone(),
                PortsConfig {
                    ascii_port: cc.ascii_port,
                    eth_port: cc.pmac_eth_port,
                    limits: ctx.config.host,
                    name: cc.name.clone(),
                    bind: bind.unwrap_or(PortsConfig::default().bind),
                    link: link.clone(),
                },
            ))?;
            extra.insert("ascii".into(), serde_json::json!(ports.ascii.port()));
            extra.insert("pmac_eth".into(), serde_json::json!(ports.pmac_eth.port()));
            Box::new(ports)
        };
        let queryable = rt
            .block_on(declare_cmd_queryable(
                &ctx.session,
                &ctx.config.cluster,
                u32::from(cc.number),
                handle.clone(),
            ))
            .map_err(|e| anyhow!("declare card command queryable: {e}"))?;
        // Synchronized start (`card/<n>/at`): a tick waits at most this long for a commit
        // (the clock's choice: well under the frozen-member wait).
        let stall = ctx.config.sync_start_stall();
        let at_queryable = sync_start::declare_at_queryable(
            &ctx.session,
            &ctx.config.cluster,
            u32::from(cc.number),
            std::sync::Arc::clone(&runner.sync),
        )
        .map_err(|e| anyhow!("declare card at queryable: {e}"))?;

        extra.insert("number".into(), serde_json::json!(cc.number));
        extra.insert("profile".into(), serde_json::json!(cc.profile));
        // A refused state file (issue 9 item 7): `cards[].state_file_error` in the status.
        extra.insert("state_file_error".into(), serde_json::json!(load_error));
        // The daisy chain (pmac-commands §8.3): every chain byte reaches every card.
        let chain_q = rt
            .block_on(chain::declare_chain_queryable(
                &ctx.session,
                &ctx.config.cluster,
                u32::from(cc.number),
                handle.clone(),
            ))
            .map_err(|e| anyhow!("declare card chain queryable: {e}"))?;
        let app = ring_app::CardRingApp::new(runner, &cc.nodes)
            .with_sync_stall(stall)
            .with_link_faults(link)
            .with_startup(Box::new(move |card: &mut Card| {
                if let Err(e) = layer(card) {
                    tracing::warn!("re-applying the start-up settings after a reset: {e:#}");
                }
            }))
            .with_resource(Box::new(chain_q))
            .with_resource(Box::new(at_queryable))
            .with_resource(Box::new(queryable))
            .with_resource(ports)
            .with_resource(Box::new(rt));
        Ok((app, extra))
    })
}

/// The card at process start: the saved image from `storage` (read here, before the servo
/// loop runs), or factory defaults; a bad image is reported in the log, kept aside as
/// `<file>.bad-<n>` and never silently overwritten (the next SAVE writes a fresh file).
/// Stale temporaries of a SAVE cut short are removed. Returns the reason a bad image was
/// refused.
pub(crate) fn startup_card(
    profile: Profile,
    storage: Option<&FileStorage>,
) -> (Card, Option<String>) {
    let mut card = Card::new(profile);
    let Some(st) = storage else {
        return (card, None);
    };
    storage::remove_stale_temporaries(st.path());
    let bytes = storage::read(st.path());
    let result = card.apply_loaded(crate::lang::EffectResult::Loaded(bytes));
    let err = result.err();
    if let Some(e) = &err {
        let aside = storage::keep_aside(st.path());
        tracing::error!(
            file = %st.path().display(),
            kept_as = %aside.as_ref().map(|p| p.display().to_string()).unwrap_or_default(),
            "saved state refused, factory defaults in use: {e}"
        );
    }
    (card, err)
}

fn profile_of(cc: &mcc_contracts::config::CardConfig) -> Profile {
    Profile::from_name(&cc.profile).unwrap_or(Profile::Pmac2)
}

/// Check a card's config before anything starts (`mcc up`): its `ivars` applied as the card
/// applies them at start-up, on a card of its profile; the first refused one is named with the
/// card's error.
pub fn check_card_config(cc: &mcc_contracts::config::CardConfig) -> anyhow::Result<()> {
    let mut card = Card::new(profile_of(cc));
    crate::core::chain::apply_chain_defaults(&mut card, cc.number);
    apply_ivars(&mut card, &cc.ivars)
}

/// The config keys that are the ring's check settings of a card (read by the ring runtime,
/// `card_check`): on a Power card they are no Power I-variables (Power `I1001` is
/// `Motor[10].PhaseCtrl`; the check is `Macro.TestPeriod`/`TestMaxErrors`/`TestReqdSynchs`,
/// power-pmac.md §3.10), so they set the model's ring-check variables instead of going to
/// its dialect.
const RING_CHECK_KEYS: [&str; 4] = ["I1001", "I1004", "I1005", "I8"];

/// Apply a card config's start-up I-variables as the card process does at start-up (a
/// Power card takes the ring-check keys as its `Macro` ring check; see `apply_ivars`):
/// for in-process harnesses that build the card as the process does.
pub fn apply_config_ivars(
    card: &mut Card,
    ivars: &std::collections::BTreeMap<String, mcc_contracts::config::IVarValue>,
) -> anyhow::Result<()> {
    apply_ivars(card, ivars)
}

/// Apply the config's start-up I-variable overrides (`I1001 = 8`, ...) as on-line commands in
/// the card's own language (a Power card: its dialect, Power numbering).
fn apply_ivars(
    card: &mut Card,
    ivars: &std::collections::BTreeMap<String, mcc_contracts::config::IVarValue>,
) -> anyhow::Result<()> {
    let power = card.profile() == Profile::Power;
    let mut dialect = crate::lang::Dialect::for_card(card);
    let mut s = crate::lang::Session::default();
    for (k, v) in ivars {
        let line = format!("{k}={}", v.as_f64());
        if power && RING_CHECK_KEYS.iter().any(|r| r.eq_ignore_ascii_case(k)) {
            // The card's own ring check (Macro.TestPeriod/TestMaxErrors/TestReqdSynchs)
            // is kept in the model's ring I-variables.
            let rv = card.state.ring_ivars();
            let slot = match k.to_ascii_uppercase().as_str() {
                "I1001" => Some(rv.check_period),
                "I1004" => Some(rv.error_limit),
                "I1005" => Some(rv.sync_min),
                _ => None,
            };
            if let Some(n) = slot {
                if card.state.set_ivar(n, v.as_f64()).is_err() {
                    anyhow::bail!("cards.ivars: '{line}' is out of range for the ring check");
                }
            }
            continue;
        }
        let (reply, refused) = dialect.detached_line(card, &mut s, 0, line.as_bytes());
        if let Some(e) = refused {
            anyhow::bail!(
                "ivars: {k} = {}: the card refuses it: {}",
                v.as_f64(),
                startup::refusal_text(&reply, e)
            );
        }
    }
    Ok(())
}
