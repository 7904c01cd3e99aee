//! The PMAC standard PID servo filter (pmac-variables-servo-macro.md §3.7, §4.1).
//!
//! ```text
//! FE'   = clip(FE, ±Ix67/16)                                 (counts)
//! FE''  = FE' + (Ix64/16)·clip(FE', ±Ix65/16)                 (deadband, proportional path only)
//! IE    = clamp(IE + Ix33·FE'/2^23, ±|Ix63|/16)               (held while saturated, or Ix34=1 & CV≠0)
//! DAC   = 2^-19·Ix30·{ Ix08·[FE'' + (Ix32·CV + Ix35·CA)/128 + IE] − Ix31·Ix09·AV/128 }
//!         + Ix68·sign(CV)
//! DAC   → notch (1+N1 z⁻¹+N2 z⁻²)/(1+D1 z⁻¹+D2 z⁻²) (Ix36..Ix39) → clip ±Ix69
//! ```
//! CV, CA, AV are per servo cycle (counts/cycle, counts/cycle²). The output is in 16-bit DAC
//! bits (a float; the caller quantises it into the node register).

/// 2^-19.
const K19: f64 = 1.0 / 524_288.0;
/// 2^-23.
const K23: f64 = 1.0 / 8_388_608.0;

/// Gains and modifiers of one motor, straight from its I-variables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Ix08 position scale factor.
    pub ix08: f64,
    /// Ix09 velocity scale factor.
    pub ix09: f64,
    /// Ix30 proportional gain.
    pub kp: f64,
    /// Ix31 derivative gain (on measured velocity).
    pub kd: f64,
    /// Ix32 velocity feed-forward.
    pub kvff: f64,
    /// Ix33 integral gain.
    pub ki: f64,
    /// Ix34 = 1: integrate only while the commanded velocity is zero.
    pub int_mode: bool,
    /// Ix35 acceleration feed-forward.
    pub kaff: f64,
    /// Ix36..Ix39 notch N1, N2, D1, D2.
    pub notch: [f64; 4],
    /// Ix63 integration limit (1/16 count; negative = integrated-FE fault enabled).
    pub int_limit: f64,
    /// Ix64 deadband gain factor.
    pub db_gain: f64,
    /// Ix65 deadband size (1/16 count).
    pub db_size: f64,
    /// Ix67 position-error limit into the filter (1/16 count).
    pub fe_limit: f64,
    /// Ix68 friction feed-forward (DAC bits).
    pub friction: f64,
    /// Ix69 output limit (DAC bits).
    pub out_limit: f64,
}

impl Default for PidGains {
    /// The seed's factory defaults.
    fn default() -> Self {
        PidGains {
            ix08: 96.0,
            ix09: 96.0,
            kp: 2000.0,
            kd: 1280.0,
            kvff: 1280.0,
            ki: 0.0,
            int_mode: true,
            kaff: 0.0,
            notch: [0.0; 4],
            int_limit: 4_194_304.0,
            db_gain: 0.0,
            db_size: 16.0,
            fe_limit: 4_194_304.0,
            friction: 0.0,
            out_limit: 20_480.0,
        }
    }
}

/// One servo cycle's inputs (counts and servo cycles).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct PidInput {
    /// Following error: commanded − actual position, counts.
    pub fe: f64,
    /// Commanded velocity, counts/cycle.
    pub cv: f64,
    /// Commanded acceleration, counts/cycle².
    pub ca: f64,
    /// Actual velocity, counts/cycle.
    pub av: f64,
}

/// Filter memory: integrator, saturation flag, notch delay lines.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct PidState {
    /// Integrator, counts.
    pub ie: f64,
    /// The last output was clipped at ±Ix69 (freezes the integrator input).
    pub saturated: bool,
    x: [f64; 2],
    y: [f64; 2],
}

/// Result of one filter step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PidOutput {
    /// Output in 16-bit DAC bits, within ±Ix69.
    pub dac: f64,
    /// Ix63 < 0 and the integrator sits at its limit: integrated following-error fault.
    pub integrated_fault: bool,
}

fn clip(v: f64, lim: f64) -> f64 {
    let lim = lim.abs();
    v.clamp(-lim, lim)
}

impl PidState {
    /// Clear the integrator and the filter memory (on kill/enable).
    pub(crate) fn reset(&mut self) {
        *self = PidState::default();
    }

