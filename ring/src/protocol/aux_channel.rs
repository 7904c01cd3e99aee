//! The MACRO Type 1 auxiliary (master-to-slave) channel on node 15: wire words and messages,
//! shared by the card (master side) and the station (slave side), which meet only through
//! ring packets.
//!
//! **Where it travels** [DECISION, see docs/stations.md "Station MI-variables and the node-15 auxiliary channel"]: every master's
//! node-15 packet `(m, 15)` carries, in registers 0 and 1, the ring cycle number (for the
//! synchronizing master this packet is the sync packet) and, in registers 2 and 3, one
//! auxiliary word per ring cycle: register 3 = control, register 2 = 16 data bits. A slave
//! never touches registers 0-1 of a node-15 packet; it replaces registers 2-3 only while it has
//! a reply word to send ([`crate::member::RingMember::set_aux_reply`]).
//!
//! **Control word** (register 3): bits 15-14 kind (0 idle, 1 request, 2 reply), bits 13-11
//! transaction tag (1-7; the master changes it for every transaction), bits 10-8 word index,
//! bits 7-4 node (the request's target node; 15 = every station of the master), bits 3-0 the
//! message length in words (1-8).
//!
//! **Messages** are streamed: the master sends word `k mod len` of its request in cycle k and
//! repeats the whole request until a complete reply with its tag has come back or the timeout
//! expires; a slave collects the words by index, executes a complete request once per tag, then
//! streams its reply the same way until the master goes idle or starts another transaction.
//! Lost or late frames only cost cycles. Request words: `w0 = op << 8 | sub`, then operands;
//! reply words: `w0 = status << 8 | format`, then a value or an error code (see [`Request`],
//! [`Reply`]).
//!
//! **Working** [DECISION, issue 24]: a slave that needs longer than a few cycles for a request
//! (`SAVE` writes its setup on an I/O thread, as a real station writes its flash) streams the
//! one-word message [`WORKING`] until its reply is ready. The master restarts its timeout on
//! every complete [`WORKING`] message and keeps sending its request, for at most
//! [`MAX_WORKING_CYCLES`] more cycles; a silent slave still times out after the timeout.

/// The node that carries the auxiliary channel (and the sync packet).
pub const AUX_NODE: u8 = 15;
/// Longest message, in words.
pub const MAX_WORDS: usize = 8;
/// The message a slave streams while it is still working on a request (status 2): not a
/// [`Reply`]; the master restarts its timeout on it and waits for the real reply.
pub const WORKING: [u16; 1] = [2 << 8];
/// Most cycles a master waits beyond its timeout for a slave that keeps reporting
/// [`WORKING`] (≈ 29 s at the default 442.7 µs ring cycle).
pub const MAX_WORKING_CYCLES: u32 = 1 << 16;

/// What a word is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WordKind {
    /// Nothing in flight.
    Idle,
    /// Master → slave.
    Request,
    /// Slave → master.
    Reply,
}

/// One auxiliary word: what registers 2 and 3 of a node-15 packet carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AuxWord {
    /// Idle, request or reply.
    pub kind: WordKind,
    /// Transaction tag 1-7 (0 when idle).
    pub tag: u8,
    /// Index of this word in its message.
    pub index: u8,
    /// Target node of the request (replies echo it).
    pub node: u8,
    /// Message length in words, 1-8.
    pub len: u8,
    /// The data word.
    pub data: u16,
}

impl AuxWord {
    /// The idle word (registers 2 and 3 zero).
    pub const IDLE: AuxWord = AuxWord {
        kind: WordKind::Idle,
        tag: 0,
        index: 0,
        node: 0,
        len: 0,
        data: 0,
    };

