//! A motor's I-variables gathered for the servo pipeline (pmac-variables-servo-macro.md §3).

use super::pid::PidGains;
use super::profile::RampParams;
use crate::model::CardState;

/// Everything one motor's servo cycle reads from the I-variables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorParams {
    /// Ix00 activate.
    pub active: bool,
    /// Ix03 position feedback address (PMAC2 bit 17: trigger on warning FE).
    pub ix03: u32,
    /// The feedback word's address (Ix03 without its mode bits).
    pub feedback_addr: u32,
    /// The flag image address (PMAC2 Ix25 bits 0-15, Turbo Ixx25).
    pub flag_addr: u32,
    /// The trigger of homing and jog-until-trigger is the warning following error (PMAC2
    /// Ix03 bit 17, Turbo Ixx97 bit 1) instead of the capture flag.
    pub fe_trigger: bool,
    /// Software position capture (Turbo Ixx97 bit 0): the trigger position is the position
    /// of the servo cycle that saw the trigger, not the station's hardware capture.
    pub software_capture: bool,
    /// PID gains (Ix08, Ix09, Ix30-Ix39, Ix63-Ix69).
    pub gains: PidGains,
    /// Ix11 fatal FE limit, 1/16 count (0 = off).
    pub fatal_fe: f64,
    /// Ix12 warning FE limit, 1/16 count (0 = off).
    pub warn_fe: f64,
    /// Ix13 positive software limit, counts (0 = off).
    pub soft_plus: f64,
    /// Ix14 negative software limit, counts (0 = off).
    pub soft_minus: f64,
    /// Ix15 abort/limit deceleration, counts/ms².
    pub abort_decel: f64,
    /// Ix19-Ix21.
    pub ramp: RampParams,
    /// Ix22 jog speed, counts/ms.
    pub jog_speed: f64,
    /// Ix23 homing speed and direction, counts/ms.
    pub home_speed: f64,
    /// Flag mode bits as PMAC2 Ix25 holds them (bit 17 no limits, 18 MACRO flags, 20 no
    /// amp-fault input, 21-22 kill scope, 23 fault polarity); on Turbo those are Ixx24's bits.
    pub ix25: u32,
    /// Ix26 home offset, 1/16 count.
    pub home_offset: f64,
    /// Ix28 in-position band, 1/16 count.
    pub inpos_band: f64,
    /// Ix29 output offset, DAC bits.
    pub dac_offset: f64,
    /// I7 in-position extra scans.
    pub i7: u32,
    /// I12 jog calculation time, ms.
    pub i12: f64,
    /// Ix10 ≠ 0: an absolute position read is specified (`$*` reads it instead of zeroing).
    pub abs_read: bool,
}

impl Default for MotorParams {
    /// The seed's factory defaults for motor 1 (activated).
    fn default() -> Self {
        MotorParams {
            active: true,
            ix03: 0x0721,
            feedback_addr: 0x0721,
            flag_addr: 0x0F70,
            fe_trigger: false,
            software_capture: false,
            gains: PidGains::default(),
            fatal_fe: 32_000.0,
            warn_fe: 16_000.0,
            soft_plus: 0.0,
            soft_minus: 0.0,
            abort_decel: 0.25,
            ramp: RampParams::new(0.015625, 0.0, 50.0),
            jog_speed: 32.0,
            home_speed: 32.0,
            ix25: 0x40F70,
            home_offset: 0.0,
            inpos_band: 160.0,
            dac_offset: 0.0,
            i7: 0,
            i12: 10.0,
            abs_read: false,
        }
    }
}

impl MotorParams {
    /// Read motor `x`'s (1-based) variables from the card; missing ones take the defaults.
    pub fn from_state(st: &CardState, x: u16) -> Self {
        let d = MotorParams::default();
        let base = 100 * x as u32;
        let iv = |nn: u32, dflt: f64| st.vars.i(base + nn).unwrap_or(dflt);
        let gv = |n: u32, dflt: f64| st.vars.i(n).unwrap_or(dflt);
        let g = PidGains::default();
        let ix03 = iv(3, d.ix03 as f64).max(0.0) as u32;
        let turbo = st.profile() == crate::domain::Profile::Turbo;
        let (ix25, flag_addr, fe_trigger, software_capture) = if turbo {
            let ix24 = iv(24, 0.0).max(0.0) as u32;
            let ix97 = iv(97, 0.0).max(0.0) as u32;
            (
                ix24 & 0xFF_0000,
                iv(25, 0.0).max(0.0) as u32 & 0x7_FFFF,
                ix97 & 2 != 0,
                ix97 & 1 != 0,
            )
        } else {
            let ix25 = iv(25, d.ix25 as f64).max(0.0) as u32;
            (ix25, ix25 & 0xFFFF, ix03 & (1 << 17) != 0, false)
        };
        MotorParams {
            active: iv(0, 0.0) != 0.0,
            ix03,
            feedback_addr: ix03 & if turbo { 0x7_FFFF } else { 0xFFFF },
            flag_addr,
            fe_trigger,
            software_capture,
            gains: PidGains {
                ix08: iv(8, g.ix08),
                ix09: iv(9, g.ix09),
                kp: iv(30, g.kp),
                kd: iv(31, g.kd),
                kvff: iv(32, g.kvff),
                ki: iv(33, g.ki),
                int_mode: iv(34, 1.0) != 0.0,
                kaff: iv(35, g.kaff),
                notch: [iv(36, 0.0), iv(37, 0.0), iv(38, 0.0), iv(39, 0.0)],
                int_limit: iv(63, g.int_limit),
                db_gain: iv(64, g.db_gain),
                db_size: iv(65, g.db_size),
                fe_limit: iv(67, g.fe_limit),
                friction: iv(68, g.friction),
                out_limit: iv(69, g.out_limit),
            },
            fatal_fe: iv(11, d.fatal_fe),
            warn_fe: iv(12, d.warn_fe),
            soft_plus: iv(13, 0.0),
            soft_minus: iv(14, 0.0),
            abort_decel: iv(15, d.abort_decel),
            ramp: RampParams::new(iv(19, 0.015625), iv(20, 0.0), iv(21, 50.0)),
            jog_speed: iv(22, d.jog_speed),
            home_speed: iv(23, d.home_speed),
            ix25,
            home_offset: iv(26, 0.0),
            inpos_band: iv(28, d.inpos_band),
            dac_offset: iv(29, 0.0),
            i7: gv(7, 0.0).max(0.0) as u32,
            i12: gv(12, 10.0),
            abs_read: iv(10, 0.0) != 0.0,
        }
    }

    /// Ix25 bit 17: hardware overtravel inputs ignored.
    pub fn ignore_limits(&self) -> bool {
        self.ix25 & (1 << 17) != 0
    }

    /// Ix25 bit 20: amplifier-fault input ignored.
    pub fn ignore_fault(&self) -> bool {
        self.ix25 & (1 << 20) != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Profile;

    #[test]
    fn from_fresh_card_matches_seed_defaults() {
        let st = CardState::new(Profile::Pmac2);
        let p = MotorParams::from_state(&st, 1);
        assert_eq!(p, MotorParams::default());
        let p3 = MotorParams::from_state(&st, 3);
        assert!(!p3.active);
        assert_eq!((p3.ix03, p3.ix25), (0x0725, 0x40F74));
    }
}
