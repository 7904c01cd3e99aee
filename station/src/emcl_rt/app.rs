//! A station with drives: the station's own ring application runs first, then the drives
//! advance to the tick's ring time (bound drives read their node's command registers and
//! write its feedback registers, which the station app does not serve).

use mcc_ring::core::{CheckReport, RingApp, RingControl};
use mcc_ring::member::RingMember;

use super::service::{EmclService, Shared};

/// The station's ring app plus the drives it hosts.
pub struct DriveStationApp<A> {
    inner: A,
    shared: Shared,
    _service: Option<EmclService>,
}

impl<A> std::fmt::Debug for DriveStationApp<A> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DriveStationApp").finish_non_exhaustive()
    }
}

impl<A: RingApp> DriveStationApp<A> {
    /// Wrap `inner`; `service` (the queryables) lives as long as the app.
    pub fn new(inner: A, shared: Shared, service: Option<EmclService>) -> Self {
        DriveStationApp {
            inner,
            shared,
            _service: service,
        }
    }

    /// The wrapped app.
    pub fn inner(&self) -> &A {
        &self.inner
    }
}

impl<A: RingApp> RingApp for DriveStationApp<A> {
    fn tick(&mut self, cycle: u64, time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        self.inner.tick(cycle, time_ns, regs, ring_fault);
        let mut st = self.shared.lock().unwrap_or_else(|e| e.into_inner());
        st.host.advance(time_ns, Some((regs, ring_fault)));
    }

    fn take_ring_reset(&mut self) -> bool {
        self.inner.take_ring_reset()
    }

    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        self.inner.sync_ring(ring);
    }

    fn on_check(&mut self, report: &CheckReport) {
        self.inner.on_check(report);
    }

    fn status_extra(&self) -> serde_json::Map<String, serde_json::Value> {
        self.inner.status_extra()
    }

    /// The station's own faults (axis, power loss) go to the wrapped app.
    fn app_fault(&mut self, fault: &serde_json::Value) -> Result<String, String> {
        self.inner.app_fault(fault)
    }

    fn clear_app_faults(&mut self) {
        self.inner.clear_app_faults();
    }
}

/// Nodes of station `station` that drives are bound to (the station app must not serve them).
pub fn bound_nodes(cfg: &mcc_contracts::config::ClusterConfig, station: &str) -> Vec<u8> {
    cfg.drives
        .iter()
        .filter(|d| d.station.as_deref() == Some(station))
        .filter_map(|d| d.node)
        .collect()
}

/// Give station `ctx.name` its drives: power them up from their state files (in
/// `run_dir/drives` unless configured), declare the EMCL queryables, and wrap `inner`. The
/// drive names go into the member status `extra` (`drives`).
pub fn with_drives<A: RingApp>(
    ctx: &mcc_ring::runtime::process::MemberContext,
    inner: A,
    extra: &mut serde_json::Map<String, serde_json::Value>,
    run_dir: &std::path::Path,
) -> anyhow::Result<DriveStationApp<A>> {
    let (host, files, notes) =
        super::build_host(&ctx.config, &ctx.name, run_dir).map_err(anyhow::Error::msg)?;
    for n in &notes {
        tracing::warn!("{n}");
        eprintln!("mcc-station {}: {n}", ctx.name);
    }
    let names: Vec<String> = host.drives.iter().map(|d| d.name.clone()).collect();
    let n = files.len();
    let shared = std::sync::Arc::new(std::sync::Mutex::new(super::service::HostState {
        host,
        files,
        errors: vec![None; n],
        member: ctx.name.clone(),
    }));
    let service = if n > 0 {
        Some(
            EmclService::start(
                &ctx.session,
                &ctx.config.cluster,
                &ctx.name,
                std::sync::Arc::clone(&shared),
            )
            .map_err(|e| anyhow::anyhow!("declaring the EMCL queryables: {e}"))?,
        )
    } else {
        None
    };
    extra.insert("drives".into(), serde_json::json!(names));
    Ok(DriveStationApp::new(inner, shared, service))
}