    /// Decode registers 2 (data) and 3 (control). Malformed control words (kind 3, a length of
    /// 0 or above [`MAX_WORDS`], an index beyond the length) read as idle.
    pub fn decode(r2: u16, r3: u16) -> AuxWord {
        let kind = match r3 >> 14 {
            1 => WordKind::Request,
            2 => WordKind::Reply,
            _ => return AuxWord::IDLE,
        };
        let len = (r3 & 0xF) as u8;
        let index = ((r3 >> 8) & 0x7) as u8;
        let tag = ((r3 >> 11) & 0x7) as u8;
        if len == 0 || usize::from(len) > MAX_WORDS || index >= len || tag == 0 {
            return AuxWord::IDLE;
        }
        AuxWord {
            kind,
            tag,
            index,
            node: ((r3 >> 4) & 0xF) as u8,
            len,
            data: r2,
        }
    }

    /// Encode to (register 2, register 3).
    pub fn encode(&self) -> (u16, u16) {
        let kind: u16 = match self.kind {
            WordKind::Idle => return (0, 0),
            WordKind::Request => 1,
            WordKind::Reply => 2,
        };
        let r3 = kind << 14
            | u16::from(self.tag & 7) << 11
            | u16::from(self.index & 7) << 8
            | u16::from(self.node & 0xF) << 4
            | u16::from(self.len & 0xF);
        (self.data, r3)
    }
}

/// Station commands of `MS{cmd}{node}`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StationCmd {
    /// `$$$`: station reset.
    Reset,
    /// `$$$***`: reset and re-initialize to factory defaults.
    Reinit,
    /// `CLRF`: clear faults (ring-fault latch once the ring is healthy, amplifier faults).
    ClearFault,
    /// `SAVE`: save the setup.
    Save,
    /// `DATE`: firmware date.
    Date,
    /// `VER`: firmware version.
    Version,
    /// `CONFIG`: report the configuration number.
    ConfigRead,
}

impl StationCmd {
    fn code(self) -> u8 {
        match self {
            StationCmd::Reset => 1,
            StationCmd::Reinit => 2,
            StationCmd::ClearFault => 3,
            StationCmd::Save => 4,
            StationCmd::Date => 5,
            StationCmd::Version => 6,
            StationCmd::ConfigRead => 7,
        }
    }

    fn from_code(c: u8) -> Option<Self> {
        Some(match c {
            1 => StationCmd::Reset,
            2 => StationCmd::Reinit,
            3 => StationCmd::ClearFault,
            4 => StationCmd::Save,
            5 => StationCmd::Date,
            6 => StationCmd::Version,
            7 => StationCmd::ConfigRead,
            _ => return None,
        })
    }
}

/// What the master asks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Request {
    /// Report MI-variable n (`MS{node},MI{n}`, `MSR`).
    ReadMi(u16),
    /// Set MI-variable n (`MS{node},MI{n}={v}`, `MSW`).
    WriteMi(u16, f64),
    /// A station command (`MS{cmd}{node}`).
    Command(StationCmd),
    /// `MS CONFIG{node}={n}`.
    ConfigWrite(f64),
    /// C-command n with its value (`MS{node},C{n}={v}`, `MSW{node},C{n},{var}`).
    CCommand(u16, f64),
    /// Type 0 parameter read (`MX{node},{param}`, `MXR`).
    ReadParam(u16),
    /// Type 0 parameter write (`MX{node},{param}={v}`, `MXW`), value −32768..32767.
    WriteParam(u16, i16),
}

fn f64_words(v: f64) -> [u16; 4] {
    let b = v.to_bits();
    [
        (b >> 48) as u16,
        (b >> 32) as u16,
        (b >> 16) as u16,
        b as u16,
    ]
}

fn words_f64(w: &[u16]) -> Option<f64> {
    let [a, b, c, d] = *w.get(..4)? else {
        return None;
    };
    let bits = u64::from(a) << 48 | u64::from(b) << 32 | u64::from(c) << 16 | u64::from(d);
    Some(f64::from_bits(bits)).filter(|v| v.is_finite())
}

