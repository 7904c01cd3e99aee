//! The slave side of the Type 1 auxiliary protocol ([`mcc_ring::aux_channel`]): collect the
//! master's streamed request from the node-15 packets of this station's master, hand a
//! complete request to the station once per transaction, then stream the reply until the
//! master goes idle or starts another transaction.
//!
//! A station answers a request whose node it serves, and every request for node 15 (all
//! stations of the master; each one executes it, and the master keeps the reply of the last
//! station before it on the ring). Requests for nodes the station does not serve are left
//! alone: it forwards them unchanged.
//!
//! A request the station cannot answer at once (`MS SAVE`, whose write runs off the tick) is
//! held ([`AuxSlave::hold`]): the station streams [`WORKING`] until the answer is set, so the
//! master keeps waiting (and, for a node-15 request, the reply of a station further upstream
//! does not pass as the answer of this one).

use mcc_ring::aux_channel::{
    slave_error, stream_word, AuxWord, Collector, Reply, Request, WordKind, AUX_NODE, WORKING,
};

/// What a complete request asks of the station.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incoming {
    /// The node it was addressed to (15 = every station).
    pub node: u8,
    /// The request.
    pub request: Request,
}

/// Slave protocol state.
#[derive(Clone, Debug, Default)]
pub struct AuxSlave {
    collector: Collector,
    tag: u8,
    node: u8,
    executed: bool,
    reply: Option<Vec<u16>>,
    sent: u64,
    held: bool,
}

impl AuxSlave {
    /// Take this cycle's latched word of the master's node-15 packet. Returns a request to
    /// execute (once per transaction); answer it with [`AuxSlave::set_reply`].
    pub fn on_word(&mut self, w: AuxWord, serves: impl Fn(u8) -> bool) -> Option<Incoming> {
        match w.kind {
            WordKind::Idle => {
                *self = AuxSlave::default();
                None
            }
            WordKind::Reply => None,
            WordKind::Request => {
                if w.tag != self.tag {
                    *self = AuxSlave {
                        tag: w.tag,
                        node: w.node,
                        ..AuxSlave::default()
                    };
                }
                if self.executed || !(w.node == AUX_NODE || serves(w.node)) {
                    return None;
                }
                let words = self.collector.push(&w)?;
                self.executed = true;
                match Request::from_words(&words) {
                    Some(request) => Some(Incoming {
                        node: w.node,
                        request,
                    }),
                    None => {
                        self.set_reply(Reply::Error(slave_error::BAD_REQUEST));
                        None
                    }
                }
            }
        }
    }

    /// The answer to the request [`AuxSlave::on_word`] returned.
    pub fn set_reply(&mut self, reply: Reply) {
        self.reply = Some(reply.words());
        self.sent = 0;
        self.held = false;
    }

    /// The request [`AuxSlave::on_word`] returned is answered later ([`AuxSlave::answer_held`]):
    /// stream [`WORKING`] meanwhile. Returns the transaction's tag.
    pub fn hold(&mut self) -> u8 {
        self.reply = Some(WORKING.to_vec());
        self.sent = 0;
        self.held = true;
        self.tag
    }

    /// Answer the held request of transaction `tag`. False (nothing changes) if the master
    /// no longer waits for it: it went idle (gave up) or started another transaction.
    pub fn answer_held(&mut self, tag: u8, reply: Reply) -> bool {
        if !self.held || self.tag != tag {
            return false;
        }
        self.set_reply(reply);
        true
    }

    /// A request is held (the station streams [`WORKING`]).
    pub fn holding(&self) -> bool {
        self.held
    }

