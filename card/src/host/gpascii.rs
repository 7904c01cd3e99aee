//! The Power PMAC `gpascii` command thread as a host sees it (pure): its banner and how a
//! byte stream becomes command lines.
//!
//! A Power PMAC runs `gpascii` on its Linux side; each instance is one communication thread
//! with its own addressed motor/C.S., echo mode, L/R stack and open buffer (power-pmac.md
//! §2.13). It prints [`BANNER`] when it starts, then reads one command line at a time; the
//! reply to each line (its output, then `ACK CR LF`, also for an empty line: hosts wait for
//! the `ACK`) is the Power dialect's (`lang::Dialect::whole_line`), sent as it is.
//!
//! [`LineSplitter`] reads the raw TCP ("Telnet") port: `CR`, `LF` and `CR LF` each end one line,
//! Telnet `IAC` negotiation is dropped, `<CTRL-C>` / `<CTRL-D>` end the session (as they end
//! `gpascii` on a terminal). The SSH shell feeds `gpascii` through its own terminal emulation
//! (`host::ssh::shell`).

/// What `gpascii` prints when it starts (hosts wait for "ASCII").
pub(crate) const BANNER: &[u8] = b"STDIN Open for ASCII Input\n";

/// Longest command line the dialect accepts (bytes, without its end). A longer line is kept
/// to one byte more (the dialect refuses it with its error #20 and runs nothing).
pub(crate) const MAX_LINE: usize = crate::lang::SCRIPT_MAX_LINE;

const CR: u8 = b'\r';
const LF: u8 = b'\n';
const CTRL_C: u8 = 0x03;
const CTRL_D: u8 = 0x04;
const IAC: u8 = 0xFF;

/// What a host sent on the raw `gpascii` port, in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum GpEvent {
    /// A command line (without its end; possibly empty; an over-long line cut to
    /// `MAX_LINE + 1` bytes).
    Line(Vec<u8>),
    /// `<CTRL-C>` or `<CTRL-D>`: the host ends the session.
    Quit,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum Telnet {
    /// Plain data.
    #[default]
    Data,
    /// After `IAC`.
    Iac,
    /// After `IAC WILL|WONT|DO|DONT`: the option byte follows.
    Option,
    /// Inside `IAC SB … IAC SE`.
    Sub,
    /// `IAC` inside a subnegotiation.
    SubIac,
}

/// Line assembler of the raw `gpascii` port (see the module docs).
#[derive(Debug, Clone, Default)]
pub(crate) struct LineSplitter {
    line: Vec<u8>,
    after_cr: bool,
    telnet: Telnet,
}

impl LineSplitter {
    /// An empty splitter.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Feed received bytes; the resulting events in order (nothing after a [`GpEvent::Quit`]).
    pub(crate) fn feed(&mut self, bytes: &[u8]) -> Vec<GpEvent> {
        let mut out = Vec::new();
        for &b in bytes {
            if let Some(data) = self.telnet(b) {
                self.push(data, &mut out);
                if out.last() == Some(&GpEvent::Quit) {
                    break;
                }
            }
        }
        out
    }

    /// Strip Telnet commands: the data byte `b` stands for, if any.
    fn telnet(&mut self, b: u8) -> Option<u8> {
        match (self.telnet, b) {
            (Telnet::Data, IAC) => self.telnet = Telnet::Iac,
            (Telnet::Data, _) => return Some(b),
            (Telnet::Iac, IAC) => {
                self.telnet = Telnet::Data;
                return Some(IAC);
            }
            (Telnet::Iac, 251..=254) => self.telnet = Telnet::Option,
            (Telnet::Iac, 250) => self.telnet = Telnet::Sub,
            (Telnet::Iac | Telnet::Option, _) => self.telnet = Telnet::Data,
            (Telnet::Sub, IAC) => self.telnet = Telnet::SubIac,
            (Telnet::Sub, _) => {}
            (Telnet::SubIac, 240) => self.telnet = Telnet::Data,
            (Telnet::SubIac, _) => self.telnet = Telnet::Sub,
        }
        None
    }

    fn push(&mut self, b: u8, out: &mut Vec<GpEvent>) {
        let after_cr = std::mem::replace(&mut self.after_cr, b == CR);
        match b {
            LF if after_cr => {}
            CR | LF => self.end_line(out),
            CTRL_C | CTRL_D => out.push(GpEvent::Quit),
            // Other control characters (and Telnet's CR NUL) are no part of a command.
            0x00..=0x1F | 0x7F => {}
            _ if self.line.len() > MAX_LINE => {}
            _ => self.line.push(b),
        }
    }

    fn end_line(&mut self, out: &mut Vec<GpEvent>) {
        out.push(GpEvent::Line(std::mem::take(&mut self.line)));
    }
}

#[cfg(test)]
mod tests {
    use super::GpEvent::*;
    use super::*;

    fn line(s: &str) -> GpEvent {
        Line(s.as_bytes().to_vec())
    }

    #[test]
    fn cr_lf_and_crlf_each_end_one_line() {
        let mut s = LineSplitter::new();
        assert_eq!(
            s.feed(b"P1\r\nP2\nP3\rP4"),
            vec![line("P1"), line("P2"), line("P3")]
        );
        assert_eq!(s.feed(b"\r\r\n"), vec![line("P4"), line("")]);
        // A CR LF split across reads is still one end.
        assert_eq!(s.feed(b"cid\r"), vec![line("cid")]);
        assert_eq!(s.feed(b"\nvers\n"), vec![line("vers")]);
    }

    #[test]
    fn telnet_negotiation_and_control_bytes_are_dropped() {
        let mut s = LineSplitter::new();
        // IAC DO ECHO, IAC SB NAWS … IAC SE, IAC IAC (a data 0xFF), CR NUL, a stray TAB.
        let input = b"\xff\xfd\x01\xff\xfa\x1f\x00\x50\x00\x18\xff\xf0P\t1\xff\xff\r\x00";
        assert_eq!(s.feed(input), vec![Line(vec![b'P', b'1', 0xFF])]);
    }

    #[test]
    fn ctrl_c_or_ctrl_d_quit_and_stop_reading() {
        let mut s = LineSplitter::new();
        assert_eq!(s.feed(b"P1\n\x03P2\n"), vec![line("P1"), Quit]);
        let mut s = LineSplitter::new();
        assert_eq!(s.feed(b"\x04"), vec![Quit]);
    }

    #[test]
    fn an_overlong_line_is_cut_to_one_byte_over_the_limit_then_reading_resumes() {
        let mut s = LineSplitter::new();
        let mut input = vec![b'1'; MAX_LINE];
        assert_eq!(s.feed(&input), vec![]);
        assert_eq!(s.feed(b"\n"), vec![Line(vec![b'1'; MAX_LINE])]);
        input.extend_from_slice(b"23\nP7\n");
        let mut cut = vec![b'1'; MAX_LINE];
        cut.push(b'2');
        assert_eq!(s.feed(&input), vec![Line(cut), line("P7")]);
    }
}
