//! The ring check of spec §6.8 (cards: I1001, I1004, I1005, RTI = I8+1 servo cycles) and the
//! station-side equivalent, as one component.
//!
//! Decision on the spec's \[GAP\]: the error-count test fires **at once**, on the check (RTI)
//! where `errors` reaches the shutdown count, not at the end of the period ("the safer
//! reading"); the period's counters then restart. The sync-count and "error on every check"
//! tests can only be made at the end of a period.

use crate::status::{RingStatus, STATUS_BYTE_VIOLATION, STATUS_ERRORS, STATUS_SYNC_RECEIVED};

/// Why a ring check declared a ring fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CheckFault {
    /// `errors` checks saw at least one receive error; the shutdown count is `limit`.
    #[error("ring errors: {errors} in the check period (shutdown count {limit})")]
    Errors {
        /// Checks that saw an error.
        errors: u32,
        /// Shutdown count (I1004).
        limit: u32,
    },
    /// Fewer sync packets than required in one check period.
    #[error("sync packets: {syncs} in the check period, {required} required")]
    MissingSyncs {
        /// Checks that saw a sync packet.
        syncs: u32,
        /// Required count (I1005).
        required: u32,
    },
    /// Every check of the period saw an error.
    #[error("an error on every one of {checks} checks")]
    ErrorEveryCheck {
        /// Checks in the period.
        checks: u32,
    },
    /// A card's sync-lock node (I996 bits 16-19) is not activated: an error at once (spec
    /// §6.3). Reported by [`crate::core::MemberCore::run_check`].
    #[error("sync node {node} is not activated in I996")]
    SyncNodeInactive {
        /// The sync node.
        node: u8,
    },
}

/// Parameters of a ring check, in servo cycles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CheckParams {
    /// Check period in servo cycles (I1001); 0 = no checking.
    pub period: u32,
    /// Servo cycles per check (RTI = I8+1); at least 1.
    pub rti: u32,
    /// Fault when this many checks saw an error (I1004).
    pub error_limit: u32,
    /// Fault when fewer checks than this saw a sync packet (I1005).
    pub sync_min: u32,
}

/// Station defaults, as a 16-axis MACRO Station's MI8/MI9/MI10: a check every 8 cycles
/// needing 4 sync packets, a fault on 4 errors.
pub const STATION_DEFAULTS: CheckParams = CheckParams {
    period: 8,
    rti: 1,
    error_limit: 4,
    sync_min: 4,
};

/// The ring check state machine (spec §6.8 pseudo-code).
#[derive(Clone, Debug)]
pub struct RingCheck {
    params: CheckParams,
    armed: bool,
    servo_count: u32,
    errors: u32,
    syncs: u32,
    checks: u32,
    elapsed: u32,
    last_period_ok: Option<bool>,
    total_errors: u64,
    byte_violations: u32,
    fault_byte_violations: u32,
    last_status: u32,
    just_checked: bool,
}

impl RingCheck {
    /// A card's check as set up at reset from I1001, I1004, I1005 and I8: armed only if
    /// I1001 > 0; I1004 = 0 and I1005 = 0 become 2. Values are clamped to their ranges
    /// (I1001, I1004: 0-255; I1005: 0-65,535).
    pub fn card(i1001: u32, i1004: u32, i1005: u32, i8: u32) -> Self {
        let i1004 = match i1004.min(255) {
            0 => 2,
            v => v,
        };
        let i1005 = match i1005.min(65_535) {
            0 => 2,
            v => v,
        };
        Self::with_params(CheckParams {
            period: i1001.min(255),
            rti: i8.saturating_add(1),
            error_limit: i1004,
            sync_min: i1005,
        })
    }

    /// A MACRO station's check from MI8 (period, ring cycles), MI10 (sync packets required;
    /// 0 = never a fault for lack of them) and MI9 (errors that make a fault), with a check
    /// every cycle. MI8 = 0 and MI9 = 0 become 8 and 4, as at a station's reset.
    pub fn station(mi8: u32, mi10: u32, mi9: u32) -> Self {
        Self::with_params(Self::station_params(mi8, mi10, mi9))
    }

    /// The parameters [`RingCheck::station`] uses.
    pub fn station_params(mi8: u32, mi10: u32, mi9: u32) -> CheckParams {
        CheckParams {
            period: if mi8 == 0 { 8 } else { mi8.min(255) },
            rti: 1,
            error_limit: if mi9 == 0 { 4 } else { mi9.min(255) },
            sync_min: mi10.min(65_535),
        }
    }

