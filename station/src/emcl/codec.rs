//! The EMCL wire format (spec emcl.md §2): 9-byte request and reply frames, the checksum, the
//! special version-string reply, and the byte-stream reassembler a bus server uses.
//!
//! Request: `address, instruction, type, motor/bank, value (i32, MSB first), checksum`.
//! Reply: `host address, module address, status, instruction, value, checksum`. The checksum
//! is the low byte of the sum of bytes 0..=7 (address included) [seed L43, L111].

use serde::{Deserialize, Serialize};

/// Bytes in a request or reply frame.
pub const FRAME_LEN: usize = 9;

/// Status codes (spec §3).
pub mod status {
    /// Executed, no error.
    pub const OK: u8 = 100;
    /// Instruction stored in program memory (download mode).
    pub const STORED: u8 = 101;
    /// Wrong checksum.
    pub const CHECKSUM: u8 = 1;
    /// Invalid instruction (unknown number).
    pub const INVALID_INSTRUCTION: u8 = 2;
    /// Wrong type (unknown parameter, port, sub-mode).
    pub const WRONG_TYPE: u8 = 3;
    /// Invalid value (out of range; motor ≠ 0; bank > 3).
    pub const INVALID_VALUE: u8 = 4;
    /// Configuration EEPROM locked (GP 73).
    pub const EEPROM_LOCKED: u8 = 5;
    /// Instruction not available (stand-alone only; refused while bound to a MACRO node).
    pub const NOT_AVAILABLE: u8 = 6;
}

/// Low byte of the sum of `b` (call it with bytes 0..=7 of a frame).
pub fn checksum(b: &[u8]) -> u8 {
    b.iter().fold(0u8, |s, &x| s.wrapping_add(x))
}

/// The 7-byte instruction core `{instruction, type, motor/bank, value}`: what a request
/// carries after its address and what one program-memory slot holds (§6.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Instr {
    /// Instruction number.
    pub op: u8,
    /// Type field.
    pub typ: u8,
    /// Motor or bank field.
    pub motor: u8,
    /// Value (two's complement on the wire).
    pub value: i32,
}

impl Instr {
    /// An instruction.
    pub const fn new(op: u8, typ: u8, motor: u8, value: i32) -> Self {
        Instr {
            op,
            typ,
            motor,
            value,
        }
    }

    /// The 7 bytes (value big-endian).
    pub fn to_bytes(self) -> [u8; 7] {
        let v = self.value.to_be_bytes();
        [self.op, self.typ, self.motor, v[0], v[1], v[2], v[3]]
    }

    /// From 7 bytes (the 8-byte TMCL-IDE binary layout: use the first 7).
    pub fn from_bytes(b: [u8; 7]) -> Self {
        Instr {
            op: b[0],
            typ: b[1],
            motor: b[2],
            value: i32::from_be_bytes([b[3], b[4], b[5], b[6]]),
        }
    }
}

/// A request frame's fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request {
    /// Target (module) address.
    pub addr: u8,
    /// The instruction.
    pub instr: Instr,
}

impl Request {
    /// Parse a frame. `Err` carries the fields of a frame whose checksum is wrong (the
    /// drive answers it with status 1 if the address is its own).
    pub fn parse(frame: &[u8; FRAME_LEN]) -> Result<Request, Request> {
        let instr = Instr::from_bytes([
            frame[1], frame[2], frame[3], frame[4], frame[5], frame[6], frame[7],
        ]);
        let r = Request {
            addr: frame[0],
            instr,
        };
        if checksum(&frame[..8]) == frame[8] {
            Ok(r)
        } else {
            Err(r)
        }
    }

    /// The 9-byte frame with its checksum.
    pub fn to_bytes(self) -> [u8; FRAME_LEN] {
        let i = self.instr.to_bytes();
        let mut f = [self.addr, i[0], i[1], i[2], i[3], i[4], i[5], i[6], 0];
        f[8] = checksum(&f[..8]);
        f
    }
}

