//! Checks of member settings the members themselves parse or apply (a card's `ivars`, a
//! station's `plant` table), run by
//! `mcc up` before anything starts, so a bad file is refused with the key and the problem
//! rather than with a member that exits during start-up.

use anyhow::{anyhow, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_station::config::PlantConfig;
use mcc_station::station_app::StationApp;

/// Every card accepts its start-up I-variables; every station's plant parses, and names only
/// servo nodes of that station.
pub fn check_members(cfg: &ClusterConfig) -> Result<()> {
    for c in &cfg.cards {
        mcc_card::check_card_config(c).map_err(|e| anyhow!("config: cards.{}.{e:#}", c.name))?;
    }
    for st in &cfg.stations {
        let plant = PlantConfig::from_table(&st.plant)
            .map_err(|e| anyhow!("config: stations.{}: {e}", st.name))?;
        StationApp::new(&st.nodes, &[], &plant)
            .map_err(|e| anyhow!("config: stations.{}: {e}", st.name))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_plants_are_named_before_anything_starts() {
        let good = ClusterConfig::default_cluster(1, 1);
        check_members(&good).unwrap();
        let mut bad = good.clone();
        let t: toml::Table = toml::from_str("[nodes.1]\ninertia = -1\n").unwrap();
        bad.stations[0].plant = t;
        let e = check_members(&bad).unwrap_err().to_string();
        assert!(
            e.contains("stations.station0") && e.contains("inertia"),
            "{e}"
        );
        let t: toml::Table = toml::from_str("[nodes.3]\ninertia = 1\n").unwrap();
        bad.stations[0].plant = t;
        let e = check_members(&bad).unwrap_err().to_string();
        assert!(e.contains("node 3"), "{e}");
    }

    #[test]
    fn ivars_a_card_refuses_are_named_before_anything_starts() {
        let mut bad = ClusterConfig::default_cluster(2, 0);
        bad.cards[1]
            .ivars
            .insert("I130".into(), mcc_contracts::config::IVarValue::Float(2.5));
        check_members(&bad).unwrap();
        bad.cards[1]
            .ivars
            .insert("I8".into(), mcc_contracts::config::IVarValue::Int(1000));
        let e = check_members(&bad).unwrap_err().to_string();
        assert!(
            e.starts_with("config: cards.card1.ivars: I8 = 1000: the card refuses it: "),
            "{e}"
        );
        assert!(e.contains("ERR"), "{e}");
    }
}
