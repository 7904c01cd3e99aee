//! Type 1 flag register (node register 3) of a servo node: the command flags the card writes
//! and the status flags the station returns.
//!
//! Register 3 is a 16-bit register that the card sees in **bits 8-23 of a 24-bit word**
//! (pmac-variables-servo-macro.md §6.5), so 24-bit bit *b* is register-3 bit *b − 8*. The layout
//! reuses the PMAC2 channel status/control word (seed L 14140-14160, L 14384: the flag inputs
//! sit in bits 15-19, AENA in bit 14), which is what the card's flag image $0F7n holds once the
//! auxiliary copy (I1000) has brought register 3 in (spec §6.7).
//!
//! | reg 3 bit | 24-bit bit | direction | name | meaning |
//! |---|---|---|---|---|
//! | 6 | 14 | card → station | AENA | amplifier enable: 1 = enable, 0 = disable (kill) |
//! | 4 | 12 | station → card | CHA | encoder channel A level (quadrature state) |
//! | 5 | 13 | station → card | CHB | encoder channel B level |
//! | 6 | 14 | station → card | AENA readback | 1 = the amplifier is enabled and not faulted |
//! | 7 | 15 | station → card | FAULT | amplifier-fault line, **low-true by default** (see below) |
//! | 8 | 16 | station → card | HMFL | home flag: 1 = home switch active |
//! | 9 | 17 | station → card | PLIM | positive end limit: 1 = tripped (switch open) |
//! | 10 | 18 | station → card | MLIM | negative end limit: 1 = tripped (switch open) |
//! | 11 | 19 | station → card | USER | user flag: 1 = active |
//!
//! All other bits are 0 in both directions (command bits other than 6 are ignored).
//!
//! **Amplifier-fault polarity.** The FAULT bit carries the *level* of the amplifier's fault
//! line, as a PMAC2 FAULTn input does. With the PMAC default Ix25 bit 23 = 0 ("low-true: low
//! means fault", spec §3.4) the station drives it low-true: **bit 7 = 1 while the amplifier is
//! healthy, 0 when it is faulted**. A node configured with `fault_high_true = true` reports
//! 1 = fault instead, to match a card set up with Ix25 bit 23 = 1. Card-side decode:
//! `amp_fault = if ix25 & (1 << 23) != 0 { bit7 } else { !bit7 }` (and ignored if Ix25 bit 20).
//! An all-zero register 3 (station absent or not yet answering) therefore reads as a fault with
//! the default polarity, which is the safe reading.
//!
//! **Limits.** PLIM blocks positive motion and MLIM blocks negative motion (the PMAC2 reading
//! recommended by spec §3.4's \[CONFLICT\] note). A limit switch trips when the motor's actual
//! position reaches the configured switch position (in encoder counts) from outside.
//!
//! **Home flag.** Turns on when the actual position enters the window
//! `home_position ..= home_position + home_width` (counts): a search in the + direction sees the
//! flag rise at `home_position`, one in the − direction at `home_position + home_width`.
//!
//! **Hysteresis** (`switch_hysteresis`, counts; a real switch's differential travel). Each
//! switch is a region — the −limit `..= minus_limit`, the +limit `plus_limit ..`, the home
//! window — that the flag turns on entering (the operate point) and only turns off again once
//! the position is more than the hysteresis outside it (the release point): the −limit releases
//! above `minus_limit + h`, the +limit below `plus_limit − h`, the home flag below
//! `home_position − h` and above `home_position + home_width + h`. The flags therefore depend
//! on the path, not only on the position: [`Switches::step`] carries them along it.

/// Register-3 bit (card → station): amplifier enable.
pub const CMD_AMP_ENABLE: u16 = 1 << 6;
/// Register-3 bit (station → card): encoder channel A level.
pub const ST_CHA: u16 = 1 << 4;
/// Register-3 bit (station → card): encoder channel B level.
pub const ST_CHB: u16 = 1 << 5;
/// Register-3 bit (station → card): amplifier enabled and not faulted (readback).
pub const ST_AMP_ENABLED: u16 = 1 << 6;
/// Register-3 bit (station → card): amplifier-fault line (polarity per node, default low-true).
pub const ST_FAULT: u16 = 1 << 7;
/// Register-3 bit (station → card): home flag.
pub const ST_HOME: u16 = 1 << 8;
/// Register-3 bit (station → card): positive end limit tripped.
pub const ST_PLIM: u16 = 1 << 9;
/// Register-3 bit (station → card): negative end limit tripped.
pub const ST_MLIM: u16 = 1 << 10;
/// Register-3 bit (station → card): user flag.
pub const ST_USER: u16 = 1 << 11;
/// Register-3 bit (station → card): a capture-flag edge has been latched; register 1 holds
/// the encoder count at that edge (low 16 bits, whole counts): the node's hardware position
/// capture.
pub const ST_CAPTURED: u16 = 1 << 12;

