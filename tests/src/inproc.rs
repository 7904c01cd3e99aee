//! A cluster config's ring built in-process on the deterministic lockstep [`RingSim`] by the
//! one ring builder ([`mcc_ring::builder`]: cores wired exactly as the member processes' are),
//! with the card's start-up layer (ring I-variables, wiring and the config's I-variables,
//! applied again after every reset); the caller supplies each station's application and how a
//! card app is wrapped. The card is owned by its ring app (as on the servo thread): reach it
//! through the app between ring cycles.

use mcc_card::{ring_startup, Card, CardHandle, CardRingApp, Session};
use mcc_contracts::config::{ClusterConfig, MemberRef, StationConfig};
use mcc_ring::builder;
use mcc_ring::core::RingApp;
use mcc_ring::sim::RingSim;
use mcc_station::config::PlantConfig;
use mcc_station::mi::Globals;
use mcc_station::station_app::StationApp;
use std::path::Path;

/// The ring of `cfg` (one card, starting as `card`; any number of stations).
pub fn ring<A: RingApp>(
    cfg: &ClusterConfig,
    card: Card,
    station: impl FnMut(&StationConfig) -> A,
    card_app: impl Fn(CardRingApp) -> A,
) -> RingSim<A> {
    ring_with_handle(cfg, card, station, card_app).0
}

/// [`ring`], and a handle to the card for host requests (served by the card's ring app at its
/// ticks, as a host port's are: send them from another thread while the ring runs).
pub fn ring_with_handle<A: RingApp>(
    cfg: &ClusterConfig,
    card: Card,
    mut station: impl FnMut(&StationConfig) -> A,
    card_app: impl Fn(CardRingApp) -> A,
) -> (RingSim<A>, CardHandle) {
    let mut handle = None;
    let mut card = Some(card);
    // A member cut off waits 100 periods before it runs on its own clock.
    let sim = builder::sim(cfg, cfg.period_ns() * 100, |core, member| match member {
        MemberRef::Card(cc) => {
            let mut c = card.take().expect("one card in the config");
            let (nodes, ivars) = (cc.nodes.clone(), cc.ivars.clone());
            let ring = Some((core.settings.i995, core.settings.i996));
            let layer = move |c: &mut Card| {
                let mut s = Session::default();
                if let Err(e) = ring_startup(c, ring, &nodes, true) {
                    panic!("test cluster start-up: {e}");
                }
                if c.profile() == mcc_card::Profile::Power {
                    // As the card process: the ring-check keys become its Macro ring check.
                    if let Err(e) = mcc_card::apply_config_ivars(c, &ivars) {
                        panic!("test cluster ivars: {e}");
                    }
                } else {
                    for (k, v) in &ivars {
                        c.command_line(&mut s, format!("{k}={}", v.as_f64()).as_bytes());
                    }
                }
            };
            layer(&mut c);
            let (app, h) = CardRingApp::with_handle(c, &cc.nodes);
            handle = Some(h);
            card_app(app.with_startup(Box::new(layer)))
        }
        MemberRef::Station(sc) => station(sc),
    })
    .unwrap_or_else(|e| panic!("test cluster: {e}"));
    let handle = handle.expect("one card in the config");
    (sim, handle)
}

/// A station's application as its process builds it from the config: the plant of its
/// `plant` table, the MI globals of its ring check, `MS SAVE` state in `<state_dir>/<name>.state`
/// (none without a directory).
pub fn station_app(sc: &StationConfig, state_dir: Option<&Path>) -> StationApp {
    let plant =
        PlantConfig::from_table(&sc.plant).unwrap_or_else(|e| panic!("stations.{}: {e}", sc.name));
    let c = sc.check;
    StationApp::new(&sc.nodes, &[], &plant)
        .unwrap_or_else(|e| panic!("stations.{}: {e}", sc.name))
        .with_setup(
            Globals::from_check(c.period, c.min_syncs, c.max_errors),
            state_dir.map(|d| d.join(format!("{}.state", sc.name))),
        )
}

/// Run one command line on the card; the reply without framing characters.
pub fn command(card: &mut Card, session: &mut Session, line: &str) -> String {
    let r = card.command_line(session, line.as_bytes());
    String::from_utf8_lossy(&r)
        .trim_matches(|ch: char| ch.is_control() || ch.is_whitespace())
        .to_string()
}
