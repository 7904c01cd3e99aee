//! The one builder of a config's ring: each member's core set up from the cluster config as a
//! member process sets it up — its I995/I996, its ring check (a card's from I1001/I1004/I1005/I8
//! in its I-variables, a station's from its `check` table), its upstream neighbour, the sync
//! source — next to the application the caller makes for it.
//!
//! Every ring of member cores is built here: a member process (`runtime::process`, one member),
//! the lockstep simulator ([`sim`]: the scenario tests' in-process rings) and the bench's
//! threaded ring over zenoh (`mcc bench ring`, through `runtime::local`). They differ only in
//! what the caller changes afterwards (the holdover clock per clock mode, a process's sequence
//! base) and in what runs the cores. Card and station logic stay with the caller: mcc-ring
//! knows neither crate.

use crate::check::{card_config_check, RingCheck};
use crate::control::MemberKind;
use crate::core::{CoreConfig, MemberCore, RingApp};
use crate::settings::RingSettings;
use crate::sim::RingSim;
use mcc_contracts::config::{ClusterConfig, MemberRef};

/// A member the config does not describe.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BuildError {
    /// No card or station of that name.
    #[error("member '{0}' is not in the config")]
    NotInConfig(String),
    /// A card or station that `ring.order` leaves out.
    #[error("member '{0}' is not in ring.order")]
    NotInOrder(String),
}

/// Member `name`'s core config. Its holdover period is the ring period (callers set the
/// clock-dependent holdover: `runtime::process::apply_clock`, or [`sim`]'s).
pub fn core_config(cfg: &ClusterConfig, name: &str) -> Result<CoreConfig, BuildError> {
    let member = cfg
        .member(name)
        .ok_or_else(|| BuildError::NotInConfig(name.to_string()))?;
    let position = cfg
        .position(name)
        .ok_or_else(|| BuildError::NotInOrder(name.to_string()))?;
    let n = cfg.ring.order.len();
    let rs = cfg
        .ring_settings(name)
        .ok_or_else(|| BuildError::NotInConfig(name.to_string()))?;
    let settings = RingSettings::new(u32::from(rs.i995), rs.i996);
    let (kind, check) = match member {
        MemberRef::Card(c) => (MemberKind::Card, card_config_check(c)),
        MemberRef::Station(s) => (
            MemberKind::Station,
            RingCheck::station(s.check.period, s.check.min_syncs, s.check.max_errors),
        ),
    };
    let mut cc = CoreConfig::new(name, kind, position as u16, settings, cfg.period_ns());
    cc.check = check;
    cc.upstream = Some(((position + n - 1) % n) as u16);
    cc.sync_source = cfg.sync_source();
    Ok(cc)
}

