//! `mcc fault MEMBER KIND [--cycles N] [--probability P] [--seed S] [--delay N]` and
//! `mcc fault clear [MEMBER]`: fault requests to members' `ctl/<member>/fault` queryables.
//!
//! Beside the ring (send-path) faults and the process drills, the application faults:
//! - `mcc fault STATION axis NODE KIND [--cycles N] [--value V]` and `mcc fault STATION
//!   power-loss` ([`axis`]): the station plant;
//! - `mcc fault CARD|chain|bus link KIND [...]` ([`link`]): host links;
//! - `mcc fault CARD input KIND` ([`input`]): a card's hardware inputs (abort/E-stop).
//!
//! Each goes to the member as [`FaultRequest::App`] with the application's own request
//! ([`app::send_app_fault`]); `mcc fault clear` clears them with the ring faults.

pub mod app;
pub mod axis;
pub mod input;
pub mod link;

use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use mcc_ring::control::{ctl_key, FaultRequest};
use mcc_ring::fault::{FaultKind, FaultSpec};

use crate::cli::FaultArgs;
use crate::cluster::attach::attach;
use crate::cluster::ctl;

/// Build the fault spec from `mcc fault MEMBER KIND` options.
pub fn fault_spec(kind_word: &str, args: &FaultArgs) -> Result<FaultSpec> {
    let kind: FaultKind = match (kind_word, args.delay) {
        ("delay" | "delay-us", Some(n)) => {
            let n = u32::try_from(n).map_err(|_| anyhow!("--delay {n} is too large"))?;
            FaultKind::parse_with(kind_word, Some(n)).map_err(anyhow::Error::msg)?
        }
        (_, Some(_)) if !kind_word.contains(['=', ':']) => {
            bail!("--delay only applies to the delay and delay-us faults, not {kind_word:?}")
        }
        _ => kind_word.parse().map_err(anyhow::Error::msg)?,
    };
    let probability = args.probability.unwrap_or(1.0);
    let spec = FaultSpec {
        kind,
        cycles: args.cycles,
        probability,
        seed: args.seed.unwrap_or(0),
    };
    spec.validate().map_err(anyhow::Error::msg)?;
    if args.cycles == Some(0) {
        bail!("--cycles must be at least 1 (omit it to fault until cleared)");
    }
    Ok(spec)
}

/// `mcc fault MEMBER KIND [...]` / `mcc fault clear [MEMBER]`.
pub fn cmd_fault(cluster: &str, args: &FaultArgs) -> Result<()> {
    let (targets, req): (Option<String>, FaultRequest) = match args.words.as_slice() {
        [clear] if clear == "clear" => (None, FaultRequest::Clear),
        [clear, member] if clear == "clear" => (Some(member.clone()), FaultRequest::Clear),
        [reset, rest @ ..] if reset == "reset" && rest.len() <= 1 => {
            let a = attach(cluster)?;
            return crate::cluster::drills::reset_latches(&a, rest.first().map(String::as_str));
        }
        [member, drill] if crate::cluster::drills::PROCESS_DRILLS.contains(&drill.as_str()) => {
            if args.cycles.is_some()
                || args.probability.is_some()
                || args.seed.is_some()
                || args.delay.is_some()
            {
                bail!("`{drill}` takes no --cycles/--probability/--seed/--delay");
            }
            let a = attach(cluster)?;
            if a.cfg.member(member).is_none() {
                bail!(
                    "unknown member {member:?} in cluster {cluster:?} (members: {})",
                    a.cfg.ring.order.join(", ")
                );
            }
            println!(
                "{member}: {}",
                crate::cluster::drills::process_drill(&a, member, drill)?
            );
            return Ok(());
        }
        [member, axis, rest @ ..] if axis == "axis" => {
            return axis::cmd_axis(cluster, member, rest, args)
        }
        [member, word] if word == "power-loss" => {
            return axis::cmd_power_loss(cluster, member, args)
        }
        [target, link, rest @ ..] if link == "link" => {
            return link::cmd_link(cluster, target, rest, args)
        }
        [member, input, rest @ ..] if input == "input" => {
            return input::cmd_input(cluster, member, rest, args)
        }
        [member, kind] => (
            Some(member.clone()),
            FaultRequest::Inject {
                spec: fault_spec(kind, args)?,
            },
        ),
        [member] => bail!(
            "missing fault kind after {member:?} (one of: {})",
            mcc_ring::fault::FAULT_WORDS
        ),
        _ => bail!("usage: mcc fault MEMBER KIND [options] | mcc fault clear [MEMBER]"),
    };
    if matches!(req, FaultRequest::Clear)
        && (args.cycles.is_some()
            || args.probability.is_some()
            || args.seed.is_some()
            || args.delay.is_some())
    {
        bail!("`mcc fault clear` takes no --cycles/--probability/--seed/--delay");
    }
    let a = attach(cluster)?;
    let members: Vec<String> = match targets.clone() {
        Some(m) => {
            if a.cfg.member(&m).is_none() {
                bail!(
                    "unknown member {m:?} in cluster {cluster:?} (members: {})",
                    a.cfg.ring.order.join(", ")
                );
            }
            vec![m]
        }
        None => a.cfg.ring.order.clone(),
    };
    let payload = serde_json::to_string(&req)?;
    let mut failed = 0;
    for m in &members {
        let key = ctl_key(&a.cfg.cluster, m, "fault");
        match ctl::query_ctl(
            &a.session,
            &key,
            Some(payload.clone()),
            Duration::from_secs(2),
        ) {
            Ok(r) if r.ok => println!("{m}: {}", r.message),
            Ok(r) => {
                failed += 1;
                eprintln!("{m}: refused: {}", r.message);
            }
            Err(e) => {
                failed += 1;
                eprintln!("{m}: {e:#}");
            }
        }
    }
    if targets.is_none() && matches!(req, FaultRequest::Clear) {
        link::clear_host_links(&a);
    }
    if failed > 0 {
        bail!(
            "{failed} of {} member(s) did not apply the request",
            members.len()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(delay: Option<u64>) -> FaultArgs {
        FaultArgs {
            words: vec![],
            cycles: Some(10),
            probability: Some(0.5),
            seed: Some(7),
            delay,
            value: None,
            cs: None,
        }
    }

    #[test]
    fn fault_specs_from_cli_words() {
        let s = fault_spec("cut", &args(None)).unwrap();
        assert_eq!(
            s,
            FaultSpec {
                kind: FaultKind::Cut,
                cycles: Some(10),
                probability: 0.5,
                seed: 7
            }
        );
        assert_eq!(
            fault_spec("delay", &args(Some(3))).unwrap().kind,
            FaultKind::DelayCycles(3)
        );
        assert_eq!(
            fault_spec("delay-us", &args(Some(250))).unwrap().kind,
            FaultKind::DelayMicros(250)
        );
        assert_eq!(
            fault_spec("delay=4", &args(None)).unwrap().kind,
            FaultKind::DelayCycles(4)
        );
    }

    #[test]
    fn bad_fault_words_are_named() {
        let e = fault_spec("melt", &args(None)).unwrap_err().to_string();
        assert!(e.contains("melt") && e.contains("drop-sync"), "{e}");
        assert!(fault_spec("delay", &args(None)).is_err());
        assert!(fault_spec("cut", &args(Some(3))).is_err());
        let mut a = args(None);
        a.probability = Some(1.5);
        assert!(fault_spec("corrupt", &a)
            .unwrap_err()
            .to_string()
            .contains("1.5"));
        a.probability = None;
        a.cycles = Some(0);
        assert!(fault_spec("corrupt", &a).is_err());
    }
}
