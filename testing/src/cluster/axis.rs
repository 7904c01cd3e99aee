//! Axis faults of a station's plant: `mcc fault STATION axis NODE KIND [--cycles N]
//! [--value V]` and `mcc fault STATION power-loss [--cycles N]`, checked before anything
//! runs (station, servo node, kind, value) with [`Error::unknown`] naming the valid ones.

use serde_json::Value;

use super::Cluster;
use crate::error::{Error, ErrorKind, Result};

/// Axis fault kinds (`mcc fault STATION axis NODE KIND`).
pub const AXIS_KINDS: &[&str] = &[
    "amp-fault",
    "encoder-loss",
    "encoder-glitch",
    "load",
    "jam",
    "plus-limit-on",
    "plus-limit-off",
    "plus-limit-chatter",
    "minus-limit-on",
    "minus-limit-off",
    "minus-limit-chatter",
    "home-on",
    "home-off",
    "home-chatter",
];
/// The axis kinds that need `value` (encoder-glitch: counts, load: N·m); the others take none.
pub const AXIS_VALUE_KINDS: &[&str] = &["encoder-glitch", "load"];

/// The servo nodes of `station` in a status document, or an unknown-station error.
fn station_nodes(status: &Value, station: &str) -> Result<Vec<u8>> {
    let stations = status["stations"].as_array().cloned().unwrap_or_default();
    let names: Vec<String> = stations
        .iter()
        .filter_map(|s| s["name"].as_str().map(str::to_string))
        .collect();
    let st = stations
        .iter()
        .find(|s| s["name"] == station)
        .ok_or_else(|| Error::unknown("station", station, &names))?;
    Ok(st["nodes"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|n| n.as_u64().and_then(|n| u8::try_from(n).ok()))
                .collect()
        })
        .unwrap_or_default())
}

fn cycles_arg(args: &mut Vec<String>, cycles: Option<u64>) -> Result<()> {
    match cycles {
        Some(0) => Err(Error::new(
            ErrorKind::Config,
            "cycles must be at least 1 (None: until cleared)",
        )),
        Some(n) => {
            args.extend(["--cycles".to_string(), n.to_string()]);
            Ok(())
        }
        None => Ok(()),
    }
}

/// The `mcc` arguments of an axis fault, checked against `status` (the cluster's).
pub(crate) fn axis_args(
    status: &Value,
    station: &str,
    node: u8,
    kind: &str,
    value: Option<f64>,
    cycles: Option<u64>,
) -> Result<Vec<String>> {
    let nodes = station_nodes(status, station)?;
    if !nodes.contains(&node) {
        return Err(Error::unknown(
            &format!("servo node of {station}"),
            node,
            &nodes,
        ));
    }
    if !AXIS_KINDS.contains(&kind) {
        return Err(Error::unknown("axis fault kind", kind, AXIS_KINDS));
    }
    let mut args: Vec<String> = ["fault", station, "axis", &node.to_string(), kind]
        .iter()
        .map(|s| s.to_string())
        .collect();
    match (AXIS_VALUE_KINDS.contains(&kind), value) {
        (true, None) => {
            return Err(Error::new(
                ErrorKind::Config,
                format!("axis fault {kind} needs a value (encoder-glitch: counts, load: N·m)"),
            ))
        }
        (false, Some(_)) => {
            return Err(Error::unknown(
                &format!("option of axis fault {kind}"),
                "value",
                &["cycles"],
            ))
        }
        (true, Some(v)) => args.extend(["--value".to_string(), v.to_string()]),
        (false, None) => {}
    }
    cycles_arg(&mut args, cycles)?;
    Ok(args)
}

impl Cluster {
    /// Inject axis fault `kind` ([`AXIS_KINDS`]) on servo node `node` of `station`
    /// (`value`: counts of an `encoder-glitch`, N·m of a `load`, none for the others;
    /// `cycles`: how long, none = until [`Cluster::clear`]). An unknown station, node or
    /// kind is refused at once naming the valid ones. Returns mcc's message.
    pub fn axis_fault(
        &mut self,
        station: &str,
        node: u8,
        kind: &str,
        value: Option<f64>,
        cycles: Option<u64>,
    ) -> Result<String> {
        let args = axis_args(&self.initial.0, station, node, kind, value, cycles)?;
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        Ok(self.runner.run(&args)?.trim().to_string())
    }

    /// Station-wide power loss on `station` (every amplifier faults; the station keeps
    /// answering the ring) for `cycles` ring cycles or until [`Cluster::clear`].
    pub fn power_loss(&mut self, station: &str, cycles: Option<u64>) -> Result<String> {
        station_nodes(&self.initial.0, station)?;
        let mut args: Vec<String> = vec!["fault".into(), station.into(), "power-loss".into()];
        cycles_arg(&mut args, cycles)?;
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        Ok(self.runner.run(&args)?.trim().to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status() -> Value {
        serde_json::json!({"stations": [
            {"name": "station0", "nodes": [0, 1, 4, 5]},
            {"name": "station1", "nodes": [8]}
        ]})
    }

    fn choices(e: &Error) -> Vec<String> {
        match &e.kind {
            ErrorKind::UnknownChoice { choices } => choices.clone(),
            k => panic!("not an unknown choice: {k:?} {e}"),
        }
    }

    #[test]
    fn axis_faults_build_the_cli_words() {
        let a = axis_args(&status(), "station0", 4, "load", Some(-0.5), Some(30)).unwrap();
        assert_eq!(
            a,
            ["fault", "station0", "axis", "4", "load", "--value", "-0.5", "--cycles", "30"]
        );
        let a = axis_args(&status(), "station1", 8, "jam", None, None).unwrap();
        assert_eq!(a, ["fault", "station1", "axis", "8", "jam"]);
    }

    #[test]
    fn unknown_station_node_kind_and_value_are_refused_naming_the_choices() {
        let e = axis_args(&status(), "station7", 0, "jam", None, None).unwrap_err();
        assert_eq!(choices(&e), ["station0", "station1"]);
        let e = axis_args(&status(), "station0", 8, "jam", None, None).unwrap_err();
        assert_eq!(choices(&e), ["0", "1", "4", "5"]);
        assert!(e.message.contains("servo node of station0 '8'"), "{e}");
        let e = axis_args(&status(), "station0", 0, "melt", None, None).unwrap_err();
        assert_eq!(choices(&e), AXIS_KINDS);
        let e = axis_args(&status(), "station0", 0, "jam", Some(1.0), None).unwrap_err();
        assert_eq!(choices(&e), ["cycles"]);
        let e = axis_args(&status(), "station0", 0, "encoder-glitch", None, None).unwrap_err();
        assert!(
            e.kind == ErrorKind::Config && e.message.contains("counts"),
            "{e}"
        );
        let e = axis_args(&status(), "station0", 0, "jam", None, Some(0)).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Config);
    }
}
