//! Host benchmark (`mcc bench host`): in-process command rate for a mixed command mix, ASCII and
//! Ethernet port round trips on loopback (p50/p99), and replies per second for `P0..1023`
//! (in-process and through the Ethernet port with GETBUFFER). Wall-clock measurements live here
//! only, never in tests.

use std::fmt;
use std::io::{self, Read, Write};
use std::net::TcpStream;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::eth_codec::{request, VR_DOWNLOAD, VR_PMAC_GETBUFFER, VR_PMAC_GETRESPONSE, VR_UPLOAD};
use super::server::{serve, PortsConfig};
use crate::domain::Profile;
use crate::lang::{Card, Session};

/// The mixed command mix: one command per line, as a host program would send them.
pub(crate) const COMMAND_MIX: &[&[u8]] = &[
    b"P1=P1+1",
    b"P2",
    b"I130",
    b"Q10=P1*2",
    b"M1",
    b"#1P",
    b"I122=32",
    b"P3=SIN(P1)+P2/3",
    b"&1%",
    b"#2?",
];

/// How much to measure.
#[derive(Debug, Clone)]
pub struct HostBenchOpts {
    /// Card profile.
    pub profile: Profile,
    /// In-process command lines to execute.
    pub inproc_commands: usize,
    /// Round trips per port.
    pub round_trips: usize,
    /// `P0..1023` executions (each 1024 replies).
    pub range_runs: usize,
}

impl Default for HostBenchOpts {
    fn default() -> Self {
        HostBenchOpts {
            profile: Profile::Pmac2,
            inproc_commands: 1_000_000,
            round_trips: 5_000,
            range_runs: 200,
        }
    }
}

/// Measured results.
#[derive(Debug, Clone)]
pub struct HostBenchReport {
    /// Command lines executed in-process.
    pub inproc_commands: usize,
    /// In-process command lines per second.
    pub inproc_per_sec: f64,
    /// ASCII port round trip median / 99th percentile.
    pub ascii_p50: Duration,
    /// ASCII port round trip 99th percentile.
    pub ascii_p99: Duration,
    /// Ethernet port round trip median.
    pub eth_p50: Duration,
    /// Ethernet port round trip 99th percentile.
    pub eth_p99: Duration,
    /// Round trips measured per port.
    pub round_trips: usize,
    /// `P0..1023` replies per second, in-process.
    pub range_replies_per_sec_inproc: f64,
    /// `P0..1023` replies per second through the Ethernet port (GETRESPONSE + GETBUFFERs).
    pub range_replies_per_sec_eth: f64,
    /// Bytes of one `P0..1023` reply.
    pub range_reply_bytes: usize,
}

impl fmt::Display for HostBenchReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "host benchmark")?;
        writeln!(
            f,
            "  in-process mixed commands: {:.0} /s ({} lines, target >= 1000000)",
            self.inproc_per_sec, self.inproc_commands
        )?;
        writeln!(
            f,
            "  ASCII port round trip:     p50 {:.1} us  p99 {:.1} us ({} trips, target p50 <= 100 us)",
            us(self.ascii_p50),
            us(self.ascii_p99),
            self.round_trips
        )?;
        writeln!(
            f,
            "  Ethernet port round trip:  p50 {:.1} us  p99 {:.1} us ({} trips, target p50 <= 100 us)",
            us(self.eth_p50),
            us(self.eth_p99),
            self.round_trips
        )?;
        write!(
            f,
            "  P0..1023 replies:          {:.0} /s in-process, {:.0} /s via Ethernet ({} bytes per reply)",
            self.range_replies_per_sec_inproc, self.range_replies_per_sec_eth, self.range_reply_bytes
        )
    }
}

fn us(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

fn per_sec(n: usize, d: Duration) -> f64 {
    n as f64 / d.as_secs_f64().max(1e-9)
}

/// Percentile (0..=100) of sorted samples.
pub(crate) fn percentile(sorted: &[Duration], p: usize) -> Duration {
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    let idx = (sorted.len() - 1) * p.min(100) / 100;
    sorted.get(idx).copied().unwrap_or_default()
}

/// Run the benchmark (starts its own runtime for the servers; clients are blocking sockets).
pub fn run_host_bench(opts: &HostBenchOpts) -> io::Result<HostBenchReport> {
    // In-process mix.
    let mut card = Card::new(opts.profile);
    let mut s = Session::default();
    let _ = card.command_line(&mut s, b"I3=2 I6=1");
    let t = Instant::now();
    for i in 0..opts.inproc_commands {
        let line = COMMAND_MIX
            .get(i % COMMAND_MIX.len())
            .copied()
            .unwrap_or(b"P1");
        std::hint::black_box(card.command_line(&mut s, line));
    }
    let inproc = t.elapsed();
    let t = Instant::now();
    let mut range_reply_bytes = 0;
    for _ in 0..opts.range_runs {
        range_reply_bytes = std::hint::black_box(card.command_line(&mut s, b"P0..1023")).len();
    }
    let range_inproc = t.elapsed();

    // Ports.
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()?;
    let (mut runner, handle) =
        crate::service::handle::channel(crate::core::CardCore::new(card), None);
    let stop = Arc::new(AtomicBool::new(false));
    let card_thread = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || runner.run_until(&stop))
    };
    let ports = rt.block_on(serve(handle, PortsConfig::default()))?;
    let ascii = ascii_round_trips(ports.ascii, opts.round_trips);
    let eth = eth_round_trips(ports.pmac_eth, opts.round_trips, opts.range_runs);
    rt.block_on(ports.shutdown());
    stop.store(true, Ordering::Relaxed);
    let _ = card_thread.join();
    let ascii = ascii?;
    let (eth, range_eth) = eth?;

    Ok(HostBenchReport {
        inproc_commands: opts.inproc_commands,
        inproc_per_sec: per_sec(opts.inproc_commands, inproc),
        ascii_p50: percentile(&ascii, 50),
        ascii_p99: percentile(&ascii, 99),
        eth_p50: percentile(&eth, 50),
        eth_p99: percentile(&eth, 99),
        round_trips: opts.round_trips,
        range_replies_per_sec_inproc: per_sec(1024 * opts.range_runs, range_inproc),
        range_replies_per_sec_eth: per_sec(1024 * opts.range_runs, range_eth),
        range_reply_bytes,
    })
}

