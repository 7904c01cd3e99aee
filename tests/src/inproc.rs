//! A cluster config's ring built in-process on the deterministic lockstep [`RingSim`], wired
//! exactly as the member processes are (ring settings from the config, the card's start-up
//! layer: ring I-variables, wiring and the config's I-variables, applied again after every
//! reset; the stations' sync check); the caller supplies each station's application and how a
//! card app is wrapped. The card is owned by its ring app (as on the servo thread): reach it
//! through the app between ring cycles.

use mcc_card::{ring_startup, Card, CardHandle, CardRingApp, Session};
use mcc_ring::config::{ClusterConfig, MemberRef, StationConfig};
use mcc_ring::control::MemberKind;
use mcc_ring::core::{CoreConfig, MemberCore, RingApp};
use mcc_ring::runtime::process::card_check;
use mcc_ring::settings::RingSettings;
use mcc_ring::sim::RingSim;

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
    let period = cfg.period_ns();
    let n = cfg.ring.order.len();
    let mut card = Some(card);
    let mut members = Vec::new();
    for name in &cfg.ring.order {
        let pos = cfg.position(name).expect("member in the ring order");
        let rs = cfg.ring_settings(name).expect("ring settings");
        let settings = RingSettings::new(u32::from(rs.i995), rs.i996);
        let (kind, check, app) = match cfg.member(name).expect("member") {
            MemberRef::Card(cc) => {
                let mut c = card.take().expect("one card in the config");
                let (nodes, ivars) = (cc.nodes.clone(), cc.ivars.clone());
                let (i995, i996) = (rs.i995, rs.i996);
                let layer = move |c: &mut Card| {
                    let mut s = Session::default();
                    let ring = Some((u32::from(i995), i996));
                    if let Err(e) = ring_startup(c, ring, &nodes, true) {
                        panic!("test cluster start-up: {e}");
                    }
                    for (k, v) in &ivars {
                        c.command_line(&mut s, format!("{k}={}", v.as_f64()).as_bytes());
                    }
                };
                layer(&mut c);
                let (app, h) = CardRingApp::with_handle(c, &cc.nodes);
                handle = Some(h);
                let app = app.with_startup(Box::new(layer));
                (MemberKind::Card, card_check(&cc.ivars), card_app(app))
            }
            MemberRef::Station(sc) => {
                let check = mcc_ring::check::RingCheck::station(
                    sc.check.period,
                    sc.check.min_syncs,
                    sc.check.max_errors,
                );
                (MemberKind::Station, check, station(sc))
            }
        };
        let mut cc = CoreConfig::new(name, kind, pos as u16, settings, period * 100);
        cc.check = check;
        cc.upstream = Some(((pos + n - 1) % n) as u16);
        members.push((MemberCore::new(cc), app));
    }
    let handle = handle.expect("one card in the config");
    (RingSim::new(members, period), handle)
}

/// Run one command line on the card; the reply without framing characters.
pub fn command(card: &mut Card, session: &mut Session, line: &str) -> String {
    let r = card.command_line(session, line.as_bytes());
    String::from_utf8_lossy(&r)
        .trim_matches(|ch: char| ch.is_control() || ch.is_whitespace())
        .to_string()
}
