//! Drive rows of `mcc status`: each drive host's `emcl/<host>/status` queryable, in config
//! order; a drive whose host does not answer is listed as unreachable.

use std::fmt::Write as _;
use std::time::Duration;

use mcc_contracts::config::ClusterConfig;
use mcc_contracts::control::emcl::{status_key, DriveStatus};
use zenoh::Wait;

use crate::cluster::status::ClusterStatus;

/// Largest status reply accepted, bytes.
const MAX_REPLY: usize = 1 << 20;

/// Every configured drive's status (`None`: its host did not answer within `timeout`).
pub fn query(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    timeout: Duration,
) -> Vec<(String, Option<DriveStatus>)> {
    let hosts = cfg.drive_hosts();
    let gets: Vec<_> = hosts
        .iter()
        .map(|h| {
            session
                .get(status_key(&cfg.cluster, h))
                .timeout(timeout)
                .wait()
        })
        .collect();
    let mut rows: Vec<DriveStatus> = Vec::new();
    for get in gets {
        let Ok(replies) = get else { continue };
        let Ok(reply) = replies.recv() else { continue };
        let Ok(sample) = reply.result() else { continue };
        if sample.payload().len() > MAX_REPLY {
            continue;
        }
        let b = sample.payload().to_bytes();
        if let Ok(v) = serde_json::from_slice::<Vec<DriveStatus>>(&b) {
            rows.extend(v);
        }
    }
    cfg.drives
        .iter()
        .map(|d| {
            let s = rows.iter().find(|r| r.name == d.name).cloned();
            (d.name.clone(), s)
        })
        .collect()
}

/// One row of a drive that did not answer.
fn unreachable(cfg: &ClusterConfig, name: &str) -> DriveStatus {
    let d = cfg.drive(name);
    DriveStatus {
        name: name.to_string(),
        host: d.map(|d| d.host().to_string()).unwrap_or_default(),
        address: d.map(|d| d.address).unwrap_or(0),
        node: d.and_then(|d| d.node),
        mode: "unreachable".into(),
        ..DriveStatus::default()
    }
}

/// Fill `doc.drives` from the drive hosts.
pub fn enrich(session: &zenoh::Session, cfg: &ClusterConfig, doc: &mut ClusterStatus) {
    doc.drives = query(session, cfg, Duration::from_millis(1500))
        .into_iter()
        .map(|(n, s)| s.unwrap_or_else(|| unreachable(cfg, &n)))
        .collect();
}

/// The error flags of a row as words (`-` when none).
pub fn flags_text(s: &DriveStatus) -> String {
    let e = &s.errors;
    let mut w = Vec::new();
    for (on, name) in [
        (e.pos_error, "POS_ERROR"),
        (e.stall, "STALL"),
        (e.eto, "ETO"),
        (e.left_limit, "LEFT_LIMIT"),
        (e.right_limit, "RIGHT_LIMIT"),
        (e.eeprom_locked, "EEPROM_LOCKED"),
        (e.driver_flags & 0x7E != 0, "DRIVER_ERROR"),
        (s.eeprom_error.is_some(), "EEPROM_WRITE_FAILED"),
    ] {
        if on {
            w.push(name);
        }
    }
    if w.is_empty() {
        "-".into()
    } else {
        w.join(",")
    }
}

/// The drive lines of the status table.
pub fn render(doc: &ClusterStatus) -> String {
    let mut o = String::new();
    if let Some(b) = &doc.emcl_bus {
        let pty = doc.emcl_bus_pty.as_deref().unwrap_or("-");
        let _ = writeln!(o, "emcl bus {b}  pty {pty}");
    }
    if doc.drives.is_empty() {
        return o;
    }
    let _ = writeln!(
        o,
        "{:<12} {:>4} {:<12} {:<9} {:<9} {:>11} {:>9} {:<6} {:>5}  {:<22} eeprom",
        "drive", "addr", "host", "mode", "motion", "position", "velocity", "prog", "pc", "flags"
    );
    for s in &doc.drives {
        let _ = writeln!(
            o,
            "{:<12} {:>4} {:<12} {:<9} {:<9} {:>11} {:>9} {:<6} {:>5}  {:<22} {}",
            s.name,
            s.address,
            s.host,
            s.mode,
            s.motion,
            s.position,
            s.velocity,
            s.program,
            s.pc,
            flags_text(s),
            s.eeprom
        );
    }
    o
}

/// Wait until every drive answers its status query (stations answer once locked; a
/// stand-alone drive process once it has declared its queryables).
pub fn wait_ready(
    session: &zenoh::Session,
    cfg: &ClusterConfig,
    timeout: Duration,
) -> anyhow::Result<()> {
    if cfg.drives.is_empty() {
        return Ok(());
    }
    let start = std::time::Instant::now();
    loop {
        let rows = query(session, cfg, Duration::from_millis(500));
        let missing: Vec<&str> = rows
            .iter()
            .filter(|(_, s)| s.is_none())
            .map(|(n, _)| n.as_str())
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        if start.elapsed() >= timeout {
            anyhow::bail!("EMCL drives did not answer: {}", missing.join(", "));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// `mcc up`'s lines about the bus and its drives.
pub fn print_ready(cfg: &ClusterConfig, info: &crate::cluster::rundir::SupervisorInfo) {
    let Some(bus) = &info.emcl_bus else { return };
    let drives: Vec<String> = cfg
        .drives
        .iter()
        .map(|d| {
            let node = d.node.map(|n| format!(" node {n}")).unwrap_or_default();
            format!("{} @{} on {}{node}", d.name, d.address, d.host())
        })
        .collect();
    match &info.emcl_bus_pty {
        Some(p) => println!("  emcl bus {bus}  pty {p}  ({})", drives.join(", ")),
        None => println!("  emcl bus {bus}  ({})", drives.join(", ")),
    }
}