fn client(addr: std::net::SocketAddr) -> io::Result<TcpStream> {
    let s = TcpStream::connect(addr)?;
    s.set_nodelay(true)?;
    s.set_read_timeout(Some(Duration::from_secs(5)))?;
    Ok(s)
}

/// Read until the reply's final byte (ACK, or CR of a BELL error) has arrived.
fn read_reply(s: &mut TcpStream, buf: &mut Vec<u8>) -> io::Result<()> {
    buf.clear();
    let mut chunk = [0u8; 4096];
    loop {
        let n = s.read(&mut chunk)?;
        if n == 0 {
            return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "card closed"));
        }
        buf.extend_from_slice(chunk.get(..n).unwrap_or_default());
        match buf.last() {
            Some(0x06) => return Ok(()),
            Some(0x0D) if buf.contains(&0x07) => return Ok(()),
            _ => {}
        }
    }
}

fn ascii_round_trips(addr: std::net::SocketAddr, n: usize) -> io::Result<Vec<Duration>> {
    let mut s = client(addr)?;
    let mut buf = Vec::new();
    let mut v = Vec::with_capacity(n);
    for _ in 0..n {
        let t = Instant::now();
        s.write_all(b"P1\r")?;
        read_reply(&mut s, &mut buf)?;
        v.push(t.elapsed());
    }
    v.sort();
    Ok(v)
}

fn eth_round_trips(
    addr: std::net::SocketAddr,
    n: usize,
    range_runs: usize,
) -> io::Result<(Vec<Duration>, Duration)> {
    let mut s = client(addr)?;
    let mut buf = Vec::new();
    let mut v = Vec::with_capacity(n);
    let p1 = request(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, 0, 2, b"P1");
    for _ in 0..n {
        let t = Instant::now();
        s.write_all(&p1)?;
        read_reply(&mut s, &mut buf)?;
        v.push(t.elapsed());
    }
    v.sort();
    let range = request(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, 0, 8, b"P0..1023");
    let getbuf = request(VR_UPLOAD, VR_PMAC_GETBUFFER, 0, 2048, &[]);
    let t = Instant::now();
    for _ in 0..range_runs {
        s.write_all(&range)?;
        let mut packet = Vec::new();
        read_packet(&mut s, &mut packet)?;
        while !matches!(packet.last(), Some(0x06 | 0x0D)) {
            s.write_all(&getbuf)?;
            read_packet(&mut s, &mut packet)?;
        }
    }
    Ok((v, t.elapsed()))
}

/// One packet as dls-pmaclib reads it: what one read returns (packets are written whole).
fn read_packet(s: &mut TcpStream, buf: &mut Vec<u8>) -> io::Result<()> {
    buf.resize(2048, 0);
    let n = s.read(buf)?;
    if n == 0 {
        return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "card closed"));
    }
    buf.truncate(n);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentile_picks_sorted_rank() {
        let v: Vec<Duration> = (1..=100).map(Duration::from_micros).collect();
        assert_eq!(percentile(&v, 50), Duration::from_micros(50));
        assert_eq!(percentile(&v, 99), Duration::from_micros(99));
        assert_eq!(percentile(&[], 50), Duration::ZERO);
    }

    #[test]
    fn small_run_completes_and_reports() {
        let opts = HostBenchOpts {
            inproc_commands: 50,
            round_trips: 20,
            range_runs: 2,
            ..Default::default()
        };
        let r = run_host_bench(&opts).unwrap();
        assert_eq!(r.inproc_commands, 50);
        assert_eq!(r.round_trips, 20);
        assert!(r.ascii_p50 <= r.ascii_p99 && r.eth_p50 <= r.eth_p99);
        assert!(r.range_reply_bytes > 0);
        let text = r.to_string();
        assert!(
            text.contains("ASCII port round trip") && text.contains("P0..1023"),
            "{text}"
        );
    }

    /// The full benchmark, for the report:
    /// `cargo test --release -p mcc-card --lib host::bench -- --ignored --nocapture`.
    #[test]
    #[ignore = "benchmark: run explicitly in release mode"]
    fn full_benchmark_report() {
        let r = run_host_bench(&HostBenchOpts::default()).unwrap();
        println!("{r}");
    }
}