    /// A check with explicit parameters (armed when `period > 0`).
    pub fn with_params(params: CheckParams) -> Self {
        let params = CheckParams {
            rti: params.rti.max(1),
            ..params
        };
        RingCheck {
            params,
            armed: params.period > 0,
            servo_count: 0,
            errors: 0,
            syncs: 0,
            checks: 0,
            elapsed: 0,
            last_period_ok: None,
            total_errors: 0,
            byte_violations: 0,
            fault_byte_violations: 0,
            last_status: 0,
            just_checked: false,
        }
    }

    /// The latest [`RingCheck::on_servo_cycle`] read the status bits (an RTI check ran).
    pub fn just_checked(&self) -> bool {
        self.just_checked
    }

    /// Replace every parameter at run time (a station's MI8/MI9/MI10); re-arms when the
    /// period is > 0 and restarts the period's counts.
    pub fn set_params(&mut self, params: CheckParams) {
        let total = self.total_errors;
        let ok = self.last_period_ok;
        *self = Self::with_params(params);
        self.total_errors = total;
        self.last_period_ok = ok;
    }

    /// Status bits read by the latest check (0 before any).
    pub fn last_status(&self) -> u32 {
        self.last_status
    }

    /// Checks with a byte violation in the period that declared the latest fault (the
    /// station's break localisation compares them with the period's error count).
    pub fn fault_byte_violations(&self) -> u32 {
        self.fault_byte_violations
    }

    /// Checking is active (I1001 was > 0 at reset).
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// Current parameters.
    pub fn params(&self) -> CheckParams {
        self.params
    }

    /// Change I1001 at run time: takes effect at once if checking was armed at reset,
    /// otherwise only at the next [`RingCheck::reset`] (`$$$` after SAVE).
    pub fn set_period(&mut self, i1001: u32) {
        self.params.period = i1001.min(255);
    }

    /// Change I1004 at run time (no 0 → 2 substitution outside reset).
    pub fn set_error_limit(&mut self, i1004: u32) {
        self.params.error_limit = i1004.min(255);
    }

    /// Change I1005 at run time (no 0 → 2 substitution outside reset).
    pub fn set_sync_min(&mut self, i1005: u32) {
        self.params.sync_min = i1005.min(65_535);
    }

    /// Reset (`$$$`): re-arm from the current period, apply the 0 → 2 defaults, clear counts.
    pub fn reset(&mut self) {
        if self.params.error_limit == 0 {
            self.params.error_limit = 2;
        }
        if self.params.sync_min == 0 {
            self.params.sync_min = 2;
        }
        let total = self.total_errors;
        *self = Self::with_params(self.params);
        self.total_errors = total;
    }

    /// Outcome of the last completed period: `Some(true)` passed, `Some(false)` faulted.
    pub fn last_period_ok(&self) -> Option<bool> {
        self.last_period_ok
    }

    /// Checks that saw an error since start (X:$07A1, "MACRO ring errors since reset").
    pub fn total_errors(&self) -> u64 {
        self.total_errors
    }

    /// Call once per servo cycle. Every `rti` servo cycles it reads and clears the status
    /// bits (one read per RTI) and counts at most one error and one sync.
    pub fn on_servo_cycle(&mut self, status: &mut RingStatus) -> Option<CheckFault> {
        self.just_checked = false;
        if !self.armed || self.params.period == 0 {
            return None;
        }
        self.servo_count += 1;
        if self.servo_count < self.params.rti {
            return None;
        }
        self.servo_count = 0;
        let s = status.read_and_clear();
        self.last_status = s;
        self.just_checked = true;
        if s & STATUS_ERRORS != 0 {
            self.errors += 1;
            self.total_errors += 1;
            if s & STATUS_BYTE_VIOLATION != 0 {
                self.byte_violations += 1;
            }
        }
        if s & STATUS_SYNC_RECEIVED != 0 {
            self.syncs += 1;
        }
        self.checks += 1;
        self.elapsed += self.params.rti;
        let p = self.params;
        let fault = if self.errors >= p.error_limit {
            Some(CheckFault::Errors {
                errors: self.errors,
                limit: p.error_limit,
            })
        } else if self.elapsed < p.period {
            return None;
        } else if self.syncs < p.sync_min {
            Some(CheckFault::MissingSyncs {
                syncs: self.syncs,
                required: p.sync_min,
            })
        } else if self.checks > 0 && self.errors == self.checks {
            Some(CheckFault::ErrorEveryCheck {
                checks: self.checks,
            })
        } else {
            None
        };
        if fault.is_some() {
            self.fault_byte_violations = self.byte_violations;
        }
        self.errors = 0;
        self.syncs = 0;
        self.checks = 0;
        self.elapsed = 0;
        self.byte_violations = 0;
        self.last_period_ok = Some(fault.is_none());
        fault
    }
}

