//! The check a process makes before it joins a cluster's ring (issue 15): every host share
//! that answers under this cluster's name must run the same config (SHA3-256 digest of the
//! resolved config). A cluster of the same name run with another config on the same zenoh
//! network (a shared router, a mistyped endpoint) is another cluster: the process refuses
//! to join it rather than mix its frames into a foreign ring.

use std::time::Duration;

use zenoh::Wait;

use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::hosts::{host_key, HostInfo};

/// How long the shares have to answer.
const ASK: Duration = Duration::from_millis(1500);
/// Largest info reply read.
const MAX_INFO: usize = 2 << 20;

/// The shares of `cluster` that answer now.
pub fn shares(session: &zenoh::Session, cluster: &str, timeout: Duration) -> Vec<HostInfo> {
    // Every share answers (not only the best-matching queryable), each reply kept.
    let Ok(replies) = session
        .get(host_key(cluster, "*", "info"))
        .target(zenoh::query::QueryTarget::All)
        .consolidation(zenoh::query::ConsolidationMode::None)
        .timeout(timeout)
        .wait()
    else {
        return Vec::new();
    };
    let mut out = Vec::new();
    while let Ok(r) = replies.recv() {
        let Ok(sample) = r.result() else { continue };
        if sample.payload().len() > MAX_INFO {
            continue;
        }
        let bytes = sample.payload().to_bytes();
        if let Ok(info) = serde_json::from_slice::<HostInfo>(&bytes) {
            if info.cluster == cluster {
                out.push(info);
            }
        }
    }
    out
}

/// Refuse when a share of this cluster runs another config.
pub fn check(session: &zenoh::Session, config: &ClusterConfig) -> anyhow::Result<()> {
    let mine = config.digest();
    for s in shares(session, &config.cluster, ASK) {
        if s.digest != mine {
            anyhow::bail!(
                "refusing to join ring {} of cluster {}: host {} (machine {}, supervisor pid {}) runs it with another config (digest {} here, {} there)",
                config.ring.name,
                config.cluster,
                s.host,
                s.machine,
                s.pid,
                short(&mine),
                short(&s.digest)
            );
        }
    }
    Ok(())
}

/// The first 12 hex digits of a digest (for messages).
pub fn short(digest: &str) -> &str {
    digest.get(..12).unwrap_or(digest)
}
