//! `mcc bench ring`, section (d): what a ring costs across hosts. The same lockstep ring
//! (2 cards + 2 stations, card0/station0 on host a, card1/station1 on host b) measured three
//! ways in one run, one after the other:
//! - one machine: `mcc up` without hosts (members linked over unix sockets);
//! - peer to peer: two hosts' shares (`mcc up --host`, each with a run directory of its own,
//!   as on two machines) on loopback, every hop a direct zenoh TCP link;
//! - through a router: the same two shares as zenoh clients of a `zenohd` on loopback
//!   (`--zenohd`, `$MCC_ZENOHD` or `zenohd` on the PATH; skipped, saying so, without one),
//!   every hop member → router → member.
//!
//! The hop cost is the ring's round trip over its members (1 / cycles/s / members): it needs
//! no common clock, so it means the same on real hosts. The members' own hop figures (`hop`
//! in their status, send stamp to receipt) are shown too; they compare `CLOCK_MONOTONIC` of
//! two processes and are only meaningful on one machine (as here, or network namespaces).
//! On real hosts the network's own latency comes on top of the figures measured here.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_ring::config::ClusterConfig;
use mcc_ring::transport::cluster::Role;

use super::bringup::{mcc, run_bounded};
use super::cluster::{self, member_status, ClusterSpec};

/// The router's real-time queue: as deep as mcc's own (README "Running on several machines").
const ROUTER_CONFIG: &str =
    "{ mode: \"router\", transport: { link: { tx: { queue: { size: { real_time: 16 } } } } } }";

/// One way of linking the ring.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Path2 {
    PeerToPeer,
    Router(u16),
}

/// Figures of one window.
#[derive(Debug, Clone, Copy)]
struct Figures {
    cycles_per_s: f64,
    /// Median of the members' hop p50 and the largest p99, µs (one machine only).
    stamped: Option<(f64, f64)>,
}

impl Figures {
    /// Mean hop, µs: the round trip over the ring's members.
    fn hop_us(&self, members: usize) -> f64 {
        1e6 / self.cycles_per_s / members as f64
    }
}

/// A zenohd started for the bench; killed when dropped.
struct Router(Child);

impl Drop for Router {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The two shares; both taken down when dropped.
struct Shares {
    cluster: String,
    dirs: [PathBuf; 2],
}

impl Drop for Shares {
    fn drop(&mut self) {
        for d in &self.dirs {
            if let Ok(mut down) = mcc() {
                down.args(["down", "--cluster", &self.cluster, "--timeout", "10"])
                    .env("MCC_RUN_DIR", d);
                let _ = run_bounded(down, Duration::from_secs(30));
            }
        }
        if let Some(base) = self.dirs[0].parent() {
            let _ = std::fs::remove_dir_all(base);
        }
    }
}

/// The zenohd to use: `--zenohd`, `$MCC_ZENOHD`, or `zenohd` on the PATH.
pub fn find_zenohd(given: Option<&Path>) -> Option<PathBuf> {
    if let Some(p) = given {
        return Some(p.to_path_buf());
    }
    if let Some(p) = std::env::var_os("MCC_ZENOHD") {
        return Some(PathBuf::from(p));
    }
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("zenohd"))
            .find(|p| p.is_file())
    })
}

fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

/// The two-host config of `path`.
fn config_text(cluster: &str, path: Path2) -> Result<String> {
    let mut t = format!("cluster = \"{cluster}\"\nclock = \"lockstep\"\n");
    match path {
        Path2::Router(port) => {
            t.push_str(&format!("[zenoh]\nrouters = [\"tcp/127.0.0.1:{port}\"]\n"));
        }
        Path2::PeerToPeer => {
            for h in ["a", "b"] {
                t.push_str(&format!(
                    "[hosts.{h}]\naddress = \"127.0.0.1\"\nport = {}\n",
                    free_port()?
                ));
            }
        }
    }
    for (i, h) in ["a", "b"].iter().enumerate() {
        t.push_str(&format!(
            "[[cards]]\nname = \"card{i}\"\nnumber = {i}\nmaster = {i}\nhost = \"{h}\"\n\
             [[stations]]\nname = \"station{i}\"\nmaster = {i}\nhost = \"{h}\"\n"
        ));
    }
    Ok(t)
}