    /// Registers 2 and 3 to put into the master's node-15 packet next cycle (None = forward
    /// it unchanged).
    pub fn reply_regs(&mut self) -> Option<(u16, u16)> {
        let msg = self.reply.as_ref()?;
        let w = stream_word(WordKind::Reply, self.tag, self.node, msg, self.sent);
        self.sent += 1;
        Some(w.encode())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcc_ring::aux_channel::StationCmd;

    fn words(req: Request, tag: u8, node: u8) -> impl Iterator<Item = AuxWord> {
        let msg = req.words();
        (0..).map(move |k| stream_word(WordKind::Request, tag, node, &msg, k))
    }

    #[test]
    fn executes_once_per_transaction_and_streams_the_reply() {
        let mut s = AuxSlave::default();
        let serves = |n: u8| n == 0 || n == 1;
        let mut got = Vec::new();
        for w in words(Request::WriteMi(910, 7.0), 3, 1).take(20) {
            got.extend(s.on_word(w, serves));
        }
        assert_eq!(
            got,
            vec![Incoming {
                node: 1,
                request: Request::WriteMi(910, 7.0)
            }]
        );
        assert_eq!(s.reply_regs(), None, "no reply before the station answered");
        s.set_reply(Reply::Done);
        let (r2, r3) = s.reply_regs().unwrap();
        let w = AuxWord::decode(r2, r3);
        assert_eq!((w.kind, w.tag, w.node, w.len), (WordKind::Reply, 3, 1, 1));
        // the master goes idle: the station stops replying
        assert_eq!(s.on_word(AuxWord::IDLE, serves), None);
        assert_eq!(s.reply_regs(), None);
    }

    #[test]
    fn a_held_request_streams_working_until_answered_for_its_own_transaction() {
        let serves = |n: u8| n == 0;
        let mut s = AuxSlave::default();
        let inc = words(Request::Command(StationCmd::Save), 2, 0)
            .take(3)
            .find_map(|w| s.on_word(w, serves));
        assert!(inc.is_some());
        let tag = s.hold();
        assert_eq!(tag, 2);
        assert!(s.holding());
        for _ in 0..3 {
            let (r2, r3) = s.reply_regs().unwrap();
            let w = AuxWord::decode(r2, r3);
            assert_eq!(
                (w.kind, w.tag, w.len, w.data),
                (WordKind::Reply, 2, 1, WORKING[0])
            );
        }
        assert!(
            !s.answer_held(5, Reply::Done),
            "another transaction's answer"
        );
        assert!(s.answer_held(2, Reply::Done));
        assert!(!s.holding());
        let (r2, r3) = s.reply_regs().unwrap();
        assert_eq!(AuxWord::decode(r2, r3).data, 0, "Done");
        // the master gave up (idle): a late answer goes nowhere
        s.on_word(
            words(Request::Command(StationCmd::Save), 3, 0)
                .next()
                .unwrap(),
            serves,
        );
        s.hold();
        s.on_word(AuxWord::IDLE, serves);
        assert!(!s.answer_held(3, Reply::Done));
        assert_eq!(s.reply_regs(), None);
    }

    #[test]
    fn ignores_other_nodes_answers_broadcasts_and_refuses_garbage() {
        let serves = |n: u8| n == 0;
        let mut s = AuxSlave::default();
        assert!(words(Request::ReadMi(8), 1, 4)
            .take(10)
            .all(|w| s.on_word(w, serves).is_none()));
        assert_eq!(s.reply_regs(), None);
        let mut s = AuxSlave::default();
        let got: Vec<_> = words(Request::ReadMi(8), 2, 15)
            .take(4)
            .filter_map(|w| s.on_word(w, serves))
            .collect();
        assert_eq!(got.len(), 1);
        // a complete message that is no request: BAD_REQUEST
        let mut s = AuxSlave::default();
        let bad = [9u16 << 8];
        let w = stream_word(WordKind::Request, 5, 0, &bad, 0);
        assert_eq!(s.on_word(w, serves), None);
        let mut c = Collector::default();
        let mut all = None;
        for _ in 0..2 {
            let (r2, r3) = s.reply_regs().unwrap();
            let w = AuxWord::decode(r2, r3);
            assert_eq!(w.kind, WordKind::Reply);
            all = c.push(&w);
        }
        assert_eq!(
            Reply::from_words(&all.unwrap()),
            Some(Reply::Error(slave_error::BAD_REQUEST))
        );
    }
}
