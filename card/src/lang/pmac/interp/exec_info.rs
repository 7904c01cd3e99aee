//! Global commands (§3.2.1, §3.2.2, §8.2): reset/save/password, information replies, global
//! status, serial-chain addressing.

use super::exec::{Exec, Flow, Out};
use super::image::Effect;
use super::{Pmac, Session};
use crate::domain::ErrCode;
use crate::lang::pmac::ast::CmdKind;

/// `VERSION` reply. [DECISION] `1.17` rather than the digest's `1.17C`: host software requires
/// `^\d+\.\d+$` (host-protocols §0 item 2).
pub(super) const VERSION: &str = "1.17";
/// `DATE` reply (firmware date, `mm/dd/yy`).
pub(super) const DATE: &str = "06/12/02";
/// `TYPE` reply (spec §3.2.2 [DECISION]).
pub(super) const TYPE: &str = "PMAC2, ISA, FLASH, PID, CLK X1";
/// `EAVERSION`: PMAC2 (1), AMD flash (1), standard (0), released (0), no revision letter (0), 117.
pub(super) const EAVERSION: &str = "11000117";
/// `CHECKSUM`: firmware reference checksum, hex without `$`.
pub(super) const CHECKSUM: &str = "5A17C3";
/// `LIST LINK` dummy line (no compiled-PLC support).
pub(super) const LIST_LINK: &str = "000000 000000 000000 000000 000000 000000";

impl Pmac<'_> {
    pub(crate) fn exec_info(&mut self, s: &mut Session, cmd: &CmdKind, out: &mut Out) -> Exec {
        match cmd {
            // The saved image is read off the servo thread; the line finishes (silently) once
            // it is back and applied (`LineRun`).
            CmdKind::Reset => out.flow = Flow::Effect(Effect::Load),
            CmdKind::Reinit => {
                self.reinit();
                *s = Session {
                    chain_addressed: s.chain_addressed,
                    chain_all: s.chain_all,
                    echo: s.echo,
                    ..Session::with_id(s.id)
                };
            }
            // The file write happens off the servo thread; a failed write is ERR003.
            CmdKind::Save => out.flow = Flow::Effect(Effect::Save(self.save_image())),
            CmdKind::Password(bytes) => self.password(bytes)?,
            CmdKind::ClearFault => {}
            CmdKind::Type => out.line(TYPE),
            CmdKind::Version => out.line(VERSION),
            CmdKind::Date => out.line(DATE),
            CmdKind::EaVersion => out.line(EAVERSION),
            CmdKind::Checksum => out.line(CHECKSUM),
            CmdKind::Size => {
                let free = self.model.bufs.free();
                out.line(if self.mem.open.is_some() {
                    format!("-{free}")
                } else {
                    free.to_string()
                });
            }
            CmdKind::Cid => match self.model.state.limits().cid {
                Some(v) => out.line(v.to_string()),
                None => return Err(ErrCode::Data),
            },
            CmdKind::Cpu => match self.model.state.limits().cpu {
                Some(v) => out.line(v),
                None => return Err(ErrCode::Data),
            },
            CmdKind::GlobalStatus => {
                self.sync_global_flags();
                out.line(self.model.state.global_status_text());
            }
            CmdKind::AddrCard(n) => self.chain_select(s, Some(*n))?,
            CmdKind::AddrAllCards => self.chain_select(s, None)?,
            CmdKind::ReportCard => {
                self.chain_allowed()?;
                if s.chain_all {
                    out.line("@");
                } else {
                    out.line(format!("{:X}", self.card_number()));
                }
            }
            _ => return Err(ErrCode::Data),
        }
        Ok(())
    }

    /// `PASSWORD=`: change when matched (or null), otherwise a match attempt (ERR002 on failure).
    fn password(&mut self, bytes: &[u8]) -> Exec {
        let text = String::from_utf8_lossy(bytes).into_owned();
        if self.model.state.password.is_empty() || self.model.state.password_matched {
            self.model.state.password = text;
            self.model.state.password_matched = true;
            Ok(())
        } else if self.model.state.password == text {
            self.model.state.password_matched = true;
            Ok(())
        } else {
            Err(ErrCode::Password)
        }
    }

    /// Whether a protected buffer may be opened/listed now.
    pub(crate) fn password_ok(&self) -> bool {
        self.model.state.password.is_empty() || self.model.state.password_matched
    }

    /// `@` forms need I1 = 2 or 3 (software addressing), else ERR003.
    fn chain_allowed(&self) -> Exec {
        if self.software_addressing() {
            Ok(())
        } else {
            Err(ErrCode::Data)
        }
    }

    /// I1 bit 1: the card obeys `@` addressing (otherwise it assumes it is alone on its port
    /// and answers everything).
    pub(crate) fn software_addressing(&self) -> bool {
        self.model.state.peek_ivar(1).unwrap_or(0.0) as u32 & 2 != 0
    }

    /// This card's serial number (I0).
    pub(crate) fn card_number(&self) -> u8 {
        (self.model.state.peek_ivar(0).unwrap_or(0.0) as u32 & 0xF) as u8
    }

    /// `@n` (`Some(n)`) or `@@` (`None`) received on `s`'s connection: update its addressing
    /// and the `???` word-1 chain bits. ERR003 without software addressing (I1 bit 1).
    pub(crate) fn chain_select(
        &mut self,
        s: &mut Session,
        card: Option<u8>,
    ) -> Result<(), ErrCode> {
        self.chain_allowed()?;
        match card {
            Some(n) => {
                s.chain_all = false;
                s.chain_addressed = n == self.card_number();
                self.set_chain_bits(s.chain_addressed, false);
            }
            None => {
                s.chain_all = true;
                s.chain_addressed = true;
                self.set_chain_bits(false, true);
            }
        }
        Ok(())
    }

    /// Whether `s` currently takes commands on this card: always without software addressing,
    /// else when addressed by `@n` or `@@`.
    pub(crate) fn chain_listening(&self, s: &Session) -> bool {
        !self.software_addressing() || s.chain_addressed
    }

    /// Whether this card answers on `s`: it takes commands and, under `@@`, it is card 0.
    pub(crate) fn chain_talking(&self, s: &Session) -> bool {
        !self.software_addressing()
            || (s.chain_addressed && (!s.chain_all || self.card_number() == 0))
    }

    /// `???` word 1 bit 0 (addressed by `@n`) and bit 1 (`@@`).
    fn set_chain_bits(&mut self, this: bool, all: bool) {
        let w = self.model.state.global.word1_other & !3;
        self.model.state.global.word1_other = w | u32::from(this) | (u32::from(all) << 1);
    }
}
