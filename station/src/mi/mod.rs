//! Station MI-variables: the station's own setup, read and written from a card over the Type 1
//! auxiliary channel (`MS{node},MI{n}[=v]`, `MSR`, `MSW`), numbered as on a 16-axis MACRO
//! Station where it has the variable (station/README.md has the table).
//!
//! The cluster config supplies the start-up (factory) values: `[stations] check` gives
//! MI8/MI9/MI10 and `[stations.plant]` the node variables, so the config and the MI-variables
//! are one thing, never two copies. `MS SAVE` keeps the current values in the station's state
//! file, which start-up and `MS$$$` load instead of the config; `MS$$$***` goes back to the
//! config values.
//!
//! A write is checked as a whole node or global setup: out of range, read-only or unknown
//! refuses with the slave error code and changes nothing.

// The station state file is an I/O edge: `MS SAVE` writes it on the station's save thread
// (`crate::save_io`); start-up and a reset's reload read it (a few KiB; see docs/stations.md,
// "State file").
#[allow(clippy::disallowed_methods, clippy::disallowed_types)]
pub mod persist;

use std::collections::BTreeMap;

use mcc_ring::aux_channel::{slave_error, ValueFormat};
use serde::{Deserialize, Serialize};

use crate::config::NodePlantConfig;
use crate::plant::amplifier::AmpMode;

/// Firmware version reported by MI0 and `MS VER`.
pub const FIRMWARE_VERSION: f64 = 1.104;
/// Firmware date reported by MI1 and `MS DATE`, as YYYYMMDD.
pub const FIRMWARE_DATE: f64 = 19_990_812.0;

/// MI4 station status bits.
pub mod status_bits {
    /// Ring fault latched.
    pub const RING_FAULT: u32 = 0x01;
    /// The latest ring fault was localised to the link directly upstream.
    pub const BREAK_UPSTREAM: u32 = 0x02;
    /// The state file was unreadable at start-up: factory defaults in use.
    pub const CONFIG_ERROR: u32 = 0x04;
    /// The ring fault came from MI6 (too many errors in one second).
    pub const ERRORS_PER_SECOND: u32 = 0x08;
}

/// Global (MS{anynode}) setup values that SAVE keeps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Globals {
    /// MI2 / `MS CONFIG`: user configuration number.
    pub config_number: u32,
    /// MI6: ring errors permitted in one second (0 = no limit).
    pub max_errors_per_second: u32,
    /// MI8: ring check period, ring cycles (0 at reset → 8).
    pub check_period: u32,
    /// MI9: ring error shutdown count (0 at reset → 4).
    pub error_count: u32,
    /// MI10: sync packets required per period (0 = never shut down for lack of syncs).
    pub sync_count: u32,
}

impl Globals {
    /// Start-up values from the config's `check` table.
    pub fn from_check(period: u32, min_syncs: u32, max_errors: u32) -> Self {
        Globals {
            config_number: 0,
            max_errors_per_second: 0,
            check_period: period,
            error_count: max_errors,
            sync_count: min_syncs,
        }
    }

    /// The reset rule: MI8 = 0 becomes 8, MI9 = 0 becomes 4.
    pub fn at_reset(mut self) -> Self {
        if self.check_period == 0 {
            self.check_period = 8;
        }
        if self.error_count == 0 {
            self.error_count = 4;
        }
        self
    }
}

/// Everything SAVE keeps: globals and each servo node's parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Setup {
    /// Global variables.
    pub globals: Globals,
    /// Node variables by node number.
    pub nodes: BTreeMap<u8, NodePlantConfig>,
}

/// Values that are not setup but state: read through MI-variables.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Live {
    /// MI4 status bits.
    pub status: u32,
    /// MI5: ring errors since reset (writable).
    pub errors: u32,
    /// MI12: ring errors in the last full second.
    pub errors_last_second: u32,
    /// MI995: ring configuration (I995 layout).
    pub i995: u32,
    /// MI996: node activation, sync node, master number (I996 layout).
    pub i996: u32,
}

/// How a global MI-variable is stored.
#[derive(Clone, Copy)]
enum G {
    Version,
    Date,
    Config,
    Status,
    Errors,
    MaxPerSecond,
    Period,
    ErrorCount,
    SyncCount,
    LastSecond,
    I995,
    I996,
}

