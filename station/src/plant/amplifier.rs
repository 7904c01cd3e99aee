//! Simulated servo amplifier: torque, velocity or pulse-frequency (stepper) mode, an output
//! limit, enable from the command flags and a latched fault.
//!
//! **Command scale.** The card writes a 16-bit DAC value left-justified into the 24-bit node
//! register 0 (`dac << 8`, spec §4.1 step 6), so the amplifier reads register 0 as a signed
//! 24-bit number and normalises it by 2^23: `u = signed24(r0) / 2^23` ∈ [−1, 1)
//! (DAC 32767 → u ≈ +1). In **torque** mode the output torque is `u · torque_full_scale`; in
//! **velocity** mode the speed command is `u · velocity_full_scale` and an internal
//! proportional velocity loop produces `velocity_gain · (ω_cmd − ω)`; both are clipped to
//! ±`torque_limit` (the output limit). In **pulse** mode the command is node register 2 read
//! as a signed 16-bit value: `rate = r2 / 2^15 · pulse_full_scale` counts/s, and the drive
//! moves the shaft at exactly that rate (an ideal stepper that never loses steps).
//!
//! **Enable and faults.** The amplifier is enabled while the AENA command bit is set. A fault
//! is latched when the amplifier is enabled and either the node is configured with a fault
//! (`amp_fault = true`: it faults as soon as it is enabled) or [`Amplifier::inject_fault`] is
//! called. A faulted amplifier outputs nothing (the motor coasts). The latch is cleared by
//! dropping enable (a disabled amplifier holds its fault reset, so the next enable starts
//! clean, and re-faults at once if the configured fault is still there) or by
//! [`Amplifier::clear_fault`] (the CLRF-like reset). A fault cannot be injected into a disabled
//! amplifier (its power stage is off).

/// Amplifier operating mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AmpMode {
    /// Register 0 commands torque (current).
    Torque,
    /// Register 0 commands velocity; the amplifier closes a velocity loop.
    Velocity,
    /// Register 2 commands a pulse frequency (stepper drive).
    Pulse,
}

/// Amplifier parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AmpParams {
    /// Operating mode.
    pub mode: AmpMode,
    /// Torque at full-scale command, N·m (torque mode).
    pub torque_full_scale: f64,
    /// Output (torque) limit, N·m (≥ 0), all servo modes.
    pub torque_limit: f64,
    /// Speed at full-scale command, rad/s (velocity mode).
    pub velocity_full_scale: f64,
    /// Velocity-loop gain, N·m per rad/s (velocity mode).
    pub velocity_gain: f64,
    /// Pulse rate at full-scale register 2, counts/s (pulse mode).
    pub pulse_full_scale: f64,
    /// Configured fault: the amplifier faults whenever it is enabled.
    pub configured_fault: bool,
}

/// What the amplifier does to the shaft over the next interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AmpOutput {
    /// Torque `drive − damping·ω` (N·m); zero/zero when disabled or faulted.
    Torque {
        /// Constant part, N·m.
        drive: f64,
        /// Speed-proportional part, N·m per rad/s.
        damping: f64,
    },
    /// Drive the shaft at this rate (counts/s): pulse mode, enabled.
    Rate(f64),
}

/// A simulated amplifier.
#[derive(Clone, Debug)]
pub struct Amplifier {
    p: AmpParams,
    enabled: bool,
    fault: bool,
    command: f64,
    pulse: f64,
}

impl Amplifier {
    /// A disabled, healthy amplifier.
    pub fn new(p: AmpParams) -> Self {
        Amplifier {
            p,
            enabled: false,
            fault: false,
            command: 0.0,
            pulse: 0.0,
        }
    }

    /// Parameters.
    pub fn params(&self) -> AmpParams {
        self.p
    }

    /// Change the parameters (enable, fault latch and latched command are kept).
    pub fn set_params(&mut self, p: AmpParams) {
        self.p = p;
    }

    /// Latch the command registers: enable bit, register 0 and register 2.
    pub fn update(&mut self, enable: bool, r0: u32, r2: u16) {
        self.command = f64::from(crate::plant::encoder::signed24(r0)) / f64::from(1u32 << 23);
        self.pulse = f64::from(r2 as i16) / 32768.0;
        self.enabled = enable;
        if !enable {
            self.fault = false;
        } else if self.p.configured_fault {
            self.fault = true;
        }
    }

    /// Drop enable and zero the command at once (ring fault, station shutdown).
    pub fn shut_down(&mut self) {
        self.enabled = false;
        self.fault = false;
        self.command = 0.0;
        self.pulse = 0.0;
    }

    /// Inject an amplifier fault now (ignored while disabled).
    pub fn inject_fault(&mut self) {
        if self.enabled {
            self.fault = true;
        }
    }

    /// CLRF-like reset of the fault latch (it re-latches at the next update if the configured
    /// fault persists).
    pub fn clear_fault(&mut self) {
        self.fault = false;
    }

    /// Enable is requested (whether or not faulted).
    pub fn enable_requested(&self) -> bool {
        self.enabled
    }

    /// The fault latch.
    pub fn faulted(&self) -> bool {
        self.fault
    }

    /// Enabled and not faulted: power is applied.
    pub fn active(&self) -> bool {
        self.enabled && !self.fault
    }

    /// Normalised register-0 command, −1..1.
    pub fn command(&self) -> f64 {
        self.command
    }