/// Ring-check parameters of a card from its config: its profile's ring-check keys
/// ([`mcc_contracts::config::ring_check_keys`]: PMAC2/Power I1001/I1004/I1005, Turbo I80/I81/I82)
/// and I8; unset keys as in [`card_check`].
pub fn card_config_check(c: &mcc_contracts::config::CardConfig) -> RingCheck {
    let get = |v: Option<f64>, d: u32| v.map_or(d, |v| v.clamp(0.0, 65_535.0) as u32);
    let [period, errors, syncs] = c.ring_check();
    RingCheck::card(
        get(period, 0),
        get(errors, 2),
        get(syncs, 4),
        get(c.ivar("I8"), 2),
    )
}

/// Ring-check parameters of a card from its I-variable overrides in PMAC2 numbering (I1001,
/// I1004, I1005, I8).
pub fn card_check(
    ivars: &std::collections::BTreeMap<String, mcc_contracts::config::IVarValue>,
) -> RingCheck {
    let get = |k: &str, d: u32| {
        ivars
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(k))
            .map(|(_, v)| v.as_f64().clamp(0.0, 65_535.0) as u32)
            .unwrap_or(d)
    };
    RingCheck::card(
        get("I1001", 0),
        get("I1004", 2),
        get("I1005", 4),
        get("I8", 2),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::status::ErrorClass;

    fn run(
        check: &mut RingCheck,
        cycles: u32,
        mut each: impl FnMut(u32, &mut RingStatus),
    ) -> Vec<(u32, CheckFault)> {
        let mut st = RingStatus::new();
        let mut out = Vec::new();
        for c in 1..=cycles {
            each(c, &mut st);
            if let Some(f) = check.on_servo_cycle(&mut st) {
                out.push((c, f));
            }
        }
        out
    }

    #[test]
    fn reset_defaults_and_arming() {
        let c = RingCheck::card(0, 0, 0, 2);
        assert!(!c.armed());
        assert_eq!(
            c.params(),
            CheckParams {
                period: 0,
                rti: 3,
                error_limit: 2,
                sync_min: 2
            }
        );
        let mut c = RingCheck::card(0, 0, 0, 2);
        c.set_period(9);
        assert!(!c.armed(), "0 -> >0 needs a reset");
        c.reset();
        assert!(c.armed());
        assert_eq!(RingCheck::card(300, 999, 70_000, 0).params().period, 255);
    }

    #[test]
    fn missing_syncs_fault_at_end_of_period() {
        // I1001=8, I1005=4, I8=0: no sync at all -> fault on servo cycle 8, then every 8.
        let mut c = RingCheck::card(8, 0, 4, 0);
        let f = run(&mut c, 20, |_, _| {});
        assert_eq!(
            f,
            vec![
                (
                    8,
                    CheckFault::MissingSyncs {
                        syncs: 0,
                        required: 4
                    }
                ),
                (
                    16,
                    CheckFault::MissingSyncs {
                        syncs: 0,
                        required: 4
                    }
                )
            ]
        );
    }

    #[test]
    fn syncs_counted_once_per_rti() {
        // I8=2 (RTI = 3 servo cycles), I1001 = 9 -> 3 checks per period; a sync every cycle
        // counts 3, so I1005 = 4 can never be met ("a larger value means always fails").
        let mut c = RingCheck::card(9, 0, 4, 2);
        let f = run(&mut c, 9, |_, s| s.set_sync_received());
        assert_eq!(
            f,
            vec![(
                9,
                CheckFault::MissingSyncs {
                    syncs: 3,
                    required: 4
                }
            )]
        );
        let mut c = RingCheck::card(9, 0, 3, 2);
        assert!(run(&mut c, 90, |_, s| s.set_sync_received()).is_empty());
        assert_eq!(c.last_period_ok(), Some(true));
    }

    #[test]
    fn errors_fire_at_once() {
        // I1004 = 2, errors on every cycle, I8 = 0, I1001 = 8: fault at the 2nd check.
        let mut c = RingCheck::card(8, 2, 1, 0);
        let f = run(&mut c, 3, |_, s| {
            s.set_sync_received();
            s.record(ErrorClass::Checksum);
        });
        assert_eq!(
            f,
            vec![(
                2,
                CheckFault::Errors {
                    errors: 2,
                    limit: 2
                }
            )]
        );
        assert_eq!(c.total_errors(), 3);
    }

    #[test]
    fn many_errors_in_one_rti_count_once() {
        let mut c = RingCheck::card(8, 2, 1, 3); // RTI = 4 cycles, 2 checks per period
                                                 // errors on cycles 1-3 (one RTI), none after: 1 error, 2 checks -> no fault.
        let f = run(&mut c, 8, |n, s| {
            s.set_sync_received();
            if n <= 3 {
                s.record(ErrorClass::ByteViolation);
            }
        });
        assert!(f.is_empty(), "{f:?}");
        assert_eq!(c.total_errors(), 1);
    }

    #[test]
    fn error_on_every_check_rule() {
        // I1004 = 5 can't be reached with 4 checks, but errors on all 4 checks is a fault.
        let mut c = RingCheck::card(4, 5, 1, 0);
        let f = run(&mut c, 4, |_, s| {
            s.set_sync_received();
            s.record(ErrorClass::Overrun);
        });
        assert_eq!(f, vec![(4, CheckFault::ErrorEveryCheck { checks: 4 })]);
        // 3 errors out of 4 checks: healthy.
        let mut c = RingCheck::card(4, 5, 1, 0);
        assert!(run(&mut c, 4, |n, s| {
            s.set_sync_received();
            if n != 2 {
                s.record(ErrorClass::Overrun);
            }
        })
        .is_empty());
    }

    #[test]
    fn station_defaults() {
        let mut c = RingCheck::with_params(STATION_DEFAULTS);
        // 4 syncs and 3 errors in 8 cycles: healthy.
        assert!(run(&mut c, 8, |n, s| {
            if n % 2 == 0 {
                s.set_sync_received();
            } else if n < 7 {
                s.record(ErrorClass::Underrun);
            }
        })
        .is_empty());
        // 3 syncs: fault at cycle 8.
        let mut c = RingCheck::station(8, 4, 4);
        let f = run(&mut c, 8, |n, s| {
            if n <= 3 {
                s.set_sync_received()
            }
        });
        assert_eq!(
            f,
            vec![(
                8,
                CheckFault::MissingSyncs {
                    syncs: 3,
                    required: 4
                }
            )]
        );
        // MI9 = 4 errors: fault at once on the 4th; 3 of them byte violations.
        let mut c = RingCheck::station(8, 4, 4);
        let f = run(&mut c, 4, |n, s| {
            s.set_sync_received();
            s.record(if n == 2 {
                ErrorClass::Checksum
            } else {
                ErrorClass::ByteViolation
            });
        });
        assert_eq!(
            f,
            vec![(
                4,
                CheckFault::Errors {
                    errors: 4,
                    limit: 4
                }
            )]
        );
        assert_eq!(c.fault_byte_violations(), 3);
        // MI10 = 0: never a fault for lack of sync packets; MI8 = MI9 = 0 take the defaults.
        let mut c = RingCheck::station(0, 0, 0);
        assert_eq!(c.params(), STATION_DEFAULTS_NO_SYNC);
        assert!(run(&mut c, 40, |_, _| {}).is_empty());
    }

    const STATION_DEFAULTS_NO_SYNC: CheckParams = CheckParams {
        sync_min: 0,
        ..STATION_DEFAULTS
    };

    #[test]
    fn unarmed_never_reads_status() {
        let mut c = RingCheck::card(0, 2, 2, 0);
        let mut st = RingStatus::new();
        st.record(ErrorClass::Checksum);
        assert_eq!(c.on_servo_cycle(&mut st), None);
        assert_eq!(st.peek(), 0x04, "flags stay for the user when not checking");
    }
}
