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
//!
//! The same measurement runs the two shares in network namespaces of their own too
//! ([`Site::Lab`], section (e), [`super::netns`]).

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_contracts::config::ClusterConfig;
use mcc_netns::{AB, RA, RB};
use mcc_ring::transport::cluster::Role;

use super::bringup::{mcc, run_bounded};
use super::cluster::{self, member_status, ClusterSpec};
use super::netns::LabHosts;

/// The router's real-time queue: as deep as mcc's own (README "Running on several machines").
const ROUTER_QUEUES: &str = "link: { tx: { queue: { size: { real_time: 16 } } } }";
/// The port of every listener in a lab (each namespace has its own ports).
const LAB_PORT: u16 = 7447;
/// Status documents per second while measuring (`mcc status --json --watch`).
const WATCH_MS: &str = "100";

/// Where the two hosts' shares run.
#[derive(Debug, Clone, Copy)]
pub(super) enum Site<'a> {
    /// Both on this machine's loopback, each with a run directory of its own.
    Loopback,
    /// Host a in the lab's namespace `a`, host b in `b` (a router in `r`), authenticated.
    Lab(&'a LabHosts),
}

impl Site<'_> {
    /// `mcc` as host `h` runs it (in its namespace): stdin and stdout null, stderr piped.
    fn mcc(&self, h: &str) -> Result<Command> {
        match self {
            Site::Loopback => mcc(),
            Site::Lab(lab) => {
                let exe = std::env::current_exe().context("finding the mcc binary")?;
                let mut c = lab.lab.command(h, exe);
                c.stdin(Stdio::null())
                    .stdout(Stdio::null())
                    .stderr(Stdio::piped());
                Ok(c)
            }
        }
    }

    /// What the cluster config needs to link beyond loopback (none on loopback).
    fn security(&self, cluster: &str) -> String {
        match self {
            Site::Loopback => String::new(),
            Site::Lab(lab) => lab.cluster_security(cluster),
        }
    }

    /// Host `i`'s (0 = a, 1 = b) address and port for peer-to-peer links.
    fn peer_endpoint(&self, i: usize) -> Result<(String, u16)> {
        match self {
            Site::Loopback => Ok(("127.0.0.1".into(), free_port()?)),
            Site::Lab(_) => Ok(([AB.left.2, AB.right.2][i].into(), LAB_PORT)),
        }
    }
}

/// One way of linking the ring.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Path2 {
    /// Every hop a direct zenoh TCP link between the hosts.
    PeerToPeer,
    /// The hosts are zenoh clients of the router at these endpoints.
    Router(Vec<String>),
}

/// Figures of one window.
#[derive(Debug, Clone, Copy)]
pub(super) struct Figures {
    pub(super) cycles_per_s: f64,
    /// Median of the members' hop p50 and the largest p99, µs (one machine only).
    pub(super) stamped: Option<(f64, f64)>,
}

impl Figures {
    /// Mean hop, µs: the round trip over the ring's members.
    pub(super) fn hop_us(&self, members: usize) -> f64 {
        1e6 / self.cycles_per_s / members as f64
    }
}

/// A zenohd started for the bench; killed when dropped.
pub(super) struct Router(Child, PathBuf);

impl Drop for Router {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
        let _ = std::fs::remove_dir_all(&self.1);
    }
}

/// The two shares; both taken down when dropped.
struct Shares<'a> {
    site: Site<'a>,
    cluster: String,
    dirs: [PathBuf; 2],
}

impl Drop for Shares<'_> {
    fn drop(&mut self) {
        for (h, d) in ["a", "b"].iter().zip(&self.dirs) {
            if let Ok(mut down) = self.site.mcc(h) {
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

/// The zenohd to use: `--zenohd`, `$MCC_ZENOHD`, `zenohd` on the PATH, or the one
/// `tests/hosts/install-zenohd.sh` put in the cargo target directory this `mcc` was built in.
pub fn find_zenohd(given: Option<&Path>) -> Option<PathBuf> {
    if let Some(p) = given {
        return Some(p.to_path_buf());
    }
    if let Some(p) = std::env::var_os("MCC_ZENOHD").filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p));
    }
    let on_path = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("zenohd"))
            .find(|p| p.is_file())
    });
    on_path.or_else(|| {
        let exe = std::env::current_exe().ok()?;
        mcc_netns::zenohd(exe.parent()?.parent()?)
    })
}

