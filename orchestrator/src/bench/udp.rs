//! The machine's limit: a raw UDP loopback ring of the same member count, forwarding the same
//! frame bytes hop by hop (decode to read the cycle, then send on), in lockstep.

use std::net::UdpSocket;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context, Result};
use mcc_ring::frame::{Frame, FORMAT_VERSION};

use super::stats::{new_log, since, SendLog};

/// Bytes of packets per frame (9 nodes × 12 bytes, like a card's 8 nodes plus sync).
const PACKET_BYTES: usize = 108;

fn frame(sender: u16, cycle: u64, t: u64) -> Vec<u8> {
    Frame {
        version: FORMAT_VERSION,
        sender,
        seq: cycle,
        sent_ns: t,
        cycle,
        origin_ns: t,
        declared: (PACKET_BYTES / 12) as u16,
        packets: vec![0x5a; PACKET_BYTES],
    }
    .encode()
}

/// Run `cycles` lockstep cycles around `n` UDP sockets; one send log per member.
pub fn run(n: usize, cycles: u64, epoch: Instant) -> Result<Vec<Vec<(u64, u64)>>> {
    let socks: Vec<UdpSocket> = (0..n)
        .map(|_| UdpSocket::bind("127.0.0.1:0"))
        .collect::<std::io::Result<_>>()
        .context("binding UDP sockets")?;
    let addrs: Vec<_> = socks
        .iter()
        .map(|s| s.local_addr())
        .collect::<std::io::Result<_>>()?;
    let logs: Vec<SendLog> = (0..n).map(|_| new_log(cycles as usize + 16)).collect();
    let stop = Arc::new(AtomicBool::new(false));
    let mut handles = Vec::new();
    for (k, sock) in socks.into_iter().enumerate() {
        let next = addrs[(k + 1) % n];
        let log = Arc::clone(&logs[k]);
        let stop = Arc::clone(&stop);
        handles.push(std::thread::spawn(move || -> std::io::Result<()> {
            let mut buf = vec![0u8; 2048];
            if k == 0 {
                sock.set_read_timeout(Some(Duration::from_millis(50)))?;
                for c in 1..=cycles {
                    let t = since(epoch);
                    if let Ok(mut l) = log.lock() {
                        l.push((c, t));
                    }
                    sock.send_to(&frame(0, c, t), next)?;
                    // Wait for this cycle's frame to come back (timeout: go on, like lockstep).
                    while let Ok((len, _)) = sock.recv_from(&mut buf) {
                        let back = buf.get(..len).and_then(|b| Frame::decode(b).ok());
                        if back.is_some_and(|f| f.cycle == c) {
                            break;
                        }
                    }
                }
                stop.store(true, Ordering::Relaxed);
            } else {
                sock.set_read_timeout(Some(Duration::from_millis(20)))?;
                while !stop.load(Ordering::Relaxed) {
                    let Ok((len, _)) = sock.recv_from(&mut buf) else {
                        continue;
                    };
                    let Some(bytes) = buf.get(..len) else {
                        continue;
                    };
                    if let Ok(f) = Frame::decode(bytes) {
                        if let Ok(mut l) = log.lock() {
                            l.push((f.cycle, since(epoch)));
                        }
                        // Re-encode as the next sender, as a ring member would.
                        sock.send_to(&frame(k as u16, f.cycle, since(epoch)), next)?;
                    }
                }
            }
            Ok(())
        }));
    }
    for h in handles {
        h.join()
            .map_err(|_| anyhow!("UDP ring thread panicked"))??;
    }
    Ok(logs
        .iter()
        .map(|l| l.lock().map(|v| v.clone()).unwrap_or_default())
        .collect())
}
