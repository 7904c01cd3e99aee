//! Reply framing per I3 (handshake), I4 (checksums) and I6 (error reporting) — spec §2.1-§2.3,
//! §2.7, §2.8. Pure: the executor pushes data lines and finally an outcome; this module adds
//! `<LF>`, `<CR>`, `<ACK>`, `<BELL>`, `ERRnnn` and checksum bytes.
//!
//! Framing values are sampled when each piece is pushed, so a line such as `i6=1 i3=2 ver`
//! answers `ver` (and the final acknowledge) in the new framing (host-protocols §0 item 3).

/// Line feed.
pub(super) const LF: u8 = 0x0A;
/// Carriage return.
pub(super) const CR: u8 = 0x0D;
/// Acknowledge.
pub(super) const ACK: u8 = 0x06;
/// Bell (error indicator).
pub(super) const BELL: u8 = 0x07;

use crate::domain::ErrCode;

/// The communication I-variables that shape a reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Framing {
    /// I3: handshake / line delimiting (0..3).
    pub i3: u8,
    /// I4: bit 0 = checksums enabled.
    pub i4: u8,
    /// I6: error reporting (0..3).
    pub i6: u8,
}

impl Default for Framing {
    /// Seed defaults: I3=1, I4=0, I6=3.
    fn default() -> Self {
        Framing {
            i3: 1,
            i4: 0,
            i6: 3,
        }
    }
}

impl Framing {
    /// Build from raw I-variable values (out-of-range values are masked to their 2 low bits).
    pub(crate) fn from_ivars(i3: i64, i4: i64, i6: i64) -> Self {
        Framing {
            i3: (i3 & 3) as u8,
            i4: (i4 & 3) as u8,
            i6: (i6 & 3) as u8,
        }
    }

    fn lf_prefix(self) -> bool {
        self.i3 == 1 || self.i3 == 3
    }

    fn checksums(self) -> bool {
        self.i4 & 1 == 1
    }
}

/// Low 8 bits of the unsigned byte sum (spec §2.3 [DECISION]).
pub(super) fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |a, &b| a.wrapping_add(b))
}

/// Host→card checksum: over the printable characters of the command line only.
pub(super) fn command_checksum(line: &[u8]) -> u8 {
    line.iter()
        .filter(|b| (0x20..0x7F).contains(*b))
        .fold(0u8, |a, &b| a.wrapping_add(b))
}

/// How a command line ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// Every command succeeded: send the acknowledge (and command checksum).
    Ok,
    /// A command failed with `ERRnnn` (1..=17): data already produced stays, then the error.
    Err(ErrCode),
    /// No acknowledge at all (`$$$`).
    Silent,
}

/// Accumulates one framed reply.
#[derive(Debug, Default, Clone)]
pub(super) struct Reply {
    out: Vec<u8>,
}

impl Reply {
    /// An empty reply.
    pub(super) fn new() -> Self {
        Reply { out: Vec::new() }
    }

    /// Append one data line (`text` without terminator): `[<LF>]text<CR>[checksum]`.
    pub(super) fn data_line(&mut self, f: Framing, text: &[u8]) {
        let start = self.out.len();
        if f.lf_prefix() {
            self.out.push(LF);
        }
        self.out.extend_from_slice(text);
        self.out.push(CR);
        if f.checksums() {
            let c = checksum(&self.out[start..]);
            self.out.push(c);
        }
    }

    /// Finish the reply for the command line `line` (without its CR) with `outcome`.
    pub(super) fn finish(&mut self, f: Framing, outcome: Outcome, line: &[u8]) {
        match outcome {
            Outcome::Silent => {}
            Outcome::Ok => match f.i3 {
                0 => {}
                1 => self.ack_with_checksum(f, LF, line),
                _ => self.ack_with_checksum(f, ACK, line),
            },
            Outcome::Err(code) => self.error(f, code),
        }
    }

    fn ack_with_checksum(&mut self, f: Framing, ack: u8, line: &[u8]) {
        self.out.push(ack);
        if f.checksums() {
            self.out.push(command_checksum(line));
        }
    }

    /// Append an error report per I6 (and I3 for the `<LF>` before `ERR`).
    pub(super) fn error(&mut self, f: Framing, code: ErrCode) {
        self.out.push(BELL);
        if f.i6 == 3 {
            self.out.push(CR);
        }
        if f.i6 == 1 || f.i6 == 3 {
            if f.lf_prefix() {
                self.out.push(LF);
            }
            self.out.extend_from_slice(code.to_string().as_bytes());
            self.out.push(CR);
        }
    }

    /// Append raw bytes (control-character replies that carry their own terminator).
    pub(super) fn raw(&mut self, bytes: &[u8]) {
        self.out.extend_from_slice(bytes);
    }

    /// Bytes produced so far.
    #[cfg(test)]
    pub(super) fn as_bytes(&self) -> &[u8] {
        &self.out
    }

