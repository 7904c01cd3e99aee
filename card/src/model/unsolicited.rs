//! Unsolicited output of a card (`SEND` text and the replies of program-issued `CMD`s): a
//! bounded log that every ASCII terminal connection reads from its own position, so a host
//! sees messages its programs and PLCs send without asking. The Ethernet protocol port never
//! interleaves it into GETRESPONSE replies (host-protocols §4.4).

use std::collections::VecDeque;

/// Bytes kept at most; older output is dropped first (a host that never reads loses it).
pub(super) const UNSOLICITED_LIMIT: usize = 64 * 1024;

/// The log: chunks numbered from 1.
#[derive(Debug, Default, Clone)]
pub(crate) struct Unsolicited {
    chunks: VecDeque<(u64, Vec<u8>)>,
    bytes: usize,
    next: u64,
}

impl Unsolicited {
    /// Append `bytes` (ignored when empty), dropping the oldest chunks beyond the limit.
    pub(crate) fn push(&mut self, bytes: Vec<u8>) {
        if bytes.is_empty() {
            return;
        }
        let mut bytes = bytes;
        if bytes.len() > UNSOLICITED_LIMIT {
            bytes.drain(..bytes.len() - UNSOLICITED_LIMIT);
        }
        self.next += 1;
        self.bytes += bytes.len();
        self.chunks.push_back((self.next, bytes));
        while self.bytes > UNSOLICITED_LIMIT {
            match self.chunks.pop_front() {
                Some((_, old)) => self.bytes -= old.len(),
                None => break,
            }
        }
    }

    /// Position after the newest chunk: a reader starting here sees only later output.
    pub(crate) fn position(&self) -> u64 {
        self.next
    }

    /// Everything after position `from`, and the new position.
    pub(crate) fn since(&self, from: u64) -> (Vec<u8>, u64) {
        let mut out = Vec::new();
        for (n, c) in &self.chunks {
            if *n > from {
                out.extend_from_slice(c);
            }
        }
        (out, self.next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readers_see_what_came_after_their_position() {
        let mut u = Unsolicited::default();
        u.push(b"A\r".to_vec());
        let p = u.position();
        u.push(Vec::new());
        u.push(b"B\r".to_vec());
        u.push(b"C\r".to_vec());
        assert_eq!(u.since(p), (b"B\rC\r".to_vec(), 3));
        assert_eq!(u.since(0).0, b"A\rB\rC\r".to_vec());
        assert_eq!(u.since(3).0, Vec::<u8>::new());
    }

    #[test]
    fn the_log_is_bounded() {
        let mut u = Unsolicited::default();
        for _ in 0..100 {
            u.push(vec![b'x'; 1000]);
        }
        let (all, pos) = u.since(0);
        assert!(all.len() <= UNSOLICITED_LIMIT);
        assert_eq!(pos, 100);
        u.push(vec![b'y'; UNSOLICITED_LIMIT * 2]);
        assert_eq!(u.since(0).0.len(), UNSOLICITED_LIMIT);
    }
}
