//! PMAC Ethernet protocol (Acc-54E / Turbo "VR_" packets), one connection's state machine
//! (pure: bytes in, packets out; spec host-protocols.md §1.1 and §4.4).
//!
//! A request is an 8-byte header `bRequestType bRequest wValue wIndex wLength` (16-bit fields
//! big-endian) followed, for `VR_DOWNLOAD` (0x40) requests, by exactly `wLength` data bytes.
//! Every reply is produced as one [`EthAction::Send`] so the server writes it with one write.
//! A long reply is pulled from the card part by part as the host fetches it (streamed lines:
//! a connection holds at most about one part plus one packet, whatever the reply's length).
//! Long replies go out in packets of at least [`PACKET_DATA`] bytes (fewer only if `GETBUFFER`'s
//! `wLength` asks for fewer) that never end in `<CR>`, `<ACK>` or `<NUL>` unless they are the last
//! one; the rest waits for `VR_PMAC_GETBUFFER`.

use std::collections::VecDeque;

use super::ascii::{AsciiCodec, AsciiEvent};
use super::port::{run_event, run_events, Interpreter};

/// Header length in bytes.
pub(crate) const HEADER_LEN: usize = 8;
/// Largest data part of a request (`bData[1492]`).
pub(crate) const MAX_PAYLOAD: usize = 1492;
/// Data bytes per reply packet (real firmware cuts here).
pub(crate) const PACKET_DATA: usize = 1400;

/// `bRequestType`: host to card data.
pub(crate) const VR_DOWNLOAD: u8 = 0x40;
/// `bRequestType`: card to host data.
pub(crate) const VR_UPLOAD: u8 = 0xC0;
/// Send a line; the reply is kept for `GETLINE`.
pub(crate) const VR_PMAC_SENDLINE: u8 = 0xB0;
/// Next pending reply line.
pub(crate) const VR_PMAC_GETLINE: u8 = 0xB1;
/// Discard pending output (answer `@`).
pub(crate) const VR_PMAC_FLUSH: u8 = 0xB3;
/// Execute a command line and return its reply.
pub(crate) const VR_PMAC_GETRESPONSE: u8 = 0xBF;
/// Is output pending? (2 bytes).
pub(crate) const VR_PMAC_READREADY: u8 = 0xC2;
/// Execute a control character (in `wValue`) and return its reply.
pub(crate) const VR_CTRL_RESPONSE: u8 = 0xC4;
/// Next packet of a long reply.
pub(crate) const VR_PMAC_GETBUFFER: u8 = 0xC5;
/// Several NUL-separated lines; 4-byte status reply.
pub(crate) const VR_PMAC_WRITEBUFFER: u8 = 0xC6;

/// Reply to FLUSH and SENDLINE (real cards send `@`).
pub(crate) const FLUSH_REPLY: u8 = b'@';
const ACK: u8 = 0x06;
const CR: u8 = 0x0D;
const NUL: u8 = 0x00;
const BELL: u8 = 0x07;

/// A parsed request header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Header {
    /// `VR_DOWNLOAD` or `VR_UPLOAD`.
    pub request_type: u8,
    /// The `VR_…` request code.
    pub request: u8,
    /// `wValue` (big-endian on the wire).
    pub value: u16,
    /// `wIndex` (big-endian on the wire).
    pub index: u16,
    /// `wLength` (big-endian on the wire).
    pub length: u16,
}

impl Header {
    /// Decode 8 header bytes.
    pub(crate) fn parse(b: &[u8; HEADER_LEN]) -> Header {
        Header {
            request_type: b[0],
            request: b[1],
            value: u16::from_be_bytes([b[2], b[3]]),
            index: u16::from_be_bytes([b[4], b[5]]),
            length: u16::from_be_bytes([b[6], b[7]]),
        }
    }

    /// Encode as 8 bytes (clients and tests).
    pub(crate) fn to_bytes(self) -> [u8; HEADER_LEN] {
        let [v0, v1] = self.value.to_be_bytes();
        let [i0, i1] = self.index.to_be_bytes();
        let [l0, l1] = self.length.to_be_bytes();
        [self.request_type, self.request, v0, v1, i0, i1, l0, l1]
    }

    /// Bytes of data that follow this header on the wire.
    pub(crate) fn payload_len(&self) -> usize {
        if self.request_type == VR_DOWNLOAD {
            self.length as usize
        } else {
            0
        }
    }
}

