//! The drives one process hosts (a station, or a stand-alone drive process): frames from the
//! bus go to every drive (each filters by its address, as on a multi-drop RS485 line), and
//! ring time drives their 1 ms ticks. Pure: time and frames are arguments.

use mcc_contracts::control::emcl::{DriveErrors, DriveStatus};
use mcc_ring::member::RingMember;

use super::codec::FRAME_LEN;
use super::drive::{Answer, Drive, EepromLoad};
use super::motion::Mode;

/// Most ms one advance runs (a longer gap in ring time is skipped, and counted).
pub const MAX_MS_PER_ADVANCE: u64 = 10_000;
/// Longest interval one bound-mode integration covers, ns.
const MAX_DT_NS: u64 = 10_000_000_000;

/// One drive and its name.
#[derive(Clone, Debug)]
pub struct HostedDrive {
    /// Config name.
    pub name: String,
    /// The drive.
    pub drive: Drive,
}

/// The drives of one process.
#[derive(Clone, Debug, Default)]
pub struct DriveHost {
    /// Drives in config order.
    pub drives: Vec<HostedDrive>,
    last_ns: Option<u64>,
    last_ms: Option<u64>,
    /// ms skipped because ring time jumped by more than [`MAX_MS_PER_ADVANCE`].
    pub skipped_ms: u64,
}

impl DriveHost {
    /// A host for these drives.
    pub fn new(drives: Vec<HostedDrive>) -> Self {
        DriveHost {
            drives,
            ..Default::default()
        }
    }

    /// Nodes bound (configured) to drives.
    pub fn nodes(&self) -> Vec<u8> {
        self.drives.iter().filter_map(|d| d.drive.node()).collect()
    }

    /// A frame on the bus: the answers of every drive it addresses (index, answer). More
    /// than one answer is a bus collision (two drives with the same address).
    pub fn frame(&mut self, f: &[u8; FRAME_LEN]) -> Vec<(usize, Answer)> {
        self.drives
            .iter_mut()
            .enumerate()
            .filter_map(|(k, d)| d.drive.handle_frame(f).map(|a| (k, a)))
            .collect()
    }

    /// Advance to ring time `time_ns`: bound drives integrate their node's pulse command
    /// over the elapsed time and write their feedback registers (`ring`: the member's
    /// register image and its ring-fault latch); then every drive runs the whole ms ticks
    /// elapsed.
    pub fn advance(&mut self, time_ns: u64, ring: Option<(&mut RingMember, bool)>) {
        let dt = match self.last_ns {
            Some(t0) if time_ns > t0 => (time_ns - t0).min(MAX_DT_NS),
            _ => 0,
        };
        // Time that went back (the ring renumbered by a restarted sync master) is the new
        // origin: drives go on stepping from it.
        self.last_ns = Some(time_ns);
        if let Some((regs, fault)) = ring {
            for d in &mut self.drives {
                let Some(n) = d.drive.node() else { continue };
                let fb = if d.drive.is_bound() {
                    d.drive.bound_tick(regs.read_regs(n), dt, fault)
                } else {
                    d.drive.bound_tick_idle();
                    d.drive.bound_feedback()
                };
                *regs.write_regs_mut(n) = fb;
            }
        }
        let ms = time_ns / 1_000_000;
        let n = match self.last_ms {
            Some(m) if ms > m => ms - m,
            Some(_) => 0,
            None => 0,
        };
        self.last_ms = Some(self.last_ms.map_or(ms, |m| m.max(ms)));
        let run = n.min(MAX_MS_PER_ADVANCE);
        self.skipped_ms += n - run;
        for d in &mut self.drives {
            d.drive.run_ms(run);
        }
    }

    /// Status of drive `k` (`host`: the process's member name).
    pub fn status(&self, k: usize, host: &str) -> Option<DriveStatus> {
        let h = self.drives.get(k)?;
        Some(h.drive.status(&h.name, host))
    }
}

impl Drive {
    /// Not bound (AP 254 = 0) but on a node: report the enable off.
    pub(crate) fn bound_tick_idle(&mut self) {
        self.bound = Default::default();
    }