/// Where a bench says it found no zenohd.
pub(super) const NO_ZENOHD: &str = "no zenohd: --zenohd, $MCC_ZENOHD, PATH or target/zenohd-*; \
                                    tests/hosts/install-zenohd.sh builds the pinned one";

fn free_port() -> Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

/// The two-host config of `path`; `peers` are the hosts' peer-to-peer endpoints, `security`
/// the zenoh authentication and access-control tables (if any).
pub(super) fn config_text(
    cluster: &str,
    path: &Path2,
    peers: [(String, u16); 2],
    security: &str,
) -> String {
    let mut t = format!("cluster = \"{cluster}\"\nclock = \"lockstep\"\n");
    match path {
        Path2::Router(endpoints) => {
            let list: Vec<String> = endpoints.iter().map(|e| format!("\"{e}\"")).collect();
            t.push_str(&format!("[zenoh]\nrouters = [{}]\n", list.join(", ")));
        }
        Path2::PeerToPeer => {
            for (h, (addr, port)) in ["a", "b"].iter().zip(peers) {
                t.push_str(&format!(
                    "[hosts.{h}]\naddress = \"{addr}\"\nport = {port}\n"
                ));
            }
        }
    }
    t.push_str(security);
    for (i, h) in ["a", "b"].iter().enumerate() {
        t.push_str(&format!(
            "[[cards]]\nname = \"card{i}\"\nnumber = {i}\nmaster = {i}\nhost = \"{h}\"\n\
             [[stations]]\nname = \"station{i}\"\nmaster = {i}\nhost = \"{h}\"\n"
        ));
    }
    t
}

/// The sync master's cycle in one `mcc status --json` document.
fn sync_cycle(doc: &str, sync: &str) -> Option<u64> {
    let v: serde_json::Value = serde_json::from_str(doc).ok()?;
    v.get("members")?
        .as_array()?
        .iter()
        .find(|m| m.get("name").and_then(|n| n.as_str()) == Some(sync))?
        .get("cycle")?
        .as_u64()
}

/// A child process killed when dropped.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Ring cycles per second: `mcc status --json --watch` run as host a, the sync master's cycle
/// in a document one second in and in the first one `window` later, each stamped when it
/// arrived here (the documents take the same path each time, so their delay cancels out).
fn cycles_per_s(
    site: Site<'_>,
    cluster: &str,
    dir: &Path,
    sync: &str,
    window: Duration,
) -> Result<f64> {
    let mut cmd = site.mcc("a")?;
    cmd.args([
        "status",
        "--cluster",
        cluster,
        "--json",
        "--watch",
        WATCH_MS,
    ])
    .env("MCC_RUN_DIR", dir)
    .stdout(Stdio::piped())
    .stderr(Stdio::null());
    let mut child = Killed(cmd.spawn().context("starting mcc status --watch")?);
    let out = child
        .0
        .stdout
        .take()
        .ok_or_else(|| anyhow!("mcc status --watch: no stdout"))?;
    let (tx, rx) = mpsc::channel();
    let sync = sync.to_string();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(out).lines() {
            let Ok(line) = line else { break };
            let t = Instant::now();
            if let Some(c) = sync_cycle(&line, &sync) {
                if tx.send((t, c)).is_err() {
                    break;
                }
            }
        }
    });
    // Generous bounds: a status document is due every WATCH_MS.
    let wait = Duration::from_secs(30) + window;
    let next = || {
        rx.recv_timeout(wait)
            .map_err(|_| anyhow!("no status from mcc status --watch within {wait:?}"))
    };
    let (first, _) = next()?;
    let (t0, c0) = loop {
        let s = next()?;
        if s.0 >= first + Duration::from_secs(1) {
            break s;
        }
    };
    let (t1, c1) = loop {
        let s = next()?;
        if s.0 >= t0 + window {
            break s;
        }
    };
    drop(child);
    Ok(c1.saturating_sub(c0) as f64 / (t1 - t0).as_secs_f64())
}

/// The members' own hop figures (send stamp to receipt): median p50 and largest p99, µs.
/// Read over a zenoh session of this process, so on loopback only.
fn stamped(file: &Path, cluster: &str) -> Result<Option<(f64, f64)>> {
    let cfg = ClusterConfig::from_file(file)?;
    let session = crate::cluster::hosts::open(&cfg, Role::Client { host: "a" })?;
    crate::cluster::hosts::settle(&session, &cfg, 1, Duration::from_secs(3));
    let mut p50 = Vec::new();
    let mut p99: Option<f64> = None;
    for m in &cfg.ring.order {
        let hop = member_status(&session, cluster, m)
            .ok()
            .and_then(|s| s.extra.get("hop").cloned())
            .and_then(|h| Some((h.get("p50_us")?.as_f64()?, h.get("p99_us")?.as_f64()?)));
        if let Some((a, b)) = hop {
            p50.push(a);
            p99 = Some(p99.map_or(b, |x| x.max(b)));
        }
    }
    p50.sort_by(f64::total_cmp);
    let _ = zenoh::Wait::wait(session.close());
    Ok(p50.get(p50.len() / 2).copied().zip(p99))
}