impl Request {
    /// The request's words.
    pub fn words(&self) -> Vec<u16> {
        let mut w = Vec::with_capacity(6);
        match *self {
            Request::ReadMi(n) => w.extend([1 << 8, n]),
            Request::WriteMi(n, v) => {
                w.extend([2 << 8, n]);
                w.extend(f64_words(v));
            }
            Request::Command(c) => w.push(3 << 8 | u16::from(c.code())),
            Request::ConfigWrite(v) => {
                w.push(4 << 8);
                w.extend(f64_words(v));
            }
            Request::CCommand(n, v) => {
                w.extend([5 << 8, n]);
                w.extend(f64_words(v));
            }
            Request::ReadParam(p) => w.extend([6 << 8, p]),
            Request::WriteParam(p, v) => w.extend([7 << 8, p, v as u16]),
        }
        w
    }

    /// Parse a complete message; None if it is not a valid request.
    pub fn from_words(w: &[u16]) -> Option<Request> {
        let (&w0, rest) = w.split_first()?;
        let sub = (w0 & 0xFF) as u8;
        let exact = |n: usize| (rest.len() == n).then_some(());
        Some(match w0 >> 8 {
            1 => {
                exact(1)?;
                Request::ReadMi(rest[0])
            }
            2 => {
                exact(5)?;
                Request::WriteMi(rest[0], words_f64(&rest[1..])?)
            }
            3 => {
                exact(0)?;
                Request::Command(StationCmd::from_code(sub)?)
            }
            4 => {
                exact(4)?;
                Request::ConfigWrite(words_f64(rest)?)
            }
            5 => {
                exact(5)?;
                Request::CCommand(rest[0], words_f64(&rest[1..])?)
            }
            6 => {
                exact(1)?;
                Request::ReadParam(rest[0])
            }
            7 => {
                exact(2)?;
                Request::WriteParam(rest[0], rest[1] as i16)
            }
            _ => return None,
        })
    }
}

/// How the master prints a returned value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValueFormat {
    /// As the card prints a number.
    Decimal,
    /// Hexadecimal (`$` prefix when I9 bit 1 is set).
    Hex,
    /// A firmware version: three decimals (`1.104`).
    Version,
    /// A date: the value is YYYYMMDD, printed `MM/DD/YYYY`.
    Date,
}

/// What the slave answers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reply {
    /// Done, nothing to report.
    Done,
    /// A value and how to print it.
    Value(f64, ValueFormat),
    /// The slave refused: its 16-bit error code (X:$0798 = code << 8 | $FE on the card).
    Error(u16),
}

/// Slave error codes (the xxxx of X:$0798 = $xxxxFE).
pub mod slave_error {
    /// No such MI-variable, C-command or parameter.
    pub const UNKNOWN_VARIABLE: u16 = 0x0001;
    /// Value out of the variable's range.
    pub const OUT_OF_RANGE: u16 = 0x0002;
    /// The variable is read-only.
    pub const READ_ONLY: u16 = 0x0003;
    /// The request is not one this station understands.
    pub const BAD_REQUEST: u16 = 0x0004;
    /// SAVE could not write the state file.
    pub const SAVE_FAILED: u16 = 0x0005;
    /// A node-specific variable addressed through a node the station does not serve.
    pub const WRONG_NODE: u16 = 0x0006;
    /// The station is busy: a SAVE is still writing its setup (every request until it is
    /// done; the SAVE itself answers when the write is).
    pub const BUSY: u16 = 0x0007;
}

impl Reply {
    /// The reply's words.
    pub fn words(&self) -> Vec<u16> {
        match *self {
            Reply::Done => vec![0],
            Reply::Value(v, f) => {
                let f = match f {
                    ValueFormat::Decimal => 0,
                    ValueFormat::Hex => 1,
                    ValueFormat::Version => 2,
                    ValueFormat::Date => 3,
                };
                let mut w = vec![1 << 8 | f];
                w.extend(f64_words(v));
                w
            }
            Reply::Error(code) => vec![0xFE << 8, code],
        }
    }

