//! Loss of light on a member's input: the member downstream of a dead process learns it from
//! zenoh liveliness (`mcc/<cluster>/alive/<upstream>` goes away when the upstream process dies
//! and its transport closes), not from a timeout.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use tracing::{info, warn};
use zenoh::pubsub::Subscriber;
use zenoh::sample::SampleKind;
use zenoh::Wait;

use crate::control::alive_key;

/// Keeps the watch declared; drop it to undeclare.
pub struct UpstreamWatch {
    _subscriber: Subscriber<()>,
    /// Raised while the upstream member is known dead.
    pub dead: Arc<AtomicBool>,
}

impl std::fmt::Debug for UpstreamWatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UpstreamWatch")
            .field("dead", &self.dead)
            .finish_non_exhaustive()
    }
}

/// Watch `upstream`'s liveliness token: the flag rises when a token that was seen goes away
/// and falls when it comes back (a restarted process).
pub fn watch_upstream(
    session: &zenoh::Session,
    cluster: &str,
    upstream: &str,
) -> Result<UpstreamWatch, String> {
    let dead = Arc::new(AtomicBool::new(false));
    let seen = AtomicBool::new(false);
    let flag = Arc::clone(&dead);
    let name = upstream.to_string();
    let subscriber = session
        .liveliness()
        .declare_subscriber(alive_key(cluster, upstream))
        .history(true)
        .callback(move |sample| match sample.kind() {
            SampleKind::Put => {
                seen.store(true, Ordering::Relaxed);
                if flag.swap(false, Ordering::Relaxed) {
                    info!(upstream = %name, "upstream member is back: light on the input");
                }
            }
            SampleKind::Delete => {
                if seen.load(Ordering::Relaxed) && !flag.swap(true, Ordering::Relaxed) {
                    warn!(upstream = %name, "upstream member went away: loss of light on the input");
                }
            }
        })
        .wait()
        .map_err(|e| format!("declare upstream liveliness watch: {e}"))?;
    Ok(UpstreamWatch {
        _subscriber: subscriber,
        dead,
    })
}