/// Command flags decoded from the register 3 the card wrote.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CommandFlags {
    /// Amplifier enable requested.
    pub amp_enable: bool,
}

impl CommandFlags {
    /// Decode register 3 (only the AENA bit is meaningful).
    pub fn from_reg3(r3: u16) -> Self {
        CommandFlags {
            amp_enable: r3 & CMD_AMP_ENABLE != 0,
        }
    }

    /// Encode as register 3 (what a card writes).
    pub fn to_reg3(self) -> u16 {
        if self.amp_enable {
            CMD_AMP_ENABLE
        } else {
            0
        }
    }
}

/// Status flags of a servo node, in logical terms (true = active).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StatusFlags {
    /// Encoder channel A level.
    pub cha: bool,
    /// Encoder channel B level.
    pub chb: bool,
    /// Amplifier enabled and healthy.
    pub amp_enabled: bool,
    /// Amplifier faulted.
    pub amp_fault: bool,
    /// Home switch active.
    pub home: bool,
    /// Positive end limit tripped.
    pub plus_limit: bool,
    /// Negative end limit tripped.
    pub minus_limit: bool,
    /// User flag active.
    pub user: bool,
}

impl StatusFlags {
    /// Encode as register 3; `fault_high_true` selects the FAULT line polarity.
    pub fn to_reg3(self, fault_high_true: bool) -> u16 {
        let b = |on: bool, mask: u16| if on { mask } else { 0 };
        b(self.cha, ST_CHA)
            | b(self.chb, ST_CHB)
            | b(self.amp_enabled, ST_AMP_ENABLED)
            | b(self.amp_fault == fault_high_true, ST_FAULT)
            | b(self.home, ST_HOME)
            | b(self.plus_limit, ST_PLIM)
            | b(self.minus_limit, ST_MLIM)
            | b(self.user, ST_USER)
    }

    /// Decode register 3 with the given FAULT polarity (inverse of [`StatusFlags::to_reg3`]).
    pub fn from_reg3(r3: u16, fault_high_true: bool) -> Self {
        let has = |mask: u16| r3 & mask != 0;
        StatusFlags {
            cha: has(ST_CHA),
            chb: has(ST_CHB),
            amp_enabled: has(ST_AMP_ENABLED),
            amp_fault: has(ST_FAULT) == fault_high_true,
            home: has(ST_HOME),
            plus_limit: has(ST_PLIM),
            minus_limit: has(ST_MLIM),
            user: has(ST_USER),
        }
    }
}

/// Switch positions of one axis, in encoder counts (actual motor position).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Switches {
    /// Home window start (counts).
    pub home_position: f64,
    /// Home window width (counts, ≥ 0).
    pub home_width: f64,
    /// Positive limit switch position (counts); None = no switch.
    pub plus_limit: Option<f64>,
    /// Negative limit switch position (counts); None = no switch.
    pub minus_limit: Option<f64>,
    /// Differential travel of every switch (counts, ≥ 0): how far past its operate point a
    /// switch that is on must come back before it turns off.
    pub hysteresis: f64,
}

/// Which position switches are active at a position.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SwitchStates {
    /// Home switch active.
    pub home: bool,
    /// Positive limit tripped.
    pub plus_limit: bool,
    /// Negative limit tripped.
    pub minus_limit: bool,
}

/// One of the position switches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Switch {
    /// The home switch.
    Home,
    /// The positive limit.
    PlusLimit,
    /// The negative limit.
    MinusLimit,
}

impl SwitchStates {
    /// The state of switch `s`.
    pub fn get(&self, s: Switch) -> bool {
        match s {
            Switch::Home => self.home,
            Switch::PlusLimit => self.plus_limit,
            Switch::MinusLimit => self.minus_limit,
        }
    }
}

impl Switches {
    /// The operate region of switch `s` (`lo ..= hi`, either end may be infinite), or None
    /// when it is not fitted.
    fn region(&self, s: Switch) -> Option<(f64, f64)> {
        match s {
            Switch::Home => Some((self.home_position, self.home_position + self.home_width)),
            Switch::PlusLimit => self.plus_limit.map(|p| (p, f64::INFINITY)),
            Switch::MinusLimit => self.minus_limit.map(|m| (f64::NEG_INFINITY, m)),
        }
    }