    /// Parse a complete reply message.
    pub fn from_words(w: &[u16]) -> Option<Reply> {
        let (&w0, rest) = w.split_first()?;
        Some(match w0 >> 8 {
            0 if rest.is_empty() => Reply::Done,
            1 if rest.len() == 4 => {
                let f = match w0 & 0xFF {
                    0 => ValueFormat::Decimal,
                    1 => ValueFormat::Hex,
                    2 => ValueFormat::Version,
                    3 => ValueFormat::Date,
                    _ => return None,
                };
                Reply::Value(words_f64(rest)?, f)
            }
            0xFE if rest.len() == 1 => Reply::Error(rest[0]),
            _ => return None,
        })
    }
}

/// Collects the words of one streamed message (by tag and index).
#[derive(Clone, Debug, Default)]
pub struct Collector {
    tag: u8,
    len: u8,
    have: u8,
    words: [u16; MAX_WORDS],
}

impl Collector {
    /// Forget any partial message.
    pub fn reset(&mut self) {
        *self = Collector::default();
    }

    /// Add a word; returns the complete message once every index has been seen. A word of
    /// another tag or length restarts the collection.
    pub fn push(&mut self, w: &AuxWord) -> Option<Vec<u16>> {
        if w.tag != self.tag || w.len != self.len {
            *self = Collector {
                tag: w.tag,
                len: w.len,
                ..Default::default()
            };
        }
        let i = usize::from(w.index);
        *self.words.get_mut(i)? = w.data;
        self.have |= 1 << i;
        let full = if self.len >= 8 {
            0xFF
        } else {
            (1u8 << self.len) - 1
        };
        (self.have == full).then(|| self.words[..usize::from(self.len)].to_vec())
    }
}

/// The word of a streamed message to send in cycle `k`.
pub fn stream_word(kind: WordKind, tag: u8, node: u8, msg: &[u16], k: u64) -> AuxWord {
    let len = msg.len().clamp(1, MAX_WORDS);
    let index = (k % len as u64) as usize;
    AuxWord {
        kind,
        tag,
        index: index as u8,
        node,
        len: len as u8,
        data: msg.get(index).copied().unwrap_or(0),
    }
}

/// How a master's transaction ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    /// A complete reply came back.
    Reply(Reply),
    /// No complete reply within the timeout.
    Timeout,
}

#[derive(Clone, Debug)]
struct Active {
    node: u8,
    msg: Vec<u16>,
    sent: u64,
    /// Cycles since the start or the latest [`WORKING`] message.
    cycles: u32,
    /// Cycles since the start.
    waited: u32,
    timeout: u32,
}

/// The master side of the channel: one transaction in flight at a time, streamed one word per
/// cycle, finished by a complete reply with its tag or by the timeout (in servo cycles).
#[derive(Clone, Debug, Default)]
pub struct AuxMaster {
    tag: u8,
    active: Option<Active>,
    collector: Collector,
}

impl AuxMaster {
    /// A transaction is in flight.
    pub fn busy(&self) -> bool {
        self.active.is_some()
    }

    /// Start a transaction to `node` (15 = every station). Returns false (and changes
    /// nothing) while another one is in flight.
    pub fn start(&mut self, node: u8, request: Request, timeout_cycles: u32) -> bool {
        if self.busy() {
            return false;
        }
        self.tag = self.tag % 7 + 1;
        self.collector.reset();
        self.active = Some(Active {
            node: node & 0xF,
            msg: request.words(),
            sent: 0,
            cycles: 0,
            waited: 0,
            timeout: timeout_cycles.max(1),
        });
        true
    }

    /// Give up the transaction in flight (the channel goes idle).
    pub fn abort(&mut self) {
        self.active = None;
    }

