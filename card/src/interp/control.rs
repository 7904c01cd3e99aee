//! Control-character commands (§3.1). They act immediately, are never acknowledged, and their
//! report lines end in `<CR>` (CTRL-Y: no `<CR>`; CTRL-N: one byte).

use super::exec::Out;
use super::reply::{command_checksum, control_line};
use super::{Action, ActionKind, Card, Session};
use crate::lang::ast::CmdKind;
use crate::state::number::format_position;

/// CTRL-N reply: the checksum of the characters received so far on the current line (the host
/// port owns the partial line and answers CTRL-N with this byte itself).
pub fn ctrl_n(partial_line: &[u8]) -> Vec<u8> {
    vec![command_checksum(partial_line)]
}

impl Card {
    fn ctrl_action(&mut self, s: &Session, c: u8) {
        self.push_action(Action {
            motor: s.motor,
            coord: s.coord,
            kind: ActionKind::Ctrl(c),
        });
    }

    fn motor_reports(&self, pick: impl Fn(&(f64, f64, f64)) -> f64) -> String {
        self.run
            .report
            .iter()
            .map(|r| format_position(pick(r)))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// Run `cmd` on every C.S. that has at least one motor (CTRL-R / CTRL-S); refusals are silent.
    fn each_cs(&mut self, s: &Session, cmd: &CmdKind) {
        for cs in 1..=self.state.limits().coords {
            if self.run.motors_in(cs).is_empty() {
                continue;
            }
            let mut t = Session {
                coord: cs,
                ..s.clone()
            };
            let c = if matches!(cmd, CmdKind::Step) && self.cs_running(cs) {
                &CmdKind::Quit
            } else {
                cmd
            };
            let _ = self.exec_motion(&mut t, c, &mut Out::default());
        }
    }

    pub(crate) fn control(&mut self, s: &mut Session, c: u8) -> Vec<u8> {
        self.clamp_session(s);
        let f = self.framing();
        match c {
            0x01 => {
                // Abort everything: programs stop, killed/open-loop activated motors hold.
                for cs in 1..=self.state.limits().coords {
                    self.state.coords[cs as usize - 1].running = false;
                    self.state.coords[cs as usize - 1].continuous_request = false;
                }
                for m in 1..=self.state.limits().motors {
                    let active = self.state.peek_ivar(100 * u32::from(m)).unwrap_or(0.0) != 0.0;
                    if let Some(fl) = self.state.motors.get_mut(m as usize - 1) {
                        if active {
                            fl.open_loop = false;
                            fl.amp_enabled = true;
                            fl.desired_velocity_zero = true;
                        }
                    }
                }
                self.run.motors.iter_mut().for_each(|r| r.moving = false);
                self.ctrl_action(s, c);
                Vec::new()
            }
            0x02 => {
                let n = self.state.limits().motors;
                let t: Vec<String> = (1..=n).map(|m| self.state.motor_status_text(m)).collect();
                control_line(f, t.join(" ").as_bytes())
            }
            0x03 => {
                let n = self.state.limits().coords;
                let t: Vec<String> = (1..=n).map(|x| self.state.cs_status_text(x)).collect();
                control_line(f, t.join(" ").as_bytes())
            }
            0x04 => {
                self.run.plc.iter_mut().for_each(|p| p.enabled = false);
                Vec::new()
            }
            0x06 => control_line(f, self.motor_reports(|r| r.2).as_bytes()),
            0x07 => {
                self.sync_global_flags();
                control_line(f, self.state.global_status_text().as_bytes())
            }
            0x09 => {
                let line = self.last_line.clone();
                self.run_line(s, &line, false)
            }
            0x0B => {
                for fl in self.state.motors.iter_mut() {
                    fl.open_loop = true;
                    fl.amp_enabled = false;
                    fl.desired_velocity_zero = false;
                }
                for cs in self.state.coords.iter_mut() {
                    cs.running = false;
                    cs.continuous_request = false;
                }
                self.run.motors.iter_mut().for_each(|r| r.moving = false);
                self.ctrl_action(s, c);
                Vec::new()
            }
            0x0C => {
                if self
                    .open
                    .is_some_and(|o| o.id == super::buffers::BufId::Rot)
                {
                    let _ = self.close_buffer();
                }
                Vec::new()
            }
            0x0E => ctrl_n(&[]),
            0x0F => {
                self.run.cs.iter_mut().for_each(|r| r.held = true);
                self.ctrl_action(s, c);
                Vec::new()
            }
            0x10 => control_line(f, self.motor_reports(|r| r.0).as_bytes()),
            0x11 => {
                for cs in self.state.coords.iter_mut() {
                    if cs.running {
                        cs.running = false;
                        cs.continuous_request = false;
                        cs.single_step = true;
                    }
                }
                self.ctrl_action(s, c);
                Vec::new()
            }
            0x12 => {
                self.each_cs(s, &CmdKind::Run);
                Vec::new()
            }
            0x13 => {
                self.each_cs(s, &CmdKind::Step);
                Vec::new()
            }
            0x14 => {
                self.echo = !self.echo;
                Vec::new()
            }
            0x15 => {
                if self.open.is_none() {
                    let _ = self.exec_buffers(
                        s,
                        &CmdKind::Open(crate::lang::ast::OpenTarget::Rotary),
                        &mut Out::default(),
                    );
                }
                Vec::new()
            }
            0x16 => control_line(f, self.motor_reports(|r| r.1).as_bytes()),
            0x18 => {
                if self.state.peek_ivar(63).unwrap_or(0.0) != 0.0 {
                    vec![0x18]
                } else {
                    Vec::new()
                }
            }
            0x19 => self.last_line.clone(),
            _ => Vec::new(),
        }
    }
}
