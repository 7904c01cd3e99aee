//! `mcc fault CARD|chain|bus link KIND [--probability P --seed S --cycles N --delay MS]`:
//! host-link faults (`mcc_ring::linkfault`). A card's go to the card
//! (`{"link": spec}` as its application fault: every host port of the card); the chain's and
//! the bus's to the supervisor's `ctl/orchestrator/link` queryable (`cluster::link_ctl`).
//! `--cycles N` is the next N replies (hit or not), `--probability` is drawn per reply.

use anyhow::{bail, Result};
use mcc_ring::linkfault::{LinkFaultKind, LinkFaultSpec, LinkTarget};

use crate::cli::FaultArgs;
use crate::cluster::attach::attach;
use crate::cluster::link_ctl::{ask, LinkCtl};

/// The spec `mcc fault TARGET link KIND [options]` asks for, checked for `target`.
pub fn link_spec(target: LinkTarget, words: &[String], args: &FaultArgs) -> Result<LinkFaultSpec> {
    let kind: LinkFaultKind = match words {
        [k] => k.parse()?,
        [] => bail!(
            "missing link fault kind (one of: {})",
            LinkFaultKind::words()
        ),
        [_, extra, ..] => bail!("unexpected {extra:?} after the link fault kind"),
    };
    if args.value.is_some() {
        bail!("link faults take no --value (options: --probability, --seed, --cycles, --delay)");
    }
    let spec = LinkFaultSpec {
        kind,
        probability: args.probability.unwrap_or(1.0),
        seed: args.seed.unwrap_or(0),
        replies: args.cycles,
        delay_ms: args.delay.unwrap_or(0),
    };
    spec.validate(target)?;
    Ok(spec)
}

/// `mcc fault TARGET link KIND`.
pub fn cmd_link(cluster: &str, target: &str, words: &[String], args: &FaultArgs) -> Result<()> {
    let a = attach(cluster)?;
    match target {
        "chain" | "bus" => {
            let t = if target == "chain" {
                LinkTarget::Chain
            } else {
                LinkTarget::Bus
            };
            let fault = link_spec(t, words, args)?;
            let replies = ask(
                &a.session,
                &a.cfg.cluster,
                &LinkCtl::Set {
                    target: target.to_string(),
                    fault,
                },
            )?;
            report(target, &replies)
        }
        card if a.cfg.cards.iter().any(|c| c.name == card) => {
            let fault = link_spec(LinkTarget::CardPorts, words, args)?;
            let msg = super::app::send_app_fault(&a, card, serde_json::json!({ "link": fault }))?;
            println!("{card}: {msg}");
            Ok(())
        }
        other => {
            let cards: Vec<&str> = a.cfg.cards.iter().map(|c| c.name.as_str()).collect();
            bail!(
                "{other:?} has no host link to fault (a card: {}; or chain, bus)",
                cards.join(", ")
            )
        }
    }
}

fn report(target: &str, replies: &[mcc_ring::control::CtlReply]) -> Result<()> {
    let mut refused = Vec::new();
    for r in replies {
        if r.ok {
            println!("{}", r.message);
        } else {
            refused.push(r.message.clone());
        }
    }
    if !refused.is_empty() {
        bail!("{target}: refused: {}", refused.join("; "));
    }
    Ok(())
}

/// `mcc fault clear` (every member): the chain's and bus's faults too. A supervisor that
/// does not answer (an older one) is a warning, not a failure.
pub fn clear_host_links(a: &crate::cluster::attach::Attached) {
    match ask(&a.session, &a.cfg.cluster, &LinkCtl::Clear) {
        Ok(r) => {
            for r in r {
                println!("{}", r.message);
            }
        }
        Err(e) => eprintln!("chain/bus: {e:#}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args() -> FaultArgs {
        FaultArgs {
            words: vec![],
            cycles: None,
            probability: None,
            seed: None,
            delay: None,
            value: None,
            cs: None,
        }
    }

    fn w(s: &str) -> Vec<String> {
        vec![s.to_string()]
    }

    #[test]
    fn cli_words_make_specs() {
        let mut a = args();
        a.delay = Some(40);
        a.cycles = Some(3);
        let s = link_spec(LinkTarget::Chain, &w("late"), &a).unwrap();
        assert_eq!(
            (s.kind, s.delay_ms, s.replies),
            (LinkFaultKind::Late, 40, Some(3))
        );
        let s = link_spec(LinkTarget::Bus, &w("bad-checksum"), &args()).unwrap();
        assert_eq!((s.kind, s.probability), (LinkFaultKind::BadChecksum, 1.0));
    }

    #[test]
    fn bad_words_and_options_are_named() {
        let e = link_spec(LinkTarget::CardPorts, &w("bad-checksum"), &args()).unwrap_err();
        assert!(e.to_string().contains("EMCL bus only"), "{e}");
        let e = link_spec(LinkTarget::CardPorts, &w("melt"), &args()).unwrap_err();
        assert!(e.to_string().contains("no-reply, late"), "{e}");
        let e = link_spec(LinkTarget::CardPorts, &[], &args()).unwrap_err();
        assert!(e.to_string().contains("stray-ctrl"), "{e}");
        assert!(link_spec(LinkTarget::Chain, &w("late"), &args()).is_err());
        let mut a = args();
        a.value = Some(1.0);
        assert!(link_spec(LinkTarget::Chain, &w("short"), &a).is_err());
        a.value = None;
        a.cycles = Some(0);
        assert!(link_spec(LinkTarget::Chain, &w("short"), &a).is_err());
    }
}