/// Start both shares of a two-host ring linked by `path`, measure `window`, take them down.
fn measure(path: Path2, tag: &str, window: Duration) -> Result<Figures> {
    let cluster = format!("bench-hosts-{}-{tag}", std::process::id());
    let base = std::env::temp_dir().join(&cluster);
    let dirs = [base.join("machine-a"), base.join("machine-b")];
    for d in &dirs {
        std::fs::create_dir_all(d)?;
    }
    let file = base.join("lab.toml");
    std::fs::write(&file, config_text(&cluster, path)?)?;
    let shares = Shares {
        cluster: cluster.clone(),
        dirs: dirs.clone(),
    };
    let ups: Vec<_> = ["a", "b"]
        .iter()
        .zip(&dirs)
        .map(|(h, d)| -> Result<_> {
            let mut up = mcc()?;
            up.args(["up", "--detach", "--timeout", "60", "--host", *h])
                .arg("--config")
                .arg(&file)
                .env("MCC_RUN_DIR", d);
            Ok(std::thread::spawn(move || {
                run_bounded(up, Duration::from_secs(120))
            }))
        })
        .collect::<Result<_>>()?;
    for (h, t) in ["a", "b"].iter().zip(ups) {
        let (ok, err) = t
            .join()
            .map_err(|_| anyhow!("host {h}: mcc up panicked"))??;
        if !ok {
            bail!("mcc up --host {h} ({path:?}) failed: {}", err.trim());
        }
    }
    let cfg = ClusterConfig::from_file(&file)?;
    let session = crate::cluster::hosts::open(&cfg, Role::Client { host: "a" })?;
    crate::cluster::hosts::settle(&session, &cfg, 1, Duration::from_secs(3));
    let sync = cfg.ring.sync_master.clone();
    std::thread::sleep(Duration::from_secs(1));
    let sample = || -> Result<(u64, Instant)> {
        let before = Instant::now();
        let s = member_status(&session, &cluster, &sync)?;
        Ok((s.cycle, before + (Instant::now() - before) / 2))
    };
    let (c0, t0) = sample()?;
    std::thread::sleep(window);
    let (c1, t1) = sample()?;
    let mut p50 = Vec::new();
    let mut p99: Option<f64> = None;
    for m in &cfg.ring.order {
        let hop = member_status(&session, &cluster, m)
            .ok()
            .and_then(|s| s.extra.get("hop").cloned())
            .and_then(|h| Some((h.get("p50_us")?.as_f64()?, h.get("p99_us")?.as_f64()?)));
        if let Some((a, b)) = hop {
            p50.push(a);
            p99 = Some(p99.map_or(b, |x| x.max(b)));
        }
    }
    p50.sort_by(f64::total_cmp);
    let stamped = p50.get(p50.len() / 2).copied().zip(p99);
    let _ = zenoh::Wait::wait(session.close());
    drop(shares);
    Ok(Figures {
        cycles_per_s: c1.saturating_sub(c0) as f64 / (t1 - t0).as_secs_f64(),
        stamped,
    })
}

fn start_router(zenohd: &Path) -> Result<(Router, u16, PathBuf)> {
    let port = free_port()?;
    let dir = std::env::temp_dir().join(format!("mcc-bench-zenohd-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let conf = dir.join("zenohd.json5");
    std::fs::write(&conf, ROUTER_CONFIG)?;
    let child = Command::new(zenohd)
        .args(["--no-multicast-scouting", "-l"])
        .arg(format!("tcp/127.0.0.1:{port}"))
        .arg("-c")
        .arg(&conf)
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .with_context(|| format!("starting {}", zenohd.display()))?;
    let router = Router(child);
    // Up once it accepts a connection.
    let deadline = Instant::now() + Duration::from_secs(10);
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        if Instant::now() > deadline {
            bail!("{} did not listen on port {port}", zenohd.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok((router, port, dir))
}

fn row(label: &str, f: &Figures, members: usize, base: f64) {
    let stamped = f
        .stamped
        .map(|(a, b)| format!("{a:.1} / {b:.1}"))
        .unwrap_or_else(|| "-".into());
    println!(
        "    {:<30} {:>9.0} {:>12.1} {:>8.2} {:>17}",
        label,
        f.cycles_per_s,
        f.hop_us(members),
        f.hop_us(members) / base,
        stamped
    );
}

/// Section (d) of `mcc bench ring`.
pub fn run(window: Duration, zenohd: Option<&Path>) -> Result<()> {
    let members = 4;
    println!(
        "\n(d) across hosts: 2 cards + 2 stations, lockstep, card0/station0 on host a and card1/\
         station1 on host b (both shares on this machine, each its own run dir); {} s each",
        window.as_secs_f64()
    );
    println!(
        "    {:<30} {:>9} {:>12} {:>8} {:>17}",
        "", "cycles/s", "hop µs", "× one", "stamped p50/p99"
    );
    let spec = ClusterSpec {
        cards: 2,
        stations: 2,
        clock: Some("lockstep".into()),
        rate: None,
    };
    let one = cluster::measure(&spec, "h0", Duration::from_secs(1), window)?;
    let one = Figures {
        cycles_per_s: one.cycles_per_s,
        stamped: one.hop_us(),
    };
    let base = one.hop_us(members);
    row("one machine (unix sockets)", &one, members, base);
    let p2p = measure(Path2::PeerToPeer, "p2p", window)?;
    row("two hosts, peer to peer (TCP)", &p2p, members, base);
    match find_zenohd(zenohd) {
        None => println!(
            "    two hosts through zenohd: SKIPPED (no zenohd: --zenohd, $MCC_ZENOHD or PATH; \
             tests/hosts/install-zenohd.sh builds the pinned one)"
        ),
        Some(z) => {
            let (router, port, dir) = start_router(&z)?;
            let r = measure(Path2::Router(port), "router", window);
            drop(router);
            let _ = std::fs::remove_dir_all(dir);
            let r = r?;
            row("two hosts through zenohd", &r, members, base);
            println!(
                "    through the router vs peer to peer: hop {:.2}× ({:+.1} µs per hop)",
                r.hop_us(members) / p2p.hop_us(members),
                r.hop_us(members) - p2p.hop_us(members)
            );
        }
    }
    println!(
        "    hop µs = ring round trip / members (no common clock needed: valid on real hosts); \
         stamped = members' send-to-receipt figures (one machine only); real hosts add the \
         network's latency per hop that crosses it"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bench_configs_are_valid_two_host_clusters() {
        for path in [Path2::PeerToPeer, Path2::Router(7447)] {
            let text = config_text("bench-x", path).unwrap();
            let cfg = ClusterConfig::from_toml_str(&text).unwrap();
            assert!(cfg.is_multi_host(), "{text}");
            assert_eq!(cfg.host_names(), ["a", "b"]);
            assert_eq!(cfg.member_host("station1"), Some("b"));
        }
        let f = Figures {
            cycles_per_s: 1000.0,
            stamped: None,
        };
        assert!((f.hop_us(4) - 250.0).abs() < 1e-9);
    }
}
