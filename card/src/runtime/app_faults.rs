//! The card's application faults (`FaultRequest::App`, `mcc fault CARD ...`): the request
//! type the card parses, and the host-link fault of its ports ([`LinkFaultSlot`]).
//!
//! JSON: `{"link": {"kind": "no-reply", "probability": 0.5, "seed": 1, "replies": 10,
//! "delay_ms": 0}}` (the spec of `mcc_ring::linkfault`). The active link fault shows in the
//! card's status as `link_fault` (null when none).

use mcc_ring::linkfault::{LinkFaultSlot, LinkFaultSpec, LinkTarget};
use serde::Deserialize;

/// An application fault request to a card.
#[derive(Debug, Clone, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub(crate) enum CardAppFault {
    /// A fault on every host port of the card.
    Link(LinkFaultSpec),
}

/// The application faults a card understands (for refusals).
const FAMILIES: &str = "link";

/// Apply `fault` to the card's link slot: what was done, or why not.
pub(crate) fn apply(link: &LinkFaultSlot, fault: &serde_json::Value) -> Result<String, String> {
    let req: CardAppFault = serde_json::from_value(fault.clone())
        .map_err(|e| format!("not a card fault request ({e}); the card takes: {FAMILIES}"))?;
    match req {
        CardAppFault::Link(spec) => {
            spec.validate(LinkTarget::CardPorts)
                .map_err(|e| e.to_string())?;
            let msg = format!(
                "link fault {} on every host port (probability {}, {})",
                spec.kind,
                spec.probability,
                spec.replies
                    .map_or("until cleared".to_string(), |n| format!("next {n} replies"))
            );
            link.set(spec);
            Ok(msg)
        }
    }
}

/// The status fields of the card's application faults.
pub(crate) fn status(link: &LinkFaultSlot) -> serde_json::Map<String, serde_json::Value> {
    let mut m = serde_json::Map::new();
    m.insert(
        "link_fault".into(),
        serde_json::to_value(link.active()).unwrap_or_default(),
    );
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_link_request_installs_the_fault_and_shows_in_the_status() {
        let slot = LinkFaultSlot::default();
        let m = apply(
            &slot,
            &json!({"link": {"kind": "short", "probability": 0.5, "seed": 3, "replies": 4}}),
        )
        .unwrap();
        assert!(m.contains("short") && m.contains("next 4 replies"), "{m}");
        let st = status(&slot);
        assert_eq!(st["link_fault"]["kind"], "short");
        assert_eq!(st["link_fault"]["replies"], 4);
        assert_eq!(st["link_fault"]["seen"], 0);
        slot.clear();
        assert_eq!(status(&slot)["link_fault"], serde_json::Value::Null);
    }

    #[test]
    fn refusals_name_why_and_the_choices() {
        let slot = LinkFaultSlot::default();
        let e = apply(&slot, &json!({"link": {"kind": "bad-checksum"}})).unwrap_err();
        assert!(e.contains("EMCL bus only") && e.contains("no-reply"), "{e}");
        let e = apply(&slot, &json!({"link": {"kind": "melt"}})).unwrap_err();
        assert!(e.contains("melt") && e.contains("stray-cr"), "{e}");
        let e = apply(&slot, &json!({"melt": {}})).unwrap_err();
        assert!(e.contains("link"), "{e}");
        assert!(!slot.armed());
    }
}
