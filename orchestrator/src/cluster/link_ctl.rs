//! Host-link faults of the daisy chain and the EMCL bus (`mcc fault chain|bus link KIND`):
//! both run in the supervisor (`mcc up`), which holds one [`LinkFaultSlot`] for each and
//! answers `mcc/<cluster>/ctl/orchestrator/link` ([`link_key`]) with a [`LinkCtl`] JSON
//! request → [`CtlReply`]; `status` answers the active faults as a [`LinkFaults`] JSON
//! message (`link_faults` in `mcc status --json`). On several hosts every supervisor
//! answers for its own chain and bus.
//!
//! What each server does with a faulted reply is `mcc_ring::linkfault`'s outcome: the chain
//! (TCP and pty) and the bus write its bytes after its delay; a `reset` closes the TCP
//! connection with RST (on a pty, which has no connection, the reply is simply dropped).

use std::io::Write;
use std::net::TcpStream;
use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use mcc_ring::control::{ctl_key, CtlReply};
use mcc_ring::linkfault::{ActiveLinkFault, LinkFaultSlot, LinkFaultSpec, LinkOutcome, LinkTarget};
use serde::{Deserialize, Serialize};
use zenoh::Wait;

/// Key of the supervisor's link-fault queryable.
pub fn link_key(cluster: &str) -> String {
    ctl_key(cluster, "orchestrator", "link")
}

/// A request to the supervisor's link-fault queryable.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "kebab-case")]
pub enum LinkCtl {
    /// Install `fault` on `target` (`chain` or `bus`).
    Set {
        /// `chain` or `bus`.
        target: String,
        /// The fault.
        fault: LinkFaultSpec,
    },
    /// Remove both faults.
    Clear,
    /// The active faults ([`LinkFaults`] JSON in the reply's message).
    Status,
}

/// The active link faults of the chain and the bus (`link_faults` in `mcc status --json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LinkFaults {
    /// The daisy chain's fault, if any.
    pub chain: Option<ActiveLinkFault>,
    /// The EMCL bus's fault, if any.
    pub bus: Option<ActiveLinkFault>,
}

/// The supervisor's two slots.
#[derive(Debug, Clone, Default)]
pub struct HostLinks {
    /// The daisy chain's.
    pub chain: LinkFaultSlot,
    /// The EMCL bus's.
    pub bus: LinkFaultSlot,
    /// This supervisor serves a bus (a cluster with drives).
    pub has_bus: bool,
}

impl HostLinks {
    /// Answer one request (JSON text).
    pub fn answer(&self, req: &str) -> CtlReply {
        let fail = |message: String| CtlReply { ok: false, message };
        let req: LinkCtl = match serde_json::from_str(req) {
            Ok(r) => r,
            Err(e) => return fail(format!("not a link-fault request: {e}")),
        };
        match req {
            LinkCtl::Set { target, fault } => {
                let (slot, t) = match target.as_str() {
                    "chain" => (&self.chain, LinkTarget::Chain),
                    "bus" if self.has_bus => (&self.bus, LinkTarget::Bus),
                    "bus" => {
                        return fail(
                            "this cluster has no EMCL bus (no [[drives]] in the config)".into(),
                        )
                    }
                    other => return fail(format!("unknown link {other:?} (chain or bus)")),
                };
                if let Err(e) = fault.validate(t) {
                    return fail(e.to_string());
                }
                let message = format!("{target}: link fault {} installed", fault.kind);
                tracing::info!(%target, ?fault, "host-link fault");
                slot.set(fault);
                CtlReply { ok: true, message }
            }
            LinkCtl::Clear => {
                self.chain.clear();
                self.bus.clear();
                CtlReply {
                    ok: true,
                    message: "chain and bus link faults cleared".into(),
                }
            }
            LinkCtl::Status => CtlReply {
                ok: true,
                message: serde_json::to_string(&LinkFaults {
                    chain: self.chain.active(),
                    bus: self.bus.active(),
                })
                .unwrap_or_default(),
            },
        }
    }

    /// Serve [`link_key`] on `session` (answered on zenoh's callback thread: a lock and a
    /// JSON reply).
    pub fn declare(
        &self,
        session: &zenoh::Session,
        cluster: &str,
    ) -> Result<zenoh::query::Queryable<()>> {
        let me = self.clone();
        session
            .declare_queryable(link_key(cluster))
            .callback(move |q| {
                let req = q
                    .payload()
                    .and_then(|p| p.try_to_string().ok().map(|s| s.into_owned()))
                    .unwrap_or_default();
                let body = serde_json::to_vec(&me.answer(&req)).unwrap_or_default();
                let _ = q.reply(q.key_expr().clone(), body).wait();
            })
            .wait()
            .map_err(|e| anyhow!("cannot declare the link-fault queryable: {e}"))
    }
}

