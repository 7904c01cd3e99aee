//! `mcc fault CARD input KIND [--cs N] [--cycles N]`: a card's hardware stop inputs (the
//! JPAN STOP/ and HOLD/ inputs of a PMAC2/Turbo card, the global abort input of a Power card;
//! README "Card inputs (abort/E-stop)"). The input is held active until `mcc fault clear
//! [CARD]`, or for N ring cycles.

use anyhow::{bail, Result};
use mcc_card::{InputFaultRequest, InputKind};
use mcc_contracts::config::MemberRef;

use super::app::send_app_fault;
use crate::cli::FaultArgs;
use crate::cluster::attach::attach;

/// The card's request for `words` (`[KIND]`) and `args`, checked before anything is sent.
pub fn input_request(words: &[String], args: &FaultArgs) -> Result<InputFaultRequest> {
    let kind = match words {
        [k] => InputKind::parse(k).map_err(anyhow::Error::msg)?,
        [] => bail!("missing input kind (one of: {})", InputKind::WORDS),
        _ => bail!("usage: mcc fault CARD input KIND [--cs N] [--cycles N]"),
    };
    if args.probability.is_some() || args.seed.is_some() || args.delay.is_some() {
        bail!("`input` takes --cs and --cycles only (no --probability/--seed/--delay)");
    }
    if args.value.is_some() {
        bail!("`input` takes no --value (the selected C.S. is --cs N)");
    }
    if args.cycles == Some(0) {
        bail!("--cycles must be at least 1 (omit it to hold the input until cleared)");
    }
    Ok(InputFaultRequest {
        family: "input".into(),
        kind: kind.word().into(),
        select: args.cs,
        cycles: args.cycles,
    })
}

/// `mcc fault CARD input KIND`.
pub fn cmd_input(cluster: &str, member: &str, words: &[String], args: &FaultArgs) -> Result<()> {
    let req = input_request(words, args)?;
    let a = attach(cluster)?;
    match a.cfg.member(member) {
        Some(MemberRef::Card(_)) => {}
        Some(_) => bail!(
            "{member} is a station: inputs are a card's (cards: {})",
            cards(&a)
        ),
        None => bail!(
            "unknown member {member:?} in cluster {cluster:?} (cards: {})",
            cards(&a)
        ),
    }
    let msg = send_app_fault(&a, member, serde_json::to_value(&req)?)?;
    println!("{member}: {msg}");
    Ok(())
}

fn cards(a: &crate::cluster::attach::Attached) -> String {
    let v: Vec<&str> = a.cfg.cards.iter().map(|c| c.name.as_str()).collect();
    v.join(", ")
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

    #[test]
    fn input_words_become_the_cards_request() {
        let mut a = args();
        a.cs = Some(2);
        a.cycles = Some(50);
        let r = input_request(&["abort".into()], &a).unwrap();
        assert_eq!(
            serde_json::to_value(&r).unwrap(),
            serde_json::json!({"family": "input", "kind": "abort", "select": 2, "cycles": 50})
        );
        let r = input_request(&["feed-hold".into()], &args()).unwrap();
        assert_eq!(
            (r.kind.as_str(), r.select, r.cycles),
            ("feed-hold", None, None)
        );
    }

    #[test]
    fn bad_input_words_name_the_choices() {
        let e = input_request(&["estop".into()], &args())
            .unwrap_err()
            .to_string();
        assert!(e.contains("estop") && e.contains("abort, feed-hold"), "{e}");
        let e = input_request(&[], &args()).unwrap_err().to_string();
        assert!(e.contains("abort, feed-hold"), "{e}");
        let mut a = args();
        a.probability = Some(0.5);
        assert!(input_request(&["abort".into()], &a).is_err());
        let mut a = args();
        a.cycles = Some(0);
        assert!(input_request(&["abort".into()], &a).is_err());
    }
}