/// Every member of `cfg`'s ring, in ring order: its core config ([`core_config`]) and the
/// application `make_app` builds for it from that and the member's config section.
pub fn members<A>(
    cfg: &ClusterConfig,
    mut make_app: impl FnMut(&CoreConfig, MemberRef<'_>) -> A,
) -> Result<Vec<(CoreConfig, A)>, BuildError> {
    cfg.ring
        .order
        .iter()
        .map(|name| {
            let cc = core_config(cfg, name)?;
            let member = cfg
                .member(name)
                .ok_or_else(|| BuildError::NotInConfig(name.clone()))?;
            let app = make_app(&cc, member);
            Ok((cc, app))
        })
        .collect()
}

/// `cfg`'s ring on the deterministic lockstep simulator ([`RingSim`], one cycle per ring
/// period): [`members`] with each core's holdover period `holdover_ns` (how long a member
/// cut off from the ring waits before it runs cycles on its own clock).
pub fn sim<A: RingApp>(
    cfg: &ClusterConfig,
    holdover_ns: u64,
    make_app: impl FnMut(&CoreConfig, MemberRef<'_>) -> A,
) -> Result<RingSim<A>, BuildError> {
    let members = members(cfg, make_app)?
        .into_iter()
        .map(|(mut cc, app)| {
            cc.period_ns = holdover_ns;
            (MemberCore::new(cc), app)
        })
        .collect();
    Ok(RingSim::new(members, cfg.period_ns()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::STATION_DEFAULTS;
    use mcc_contracts::config::IVarValue;

    #[test]
    fn each_member_is_set_up_from_its_config_section() {
        let mut cfg = ClusterConfig::default_cluster(2, 2);
        cfg.stations[1].check.period = 12;
        cfg.cards[1]
            .ivars
            .insert("I1001".to_string(), IVarValue::Int(40));
        let order = cfg.ring.order.clone();
        assert_eq!(order, ["card0", "station0", "card1", "station1"]);
        let mut seen = Vec::new();
        let ms = members(&cfg, |cc, m| {
            seen.push(matches!(m, MemberRef::Card(_)));
            cc.name.clone()
        })
        .unwrap();
        assert_eq!(seen, [true, false, true, false]);
        for (k, (cc, app)) in ms.iter().enumerate() {
            assert_eq!((&cc.name, app), (&order[k], &order[k]));
            assert_eq!(cc.position as usize, k);
            assert_eq!(cc.upstream, Some(((k + 3) % 4) as u16));
            assert_eq!(cc.sync_source, Some(0), "{}", cc.name);
            assert_eq!(cc.period_ns, cfg.period_ns());
            let rs = cfg.ring_settings(&cc.name).unwrap();
            assert_eq!(cc.settings, RingSettings::new(u32::from(rs.i995), rs.i996));
        }
        let kinds: Vec<_> = ms.iter().map(|(cc, _)| cc.kind).collect();
        assert_eq!(
            kinds,
            [
                MemberKind::Card,
                MemberKind::Station,
                MemberKind::Card,
                MemberKind::Station
            ]
        );
        assert!(ms[0].0.settings.is_sync_master());
        assert!(!ms[2].0.settings.is_sync_master());
        // The ring checks: the default card's I1001 = 16, card1's own; the stations' tables.
        assert_eq!(
            ms[0].0.check.params(),
            RingCheck::card(16, 2, 4, 2).params()
        );
        assert_eq!(
            ms[2].0.check.params(),
            RingCheck::card(40, 2, 4, 2).params()
        );
        assert_eq!(ms[1].0.check.params(), STATION_DEFAULTS);
        assert_eq!(
            ms[3].0.check.params(),
            RingCheck::station(12, 4, 4).params()
        );
    }

    #[test]
    fn a_member_outside_the_config_or_the_ring_order_is_named() {
        let mut cfg = ClusterConfig::default_cluster(1, 1);
        assert_eq!(
            core_config(&cfg, "card7").unwrap_err().to_string(),
            "member 'card7' is not in the config"
        );
        cfg.ring.order.retain(|m| m != "station0");
        assert_eq!(
            core_config(&cfg, "station0").unwrap_err(),
            BuildError::NotInOrder("station0".into())
        );
        assert_eq!(
            members(&cfg, |_, _| ()).unwrap().len(),
            1,
            "the ring is what ring.order names"
        );
    }

    #[test]
    fn the_simulated_ring_of_the_default_cluster_runs_clean() {
        struct Idle;
        impl RingApp for Idle {
            fn tick(&mut self, _: u64, _: u64, _: &mut crate::member::RingMember, _: bool) {}
        }
        let cfg = ClusterConfig::default_cluster(2, 2);
        let mut sim = sim(&cfg, cfg.period_ns() * 3 / 2, |_, _| Idle).unwrap();
        assert_eq!(sim.len(), 4);
        assert_eq!(sim.sync_master(), Some(0));
        sim.run(40);
        for i in 0..4 {
            let s = sim.member(i).status();
            assert!(s.locked && !s.ring_fault && s.holdover_cycles == 0, "{s:?}");
            assert_eq!(s.errors, Default::default(), "{s:?}");
            assert_eq!(s.cycle, 40, "{s:?}");
        }
    }
}