/// A complete request packet as a client sends it (header + data).
pub(crate) fn request(
    request_type: u8,
    request: u8,
    value: u16,
    length: u16,
    data: &[u8],
) -> Vec<u8> {
    let h = Header {
        request_type,
        request,
        value,
        index: 0,
        length,
    };
    let mut v = h.to_bytes().to_vec();
    v.extend_from_slice(data);
    v
}

/// Why the card closed a connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CloseReason {
    /// `bRequestType` is neither 0x40 nor 0xC0 (not this protocol).
    BadRequestType(u8),
    /// A request code this card does not implement.
    UnsupportedRequest(u8),
    /// `wLength` of a download larger than [`MAX_PAYLOAD`].
    Oversized(u16),
}

impl std::fmt::Display for CloseReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CloseReason::BadRequestType(t) => write!(f, "bad bRequestType 0x{t:02X}"),
            CloseReason::UnsupportedRequest(r) => write!(f, "unsupported request 0x{r:02X}"),
            CloseReason::Oversized(n) => write!(f, "wLength {n} exceeds {MAX_PAYLOAD}"),
        }
    }
}

/// What the server must do, in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum EthAction {
    /// Write these bytes with a single write (one reply packet).
    Send(Vec<u8>),
    /// Close the connection (nothing further is processed).
    Close(CloseReason),
}

/// One Ethernet connection: input reassembly, pending reply, line assembler.
#[derive(Debug, Default)]
pub(crate) struct EthConn {
    inbuf: Vec<u8>,
    pending: Vec<u8>,
    pos: usize,
    lines: AsciiCodec,
    closed: bool,
    /// The card has more of the current line's reply ([`Interpreter::line_more`]).
    streaming: bool,
    /// Events of the current request still to run once the streamed line is done.
    deferred: VecDeque<AsciiEvent>,
}

impl EthConn {
    /// A fresh connection.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// True while part of a request has arrived but not all of it.
    pub(crate) fn has_partial_request(&self) -> bool {
        !self.inbuf.is_empty()
    }

    /// Bytes of the current reply held here and not yet sent (the card may have more).
    pub(crate) fn pending_len(&self) -> usize {
        self.pending.len() - self.pos
    }

    /// Bytes this connection holds for its host (bounded: about a streamed part + a packet).
    #[cfg(test)]
    pub(crate) fn held_bytes(&self) -> usize {
        self.pending.len() + self.inbuf.len()
    }

    fn more_at_card(&self) -> bool {
        self.streaming || !self.deferred.is_empty()
    }

    /// Pull from the card until at least `want` bytes are held or the reply is complete.
    fn refill<I: Interpreter + ?Sized>(&mut self, want: usize, interp: &mut I) {
        while self.pending_len() < want && self.more_at_card() {
            let out = self.pull(interp);
            let mut next = Vec::with_capacity(self.pending_len() + out.len());
            next.extend_from_slice(self.pending.get(self.pos..).unwrap_or_default());
            next.extend_from_slice(&out);
            self.set_pending(next);
        }
    }

    /// The next piece of the reply from the card: the streamed line's next part, then the
    /// request's remaining events.
    fn pull<I: Interpreter + ?Sized>(&mut self, interp: &mut I) -> Vec<u8> {
        let mut out = Vec::new();
        if self.streaming {
            let p = interp.line_more();
            out = p.bytes;
            self.streaming = p.more;
        }
        if !self.streaming {
            self.run_deferred(interp, &mut out);
        }
        out
    }

    /// Run deferred events into `out` until one starts a streamed reply.
    fn run_deferred<I: Interpreter + ?Sized>(&mut self, interp: &mut I, out: &mut Vec<u8>) {
        while !self.streaming {
            let Some(ev) = self.deferred.pop_front() else {
                return;
            };
            match ev {
                AsciiEvent::Line(l) => {
                    let p = interp.line_start(&l);
                    out.extend_from_slice(&p.bytes);
                    self.streaming = p.more;
                }
                other => run_event(other, interp, out),
            }
        }
    }

    /// Forget the rest of the current reply (the card drops a streamed line on the next request).
    fn abandon(&mut self) {
        self.set_pending(Vec::new());
        self.streaming = false;
        self.deferred.clear();
    }