/// Start both shares of a two-host ring at `site` linked by `path`, measure `window`, take
/// them down.
pub(super) fn measure(
    site: Site<'_>,
    path: &Path2,
    tag: &str,
    window: Duration,
) -> Result<Figures> {
    let cluster = format!("bench-hosts-{}-{tag}", std::process::id());
    let base = std::env::temp_dir().join(&cluster);
    let dirs = [base.join("machine-a"), base.join("machine-b")];
    for d in &dirs {
        std::fs::create_dir_all(d)?;
    }
    let file = base.join("lab.toml");
    let peers = [site.peer_endpoint(0)?, site.peer_endpoint(1)?];
    std::fs::write(
        &file,
        config_text(&cluster, path, peers, &site.security(&cluster)),
    )?;
    let shares = Shares {
        site,
        cluster: cluster.clone(),
        dirs: dirs.clone(),
    };
    let ups: Vec<_> = ["a", "b"]
        .iter()
        .zip(&dirs)
        .map(|(h, d)| -> Result<_> {
            let mut up = site.mcc(h)?;
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
    let sync = ClusterConfig::from_file(&file)?.ring.sync_master;
    let cycles_per_s = cycles_per_s(site, &cluster, &dirs[0], &sync, window)?;
    let stamped = match site {
        Site::Loopback => stamped(&file, &cluster)?,
        Site::Lab(_) => None,
    };
    drop(shares);
    Ok(Figures {
        cycles_per_s,
        stamped,
    })
}

/// Where zenohd in the lab's namespace `r` listens: its end of both links.
fn lab_router_listen() -> Vec<String> {
    [RA.left.2, RB.left.2]
        .iter()
        .map(|a| format!("{a}:{LAB_PORT}"))
        .collect()
}

/// The lab's two ways of linking the ring, each with the hosts' peer-to-peer endpoints.
#[cfg(test)]
pub(super) fn lab_paths() -> Vec<(Path2, [(String, u16); 2])> {
    let peers = [
        (AB.left.2.to_string(), LAB_PORT),
        (AB.right.2.to_string(), LAB_PORT),
    ];
    let routers = lab_router_listen()
        .iter()
        .map(|l| format!("tcp/{l}"))
        .collect();
    vec![
        (Path2::PeerToPeer, peers.clone()),
        (Path2::Router(routers), peers),
    ]
}

/// Start `zenohd` for the hosts of `site`: on a free loopback port, or in the lab's namespace
/// `r` listening on its two links. Returns once it listens, with the endpoints to connect to.
pub(super) fn start_router(zenohd: &Path, site: Site<'_>) -> Result<(Router, Vec<String>)> {
    let (mut cmd, listen, dir, config) = match site {
        Site::Loopback => (
            Command::new(zenohd),
            vec![format!("127.0.0.1:{}", free_port()?)],
            std::env::temp_dir().join(format!("mcc-bench-zenohd-{}", std::process::id())),
            format!("{{ mode: \"router\", transport: {{ {ROUTER_QUEUES} }} }}"),
        ),
        // The config holds the password: in the lab's private directory.
        Site::Lab(lab) => (
            lab.lab.command("r", zenohd),
            lab_router_listen(),
            lab.dir().join("zenohd"),
            lab.router_config(ROUTER_QUEUES),
        ),
    };
    std::fs::create_dir_all(&dir)?;
    let conf = dir.join("zenohd.json5");
    std::fs::write(&conf, config)?;
    cmd.arg("--no-multicast-scouting");
    for l in &listen {
        cmd.arg("-l").arg(format!("tcp/{l}"));
    }
    let child = cmd
        .arg("-c")
        .arg(&conf)
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .with_context(|| format!("starting {}", zenohd.display()))?;
    let mut router = Router(child, dir);
    // Up once it listens on every endpoint.
    let deadline = Instant::now() + Duration::from_secs(10);
    while !listening(site, &listen) {
        if let Some(st) = router.0.try_wait()? {
            bail!("{} exited ({st}) before it listened", zenohd.display());
        }
        if Instant::now() > deadline {
            bail!("{} did not listen on {listen:?}", zenohd.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok((router, listen.iter().map(|l| format!("tcp/{l}")).collect()))
}

/// Whether something listens on every `addr:port` of `listen` (in namespace `r` of a lab:
/// `ss -ltn` there, this process cannot reach it).
fn listening(site: Site<'_>, listen: &[String]) -> bool {
    match site {
        Site::Loopback => listen
            .iter()
            .all(|l| std::net::TcpStream::connect(l.as_str()).is_ok()),
        Site::Lab(lab) => lab
            .lab
            .command("r", "ss")
            .arg("-ltn")
            .stdin(Stdio::null())
            .stderr(Stdio::null())
            .output()
            .map(|o| {
                let text = String::from_utf8_lossy(&o.stdout);
                listen.iter().all(|l| text.contains(l.as_str()))
            })
            .unwrap_or(false),
    }
}

pub(super) fn row(label: &str, f: &Figures, members: usize, base: f64) {
    let stamped = f
        .stamped
        .map(|(a, b)| format!("{a:.1} / {b:.1}"))
        .unwrap_or_else(|| "-".into());
    println!(
        "    {:<32} {:>9.0} {:>12.1} {:>8.2} {:>17}",
        label,
        f.cycles_per_s,
        f.hop_us(members),
        f.hop_us(members) / base,
        stamped
    );
}

/// The column header of [`row`]; `base` names what the ratio column compares with.
pub(super) fn header(base: &str) {
    println!(
        "    {:<32} {:>9} {:>12} {:>8} {:>17}",
        "", "cycles/s", "hop µs", base, "stamped p50/p99"
    );
}

/// The ring through a zenohd at `site` (row `label`) and its hop cost against `p2p`
/// measured just before; a row saying SKIPPED, and why, without a zenohd.
pub(super) fn through_router(
    site: Site<'_>,
    zenohd: Option<&Path>,
    label: &str,
    window: Duration,
    (p2p, base): (&Figures, f64),
) -> Result<()> {
    let members = 4;
    let Some(z) = find_zenohd(zenohd) else {
        println!("    {label}: SKIPPED ({NO_ZENOHD})");
        return Ok(());
    };
    let (router, endpoints) = start_router(&z, site)?;
    let r = measure(site, &Path2::Router(endpoints), "router", window);
    drop(router);
    let r = r?;
    row(label, &r, members, base);
    println!(
        "    through the router vs peer to peer: hop {:.2}× ({:+.1} µs per hop)",
        r.hop_us(members) / p2p.hop_us(members),
        r.hop_us(members) - p2p.hop_us(members)
    );
    Ok(())
}

/// Section (d) of `mcc bench ring`.
pub fn run(window: Duration, zenohd: Option<&Path>) -> Result<()> {
    let members = 4;
    println!(
        "\n(d) across hosts: 2 cards + 2 stations, lockstep, card0/station0 on host a and card1/\
         station1 on host b (both shares on this machine, each its own run dir); {} s each",
        window.as_secs_f64()
    );
    header("× one");
    let spec = ClusterSpec {
        cards: 2,
        stations: 2,
        clock: Some("lockstep".into()),
        rate: None,
        in_flight: None,
    };
    let one = cluster::measure(&spec, "h0", Duration::from_secs(1), window)?;
    let one = Figures {
        cycles_per_s: one.cycles_per_s,
        stamped: one.hop_us(),
    };
    let base = one.hop_us(members);
    row("one machine (unix sockets)", &one, members, base);
    let p2p = measure(Site::Loopback, &Path2::PeerToPeer, "p2p", window)?;
    row("two hosts, peer to peer (TCP)", &p2p, members, base);
    through_router(
        Site::Loopback,
        zenohd,
        "two hosts through zenohd",
        window,
        (&p2p, base),
    )?;
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
        let loopback = [("127.0.0.1".into(), 7447), ("127.0.0.1".into(), 7448)];
        for path in [
            Path2::PeerToPeer,
            Path2::Router(vec!["tcp/127.0.0.1:7447".into()]),
        ] {
            let text = config_text("bench-x", &path, loopback.clone(), "");
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
        let doc = r#"{"members":[{"name":"card0","cycle":12},{"name":"card1","cycle":7}]}"#;
        assert_eq!(sync_cycle(doc, "card1"), Some(7));
        assert_eq!(sync_cycle(doc, "station0"), None);
        assert_eq!(sync_cycle("not json", "card0"), None);
    }
}