    /// The output for the interval to come, given shaft speed `omega` (rad/s).
    pub fn output(&self, omega: f64) -> AmpOutput {
        let off = AmpOutput::Torque {
            drive: 0.0,
            damping: 0.0,
        };
        if !self.active() {
            return off;
        }
        let lim = self.p.torque_limit.max(0.0);
        match self.p.mode {
            AmpMode::Torque => {
                let t = (self.command * self.p.torque_full_scale).clamp(-lim, lim);
                AmpOutput::Torque {
                    drive: t,
                    damping: 0.0,
                }
            }
            AmpMode::Velocity => {
                let kv = self.p.velocity_gain.max(0.0);
                let wcmd = self.command * self.p.velocity_full_scale;
                let t = kv * (wcmd - omega);
                if t > lim {
                    AmpOutput::Torque {
                        drive: lim,
                        damping: 0.0,
                    }
                } else if t < -lim {
                    AmpOutput::Torque {
                        drive: -lim,
                        damping: 0.0,
                    }
                } else {
                    AmpOutput::Torque {
                        drive: kv * wcmd,
                        damping: kv,
                    }
                }
            }
            AmpMode::Pulse => AmpOutput::Rate(self.pulse * self.p.pulse_full_scale),
        }
    }

    /// Torque the amplifier applies at shaft speed `omega` (0 in pulse mode), N·m.
    pub fn torque(&self, omega: f64) -> f64 {
        match self.output(omega) {
            AmpOutput::Torque { drive, damping } => drive - damping * omega,
            AmpOutput::Rate(_) => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn amp(mode: AmpMode, fault: bool) -> Amplifier {
        Amplifier::new(AmpParams {
            mode,
            torque_full_scale: 4.0,
            torque_limit: 3.0,
            velocity_full_scale: 300.0,
            velocity_gain: 0.01,
            pulse_full_scale: 100_000.0,
            configured_fault: fault,
        })
    }

    /// DAC value as the card writes it into register 0.
    fn dac(v: i32) -> u32 {
        ((v << 8) as u32) & 0xFF_FFFF
    }

    #[test]
    fn torque_mode_scales_the_24_bit_command_and_clips_at_the_limit() {
        let mut a = amp(AmpMode::Torque, false);
        a.update(true, dac(8192), 0);
        assert_eq!(a.torque(0.0), 1.0); // 8192/32768 · 4 N·m
        a.update(true, dac(-16384), 0);
        assert_eq!(a.torque(123.0), -2.0);
        a.update(true, dac(32767), 0);
        assert_eq!(a.torque(0.0), 3.0); // 3.9999 clipped to the 3 N·m limit
        a.update(true, dac(-32768), 0);
        assert_eq!(a.torque(0.0), -3.0);
        a.update(false, dac(8192), 0);
        assert_eq!(a.torque(0.0), 0.0);
    }

    #[test]
    fn velocity_mode_closes_a_velocity_loop_with_limit() {
        let mut a = amp(AmpMode::Velocity, false);
        a.update(true, dac(16384), 0); // 150 rad/s
        assert_eq!(
            a.output(100.0),
            AmpOutput::Torque {
                drive: 1.5,
                damping: 0.01
            }
        );
        assert!((a.torque(100.0) - 0.5).abs() < 1e-12);
        assert_eq!(
            a.output(-200.0),
            AmpOutput::Torque {
                drive: 3.0,
                damping: 0.0
            }
        );
        assert_eq!(
            a.output(600.0),
            AmpOutput::Torque {
                drive: -3.0,
                damping: 0.0
            }
        );
    }

    #[test]
    fn pulse_mode_reads_register_2() {
        let mut a = amp(AmpMode::Pulse, false);
        a.update(true, dac(32767), 0x4000);
        assert_eq!(a.output(0.0), AmpOutput::Rate(50_000.0));
        a.update(true, 0, 0xC000);
        assert_eq!(a.output(0.0), AmpOutput::Rate(-50_000.0));
        a.update(false, 0, 0x4000);
        assert_eq!(
            a.output(0.0),
            AmpOutput::Torque {
                drive: 0.0,
                damping: 0.0
            }
        );
    }

    #[test]
    fn configured_fault_latches_when_enabled_and_clears_on_disable() {
        let mut a = amp(AmpMode::Torque, true);
        a.update(false, dac(8192), 0);
        assert!(!a.faulted());
        a.update(true, dac(8192), 0);
        assert!(a.faulted() && !a.active());
        assert_eq!(a.torque(0.0), 0.0);
        a.clear_fault();
        assert!(!a.faulted());
        a.update(true, dac(8192), 0); // the configured fault is still there
        assert!(a.faulted());
        a.update(false, 0, 0);
        assert!(!a.faulted());
    }

    #[test]
    fn injected_fault_latches_until_disable_or_clear() {
        let mut a = amp(AmpMode::Torque, false);
        a.inject_fault(); // disabled: ignored
        assert!(!a.faulted());
        a.update(true, dac(8192), 0);
        assert!(a.active());
        a.inject_fault();
        for _ in 0..3 {
            a.update(true, dac(8192), 0);
            assert!(a.faulted() && a.torque(0.0) == 0.0);
        }
        a.clear_fault();
        a.update(true, dac(8192), 0);
        assert!(a.active() && a.torque(0.0) == 1.0);
        a.inject_fault();
        a.update(false, 0, 0);
        a.update(true, dac(8192), 0);
        assert!(a.active());
        a.shut_down();
        assert!(!a.enable_requested() && a.command() == 0.0);
    }
}