/// A normal reply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reply {
    /// Reply (host) address, GP 76.
    pub host: u8,
    /// Module address, GP 66.
    pub module: u8,
    /// Status code.
    pub status: u8,
    /// Instruction echoed.
    pub op: u8,
    /// Value.
    pub value: i32,
}

impl Reply {
    /// The 9-byte frame with its checksum.
    pub fn to_bytes(self) -> [u8; FRAME_LEN] {
        let v = self.value.to_be_bytes();
        let mut f = [
            self.host,
            self.module,
            self.status,
            self.op,
            v[0],
            v[1],
            v[2],
            v[3],
            0,
        ];
        f[8] = checksum(&f[..8]);
        f
    }

    /// Parse a reply frame (None if the checksum is wrong).
    pub fn parse(frame: &[u8; FRAME_LEN]) -> Option<Reply> {
        (checksum(&frame[..8]) == frame[8]).then(|| Reply {
            host: frame[0],
            module: frame[1],
            status: frame[2],
            op: frame[3],
            value: i32::from_be_bytes([frame[4], frame[5], frame[6], frame[7]]),
        })
    }
}

/// The special reply to 136 type 0: host address then 8 ASCII characters, **no checksum**
/// (§2.4).
pub fn version_string_reply(host: u8, text: &[u8; 8]) -> [u8; FRAME_LEN] {
    let mut f = [host; FRAME_LEN];
    f[1..].copy_from_slice(text);
    f
}

/// Cuts a byte stream (a TCP connection, a pty) into 9-byte frames. There is no timing
/// inside a frame on a byte stream: frames are cut strictly every 9 bytes, whatever the
/// segmentation. A partial frame followed by `silence_ms` without a byte is discarded (the
/// inter-byte timeout of the drive's UART, spec §2.6), which is how a host that sent garbage
/// gets back in step: it waits for a reply that does not come, and the partial frame goes.
/// Pure: the caller passes the time of each arrival.
#[derive(Clone, Debug)]
pub struct FrameAssembler {
    buf: [u8; FRAME_LEN],
    len: usize,
    last_ms: u64,
    silence_ms: u64,
    discarded: u64,
}

impl FrameAssembler {
    /// An empty assembler that drops a partial frame after `silence_ms` of silence.
    pub fn new(silence_ms: u64) -> Self {
        FrameAssembler {
            buf: [0; FRAME_LEN],
            len: 0,
            last_ms: 0,
            silence_ms,
            discarded: 0,
        }
    }

    /// Bytes arrived at `now_ms`: the complete frames, in order.
    pub fn push(&mut self, data: &[u8], now_ms: u64) -> Vec<[u8; FRAME_LEN]> {
        self.expire(now_ms);
        let mut out = Vec::with_capacity((self.len + data.len()) / FRAME_LEN);
        for &b in data {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
            }
            self.len += 1;
            if self.len == FRAME_LEN {
                out.push(self.buf);
                self.len = 0;
            }
        }
        if !data.is_empty() {
            self.last_ms = now_ms;
        }
        out
    }

    /// Drop a partial frame that has been silent for the timeout; true if one was dropped.
    pub fn expire(&mut self, now_ms: u64) -> bool {
        if self.len > 0 && now_ms.saturating_sub(self.last_ms) >= self.silence_ms {
            self.len = 0;
            self.discarded += 1;
            return true;
        }
        false
    }

    /// Bytes of the partial frame held.
    pub fn pending(&self) -> usize {
        self.len
    }

    /// When the partial frame (if any) expires.
    pub fn deadline_ms(&self) -> Option<u64> {
        (self.len > 0).then(|| self.last_ms.saturating_add(self.silence_ms))
    }

    /// Partial frames discarded so far.
    pub fn discarded(&self) -> u64 {
        self.discarded
    }
}

#[cfg(test)]
#[path = "codec_tests.rs"]
mod tests;