    /// Feed received bytes; every complete request is executed against `interp`.
    pub(crate) fn feed<I: Interpreter + ?Sized>(
        &mut self,
        bytes: &[u8],
        interp: &mut I,
    ) -> Vec<EthAction> {
        let mut actions = Vec::new();
        if self.closed {
            return actions;
        }
        self.inbuf.extend_from_slice(bytes);
        let mut start = 0;
        while let Some(hb) = self.inbuf.get(start..start + HEADER_LEN) {
            let mut raw = [0u8; HEADER_LEN];
            raw.copy_from_slice(hb);
            let h = Header::parse(&raw);
            if h.request_type != VR_DOWNLOAD && h.request_type != VR_UPLOAD {
                self.close(CloseReason::BadRequestType(h.request_type), &mut actions);
                return actions;
            }
            if h.payload_len() > MAX_PAYLOAD {
                self.close(CloseReason::Oversized(h.length), &mut actions);
                return actions;
            }
            let end = start + HEADER_LEN + h.payload_len();
            let Some(payload) = self.inbuf.get(start + HEADER_LEN..end) else {
                break;
            };
            let payload = payload.to_vec();
            start = end;
            match self.request(&h, &payload, interp) {
                Ok(reply) => actions.push(EthAction::Send(reply)),
                Err(reason) => {
                    self.close(reason, &mut actions);
                    return actions;
                }
            }
        }
        self.inbuf.drain(..start);
        actions
    }

    fn close(&mut self, reason: CloseReason, actions: &mut Vec<EthAction>) {
        self.closed = true;
        self.inbuf.clear();
        actions.push(EthAction::Close(reason));
    }

    fn request<I: Interpreter + ?Sized>(
        &mut self,
        h: &Header,
        payload: &[u8],
        interp: &mut I,
    ) -> Result<Vec<u8>, CloseReason> {
        Ok(match h.request {
            VR_PMAC_GETRESPONSE => {
                let out = self.execute(payload, interp);
                let empty = out.is_empty() && !self.more_at_card();
                self.set_pending(if empty { vec![ACK] } else { out });
                self.next_packet(PACKET_DATA, interp)
            }
            VR_PMAC_GETBUFFER => {
                self.refill(1, interp);
                if self.pending_len() == 0 {
                    vec![ACK]
                } else {
                    let limit = match h.length as usize {
                        0 => PACKET_DATA,
                        n => n.min(PACKET_DATA),
                    };
                    self.next_packet(limit, interp)
                }
            }
            VR_PMAC_READREADY => {
                self.refill(1, interp);
                vec![u8::from(self.pending_len() > 0), 0]
            }
            VR_PMAC_FLUSH => {
                self.abandon();
                self.lines.discard_partial();
                // The card's own <CTRL-X> (empties its queue); its echo is not sent here.
                let _ = interp.control(0x18);
                vec![FLUSH_REPLY]
            }
            VR_CTRL_RESPONSE => {
                let [hi, lo] = h.value.to_be_bytes();
                let c = if lo != 0 { lo } else { hi };
                let mut out = Vec::new();
                if (0x01..=0x1A).contains(&c) && c != CR && c != 0x0A {
                    let events = self.lines.feed(&[c]);
                    run_events(events, interp, &mut out);
                }
                self.abandon();
                self.set_pending(if out.is_empty() { vec![ACK] } else { out });
                self.next_packet(PACKET_DATA, interp)
            }
            VR_PMAC_SENDLINE => {
                let out = self.execute(payload, interp);
                self.set_pending(out);
                vec![FLUSH_REPLY]
            }
            VR_PMAC_GETLINE => self.next_line(interp),
            VR_PMAC_WRITEBUFFER => self.write_buffer(payload, interp),
            other => return Err(CloseReason::UnsupportedRequest(other)),
        })
    }

    /// Run `payload` as a command line with an implicit `<CR>`: the replies up to the first
    /// part of a streamed one (the rest is pulled by [`EthConn::refill`]).
    fn execute<I: Interpreter + ?Sized>(&mut self, payload: &[u8], interp: &mut I) -> Vec<u8> {
        self.abandon();
        let mut events = self.lines.feed(payload);
        self.lines.finish_line(&mut events);
        self.deferred = events.into();
        let mut out = Vec::new();
        self.run_deferred(interp, &mut out);
        out
    }

