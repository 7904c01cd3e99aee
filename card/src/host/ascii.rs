//! ASCII terminal-port codec (pure): a raw byte stream from the host becomes command lines and
//! control-character commands, exactly as the PMAC serial port reads them (spec pmac-commands.md
//! §1.3, §3.1).
//!
//! - `<CR>` ends a line; a `<LF>` is always ignored (so CR LF works too).
//! - Control characters act at once and never enter the line buffer. `<CTRL-H>` (backspace),
//!   `<CTRL-I>` (repeat last line), `<CTRL-N>` (checksum of the partial line), `<CTRL-X>` (flush)
//!   and `<CTRL-Y>` (recall last line) are line-editing commands handled here; the other
//!   `<CTRL-A>`..`<CTRL-Z>` go to the interpreter. 0x00 and 0x1B..0x1F are ignored.
//! - A line longer than [`MAX_LINE`] is discarded; at its `<CR>` the port answers the card's
//!   ERR003 ([`AsciiEvent::Overlong`]) and reading resumes with the next line.

/// Longest command line accepted (bytes, without the `<CR>`): the interpreter's limit.
pub(crate) const MAX_LINE: usize = crate::lang::MAX_LINE;

/// Control characters handled by the port itself rather than by the interpreter.
const CTRL_H: u8 = 0x08;
const CTRL_I: u8 = 0x09;
const LF: u8 = 0x0A;
const CR: u8 = 0x0D;
const CTRL_N: u8 = 0x0E;
const CTRL_X: u8 = 0x18;
const CTRL_Y: u8 = 0x19;

/// What the host sent, in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum AsciiEvent {
    /// A complete command line (without its `<CR>`) to execute.
    Line(Vec<u8>),
    /// A control-character command (`<CTRL-A>`..`<CTRL-Z>`) for the interpreter.
    Control(u8),
    /// Bytes the port answers by itself (`<CTRL-N>` checksum, `<CTRL-Y>` line recall).
    Reply(Vec<u8>),
    /// `<CTRL-X>`: drop any reply not yet sent, then pass 0x18 to the interpreter.
    Cancel,
    /// A line longer than [`MAX_LINE`] ended: answer with the card's ERR003.
    Overlong,
}

/// Per-connection line assembler.
#[derive(Debug, Default, Clone)]
pub(crate) struct AsciiCodec {
    line: Vec<u8>,
    overflow: bool,
    last_line: Vec<u8>,
    echo: bool,
}

impl AsciiCodec {
    /// A codec with an empty line buffer and no remembered line.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Part of a line has arrived (its `<CR>` has not).
    pub(crate) fn has_partial(&self) -> bool {
        !self.line.is_empty() || self.overflow
    }

    /// The partial line received so far (not yet terminated by `<CR>`).
    #[cfg(test)]
    pub(crate) fn partial(&self) -> &[u8] {
        &self.line
    }

    /// Full-duplex echo (`<CTRL-T>`): when on, received line characters and `<CR>` are sent back
    /// ([`AsciiEvent::Reply`]) ahead of whatever they cause.
    pub(crate) fn set_echo(&mut self, on: bool) {
        self.echo = on;
    }

    /// Feed received bytes; returns the resulting events in order.
    pub(crate) fn feed(&mut self, bytes: &[u8]) -> Vec<AsciiEvent> {
        let mut out = Vec::new();
        let mut echo = Vec::new();
        let mut evs = Vec::new();
        for &b in bytes {
            self.push(b, &mut evs);
            if self.echo && (b == CR || b >= 0x20) {
                echo.push(b);
            }
            if !evs.is_empty() {
                if !echo.is_empty() {
                    out.push(AsciiEvent::Reply(std::mem::take(&mut echo)));
                }
                out.append(&mut evs);
            }
        }
        if !echo.is_empty() {
            out.push(AsciiEvent::Reply(echo));
        }
        out
    }

    /// End the partial line as if a `<CR>` had arrived, if anything is in it (used by the
    /// Ethernet port, whose GETRESPONSE payload carries an implicit `<CR>`).
    pub(crate) fn finish_line(&mut self, out: &mut Vec<AsciiEvent>) {
        if !self.line.is_empty() || self.overflow {
            self.end_line(out);
        }
    }

    /// Forget the partial line (FLUSH / `<CTRL-X>`).
    pub(crate) fn discard_partial(&mut self) {
        self.line.clear();
        self.overflow = false;
    }

    /// Process one byte.
    pub(crate) fn push(&mut self, b: u8, out: &mut Vec<AsciiEvent>) {
        match b {
            CR => self.end_line(out),
            LF => {}
            CTRL_H => {
                if !self.overflow {
                    self.line.pop();
                }
            }
            CTRL_I => {
                if !self.last_line.is_empty() {
                    out.push(AsciiEvent::Line(self.last_line.clone()));
                }
            }
            CTRL_N => {
                let sum = self.line.iter().fold(0u8, |acc, &c| acc.wrapping_add(c));
                out.push(AsciiEvent::Reply(vec![sum]));
            }
            CTRL_X => {
                self.discard_partial();
                out.push(AsciiEvent::Cancel);
            }
            CTRL_Y => {
                self.overflow = false;
                self.line.clone_from(&self.last_line);
                out.push(AsciiEvent::Reply(self.last_line.clone()));
            }
            0x01..=0x1A => out.push(AsciiEvent::Control(b)),
            0x00 | 0x1B..=0x1F => {}
            _ => {
                if self.overflow {
                    return;
                }
                if self.line.len() >= MAX_LINE {
                    self.overflow = true;
                    self.line.clear();
                } else {
                    self.line.push(b);
                }
            }
        }
    }