    /// The drive's status row (`mcc status`).
    pub fn status(&self, name: &str, host: &str) -> DriveStatus {
        let m = &self.motion;
        let motion = if self.is_bound() {
            "bound"
        } else if self.rfs.is_some() {
            "reference"
        } else {
            match m.mode {
                Mode::Idle => "idle",
                Mode::Velocity if m.target_vel == 0 && m.v == 0 => "idle",
                Mode::Velocity => "velocity",
                Mode::Position => "position",
                Mode::Stopping(_) => "stopping",
            }
        };
        let mode = if self.download.is_some() {
            "download"
        } else if self.is_bound() {
            "bound"
        } else {
            "direct"
        };
        let eeprom = match &self.load_status {
            EepromLoad::Loaded => "loaded".to_string(),
            EepromLoad::Factory => "factory".to_string(),
            EepromLoad::MagicReset => "factory (GP 64 magic reset)".to_string(),
            EepromLoad::Corrupt(e) => format!("CORRUPT ({e}): factory defaults"),
        };
        DriveStatus {
            name: name.to_string(),
            host: host.to_string(),
            address: self.address(),
            secondary_address: self.gp[87] as u8,
            node: self.node,
            mode: mode.into(),
            motion: motion.into(),
            position: m.pos,
            target: m.target_pos,
            velocity: self.actual_velocity(),
            encoder: self.get_ap(209).unwrap_or(0),
            target_reached: self.target_reached(),
            program: self.prog.state.name().into(),
            pc: self.prog.pc,
            program_size: self.eeprom.program.len(),
            errors: DriveErrors {
                pos_error: self.pos_error,
                stall: self.stall_stop,
                eto: self.prog.flags.eto,
                driver_flags: self.driver_flags(),
                left_limit: self.left_limit_active(),
                right_limit: self.right_limit_active(),
                eeprom_locked: self.eeprom_locked(),
            },
            eeprom,
            eeprom_error: None,
            state_file: None,
            frames: self.counters.frames,
            frame_errors: self.counters.errors,
            now_ms: self.now_ms,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emcl::codec::{Instr, Request};
    use crate::emcl::spec::DriveSpec;

    fn host(addrs: &[u8]) -> DriveHost {
        DriveHost::new(
            addrs
                .iter()
                .map(|&a| HostedDrive {
                    name: format!("d{a}"),
                    drive: Drive::new(DriveSpec {
                        address: a,
                        ..DriveSpec::default()
                    }),
                })
                .collect(),
        )
    }

    #[test]
    fn ring_time_drives_whole_ms_ticks() {
        let mut h = host(&[1]);
        let period = 442_733u64;
        for k in 0..10_000u64 {
            h.advance(1_000_000_000 + k * period, None);
        }
        let want = (1_000_000_000 + 9_999 * period) / 1_000_000 - 1000;
        assert_eq!(h.drives[0].drive.now_ms(), want);
        // A jump of a minute runs at most MAX_MS_PER_ADVANCE ticks and counts the rest.
        h.advance(1_000_000_000 + 9_999 * period + 60_000_000_000, None);
        assert_eq!(h.drives[0].drive.now_ms(), want + MAX_MS_PER_ADVANCE);
        assert_eq!(h.skipped_ms, 50_000);
        // Time going backwards runs nothing.
        h.advance(5, None);
        assert_eq!(h.drives[0].drive.now_ms(), want + MAX_MS_PER_ADVANCE);
    }

    #[test]
    fn frames_reach_the_addressed_drive_only() {
        let mut h = host(&[1, 2, 3]);
        let f = Request {
            addr: 2,
            instr: Instr::new(10, 66, 0, 0),
        }
        .to_bytes();
        let a = h.frame(&f);
        assert_eq!(a.len(), 1);
        assert_eq!(a[0].0, 1);
        let none = Request {
            addr: 9,
            instr: Instr::new(10, 66, 0, 0),
        }
        .to_bytes();
        assert!(h.frame(&none).is_empty());
        let st = h.status(2, "station0").unwrap();
        assert_eq!((st.name.as_str(), st.address), ("d3", 3));
    }
}
