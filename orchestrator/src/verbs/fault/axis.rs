//! `mcc fault STATION axis NODE KIND [--cycles N] [--value V]` and `mcc fault STATION
//! power-loss [--cycles N]`: faults of a station's plant ([`mcc_station::faults`]). The words
//! are checked here first (kind, value, node against the config's servo nodes of that
//! station), then the station checks the same request again and answers.

use anyhow::{anyhow, bail, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_station::faults::{AxisFaultKind, StationFaultRequest, AXIS_KINDS};

use super::app::send_app_fault;
use crate::cli::FaultArgs;
use crate::cluster::attach::attach;

/// Refuse the options axis faults do not take, and `--cycles 0`.
fn check_options(what: &str, args: &FaultArgs) -> Result<()> {
    if args.probability.is_some() || args.seed.is_some() || args.delay.is_some() {
        bail!("`{what}` takes only --cycles N (and --value V for encoder-glitch, load), not --probability/--seed/--delay");
    }
    if args.cycles == Some(0) {
        bail!("--cycles must be at least 1 (omit it to fault until cleared)");
    }
    Ok(())
}

/// The request for `axis NODE KIND` words (kind and value checked, node not yet).
pub fn axis_request(words: &[String], args: &FaultArgs) -> Result<StationFaultRequest> {
    check_options("axis", args)?;
    let (node, kind) = match words {
        [node, kind] => (node, kind),
        [_] => bail!(
            "missing axis fault kind after the node (one of: {})",
            AXIS_KINDS.join(", ")
        ),
        _ => bail!(
            "usage: mcc fault STATION axis NODE KIND [--cycles N] [--value V] (KIND one of: {})",
            AXIS_KINDS.join(", ")
        ),
    };
    let node: u8 = node
        .parse()
        .map_err(|_| anyhow!("axis fault node {node:?}: not a node number (0-15)"))?;
    AxisFaultKind::parse(kind, args.value)?;
    Ok(StationFaultRequest::Axis {
        node,
        kind: kind.clone(),
        value: args.value,
        cycles: args.cycles,
    })
}

/// `member` is a station of `cfg` serving `node` (when given).
fn check_station(cfg: &ClusterConfig, member: &str, node: Option<u8>) -> Result<()> {
    let Some(st) = cfg.stations.iter().find(|s| s.name == member) else {
        let names: Vec<&str> = cfg.stations.iter().map(|s| s.name.as_str()).collect();
        bail!(
            "{member:?} is not a station of cluster {:?}: axis faults and power-loss go to a station (stations: {})",
            cfg.cluster,
            if names.is_empty() { "none".to_string() } else { names.join(", ") }
        );
    };
    if let Some(n) = node {
        if !st.nodes.contains(&n) {
            let list: Vec<String> = st.nodes.iter().map(u8::to_string).collect();
            bail!(
                "node {n} is not a servo node of {member} (servo nodes: {})",
                list.join(", ")
            );
        }
    }
    Ok(())
}

/// `mcc fault STATION axis NODE KIND`.
pub fn cmd_axis(cluster: &str, member: &str, words: &[String], args: &FaultArgs) -> Result<()> {
    let req = axis_request(words, args)?;
    let node = match &req {
        StationFaultRequest::Axis { node, .. } => Some(*node),
        StationFaultRequest::PowerLoss { .. } => None,
    };
    send(cluster, member, node, &req)
}

/// `mcc fault STATION power-loss`.
pub fn cmd_power_loss(cluster: &str, member: &str, args: &FaultArgs) -> Result<()> {
    check_options("power-loss", args)?;
    if let Some(v) = args.value {
        bail!("`power-loss` takes no --value (got {v})");
    }
    let req = StationFaultRequest::PowerLoss {
        cycles: args.cycles,
    };
    send(cluster, member, None, &req)
}

fn send(cluster: &str, member: &str, node: Option<u8>, req: &StationFaultRequest) -> Result<()> {
    let a = attach(cluster)?;
    check_station(&a.cfg, member, node)?;
    let msg = send_app_fault(&a, member, serde_json::to_value(req)?)?;
    println!("{member}: {msg}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(cycles: Option<u64>, value: Option<f64>) -> FaultArgs {
        FaultArgs {
            words: vec![],
            cycles,
            probability: None,
            seed: None,
            delay: None,
            value,
            cs: None,
        }
    }

    fn w(s: &[&str]) -> Vec<String> {
        s.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn axis_words_build_the_station_request() {
        let r = axis_request(&w(&["4", "load"]), &args(Some(7), Some(-0.5))).unwrap();
        assert_eq!(
            serde_json::to_value(&r).unwrap(),
            serde_json::json!({"op": "axis", "node": 4, "kind": "load", "value": -0.5, "cycles": 7})
        );
        let r = axis_request(&w(&["0", "jam"]), &args(None, None)).unwrap();
        assert_eq!(
            serde_json::to_value(&r).unwrap(),
            serde_json::json!({"op": "axis", "node": 0, "kind": "jam"})
        );
    }

    #[test]
    fn bad_axis_words_name_the_choices() {
        let e = |words: &[&str], a: FaultArgs| axis_request(&w(words), &a).unwrap_err().to_string();
        let m = e(&["0", "melt"], args(None, None));
        assert!(m.contains("melt") && m.contains("encoder-loss"), "{m}");
        assert!(e(&["0"], args(None, None)).contains("amp-fault"));
        assert!(e(&["x", "jam"], args(None, None)).contains("not a node number"));
        assert!(e(&["0", "load"], args(None, None)).contains("needs --value"));
        assert!(e(&["0", "jam"], args(None, Some(1.0))).contains("takes no --value"));
        assert!(e(&["0", "jam"], args(Some(0), None)).contains("at least 1"));
        let mut a = args(None, None);
        a.seed = Some(1);
        assert!(e(&["0", "jam"], a).contains("--seed"));
    }

    #[test]
    fn fault_help_lists_every_axis_kind() {
        use clap::CommandFactory;
        let mut cli = crate::cli::Cli::command();
        let help = cli
            .find_subcommand_mut("fault")
            .expect("fault verb")
            .render_long_help()
            .to_string();
        for k in AXIS_KINDS.iter().chain(&["power-loss"]) {
            assert!(help.contains(k), "{k} missing from `mcc fault --help`");
        }
    }

    #[test]
    fn only_a_station_and_its_servo_nodes_are_taken() {
        let cfg = ClusterConfig::default_cluster(1, 1);
        let st = &cfg.stations[0];
        check_station(&cfg, &st.name, Some(st.nodes[0])).unwrap();
        let m = check_station(&cfg, &st.name, Some(2))
            .unwrap_err()
            .to_string();
        assert!(
            m.contains("node 2") && m.contains("servo nodes: 0, 1, 4"),
            "{m}"
        );
        let card = &cfg.cards[0].name;
        let m = check_station(&cfg, card, None).unwrap_err().to_string();
        assert!(m.contains("not a station") && m.contains(&st.name), "{m}");
    }
}
