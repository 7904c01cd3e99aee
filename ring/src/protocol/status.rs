//! Receive error classes, the latched I995 status bits and the cumulative counters.

use crate::control::ErrorCounters;

/// I995 bit 0: data (packet) overrun error.
pub const STATUS_OVERRUN: u32 = 0x01;
/// I995 bit 1: byte violation error.
pub const STATUS_BYTE_VIOLATION: u32 = 0x02;
/// I995 bit 2: packet parity (checksum) error.
pub const STATUS_CHECKSUM: u32 = 0x04;
/// I995 bit 3: packet (data) underrun error.
pub const STATUS_UNDERRUN: u32 = 0x08;
/// I995 bit 6: sync node packet received.
pub const STATUS_SYNC_RECEIVED: u32 = 0x40;
/// The four error bits (what the ring check tests with `s & 0b1111`).
pub const STATUS_ERRORS: u32 = 0x0F;

/// One receive error class (architecture §3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ErrorClass {
    /// A header byte that is not a valid packet code.
    ByteViolation,
    /// Check byte mismatch.
    Checksum,
    /// More bytes than whole packets, or a frame before the previous one was consumed.
    Overrun,
    /// A truncated packet, or a frame missing its packets.
    Underrun,
}

impl ErrorClass {
    /// The I995 status bit latched by this class.
    pub fn status_bit(self) -> u32 {
        match self {
            ErrorClass::Overrun => STATUS_OVERRUN,
            ErrorClass::ByteViolation => STATUS_BYTE_VIOLATION,
            ErrorClass::Checksum => STATUS_CHECKSUM,
            ErrorClass::Underrun => STATUS_UNDERRUN,
        }
    }
}

/// Latched I995 status bits (cleared on read) plus counters that only grow.
#[derive(Clone, Debug, Default)]
pub struct RingStatus {
    latched: u32,
    counters: ErrorCounters,
}

impl RingStatus {
    /// Fresh status: nothing latched, counters zero.
    pub fn new() -> Self {
        Self::default()
    }

    /// Record one receive error: counter + latched bit.
    pub fn record(&mut self, class: ErrorClass) {
        let c = &mut self.counters;
        match class {
            ErrorClass::ByteViolation => c.byte_violation += 1,
            ErrorClass::Checksum => c.checksum += 1,
            ErrorClass::Overrun => c.overrun += 1,
            ErrorClass::Underrun => c.underrun += 1,
        }
        self.latched |= class.status_bit();
    }

    /// Record a frame rejected before packet parsing (no I995 bit: the ring IC never saw it).
    pub fn record_bad_frame(&mut self) {
        self.counters.bad_frames += 1;
    }

    /// Latch I995 bit 6 (sync node packet received).
    pub fn set_sync_received(&mut self) {
        self.latched |= STATUS_SYNC_RECEIVED;
    }

    /// Read the status bits (0-3, 6) and clear them, as reading I995 does on the card.
    pub fn read_and_clear(&mut self) -> u32 {
        std::mem::take(&mut self.latched)
    }

    /// The latched bits without clearing them (the card's I995 view; the ring check reads and
    /// clears them once per RTI).
    pub fn peek(&self) -> u32 {
        self.latched
    }

    /// Cumulative counters since start.
    pub fn counters(&self) -> ErrorCounters {
        self.counters
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_latch_and_clear_on_read() {
        let mut s = RingStatus::new();
        s.record(ErrorClass::Checksum);
        s.record(ErrorClass::Checksum);
        s.record(ErrorClass::Underrun);
        s.set_sync_received();
        assert_eq!(s.peek(), 0x4C);
        assert_eq!(s.read_and_clear(), 0x4C);
        assert_eq!(s.read_and_clear(), 0);
        s.record(ErrorClass::Overrun);
        s.record(ErrorClass::ByteViolation);
        s.record_bad_frame();
        assert_eq!(s.read_and_clear(), 0x03);
        let c = s.counters();
        assert_eq!(
            (
                c.byte_violation,
                c.checksum,
                c.overrun,
                c.underrun,
                c.bad_frames
            ),
            (1, 2, 1, 1, 1)
        );
    }
}