    /// Run `payload` to its end keeping only what tells whether it failed: the `ERRnnn` code
    /// (`Some(0)`: failed without a readable code).
    fn execute_for_error<I: Interpreter + ?Sized>(
        &mut self,
        payload: &[u8],
        interp: &mut I,
    ) -> Option<u8> {
        let mut tail = self.execute(payload, interp);
        loop {
            if tail.contains(&BELL) {
                let from = tail.iter().position(|&b| b == BELL).unwrap_or(0);
                let code = error_code(tail.get(from..).unwrap_or_default()).unwrap_or(0);
                self.abandon();
                return Some(code);
            }
            if !self.more_at_card() {
                return None;
            }
            tail = self.pull(interp);
        }
    }

    fn set_pending(&mut self, reply: Vec<u8>) {
        self.pending = reply;
        self.pos = 0;
    }

    /// Next packet: `limit` bytes, extended while it would end in CR/ACK/NUL with more to come.
    fn next_packet<I: Interpreter + ?Sized>(&mut self, limit: usize, interp: &mut I) -> Vec<u8> {
        self.refill(limit + 1, interp);
        let mut n = self.pending_len().min(limit.max(1));
        loop {
            let rest = self.pending.get(self.pos..).unwrap_or_default();
            if !matches!(rest.get(n.wrapping_sub(1)), Some(&(CR | ACK | NUL))) {
                break;
            }
            if n < rest.len() {
                n += 1;
            } else if self.more_at_card() {
                self.refill(n + 64, interp);
                if self.pending_len() <= n {
                    break;
                }
            } else {
                break;
            }
        }
        let rest = self.pending.get(self.pos..).unwrap_or_default();
        let chunk = rest.get(..n).unwrap_or_default().to_vec();
        self.pos += n;
        if self.pos >= self.pending.len() {
            self.set_pending(Vec::new());
        }
        chunk
    }

    /// GETLINE: pending bytes up to and including the next CR or ACK (or `\x06` if none).
    fn next_line<I: Interpreter + ?Sized>(&mut self, interp: &mut I) -> Vec<u8> {
        let mut want = 1;
        loop {
            self.refill(want, interp);
            let rest = self.pending.get(self.pos..).unwrap_or_default();
            let has_end = rest.iter().any(|&b| b == CR || b == ACK);
            if has_end || rest.len() >= PACKET_DATA || !self.more_at_card() {
                break;
            }
            want = rest.len() + 1;
        }
        let rest = self.pending.get(self.pos..).unwrap_or_default();
        if rest.is_empty() {
            return vec![ACK];
        }
        let n = rest
            .iter()
            .position(|&b| b == CR || b == ACK)
            .map_or(rest.len(), |i| i + 1)
            .min(PACKET_DATA);
        let chunk = rest.get(..n).unwrap_or_default().to_vec();
        self.pos += n;
        if self.pos >= self.pending.len() {
            self.set_pending(Vec::new());
        }
        chunk
    }

    /// WRITEBUFFER: run NUL-separated lines until one fails. Reply `[line lo, line hi, ERR code,
    /// 0x80]` for the first failing line (1-based within the packet), or four zero bytes.
    fn write_buffer<I: Interpreter + ?Sized>(&mut self, payload: &[u8], interp: &mut I) -> Vec<u8> {
        self.set_pending(Vec::new());
        for (i, seg) in payload.split(|&b| b == NUL).enumerate() {
            if seg.is_empty() {
                continue;
            }
            if let Some(code) = self.execute_for_error(seg, interp) {
                let [hi, lo] = u16::try_from(i + 1).unwrap_or(u16::MAX).to_be_bytes();
                return vec![lo, hi, code, 0x80];
            }
        }
        vec![0, 0, 0, 0]
    }
}

/// The `nnn` of the first `ERRnnn` in a reply, if it fits a byte.
pub(crate) fn error_code(reply: &[u8]) -> Option<u8> {
    let i = reply.windows(3).position(|w| w == b"ERR")?;
    let digits = reply.get(i + 3..i + 6)?;
    if !digits.iter().all(u8::is_ascii_digit) {
        return None;
    }
    std::str::from_utf8(digits).ok()?.parse().ok()
}

#[cfg(test)]
#[path = "tests_eth_codec.rs"]
mod tests;