    /// Switch `s` coming to `counts` in state `on`: on inside the operate region; once on, on
    /// until more than the hysteresis outside it.
    fn next(&self, s: Switch, on: bool, counts: f64) -> bool {
        let Some((lo, hi)) = self.region(s) else {
            return false;
        };
        let h = if on { self.hysteresis } else { 0.0 };
        counts >= lo - h && counts <= hi + h
    }

    /// The switch states at `counts` for a shaft that came there from outside every switch
    /// (no history: start-up, a shaft put somewhere).
    pub fn at(&self, counts: f64) -> SwitchStates {
        self.step(SwitchStates::default(), counts)
    }

    /// The switch states after a move to `counts` from a position where they were `prev`
    /// (a move short enough to cross each switch edge at most once).
    pub fn step(&self, prev: SwitchStates, counts: f64) -> SwitchStates {
        SwitchStates {
            home: self.next(Switch::Home, prev.home, counts),
            plus_limit: self.next(Switch::PlusLimit, prev.plus_limit, counts),
            minus_limit: self.next(Switch::MinusLimit, prev.minus_limit, counts),
        }
    }

    /// Where switch `s` changed to `on` on a move from `from` to `to`: its operate point
    /// entering the region, its release point (the hysteresis outside) leaving it.
    pub fn edge(&self, s: Switch, on: bool, from: f64, to: f64) -> Option<f64> {
        let (lo, hi) = self.region(s)?;
        let up = to >= from;
        let e = match (on, up) {
            (true, true) => lo,
            (true, false) => hi,
            (false, true) => hi + self.hysteresis,
            (false, false) => lo - self.hysteresis,
        };
        e.is_finite().then_some(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sw() -> Switches {
        Switches {
            home_position: 5000.0,
            home_width: 1000.0,
            plus_limit: Some(20_000.0),
            minus_limit: Some(-20_000.0),
            hysteresis: 0.0,
        }
    }

    #[test]
    fn limits_and_home_switch_at_configured_positions() {
        let s = sw();
        assert_eq!(s.at(0.0), SwitchStates::default());
        assert!(!s.at(4999.99).home);
        assert!(s.at(5000.0).home);
        assert!(s.at(6000.0).home);
        assert!(!s.at(6000.01).home);
        assert!(!s.at(19_999.99).plus_limit);
        assert!(s.at(20_000.0).plus_limit && !s.at(20_000.0).minus_limit);
        assert!(!s.at(-19_999.99).minus_limit);
        assert!(s.at(-20_000.0).minus_limit && !s.at(-20_000.0).plus_limit);
        let none = Switches {
            plus_limit: None,
            minus_limit: None,
            ..s
        };
        assert_eq!(none.at(1e12), SwitchStates::default());
    }

    /// A path through every switch, one step at a time: the states at each position.
    fn walk(s: &Switches, path: &[f64]) -> Vec<SwitchStates> {
        let mut st = s.at(path[0]);
        let mut out = vec![st];
        for &p in &path[1..] {
            st = s.step(st, p);
            out.push(st);
        }
        out
    }

    #[test]
    fn hysteresis_moves_the_release_points_out_by_the_differential_travel() {
        let s = Switches {
            hysteresis: 10.0,
            ..sw()
        };
        // Into the −limit and back out: on at −20000, still on up to −19990, off past it.
        let m: Vec<bool> = walk(&s, &[-19_999.0, -20_000.0, -20_050.0, -19_995.0, -19_990.0])
            .iter()
            .map(|x| x.minus_limit)
            .collect();
        assert_eq!(m, [false, true, true, true, true]);
        assert!(!s.step(s.at(-20_000.0), -19_989.99).minus_limit);
        // Released, a return that overshoots a few counts back towards it stays off: only
        // the operate point trips it again.
        let off = s.step(s.at(-20_000.0), -19_989.0);
        assert!(!s.step(off, -19_995.0).minus_limit);
        assert!(s.step(off, -20_000.0).minus_limit);
        // The +limit mirrors it.
        assert!(s.step(s.at(20_000.0), 19_990.0).plus_limit);
        assert!(!s.step(s.at(20_000.0), 19_989.99).plus_limit);
        // The home window: on entering at either end, off 10 counts outside either end.
        let h: Vec<bool> = walk(&s, &[4_995.0, 5_000.0, 6_005.0, 6_010.0, 6_010.01, 6_005.0])
            .iter()
            .map(|x| x.home)
            .collect();
        assert_eq!(h, [false, true, true, true, false, false]);
        assert!(s.step(s.at(5_500.0), 4_990.0).home);
        assert!(!s.step(s.at(5_500.0), 4_989.99).home);
        // The edges: operate points entering, release points leaving.
        assert_eq!(
            s.edge(Switch::MinusLimit, true, -19_000.0, -21_000.0),
            Some(-20_000.0)
        );
        assert_eq!(
            s.edge(Switch::MinusLimit, false, -21_000.0, -19_000.0),
            Some(-19_990.0)
        );
        assert_eq!(
            s.edge(Switch::PlusLimit, false, 21_000.0, 19_000.0),
            Some(19_990.0)
        );
        assert_eq!(s.edge(Switch::Home, true, 7_000.0, 5_500.0), Some(6_000.0));
        assert_eq!(s.edge(Switch::Home, false, 5_500.0, 4_000.0), Some(4_990.0));
        assert_eq!(s.edge(Switch::Home, false, 5_500.0, 7_000.0), Some(6_010.0));
        let none = Switches {
            plus_limit: None,
            ..s
        };
        assert_eq!(none.edge(Switch::PlusLimit, true, 0.0, 1e9), None);
        // Without hysteresis the flags are a function of the position alone.
        let z = sw();
        for p in [
            -20_000.5, -20_000.0, -19_999.5, 5_000.0, 6_000.0, 6_000.5, 20_000.0,
        ] {
            for prev in [
                SwitchStates::default(),
                z.at(-30_000.0),
                z.at(30_000.0),
                z.at(5_500.0),
            ] {
                assert_eq!(z.step(prev, p), z.at(p), "{p} from {prev:?}");
            }
        }
    }

    #[test]
    fn register3_bit_positions_are_the_documented_ones() {
        let one = |f: fn(&mut StatusFlags)| {
            let mut s = StatusFlags {
                amp_fault: false,
                ..Default::default()
            };
            f(&mut s);
            s.to_reg3(true)
        };
        assert_eq!(one(|_| {}), 0);
        assert_eq!(one(|s| s.cha = true), 0x0010);
        assert_eq!(one(|s| s.chb = true), 0x0020);
        assert_eq!(one(|s| s.amp_enabled = true), 0x0040);
        assert_eq!(one(|s| s.amp_fault = true), 0x0080);
        assert_eq!(one(|s| s.home = true), 0x0100);
        assert_eq!(one(|s| s.plus_limit = true), 0x0200);
        assert_eq!(one(|s| s.minus_limit = true), 0x0400);
        assert_eq!(one(|s| s.user = true), 0x0800);
        // low-true fault line (default): healthy = bit 7 set, fault = bit 7 clear
        assert_eq!(StatusFlags::default().to_reg3(false), 0x0080);
        assert_eq!(
            StatusFlags {
                amp_fault: true,
                ..Default::default()
            }
            .to_reg3(false),
            0
        );
        // 24-bit view: reg3 << 8 puts FAULT at bit 15, HOME 16, PLIM 17, MLIM 18, USER 19
        assert_eq!(u32::from(ST_FAULT) << 8, 1 << 15);
        assert_eq!(u32::from(ST_USER) << 8, 1 << 19);
        assert_eq!(u32::from(CMD_AMP_ENABLE) << 8, 1 << 14);
    }

    #[test]
    fn status_round_trips_in_both_polarities() {
        for bits in 0u16..256 {
            let s = StatusFlags {
                cha: bits & 1 != 0,
                chb: bits & 2 != 0,
                amp_enabled: bits & 4 != 0,
                amp_fault: bits & 8 != 0,
                home: bits & 16 != 0,
                plus_limit: bits & 32 != 0,
                minus_limit: bits & 64 != 0,
                user: bits & 128 != 0,
            };
            for pol in [false, true] {
                assert_eq!(StatusFlags::from_reg3(s.to_reg3(pol), pol), s);
            }
        }
        assert_eq!(
            CommandFlags::from_reg3(0xFFBF),
            CommandFlags { amp_enable: false }
        );
        assert_eq!(
            CommandFlags::from_reg3(0x0040),
            CommandFlags { amp_enable: true }
        );
        assert_eq!(CommandFlags { amp_enable: true }.to_reg3(), 0x0040);
    }
}