fn global(n: u16) -> Option<G> {
    Some(match n {
        0 => G::Version,
        1 => G::Date,
        2 => G::Config,
        4 => G::Status,
        5 => G::Errors,
        6 => G::MaxPerSecond,
        8 => G::Period,
        9 => G::ErrorCount,
        10 => G::SyncCount,
        12 => G::LastSecond,
        995 => G::I995,
        996 => G::I996,
        _ => return None,
    })
}

/// MI910 (encoder decode control): the plant's encoder is x4 quadrature, clockwise — the
/// only decode it has, so the only value MI910 takes.
const ENCODER_DECODE: u8 = 7;

/// Node variables: MI910 (decode), MI912/MI913 (capture), MI916 (output mode) and the plant
/// block MI950-MI970.
#[derive(Clone, Copy)]
enum N {
    Decode,
    OutputMode,
    CaptureControl,
    CaptureFlag,
    Mode,
    Real(fn(&mut NodePlantConfig) -> &mut f64),
    Flag(fn(&mut NodePlantConfig) -> &mut bool),
}

fn node_var(n: u16) -> Option<N> {
    Some(match n {
        910 => N::Decode,
        912 => N::CaptureControl,
        913 => N::CaptureFlag,
        916 => N::OutputMode,
        950 => N::Mode,
        951 => N::Real(|c| &mut c.torque_full_scale),
        952 => N::Real(|c| &mut c.torque_limit),
        953 => N::Real(|c| &mut c.velocity_full_scale),
        954 => N::Real(|c| &mut c.velocity_gain),
        955 => N::Real(|c| &mut c.pulse_full_scale),
        956 => N::Flag(|c| &mut c.amp_fault),
        957 => N::Flag(|c| &mut c.fault_high_true),
        958 => N::Real(|c| &mut c.inertia),
        959 => N::Real(|c| &mut c.viscous),
        960 => N::Real(|c| &mut c.coulomb),
        961 => N::Real(|c| &mut c.load_torque),
        962 => N::Real(|c| &mut c.counts_per_rev),
        963 => N::Flag(|c| &mut c.sub_count),
        964 => N::Real(|c| &mut c.home_position),
        965 => N::Real(|c| &mut c.home_width),
        966 => N::Real(|c| &mut c.plus_limit),
        967 => N::Real(|c| &mut c.minus_limit),
        968 => N::Flag(|c| &mut c.limits),
        969 => N::Flag(|c| &mut c.user_flag),
        970 => N::Real(|c| &mut c.max_substep),
        _ => return None,
    })
}

/// Is MI `n` a node-specific variable (MS{node})?
pub fn is_node_var(n: u16) -> bool {
    node_var(n).is_some()
}

fn mode_number(m: AmpMode) -> f64 {
    match m {
        AmpMode::Torque => 0.0,
        AmpMode::Velocity => 1.0,
        AmpMode::Pulse => 2.0,
    }
}

/// A whole number in `0..=max`, or the slave's out-of-range code.
fn whole(v: f64, max: u32) -> Result<u32, u16> {
    if v.is_finite() && v.fract() == 0.0 && (0.0..=f64::from(max)).contains(&v) {
        Ok(v as u32)
    } else {
        Err(slave_error::OUT_OF_RANGE)
    }
}

