//! Commands issued by programs (`CMD"..."`, §5.9.1): executed like host lines but never
//! acknowledged; errors reported per I6 (I6=2: nothing), `<CTRL-B>` tagging per I64, data lines
//! without `<CR>` when I62=1 (unless I64=1). They replace the "last line" of CTRL-I/CTRL-Y.

use super::reply::{Outcome, BELL, CR};
use super::{Pmac, Session};
use crate::domain::{CsNum, MotorNum};

/// `<CTRL-B>`: tag of unsolicited lines with I64=1.
const STX: u8 = 0x02;

impl Pmac<'_> {
    /// Execute a command line issued by a program (`CMD"..."`) with the program's addressing
    /// (motion program: #1 &1 or its own C.S.; PLC: its `ADDRESS`). Returns the unsolicited
    /// output to send to the host (possibly empty).
    pub(crate) fn program_command(&mut self, motor: u16, coord: u16, line: &[u8]) -> Vec<u8> {
        let i = |c: &Pmac<'_>, n: u32| c.model.state.peek_ivar(n).unwrap_or(0.0) != 0.0;
        let mut s = Session {
            motor: MotorNum::of(motor),
            coord: CsNum::of(coord),
            ..Session::with_id(0)
        };
        let clean: Vec<u8> = line.iter().copied().filter(|b| *b >= 0x20).collect();
        if clean.len() <= super::MAX_LINE {
            self.mem.last_line.clone_from(&clean);
        }
        self.model.state.global.from_cmd = true;
        let (outcome, lines) = self.execute_line(&mut s, &clean);
        self.model.state.global.from_cmd = false;
        let (tag, no_cr) = (i(self, 64), i(self, 62));
        let mut out = Vec::new();
        for (_, l) in lines {
            if tag {
                out.push(STX);
            }
            out.extend_from_slice(l.as_bytes());
            if tag || !no_cr {
                out.push(CR);
            }
        }
        if let Outcome::Err(code) = outcome {
            let i6 = self.model.state.peek_ivar(6).unwrap_or(3.0) as u32 & 3;
            if i6 != 2 {
                out.push(if tag { STX } else { BELL });
                if i6 == 1 || i6 == 3 {
                    out.extend_from_slice(code.to_string().as_bytes());
                    out.push(CR);
                }
            }
        }
        out
    }
}
