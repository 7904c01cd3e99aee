//! Application faults ([`FaultRequest::App`]): the request goes to the member's
//! `ctl/<member>/fault` queryable and is answered by the member's application.

use std::time::Duration;

use anyhow::{bail, Result};
use mcc_ring::control::{ctl_key, FaultRequest};

use crate::cluster::attach::Attached;
use crate::cluster::ctl;

/// Send the application fault `fault` (the application's own JSON request) to `member` of
/// the attached cluster; the member's answer, or an error naming the member and why.
#[allow(dead_code)] // the fault families (axis, link, input) are being built on it
pub fn send_app_fault(a: &Attached, member: &str, fault: serde_json::Value) -> Result<String> {
    if a.cfg.member(member).is_none() {
        bail!(
            "unknown member {member:?} in cluster {:?} (members: {})",
            a.cfg.cluster,
            a.cfg.ring.order.join(", ")
        );
    }
    let payload = serde_json::to_string(&FaultRequest::App { fault })?;
    let key = ctl_key(&a.cfg.cluster, member, "fault");
    let r = ctl::query_ctl(&a.session, &key, Some(payload), Duration::from_secs(2))?;
    if !r.ok {
        bail!("{member}: refused: {}", r.message);
    }
    Ok(r.message)
}