impl Setup {
    /// Read MI `n` through `node` (node-specific variables need a servo node of this
    /// station). The value and how the card prints it, or the slave error code.
    pub fn read(&self, live: &Live, node: u8, n: u16) -> Result<(f64, ValueFormat), u16> {
        use ValueFormat::{Decimal, Hex};
        if let Some(v) = node_var(n) {
            let mut cfg = self
                .nodes
                .get(&node)
                .cloned()
                .ok_or(slave_error::WRONG_NODE)?;
            return Ok(match v {
                N::Decode => (f64::from(ENCODER_DECODE), Decimal),
                N::OutputMode => (f64::from(cfg.output_mode), Decimal),
                N::CaptureControl => (f64::from(cfg.capture_control), Decimal),
                N::CaptureFlag => (f64::from(cfg.capture_flag), Decimal),
                N::Mode => (mode_number(cfg.mode), Decimal),
                N::Real(f) => (*f(&mut cfg), Decimal),
                N::Flag(f) => (f64::from(u8::from(*f(&mut cfg))), Decimal),
            });
        }
        let g = &self.globals;
        Ok(match global(n).ok_or(slave_error::UNKNOWN_VARIABLE)? {
            G::Version => (FIRMWARE_VERSION, ValueFormat::Version),
            G::Date => (FIRMWARE_DATE, ValueFormat::Date),
            G::Config => (f64::from(g.config_number), Decimal),
            G::Status => (f64::from(live.status), Hex),
            G::Errors => (f64::from(live.errors), Decimal),
            G::MaxPerSecond => (f64::from(g.max_errors_per_second), Decimal),
            G::Period => (f64::from(g.check_period), Decimal),
            G::ErrorCount => (f64::from(g.error_count), Decimal),
            G::SyncCount => (f64::from(g.sync_count), Decimal),
            G::LastSecond => (f64::from(live.errors_last_second), Decimal),
            G::I995 => (f64::from(live.i995), Hex),
            G::I996 => (f64::from(live.i996), Hex),
        })
    }

    /// Write MI `n` = `v` through `node`. Returns what changed, or the slave error code (then
    /// nothing changed).
    pub fn write(&mut self, live: &mut Live, node: u8, n: u16, v: f64) -> Result<Changed, u16> {
        if let Some(var) = node_var(n) {
            let mut cfg = self
                .nodes
                .get(&node)
                .cloned()
                .ok_or(slave_error::WRONG_NODE)?;
            match var {
                N::Decode => {
                    if whole(v, 15)? != u32::from(ENCODER_DECODE) {
                        return Err(slave_error::OUT_OF_RANGE);
                    }
                }
                N::OutputMode => cfg.output_mode = whole(v, 3)? as u8,
                N::CaptureControl => cfg.capture_control = whole(v, 15)? as u8,
                N::CaptureFlag => cfg.capture_flag = whole(v, 3)? as u8,
                N::Mode => {
                    cfg.mode = match whole(v, 2)? {
                        0 => AmpMode::Torque,
                        1 => AmpMode::Velocity,
                        _ => AmpMode::Pulse,
                    }
                }
                N::Real(f) => *f(&mut cfg) = v,
                N::Flag(f) => *f(&mut cfg) = whole(v, 1)? == 1,
            }
            cfg.validate().map_err(|_| slave_error::OUT_OF_RANGE)?;
            self.nodes.insert(node, cfg);
            return Ok(Changed::Node(node));
        }
        let g = &mut self.globals;
        match global(n).ok_or(slave_error::UNKNOWN_VARIABLE)? {
            G::Version | G::Date | G::Status | G::LastSecond | G::I995 | G::I996 => {
                return Err(slave_error::READ_ONLY)
            }
            G::Config => g.config_number = whole(v, 0xFF_FFFF)?,
            G::Errors => {
                live.errors = whole(v, 0xFF_FFFF)?;
                return Ok(Changed::Nothing);
            }
            G::MaxPerSecond => g.max_errors_per_second = whole(v, 0x0FFF_FFFF)?,
            G::Period => g.check_period = whole(v, 255)?,
            G::ErrorCount => g.error_count = whole(v, 255)?,
            G::SyncCount => g.sync_count = whole(v, 65_535)?,
        }
        Ok(Changed::Globals)
    }
}