    /// One servo cycle of the filter.
    pub(crate) fn step(&mut self, g: &PidGains, i: &PidInput) -> PidOutput {
        let fe1 = clip(i.fe, g.fe_limit / 16.0);
        let fe2 = fe1 + (g.db_gain / 16.0) * clip(fe1, g.db_size / 16.0);
        let ilim = g.int_limit.abs() / 16.0;
        if g.int_limit == 0.0 {
            self.ie = 0.0;
        } else if !(self.saturated || (g.int_mode && i.cv != 0.0)) {
            self.ie = clip(self.ie + g.ki * fe1 * K23, ilim);
        }
        let integrated_fault = g.int_limit < 0.0 && self.ie.abs() >= ilim;
        let fwd = g.ix08 * (fe2 + (g.kvff * i.cv + g.kaff * i.ca) / 128.0 + self.ie);
        let mut dac = K19 * g.kp * (fwd - g.kd * g.ix09 * i.av / 128.0);
        if i.cv > 0.0 {
            dac += g.friction;
        } else if i.cv < 0.0 {
            dac -= g.friction;
        }
        let [n1, n2, d1, d2] = g.notch;
        let y = dac + n1 * self.x[0] + n2 * self.x[1] - d1 * self.y[0] - d2 * self.y[1];
        let y = if y.is_finite() { y } else { 0.0 };
        self.x = [dac, self.x[0]];
        self.y = [y, self.y[0]];
        let lim = g.out_limit.abs();
        self.saturated = y.abs() > lim;
        PidOutput {
            dac: clip(y, lim),
            integrated_fault,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(g: &PidGains, fe: f64, cv: f64, ca: f64, av: f64) -> f64 {
        PidState::default()
            .step(g, &PidInput { fe, cv, ca, av })
            .dac
    }

    #[test]
    fn proportional_and_feedforward_known_answers() {
        let g = PidGains::default();
        // 2^-19·2000·96·100 = 36.62109375
        assert_eq!(step(&g, 100.0, 0.0, 0.0, 0.0), 36.62109375);
        // Kvff: 2^-19·2000·96·(1280·10/128) = 36.62109375; Kd on AV=10 cancels it exactly.
        assert_eq!(step(&g, 0.0, 10.0, 0.0, 0.0), 36.62109375);
        assert_eq!(step(&g, 0.0, 10.0, 0.0, 10.0), 0.0);
        // Kaff: Ix35 = 640, CA = 2 → 2^-19·2000·96·(640·2/128) = 3.662109375.
        let g2 = PidGains { kaff: 640.0, ..g };
        assert_eq!(step(&g2, 0.0, 0.0, 2.0, 0.0), 3.662109375);
        // Output limit.
        assert_eq!(step(&g, 1.0e6, 0.0, 0.0, 0.0), 20_480.0);
        assert_eq!(step(&g, -1.0e6, 0.0, 0.0, 0.0), -20_480.0);
    }

    #[test]
    fn fe_limit_deadband_friction() {
        // Ix67 = 1600 (100 counts): FE 500 counts acts as 100.
        let g = PidGains {
            fe_limit: 1600.0,
            ..PidGains::default()
        };
        assert_eq!(step(&g, 500.0, 0.0, 0.0, 0.0), 36.62109375);
        // True deadband Ix64 = -16, Ix65 = 32 (2 counts): FE 1.5 → 0; FE 5 → 5 − 2 = 3 counts.
        let g = PidGains {
            db_gain: -16.0,
            db_size: 32.0,
            ..PidGains::default()
        };
        assert_eq!(step(&g, 1.5, 0.0, 0.0, 0.0), 0.0);
        assert_eq!(step(&g, 5.0, 0.0, 0.0, 0.0), 3.0 * 0.3662109375);
        // Ix68 by the sign of CV (Kd cancels Kvff here).
        let g = PidGains {
            friction: 100.0,
            ..PidGains::default()
        };
        assert_eq!(step(&g, 0.0, 3.0, 0.0, 3.0), 100.0);
        assert_eq!(step(&g, 0.0, -3.0, 0.0, -3.0), -100.0);
        assert_eq!(step(&g, 0.0, 0.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn integrator_gain_limit_and_modes() {
        // Ix33 = 2^23/1000 with FE = 10: IE grows by 0.01·... exactly Ix33·FE/2^23 per cycle.
        let g = PidGains {
            ki: 8192.0,
            int_limit: 16.0 * 0.05,
            ..PidGains::default()
        };
        let mut s = PidState::default();
        let inp = PidInput {
            fe: 10.0,
            ..Default::default()
        };
        s.step(&g, &inp);
        // 8192·10/2^23 = 0.009765625 counts.
        assert_eq!(s.ie, 0.009765625);
        for _ in 0..20 {
            s.step(&g, &inp);
        }
        assert_eq!(s.ie, 0.05, "clamped at Ix63/16 counts");
        // Ix34 = 1: no integration while CV ≠ 0; Ix34 = 0 integrates.
        let mut s = PidState::default();
        s.step(
            &g,
            &PidInput {
                fe: 10.0,
                cv: 1.0,
                ..Default::default()
            },
        );
        assert_eq!(s.ie, 0.0);
        let g0 = PidGains {
            int_mode: false,
            ..g
        };
        s.step(
            &g0,
            &PidInput {
                fe: 10.0,
                cv: 1.0,
                ..Default::default()
            },
        );
        assert_eq!(s.ie, 0.009765625);
        // Saturated output freezes the integrator.
        let gs = PidGains {
            ki: 8192.0,
            ..PidGains::default()
        };
        let mut s = PidState::default();
        s.step(
            &gs,
            &PidInput {
                fe: 1.0e7,
                ..Default::default()
            },
        );
        assert!(s.saturated);
        assert_eq!(
            s.ie, 256.0,
            "one step of 8192·262144/2^23 before saturation was seen"
        );
        s.step(
            &gs,
            &PidInput {
                fe: 1.0e7,
                ..Default::default()
            },
        );
        assert_eq!(s.ie, 256.0);
        // Ix63 < 0 reports the integrated-FE fault once the integrator saturates.
        let gn = PidGains {
            int_limit: -16.0 * 0.01,
            ..g
        };
        let mut s = PidState::default();
        assert!(!s.step(&gn, &inp).integrated_fault);
        assert!(s.step(&gn, &inp).integrated_fault);
    }

    #[test]
    fn notch_filter_difference_equation() {
        // y = x + N1·x1 − D1·y1 with N1 = 0.5, D1 = -0.25 on a constant input of 1 DAC bit.
        let g = PidGains {
            kp: 524_288.0,
            ix08: 1.0,
            notch: [0.5, 0.0, -0.25, 0.0],
            ..PidGains::default()
        };
        let mut s = PidState::default();
        let inp = PidInput {
            fe: 1.0,
            ..Default::default()
        };
        assert_eq!(s.step(&g, &inp).dac, 1.0);
        assert_eq!(s.step(&g, &inp).dac, 1.0 + 0.5 + 0.25);
        assert_eq!(s.step(&g, &inp).dac, 1.5 + 0.25 * 1.75);
    }
}
