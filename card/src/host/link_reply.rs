//! Replies through the card's host-link fault ([`LinkFaultSlot`], `mcc fault CARD link KIND`):
//! every host port writes each reply through [`write_reply`] while a fault is installed. The
//! card executed the command as always; only what the host reads changes (dropped, late, cut
//! short, stray or corrupted bytes, the connection reset). Unsolicited output (`SEND`, `CMD`
//! replies of programs) is no reply and passes unchanged; the `mcc send` queryable is the
//! tool's own path, not a host link, and is never faulted.

use std::io;
use std::time::Duration;

use mcc_ring::linkfault::{LinkFaultSlot, LinkOutcome};
use tokio::io::AsyncWriteExt;
use tokio::net::TcpStream;

/// The error a port returns when the fault resets its connection (it then closes it).
pub(crate) fn reset_error() -> io::Error {
    io::Error::new(
        io::ErrorKind::ConnectionReset,
        "host-link fault: connection reset",
    )
}

/// Wait as the outcome says (`late`), off the async threads' hands when there are none.
pub(crate) async fn wait_late(o: &LinkOutcome) {
    if o.delay_ms > 0 {
        tokio::time::sleep(Duration::from_millis(o.delay_ms)).await;
    }
}

/// Write `reply` to `stream` as `slot`'s fault has it (within `timeout`); a `reset` sets a
/// zero linger (the close sends RST) and returns [`reset_error`].
pub(crate) async fn write_reply(
    stream: &mut TcpStream,
    slot: &LinkFaultSlot,
    reply: &[u8],
    timeout: Duration,
) -> io::Result<()> {
    let o = slot.on_reply(reply);
    wait_late(&o).await;
    if !o.bytes.is_empty() {
        match tokio::time::timeout(timeout, stream.write_all(&o.bytes)).await {
            Ok(r) => r?,
            Err(_) => {
                return Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    "host stopped reading",
                ))
            }
        }
    }
    if o.reset {
        let _ = stream.set_zero_linger();
        return Err(reset_error());
    }
    Ok(())
}