/// What a successful write changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Changed {
    /// Only live state.
    Nothing,
    /// A global setup value (the ring check may need new parameters).
    Globals,
    /// This node's plant parameters.
    Node(u8),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup() -> Setup {
        Setup {
            globals: Globals::from_check(8, 4, 4),
            nodes: [0u8, 1].map(|n| (n, NodePlantConfig::default())).into(),
        }
    }

    #[test]
    fn reads_globals_and_node_variables() {
        let s = setup();
        let live = Live {
            i996: 0x0F_8003,
            ..Default::default()
        };
        assert_eq!(s.read(&live, 0, 0), Ok((1.104, ValueFormat::Version)));
        assert_eq!(s.read(&live, 1, 8), Ok((8.0, ValueFormat::Decimal)));
        assert_eq!(s.read(&live, 0, 9), Ok((4.0, ValueFormat::Decimal)));
        assert_eq!(
            s.read(&live, 0, 996),
            Ok((f64::from(0x0F_8003), ValueFormat::Hex))
        );
        assert_eq!(s.read(&live, 0, 958), Ok((1.25e-5, ValueFormat::Decimal)));
        assert_eq!(s.read(&live, 1, 912), Ok((2.0, ValueFormat::Decimal)));
        assert_eq!(s.read(&live, 0, 910), Ok((7.0, ValueFormat::Decimal)));
        assert_eq!(s.read(&live, 1, 916), Ok((0.0, ValueFormat::Decimal)));
        assert_eq!(s.read(&live, 0, 7), Err(slave_error::UNKNOWN_VARIABLE));
        assert_eq!(s.read(&live, 4, 958), Err(slave_error::WRONG_NODE));
    }

    #[test]
    fn refused_writes_change_nothing() {
        let mut s = setup();
        let mut live = Live::default();
        let before = s.clone();
        for (node, n, v, e) in [
            (0u8, 958u16, -1.0, slave_error::OUT_OF_RANGE), // inertia must be > 0
            (0, 912, 1.0, slave_error::OUT_OF_RANGE),       // index capture: no index channel
            (0, 913, 4.0, slave_error::OUT_OF_RANGE),
            (0, 910, 3.0, slave_error::OUT_OF_RANGE), // x4 clockwise decode only
            (0, 916, 4.0, slave_error::OUT_OF_RANGE),
            (0, 950, 3.0, slave_error::OUT_OF_RANGE),
            (0, 967, 2e6, slave_error::OUT_OF_RANGE), // −limit above +limit
            (0, 8, 256.0, slave_error::OUT_OF_RANGE),
            (0, 9, 2.5, slave_error::OUT_OF_RANGE),
            (0, 0, 2.0, slave_error::READ_ONLY),
            (0, 996, 2.0, slave_error::READ_ONLY),
            (0, 7, 2.0, slave_error::UNKNOWN_VARIABLE),
            (5, 958, 1.0, slave_error::WRONG_NODE),
            (0, 8, f64::NAN, slave_error::OUT_OF_RANGE),
        ] {
            assert_eq!(s.write(&mut live, node, n, v), Err(e), "MI{n}={v}");
        }
        assert_eq!(s, before);
    }

    #[test]
    fn writes_take_effect() {
        let mut s = setup();
        let mut live = Live::default();
        assert_eq!(s.write(&mut live, 1, 958, 2e-5), Ok(Changed::Node(1)));
        assert_eq!(s.nodes[&1].inertia, 2e-5);
        assert_eq!(s.nodes[&0].inertia, 1.25e-5);
        assert_eq!(s.write(&mut live, 0, 950, 1.0), Ok(Changed::Node(0)));
        assert_eq!(s.nodes[&0].mode, AmpMode::Velocity);
        assert_eq!(s.write(&mut live, 0, 968, 0.0), Ok(Changed::Node(0)));
        assert!(!s.nodes[&0].limits);
        assert_eq!(s.write(&mut live, 1, 916, 2.0), Ok(Changed::Node(1)));
        assert_eq!(s.nodes[&1].output_mode, 2);
        assert_eq!(s.read(&live, 1, 916), Ok((2.0, ValueFormat::Decimal)));
        assert_eq!(s.write(&mut live, 1, 910, 7.0), Ok(Changed::Node(1)));
        assert_eq!(s.write(&mut live, 0, 10, 0.0), Ok(Changed::Globals));
        assert_eq!(s.write(&mut live, 0, 5, 17.0), Ok(Changed::Nothing));
        assert_eq!(live.errors, 17);
        assert_eq!(Globals::from_check(0, 0, 0).at_reset().check_period, 8);
        assert_eq!(Globals::from_check(0, 0, 0).at_reset().error_count, 4);
        assert_eq!(Globals::from_check(0, 0, 0).at_reset().sync_count, 0);
    }
}
