//! The interpreter as the host ports see it: a line in, reply bytes out; a control character in,
//! reply bytes out. [`CardPort`] is one connection's way to the card on its servo thread
//! (requests over the card's channel, [`CardHandle`]); tests drive the codecs with their own
//! [`Interpreter`].

use super::ascii::AsciiEvent;
use crate::core::HostRequest;
use crate::domain::Refusal;
use crate::service::handle::CardHandle;

/// A part of a reply.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Part {
    /// The bytes.
    pub bytes: Vec<u8>,
    /// More parts follow ([`Interpreter::line_more`]).
    pub more: bool,
}

/// What a host port needs from the card.
pub(crate) trait Interpreter {
    /// Execute one command line (no `<CR>`); the whole framed reply.
    fn line(&mut self, line: &[u8]) -> Vec<u8>;
    /// Execute one command line whose reply may come in parts (a port then holds at most a
    /// part of a long reply): the first part.
    fn line_start(&mut self, line: &[u8]) -> Part {
        Part {
            bytes: self.line(line),
            more: false,
        }
    }
    /// The next part of the reply [`Interpreter::line_start`] began.
    fn line_more(&mut self) -> Part {
        Part::default()
    }
    /// Execute one control-character command; its reply (possibly empty).
    fn control(&mut self, c: u8) -> Vec<u8>;
    /// The reply to a line that exceeded the port's maximum length (the card's ERR003).
    fn overlong(&mut self) -> Vec<u8>;
    /// The first refusal among the replies since the last call (`HostReply::error`), taken:
    /// a port that reports refusals beside the bytes (the zenoh cmd queryable) asks this
    /// after [`run_events`].
    fn take_refusal(&mut self) -> Option<Refusal> {
        None
    }
}

pub(crate) use crate::lang::overlong_probe;

/// One connection's view of the card: its connection id on the card and the last echo state.
/// Each call blocks until the card's servo thread has served it (between ticks, in slices).
#[derive(Debug)]
pub(crate) struct CardPort {
    card: CardHandle,
    conn: u64,
    echo: bool,
    /// The first refusal since [`Interpreter::take_refusal`].
    refused: Option<Refusal>,
}

impl CardPort {
    /// A new connection to `card`.
    pub(crate) fn new(card: CardHandle) -> Self {
        let conn = card.new_conn();
        CardPort {
            card,
            conn,
            echo: false,
            refused: None,
        }
    }

    /// Full-duplex echo (CTRL-T) as of the last reply.
    pub(crate) fn echo(&self) -> bool {
        self.echo
    }

    /// The card.
    pub(crate) fn card(&self) -> &CardHandle {
        &self.card
    }

    fn ask(&mut self, req: HostRequest) -> Vec<u8> {
        self.ask_part(req).bytes
    }

    fn ask_part(&mut self, req: HostRequest) -> Part {
        let r = self.card.host(self.conn, req);
        self.echo = r.echo;
        self.refused = self.refused.or(r.error);
        Part {
            bytes: r.bytes,
            more: r.more,
        }
    }

    /// The connection closed: the card releases a buffer it left open.
    pub(crate) fn end(&mut self) {
        let _ = self.ask(HostRequest::End);
    }
}

impl Interpreter for CardPort {
    fn line(&mut self, line: &[u8]) -> Vec<u8> {
        self.ask(HostRequest::Line(line.to_vec()))
    }

    fn line_start(&mut self, line: &[u8]) -> Part {
        self.ask_part(HostRequest::LineStreamed(line.to_vec()))
    }

    fn line_more(&mut self) -> Part {
        self.ask_part(HostRequest::More)
    }

    fn control(&mut self, c: u8) -> Vec<u8> {
        self.ask(HostRequest::Control(c))
    }

    fn overlong(&mut self) -> Vec<u8> {
        self.ask(HostRequest::Line(overlong_probe()))
    }

    fn take_refusal(&mut self) -> Option<Refusal> {
        self.refused.take()
    }
}

/// Apply terminal events to the interpreter, appending replies to `out` in order.
pub(crate) fn run_events<I: Interpreter + ?Sized>(
    events: Vec<AsciiEvent>,
    interp: &mut I,
    out: &mut Vec<u8>,
) {
    for ev in events {
        run_event(ev, interp, out);
    }
}

/// Apply one terminal event. [`AsciiEvent::Cancel`] drops whatever in `out` has not been sent
/// yet (callers send `out` only after this returns), then passes `<CTRL-X>` to the interpreter.
pub(crate) fn run_event<I: Interpreter + ?Sized>(
    ev: AsciiEvent,
    interp: &mut I,
    out: &mut Vec<u8>,
) {
    match ev {
        AsciiEvent::Line(l) => out.extend_from_slice(&interp.line(&l)),
        AsciiEvent::Control(c) => out.extend_from_slice(&interp.control(c)),
        AsciiEvent::Reply(r) => out.extend_from_slice(&r),
        AsciiEvent::Cancel => {
            // The refusals of the dropped replies go with them.
            out.clear();
            let _ = interp.take_refusal();
            out.extend_from_slice(&interp.control(0x18));
        }
        AsciiEvent::Overlong => out.extend_from_slice(&interp.overlong()),
    }
}

