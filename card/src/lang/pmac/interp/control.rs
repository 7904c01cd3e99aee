//! Control-character commands (§3.1). They act immediately, are never acknowledged, and their
//! report lines end in `<CR>` (CTRL-Y: no `<CR>`; CTRL-N: one byte).

use super::exec::Out;
use super::reply::{command_checksum, control_line};
use super::{Pmac, Session};
use crate::domain::CsNum;
use crate::lang::pmac::ast::CmdKind;
use crate::model::format_position;
use crate::model::{Action, ActionKind};

/// CTRL-N reply: the checksum of the characters received so far on the current line (the host
/// port owns the partial line and answers CTRL-N with this byte itself).
pub(crate) fn ctrl_n(partial_line: &[u8]) -> Vec<u8> {
    vec![command_checksum(partial_line)]
}

impl Pmac<'_> {
    fn ctrl_action(&mut self, s: &Session, kind: ActionKind) {
        self.model.push_action(Action {
            motor: s.motor,
            coord: s.coord,
            kind,
        });
    }

    fn motor_reports(&self, pick: impl Fn(&(f64, f64, f64)) -> f64) -> String {
        self.model
            .run
            .report
            .iter()
            .map(|r| format_position(pick(r)))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// Run `cmd` on every C.S. that has at least one motor (CTRL-R / CTRL-S); refusals are silent.
    fn each_cs(&mut self, s: &Session, cmd: &CmdKind) {
        for cs in 1..=self.model.state.limits().coords {
            if self.model.run.motors_in(cs).is_empty() {
                continue;
            }
            let mut t = Session {
                coord: CsNum::from_index(usize::from(cs) - 1),
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
                for cs in 1..=self.model.state.limits().coords {
                    self.model.state.coords[cs as usize - 1].running = false;
                    self.model.state.coords[cs as usize - 1].continuous_request = false;
                }
                for m in 1..=self.model.state.limits().motors {
                    let active = self
                        .model
                        .state
                        .peek_ivar(100 * u32::from(m))
                        .unwrap_or(0.0)
                        != 0.0;
                    if let Some(fl) = self.model.state.motors.get_mut(m as usize - 1) {
                        if active {
                            fl.open_loop = false;
                            fl.amp_enabled = true;
                            fl.desired_velocity_zero = true;
                        }
                    }
                }
                self.model
                    .run
                    .motors
                    .iter_mut()
                    .for_each(|r| r.moving = false);
                self.ctrl_action(s, ActionKind::AbortAll);
                Vec::new()
            }
            0x02 => {
                let n = self.model.state.limits().motors;
                let t: Vec<String> = (1..=n)
                    .map(|m| self.model.state.motor_status_text(m))
                    .collect();
                control_line(f, t.join(" ").as_bytes())
            }
            0x03 => {
                let n = self.model.state.limits().coords;
                let t: Vec<String> = (1..=n)
                    .map(|x| self.model.state.cs_status_text(x))
                    .collect();
                control_line(f, t.join(" ").as_bytes())
            }
            0x04 => {
                self.model
                    .run
                    .plc
                    .iter_mut()
                    .for_each(|p| p.enabled = false);
                Vec::new()
            }
            0x06 => control_line(f, self.motor_reports(|r| r.2).as_bytes()),
            0x07 => {
                self.sync_global_flags();
                control_line(f, self.model.state.global_status_text().as_bytes())
            }
            0x09 => {
                let line = self.mem.last_line.clone();
                self.run_line(s, &line, false)
            }
            0x0B => {
                for fl in self.model.state.motors.iter_mut() {
                    fl.open_loop = true;
                    fl.amp_enabled = false;
                    fl.desired_velocity_zero = false;
                }
                for cs in self.model.state.coords.iter_mut() {
                    cs.running = false;
                    cs.continuous_request = false;
                }
                self.model
                    .run
                    .motors
                    .iter_mut()
                    .for_each(|r| r.moving = false);
                self.ctrl_action(s, ActionKind::KillAll);
                Vec::new()
            }
            0x0C => {
                if self
                    .mem
                    .open
                    .is_some_and(|o| o.id == crate::model::BufId::Rot)
                {
                    let _ = self.close_buffer();
                }
                Vec::new()
            }
            0x0E => ctrl_n(&[]),
            0x0F => {
                self.model.run.cs.iter_mut().for_each(|r| r.held = true);
                self.ctrl_action(s, ActionKind::HoldAll);
                Vec::new()
            }
            0x10 => control_line(f, self.motor_reports(|r| r.0).as_bytes()),
            0x11 => {
                for cs in self.model.state.coords.iter_mut() {
                    if cs.running {
                        cs.running = false;
                        cs.continuous_request = false;
                        cs.single_step = true;
                    }
                }
                self.ctrl_action(s, ActionKind::QuitAll);
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
            // The connection's own duplex mode (`Session::echo`).
            0x14 => {
                s.echo = !s.echo;
                Vec::new()
            }
            0x15 => {
                if self.mem.open.is_none() {
                    let _ = self.exec_buffers(
                        s,
                        &CmdKind::Open(crate::lang::pmac::ast::OpenTarget::Rotary),
                        &mut Out::default(),
                    );
                }
                Vec::new()
            }
            0x16 => control_line(f, self.motor_reports(|r| r.1).as_bytes()),
            0x18 => {
                if self.model.state.peek_ivar(63).unwrap_or(0.0) != 0.0 {
                    vec![0x18]
                } else {
                    Vec::new()
                }
            }
            0x19 => self.mem.last_line.clone(),
            _ => Vec::new(),
        }
    }
}
