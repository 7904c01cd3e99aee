//! A cluster config's ring built in-process on the deterministic lockstep [`RingSim`], wired
//! exactly as the member processes are (ring settings from the config, the card's start-up
//! wiring and I-variables, the stations' sync check); the caller supplies each station's
//! application and how a card app is wrapped.

use std::sync::{Arc, Mutex};

use mcc_card::interp::{Card, Session};
use mcc_card::runtime::ring_app::{wire_macro_motors, CardRingApp};
use mcc_ring::config::{ClusterConfig, MemberRef, StationConfig};
use mcc_ring::control::MemberKind;
use mcc_ring::core::{CoreConfig, MemberCore, RingApp};
use mcc_ring::runtime::process::card_check;
use mcc_ring::settings::RingSettings;
use mcc_ring::sim::RingSim;

/// The ring of `cfg` (one card, whose state is `card`; any number of stations).
pub fn ring<A: RingApp>(
    cfg: &ClusterConfig,
    card: &Arc<Mutex<Card>>,
    mut station: impl FnMut(&StationConfig) -> A,
    card_app: impl Fn(CardRingApp) -> A,
) -> RingSim<A> {
    let period = cfg.period_ns();
    let n = cfg.ring.order.len();
    let mut members = Vec::new();
    for name in &cfg.ring.order {
        let pos = cfg.position(name).expect("member in the ring order");
        let rs = cfg.ring_settings(name).expect("ring settings");
        let settings = RingSettings::new(u32::from(rs.i995), rs.i996);
        let (kind, check, app) = match cfg.member(name).expect("member") {
            MemberRef::Card(cc) => {
                {
                    let mut c = card.lock().unwrap();
                    let mut s = Session::default();
                    let line = format!("I995=${:X} I996=${:X}", rs.i995, rs.i996);
                    c.command_line(&mut s, line.as_bytes());
                    wire_macro_motors(&mut c, &cc.nodes);
                    for (k, v) in &cc.ivars {
                        c.command_line(&mut s, format!("{k}={}", v.as_f64()).as_bytes());
                    }
                }
                let app = CardRingApp::new(Arc::clone(card), &cc.nodes).with_wiring(true);
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
    RingSim::new(members, period)
}

/// Run one command line on the card; the reply without framing characters.
pub fn command(card: &Mutex<Card>, session: &mut Session, line: &str) -> String {
    let mut c = card.lock().unwrap();
    let r = c.command_line(session, line.as_bytes());
    String::from_utf8_lossy(&r)
        .trim_matches(|ch: char| ch.is_control() || ch.is_whitespace())
        .to_string()
}