    /// One servo cycle: `returned` is the latest copy of this master's node-15 packet as it
    /// came back around the ring (registers 2 and 3). Returns the outcome when the
    /// transaction ends, and the registers 2 and 3 to send next. A complete [`WORKING`]
    /// message restarts the timeout (at most [`MAX_WORKING_CYCLES`] beyond it in all).
    pub fn tick(&mut self, returned: AuxWord) -> (Option<Outcome>, (u16, u16)) {
        let Some(a) = self.active.as_mut() else {
            return (None, AuxWord::IDLE.encode());
        };
        if returned.kind == WordKind::Reply && returned.tag == self.tag {
            match self.collector.push(&returned) {
                Some(words) if words == WORKING => a.cycles = 0,
                Some(words) => {
                    self.active = None;
                    let r =
                        Reply::from_words(&words).unwrap_or(Reply::Error(slave_error::BAD_REQUEST));
                    return (Some(Outcome::Reply(r)), AuxWord::IDLE.encode());
                }
                None => {}
            }
        }
        a.cycles += 1;
        a.waited = a.waited.saturating_add(1);
        if a.cycles > a.timeout || a.waited > a.timeout.saturating_add(MAX_WORKING_CYCLES) {
            self.active = None;
            return (Some(Outcome::Timeout), AuxWord::IDLE.encode());
        }
        let w = stream_word(WordKind::Request, self.tag, a.node, &a.msg, a.sent);
        a.sent += 1;
        (None, w.encode())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn word_round_trip_and_malformed_words_read_idle() {
        let w = AuxWord {
            kind: WordKind::Request,
            tag: 5,
            index: 3,
            node: 12,
            len: 6,
            data: 0xBEEF,
        };
        let (r2, r3) = w.encode();
        assert_eq!((r2, r3), (0xBEEF, 0x6BC6));
        assert_eq!(AuxWord::decode(r2, r3), w);
        assert_eq!(AuxWord::IDLE.encode(), (0, 0));
        assert_eq!(AuxWord::decode(0, 0), AuxWord::IDLE);
        assert_eq!(AuxWord::decode(1, 0xC001).kind, WordKind::Idle, "kind 3");
        assert_eq!(AuxWord::decode(1, 0x4800).kind, WordKind::Idle, "len 0");
        assert_eq!(
            AuxWord::decode(1, 0x4B02).kind,
            WordKind::Idle,
            "index ≥ len"
        );
        assert_eq!(AuxWord::decode(1, 0x4001).kind, WordKind::Idle, "tag 0");
    }

    #[test]
    fn requests_and_replies_round_trip() {
        let reqs = [
            Request::ReadMi(910),
            Request::WriteMi(8, 12.5),
            Request::Command(StationCmd::Reinit),
            Request::Command(StationCmd::ConfigRead),
            Request::ConfigWrite(37.0),
            Request::CCommand(2, 0.0),
            Request::ReadParam(65_535),
            Request::WriteParam(24, -2000),
        ];
        for r in reqs {
            assert!(r.words().len() <= MAX_WORDS);
            assert_eq!(Request::from_words(&r.words()), Some(r), "{r:?}");
        }
        for r in [
            Reply::Done,
            Reply::Value(-1.25e-5, ValueFormat::Decimal),
            Reply::Value(20_260_101.0, ValueFormat::Date),
            Reply::Error(slave_error::OUT_OF_RANGE),
        ] {
            assert_eq!(Reply::from_words(&r.words()), Some(r));
        }
        assert_eq!(Request::from_words(&[]), None);
        assert_eq!(Request::from_words(&[1 << 8]), None, "missing operand");
        assert_eq!(Request::from_words(&[3 << 8 | 99]), None, "unknown command");
        assert_eq!(Request::from_words(&[9 << 8, 1]), None);
        // non-finite values are refused
        let mut w = Request::WriteMi(1, 0.0).words();
        w[2..].copy_from_slice(&f64_words(f64::NAN));
        assert_eq!(Request::from_words(&w), None);
        assert_eq!(Reply::from_words(&[0xFE << 8]), None);
    }

    #[test]
    fn master_streams_until_the_reply_or_the_timeout() {
        let mut m = AuxMaster::default();
        assert!(m.start(1, Request::ReadMi(8), 32));
        assert!(
            !m.start(1, Request::ReadMi(9), 32),
            "one transaction in flight"
        );
        let (o, (r2, r3)) = m.tick(AuxWord::IDLE);
        assert_eq!(o, None);
        let w = AuxWord::decode(r2, r3);
        assert_eq!(
            (w.kind, w.tag, w.node, w.len, w.data),
            (WordKind::Request, 1, 1, 2, 1 << 8)
        );
        // a reply of another tag is ignored; the one with ours completes it
        let reply = Reply::Value(8.0, ValueFormat::Decimal).words();
        let stale = stream_word(WordKind::Reply, 7, 1, &reply, 0);
        assert_eq!(m.tick(stale).0, None);
        let mut out = None;
        for k in 0..reply.len() as u64 {
            out = m.tick(stream_word(WordKind::Reply, 1, 1, &reply, k)).0;
        }
        assert_eq!(
            out,
            Some(Outcome::Reply(Reply::Value(8.0, ValueFormat::Decimal)))
        );
        assert!(!m.busy());
        assert_eq!(m.tick(AuxWord::IDLE).1, (0, 0), "idle after the reply");
        // nobody answers: a timeout after exactly `timeout` cycles of waiting
        assert!(m.start(3, Request::ReadMi(8), 4));
        let ends: Vec<_> = (0..6).map(|_| m.tick(AuxWord::IDLE).0).collect();
        assert_eq!(
            ends,
            vec![None, None, None, None, Some(Outcome::Timeout), None]
        );
    }

    #[test]
    fn working_restarts_the_timeout_until_the_reply_or_the_cap() {
        let working = |tag| stream_word(WordKind::Reply, tag, 0, &WORKING, 0);
        assert_eq!(Reply::from_words(&WORKING), None, "WORKING is no reply");
        // the slave works for 10 timeouts, then answers: the master waited and got it
        let mut m = AuxMaster::default();
        assert!(m.start(0, Request::Command(StationCmd::Save), 4));
        for k in 0..40 {
            let (o, (r2, r3)) = m.tick(working(1));
            assert_eq!(o, None, "cycle {k}");
            assert_eq!(
                AuxWord::decode(r2, r3).kind,
                WordKind::Request,
                "still asking"
            );
        }
        let done = stream_word(WordKind::Reply, 1, 0, &Reply::Done.words(), 0);
        assert_eq!(m.tick(done).0, Some(Outcome::Reply(Reply::Done)));
        // the slave falls silent: the usual timeout from its last WORKING
        assert!(m.start(0, Request::Command(StationCmd::Save), 4));
        assert_eq!(m.tick(working(2)).0, None);
        let ends: Vec<_> = (0..5).map(|_| m.tick(AuxWord::IDLE).0).collect();
        assert_eq!(ends, vec![None, None, None, Some(Outcome::Timeout), None]);
        // WORKING of another tag does not count; a slave working for ever hits the cap
        assert!(m.start(0, Request::Command(StationCmd::Save), 4));
        let ends: Vec<_> = (0..5).map(|_| m.tick(working(2)).0).collect();
        assert_eq!(ends[4], Some(Outcome::Timeout));
        assert!(m.start(0, Request::Command(StationCmd::Save), 4));
        let mut cycles = 0u32;
        while m.tick(working(4)).0.is_none() {
            cycles += 1;
        }
        assert_eq!(cycles, 4 + MAX_WORKING_CYCLES);
    }

    #[test]
    fn collector_completes_out_of_order_and_restarts_on_a_new_tag() {
        let msg = Request::WriteMi(910, 7.0).words();
        let mut c = Collector::default();
        let mut done = None;
        for k in [3u64, 5, 0, 1, 3, 2, 4] {
            done = c.push(&stream_word(WordKind::Request, 1, 0, &msg, k));
            if k == 4 {
                break;
            }
            assert!(done.is_none());
        }
        assert_eq!(done.as_deref(), Some(&msg[..]));
        let other = Request::ReadMi(1).words();
        assert!(c
            .push(&stream_word(WordKind::Request, 2, 0, &other, 1))
            .is_none());
        assert_eq!(
            c.push(&stream_word(WordKind::Request, 2, 0, &other, 0)),
            Some(other)
        );
    }
}
