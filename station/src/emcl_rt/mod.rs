//! The I/O side of the EMCL drives: building drives from the `[[drives]]` config, their
//! EEPROM state files, the zenoh queryables the orchestrator's bus server talks to, the
//! station's ring app with drives, and the stand-alone drive process.

use std::path::{Path, PathBuf};

use mcc_contracts::config::{ClusterConfig, DriveConfig, ParamNumberError};

use crate::emcl::spec::{DriveSpec, SpecError, SwitchKind};
use crate::emcl::{Drive, DriveHost, HostedDrive};

pub mod app;
pub mod persist;
pub mod service;
pub mod standalone;

/// The drive model's description of a configured drive; the error names the key.
pub fn spec_from_config(d: &DriveConfig) -> Result<DriveSpec, DriveSpecError> {
    let m = &d.motor;
    let mut spec = DriveSpec {
        address: d.address,
        right_limit: m.limits.then_some(m.right_limit),
        left_limit: m.limits.then_some(m.left_limit),
        switch_kind: if m.switches == "normally_closed" {
            SwitchKind::NormallyClosed
        } else {
            SwitchKind::NormallyOpen
        },
        home_position: m.home_position,
        home_width: m.home_width,
        index_offset: m.index_offset,
        hard_stop_minus: m.hard_stop_minus,
        hard_stop_plus: m.hard_stop_plus,
        load: m.load,
        inputs: [0, 1, 2].map(|k| d.io.inputs.get(k).copied().unwrap_or(0) == 1),
        analog: d.io.analog,
        loopback: d.io.loopback,
        enable_in: d.io.enable_in == 1,
        reset_in: d.io.reset_in == 1,
        pulse_full_scale: d.pulse_full_scale,
        ..DriveSpec::default()
    };
    let ax = &mut spec.axis_defaults;
    ax.insert(202, i32::from(m.full_steps));
    ax.insert(6, i32::from(m.run_current));
    ax.insert(7, i32::from(m.standby_current));
    ax.insert(4, m.max_velocity);
    ax.insert(5, m.max_acceleration);
    ax.insert(210, m.encoder_lines);
    if d.node.is_some() {
        // Bound drives ship in step/direction mode (AP 254 = 1: step on the rising edge).
        ax.insert(254, 1);
    }
    for (n, v) in DriveConfig::overrides(&d.axis).map_err(DriveSpecError::Axis)? {
        spec.axis_defaults.insert(n, v);
    }
    for (n, v) in DriveConfig::overrides(&d.globals).map_err(DriveSpecError::Globals)? {
        spec.global_defaults.insert(n, v);
    }
    spec.validate()?;
    Ok(spec)
}

/// A configured drive the drive model refuses: which override or key.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DriveSpecError {
    /// An `axis` override whose key is no parameter number.
    #[error("axis: {0}")]
    Axis(ParamNumberError),
    /// A `globals` override whose key is no parameter number.
    #[error("globals: {0}")]
    Globals(ParamNumberError),
    /// A value the drive model refuses.
    #[error(transparent)]
    Spec(#[from] SpecError),
}

/// A drive of the cluster config the drive model refuses, and which drive.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DriveConfigError {
    /// Found checking the whole config ([`check_drives`]): the drive's index and name.
    #[error("config: drives[{index}] ({name}): {problem}")]
    InConfig {
        /// Position in `[[drives]]`.
        index: usize,
        /// The drive's name.
        name: String,
        /// What is wrong.
        problem: DriveSpecError,
    },
    /// Found building a host's drives ([`build_host`]): the drive's name.
    #[error("drives.{name}: {problem}")]
    Hosted {
        /// The drive's name.
        name: String,
        /// What is wrong.
        problem: DriveSpecError,
    },
}

/// Check every drive's parameters against the drive model (what the config parser cannot
/// know); the error names the drive.
pub fn check_drives(cfg: &ClusterConfig) -> Result<(), DriveConfigError> {
    for (index, d) in cfg.drives.iter().enumerate() {
        spec_from_config(d).map_err(|problem| DriveConfigError::InConfig {
            index,
            name: d.name.clone(),
            problem,
        })?;
    }
    Ok(())
}

/// Where drive `d` keeps its EEPROM image: its `state_file`, else
/// `<run dir>/drives/<name>.eeprom` (the run directory is the folder of the resolved config;
/// `mcc down` removes only its own files there, so the image survives).
pub fn state_file(d: &DriveConfig, run_dir: &Path) -> PathBuf {
    d.state_file
        .clone()
        .unwrap_or_else(|| run_dir.join("drives").join(format!("{}.eeprom", d.name)))
}

/// The drives hosted by process `host` (a station's name, or a stand-alone drive's), powered
/// up from their state files. Returns the host, each drive's state file, and a line per
/// drive whose image could not be used (to be logged).
pub fn build_host(
    cfg: &ClusterConfig,
    host: &str,
    run_dir: &Path,
) -> Result<(DriveHost, Vec<PathBuf>, Vec<String>), DriveConfigError> {
    let mut drives = Vec::new();
    let mut files = Vec::new();
    let mut notes = Vec::new();
    for d in cfg.drives.iter().filter(|d| d.host() == host) {
        let spec = spec_from_config(d).map_err(|problem| DriveConfigError::Hosted {
            name: d.name.clone(),
            problem,
        })?;
        let path = state_file(d, run_dir);
        let image = persist::load(&path);
        let bytes = match &image {
            Ok(b) => b.as_deref(),
            Err(e) => {
                notes.push(format!(
                    "drive {}: cannot read {}: {e}; factory defaults",
                    d.name,
                    path.display()
                ));
                None
            }
        };
        let drive = Drive::power_up(spec, bytes, d.node);
        if let crate::emcl::drive::EepromLoad::Corrupt(why) = drive.eeprom_load() {
            let kept = persist::keep_corrupt(&path);
            notes.push(format!(
                "drive {}: EEPROM image {} is corrupt ({why}); factory defaults in use{}",
                d.name,
                path.display(),
                kept.map(|p| format!(", the bad file was kept as {}", p.display()))
                    .unwrap_or_default()
            ));
        }
        drives.push(HostedDrive {
            name: d.name.clone(),
            drive,
        });
        files.push(path);
    }
    Ok((DriveHost::new(drives), files, notes))
}