/// Write `reply` to a TCP host as `slot`'s fault has it; false when the connection is over
/// (the host is gone, or the fault reset it: zero linger, so the close is an RST).
pub fn write_tcp(slot: &LinkFaultSlot, out: &mut TcpStream, reply: &[u8]) -> bool {
    let o = slot.on_reply(reply);
    late(&o);
    if !o.bytes.is_empty() && out.write_all(&o.bytes).and_then(|()| out.flush()).is_err() {
        return false;
    }
    if o.reset {
        // The close (when the connection's thread ends) is then an RST.
        let _ = crate::cluster::sys::zero_linger(std::os::fd::AsRawFd::as_raw_fd(&*out));
        return false;
    }
    true
}

/// Write `reply` to a pty as `slot`'s fault has it (a reset drops the reply); false when the
/// write failed.
pub fn write_pty(slot: &LinkFaultSlot, out: &mut impl Write, reply: &[u8]) -> bool {
    let o = slot.on_reply(reply);
    late(&o);
    o.bytes.is_empty() || out.write_all(&o.bytes).and_then(|()| out.flush()).is_ok()
}

fn late(o: &LinkOutcome) {
    if o.delay_ms > 0 {
        std::thread::sleep(Duration::from_millis(o.delay_ms));
    }
}

/// Ask every supervisor of the cluster `req`; their replies (at least one, or an error).
pub fn ask(session: &zenoh::Session, cluster: &str, req: &LinkCtl) -> Result<Vec<CtlReply>> {
    let key = link_key(cluster);
    let replies = session
        .get(&key)
        .payload(serde_json::to_string(req)?)
        .consolidation(zenoh::query::ConsolidationMode::None)
        .timeout(Duration::from_secs(2))
        .wait()
        .map_err(|e| anyhow!("query {key}: {e}"))?;
    let mut out = Vec::new();
    while let Ok(r) = replies.recv() {
        let Ok(sample) = r.result() else { continue };
        let b = sample.payload().to_bytes();
        if let Ok(c) = serde_json::from_slice::<CtlReply>(&b) {
            out.push(c);
        }
    }
    if out.is_empty() {
        bail!("no supervisor answered {key} (is the cluster up, and of this version?)");
    }
    Ok(out)
}

/// The active chain/bus link faults (the first supervisor's that has one), for `mcc status`.
pub fn query_status(session: &zenoh::Session, cluster: &str) -> Option<LinkFaults> {
    let replies = ask(session, cluster, &LinkCtl::Status).ok()?;
    let mut all = LinkFaults::default();
    for r in replies {
        if let Ok(f) = serde_json::from_str::<LinkFaults>(&r.message) {
            all.chain = all.chain.or(f.chain);
            all.bus = all.bus.or(f.bus);
        }
    }
    Some(all)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(v: serde_json::Value) -> String {
        v.to_string()
    }

    #[test]
    fn set_status_and_clear_through_the_queryable_request() {
        let links = HostLinks {
            has_bus: true,
            ..HostLinks::default()
        };
        let r = links.answer(&req(serde_json::json!({"op": "set", "target": "bus",
            "fault": {"kind": "bad-checksum", "replies": 3}})));
        assert!(r.ok, "{r:?}");
        let r = links.answer(&req(serde_json::json!({"op": "set", "target": "chain",
            "fault": {"kind": "late", "delay_ms": 30}})));
        assert!(r.ok, "{r:?}");
        let st = links.answer(r#"{"op":"status"}"#);
        let f: LinkFaults = serde_json::from_str(&st.message).unwrap();
        assert_eq!(f.bus.as_ref().map(|b| b.spec.replies), Some(Some(3)));
        assert_eq!(f.chain.as_ref().map(|c| c.spec.delay_ms), Some(30));
        assert_eq!(
            links.bus.on_reply(b"\x02\x01\x64\x06\0\0\0\0\x6d").bytes[8],
            0x6e
        );
        assert!(links.answer(r#"{"op":"clear"}"#).ok);
        assert!(!links.chain.armed() && !links.bus.armed());
    }

    #[test]
    fn refusals_name_the_reason() {
        let links = HostLinks::default();
        let r = links.answer(&req(serde_json::json!({"op": "set", "target": "chain",
            "fault": {"kind": "bad-checksum"}})));
        assert!(!r.ok && r.message.contains("EMCL bus only"), "{r:?}");
        let r = links.answer(&req(serde_json::json!({"op": "set", "target": "bus",
            "fault": {"kind": "short"}})));
        assert!(!r.ok && r.message.contains("no EMCL bus"), "{r:?}");
        let r = links.answer("{}");
        assert!(!r.ok && r.message.contains("link-fault request"), "{r:?}");
    }
}