/// A scripted interpreter for codec and server tests: echoes lines as `<line>\r\x06`, answers
/// `ERR` lines with `\x07ERR003\r`, `BIG<n>` with an `n`-byte reply, control `c` with `^<c>\r`
/// (empty for `<CTRL-K>`), and records everything it executed.
#[cfg(test)]
#[derive(Debug, Default)]
pub(crate) struct EchoInterp {
    /// Everything executed, in order: lines as text, control characters as `^XX` (hex).
    pub log: Vec<String>,
    /// The rest of a streamed `BIG<n>` reply (handed out [`ECHO_PART`] bytes at a time).
    pub stream: Vec<u8>,
    /// Largest part handed out at once.
    pub largest_part: usize,
}

/// Part size of [`EchoInterp`]'s streamed replies.
#[cfg(test)]
pub(crate) const ECHO_PART: usize = 1000;

#[cfg(test)]
impl EchoInterp {
    fn next_part(&mut self) -> Part {
        let n = self.stream.len().min(ECHO_PART);
        let bytes: Vec<u8> = self.stream.drain(..n).collect();
        self.largest_part = self.largest_part.max(bytes.len());
        Part {
            bytes,
            more: !self.stream.is_empty(),
        }
    }
}

#[cfg(test)]
impl Interpreter for EchoInterp {
    fn line(&mut self, line: &[u8]) -> Vec<u8> {
        let text = String::from_utf8_lossy(line).into_owned();
        self.log.push(text.clone());
        if text.starts_with("ERR") {
            return b"\x07ERR003\r".to_vec();
        }
        if let Some(n) = text
            .strip_prefix("BIG")
            .and_then(|n| n.parse::<usize>().ok())
        {
            return big_reply(n);
        }
        let mut r = line.to_vec();
        r.extend_from_slice(b"\r\x06");
        r
    }

    fn line_start(&mut self, line: &[u8]) -> Part {
        self.stream = self.line(line);
        self.next_part()
    }

    fn line_more(&mut self) -> Part {
        self.next_part()
    }

    fn control(&mut self, c: u8) -> Vec<u8> {
        self.stream.clear();
        self.log.push(format!("^{c:02X}"));
        match c {
            0x0B | 0x18 => Vec::new(),
            _ => format!("^{c:02X}\r").into_bytes(),
        }
    }

    fn overlong(&mut self) -> Vec<u8> {
        self.log.push("<overlong>".into());
        b"\x07ERR003\r".to_vec()
    }
}

#[cfg(test)]
/// `n` bytes (n ≥ 2) shaped like a PMAC data reply: lines `0123456789\r` ending in `\x06`.
pub(crate) fn big_reply(n: usize) -> Vec<u8> {
    let mut r: Vec<u8> = (0..n.saturating_sub(1))
        .map(|i| {
            if i % 11 == 10 {
                b'\r'
            } else {
                b'0' + (i % 11) as u8
            }
        })
        .collect();
    r.push(0x06);
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_run_in_order_and_cancel_drops_unsent_output() {
        let mut i = EchoInterp::default();
        let mut out = Vec::new();
        let evs = vec![
            AsciiEvent::Line(b"P1".to_vec()),
            AsciiEvent::Control(2),
            AsciiEvent::Reply(vec![117]),
        ];
        run_events(evs, &mut i, &mut out);
        assert_eq!(out, b"P1\r\x06^02\r\x75");
        run_events(
            vec![AsciiEvent::Cancel, AsciiEvent::Overlong],
            &mut i,
            &mut out,
        );
        assert_eq!(out, b"\x07ERR003\r");
        assert_eq!(i.log, vec!["P1", "^02", "^18", "<overlong>"]);
    }

    #[test]
    fn big_reply_shape() {
        assert_eq!(big_reply(13), b"0123456789\r0\x06");
        assert_eq!(big_reply(1), b"\x06");
    }

    #[test]
    fn card_port_uses_the_card() {
        let core =
            crate::core::CardCore::new(crate::lang::Card::new(crate::domain::Profile::Pmac2));
        let (mut runner, handle) = crate::service::handle::channel(core, None);
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let st = std::sync::Arc::clone(&stop);
        let t = std::thread::spawn(move || runner.run_until(&st));
        let mut p = CardPort::new(handle);
        // An over-long line is the card's ERR003 (default I6=3 prints the code).
        let bad = p.overlong();
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
        t.join().unwrap();
        assert!(bad.windows(6).any(|w| w == b"ERR003"), "{bad:?}");
        assert_eq!(bad.first(), Some(&0x07));
    }
}