    fn end_line(&mut self, out: &mut Vec<AsciiEvent>) {
        if self.overflow {
            self.overflow = false;
            self.line.clear();
            out.push(AsciiEvent::Overlong);
            return;
        }
        let line = std::mem::take(&mut self.line);
        if !line.is_empty() {
            self.last_line.clone_from(&line);
        }
        out.push(AsciiEvent::Line(line));
    }
}

#[cfg(test)]
mod tests {
    use super::AsciiEvent::*;
    use super::*;

    fn line(s: &str) -> AsciiEvent {
        Line(s.as_bytes().to_vec())
    }

    #[test]
    fn cr_and_crlf_end_lines_lf_alone_ignored() {
        let mut c = AsciiCodec::new();
        assert_eq!(
            c.feed(b"P1\rP2\r\nP\n3\r"),
            vec![line("P1"), line("P2"), line("P3")]
        );
        assert!(c.partial().is_empty());
    }

    #[test]
    fn lines_split_across_feeds() {
        let mut c = AsciiCodec::new();
        assert_eq!(c.feed(b"#1J"), vec![]);
        assert_eq!(c.partial(), b"#1J");
        assert_eq!(c.feed(b"+\r"), vec![line("#1J+")]);
    }

    #[test]
    fn empty_line_is_passed_on_but_not_remembered() {
        let mut c = AsciiCodec::new();
        assert_eq!(c.feed(b"P5\r\r\t"), vec![line("P5"), line(""), line("P5")]);
    }

    #[test]
    fn control_chars_act_immediately_and_stay_out_of_the_line() {
        let mut c = AsciiCodec::new();
        assert_eq!(
            c.feed(b"P\x021\x0b0\r"),
            vec![Control(0x02), Control(0x0B), line("P10")]
        );
    }

    #[test]
    fn tab_repeats_last_line_and_is_not_whitespace() {
        let mut c = AsciiCodec::new();
        assert_eq!(c.feed(b"\t"), vec![]);
        assert_eq!(
            c.feed(b"I10\r\t\t"),
            vec![line("I10"), line("I10"), line("I10")]
        );
        // A TAB inside a partial line does not become part of it.
        assert_eq!(c.feed(b"P1\tP2\r"), vec![line("I10"), line("P1P2")]);
    }

    #[test]
    fn backspace_removes_last_char() {
        let mut c = AsciiCodec::new();
        assert_eq!(c.feed(b"P12\x083\r\x08\r"), vec![line("P13"), line("")]);
    }

    #[test]
    fn ctrl_n_checksums_partial_line() {
        let mut c = AsciiCodec::new();
        // 'J' + '+' = 74 + 43 = 117 (manual example).
        assert_eq!(c.feed(b"J+\x0e"), vec![Reply(vec![117])]);
        assert_eq!(c.partial(), b"J+");
        // Wraps modulo 256: 3 * 'z' (122) = 366 -> 110.
        let mut c = AsciiCodec::new();
        assert_eq!(c.feed(b"zzz\x0e"), vec![Reply(vec![110])]);
    }

    #[test]
    fn ctrl_x_discards_partial_line() {
        let mut c = AsciiCodec::new();
        assert_eq!(c.feed(b"P1=5\x18P2\r"), vec![Cancel, line("P2")]);
    }

    #[test]
    fn ctrl_y_recalls_last_line_for_editing() {
        let mut c = AsciiCodec::new();
        assert_eq!(
            c.feed(b"P12\rxx\x19\x084\r"),
            vec![line("P12"), Reply(b"P12".to_vec()), line("P14")]
        );
    }

    #[test]
    fn other_bytes_ignored_or_forwarded() {
        let mut c = AsciiCodec::new();
        assert_eq!(
            c.feed(b"\x00\x1b\x1f\x01\x1a\x7f\xc3\r"),
            vec![Control(1), Control(0x1A), Line(vec![0x7F, 0xC3])]
        );
    }

    #[test]
    fn overlong_line_answers_once_then_resyncs() {
        let mut c = AsciiCodec::new();
        let mut input = vec![b'1'; MAX_LINE];
        assert_eq!(c.feed(&input), vec![]);
        input.extend_from_slice(b"234\x08\rP7\r");
        let mut c2 = AsciiCodec::new();
        assert_eq!(c2.feed(&input), vec![Overlong, line("P7")]);
        // Exactly MAX_LINE is accepted.
        assert_eq!(c.feed(b"\r"), vec![Line(vec![b'1'; MAX_LINE])]);
        // Control characters still act while discarding.
        let mut c3 = AsciiCodec::new();
        let mut long = vec![b'P'; MAX_LINE + 5];
        long.push(0x02);
        long.push(b'\r');
        assert_eq!(c3.feed(&long), vec![Control(2), Overlong]);
    }

    #[test]
    fn echo_precedes_the_reply_it_causes() {
        let mut c = AsciiCodec::new();
        c.set_echo(true);
        assert_eq!(
            c.feed(b"P1\r\nP\x02"),
            vec![
                Reply(b"P1\r".to_vec()),
                line("P1"),
                Reply(b"P".to_vec()),
                Control(2)
            ]
        );
        assert_eq!(c.feed(b"2"), vec![Reply(b"2".to_vec())]);
        c.set_echo(false);
        assert_eq!(c.feed(b"\r"), vec![line("P2")]);
    }

    #[test]
    fn finish_line_gives_implicit_cr() {
        let mut c = AsciiCodec::new();
        let mut out = c.feed(b"ver");
        c.finish_line(&mut out);
        c.finish_line(&mut out);
        assert_eq!(out, vec![line("ver")]);
    }
}