    /// The finished reply.
    pub(super) fn into_bytes(self) -> Vec<u8> {
        self.out
    }
}

/// Frame the text reply of a control character (`<CTRL-B>`, `<CTRL-G>`, ...): `text<CR>` with a
/// line checksum when I4 bit 0 is set; never an `<LF>` prefix nor an acknowledge (§2.1 [DECISION]).
pub(super) fn control_line(f: Framing, text: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(text.len() + 2);
    v.extend_from_slice(text);
    v.push(CR);
    if f.checksums() {
        let c = checksum(&v);
        v.push(c);
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fr(i3: u8, i6: u8) -> Framing {
        Framing { i3, i4: 0, i6 }
    }

    fn run(f: Framing, lines: &[&str], outcome: Outcome) -> Vec<u8> {
        let mut r = Reply::new();
        for l in lines {
            r.data_line(f, l.as_bytes());
        }
        r.finish(f, outcome, b"P1");
        r.into_bytes()
    }

    #[test]
    fn data_and_ack_for_every_i3() {
        // I6 does not matter for successful lines.
        for i6 in 0..4 {
            assert_eq!(run(fr(0, i6), &["25"], Outcome::Ok), b"25\r");
            assert_eq!(run(fr(1, i6), &["25"], Outcome::Ok), b"\n25\r\n");
            assert_eq!(run(fr(2, i6), &["25"], Outcome::Ok), b"25\r\x06");
            assert_eq!(run(fr(3, i6), &["25"], Outcome::Ok), b"\n25\r\x06");
            assert_eq!(run(fr(0, i6), &[], Outcome::Ok), b"");
            assert_eq!(run(fr(1, i6), &[], Outcome::Ok), b"\n");
            assert_eq!(run(fr(2, i6), &[], Outcome::Ok), b"\x06");
            assert_eq!(run(fr(3, i6), &[], Outcome::Ok), b"\x06");
        }
        assert_eq!(
            run(fr(1, 3), &["25", "50", "75"], Outcome::Ok),
            b"\n25\r\n50\r\n75\r\n"
        );
    }

    #[test]
    fn errors_for_every_i3_i6_combination() {
        let expect: [[&[u8]; 4]; 4] = [
            // I3 = 0
            [b"\x07", b"\x07ERR003\r", b"\x07", b"\x07\rERR003\r"],
            // I3 = 1
            [b"\x07", b"\x07\nERR003\r", b"\x07", b"\x07\r\nERR003\r"],
            // I3 = 2
            [b"\x07", b"\x07ERR003\r", b"\x07", b"\x07\rERR003\r"],
            // I3 = 3
            [b"\x07", b"\x07\nERR003\r", b"\x07", b"\x07\r\nERR003\r"],
        ];
        for i3 in 0..4u8 {
            for i6 in 0..4u8 {
                let got = run(fr(i3, i6), &[], Outcome::Err(ErrCode::Data));
                assert_eq!(got, expect[i3 as usize][i6 as usize], "I3={i3} I6={i6}");
            }
        }
    }

    #[test]
    fn data_before_error_is_kept_and_no_ack_follows() {
        assert_eq!(
            run(fr(2, 1), &["25"], Outcome::Err(ErrCode::Data)),
            b"25\r\x07ERR003\r"
        );
        assert_eq!(
            run(fr(1, 3), &["25"], Outcome::Err(ErrCode::NoProgram)),
            b"\n25\r\x07\r\nERR015\r"
        );
    }

    #[test]
    fn silent_outcome_sends_nothing() {
        assert_eq!(run(fr(2, 1), &[], Outcome::Silent), b"");
    }

    #[test]
    fn checksums_match_manual_example() {
        // I3=2, I4=1, P1=25: "25" CR 0x74 ACK 0x81.
        let f = Framing {
            i3: 2,
            i4: 1,
            i6: 1,
        };
        assert_eq!(run(f, &["25"], Outcome::Ok), b"25\r\x74\x06\x81");
        // J+ -> 74+43 = 117.
        assert_eq!(command_checksum(b"J+"), 117);
        // Control characters are excluded from the host checksum.
        assert_eq!(command_checksum(b"J\x01+"), 117);
        // With I3=1 the leading LF belongs to the line checksum.
        let f1 = Framing {
            i3: 1,
            i4: 1,
            i6: 3,
        };
        let mut r = Reply::new();
        r.data_line(f1, b"25");
        assert_eq!(r.as_bytes(), b"\n25\r\x7e");
        // No checksum after BELL.
        assert_eq!(run(f, &[], Outcome::Err(ErrCode::Data)), b"\x07ERR003\r");
        // Sum wraps modulo 256.
        assert_eq!(checksum(&[0xFF, 0x02]), 1);
    }

    #[test]
    fn control_line_has_no_ack() {
        assert_eq!(
            control_line(Framing::default(), b"000000000800"),
            b"000000000800\r"
        );
    }
}
