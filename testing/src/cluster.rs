//! A cluster under test: built from a few options on top of `mcc`'s own default layout,
//! started with `mcc up --detach --json --owner-pid` in a private run directory, driven
//! through the CLI, and taken down when dropped (`mcc down`, then SIGKILL of any process it
//! had, then its directory removed).

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use serde_json::Value;
use toml::{Table, Value as Toml};

use crate::error::{Error, ErrorKind, Result};
use crate::procs::Tracked;
use crate::run::{documents, find_mcc, Runner, VERB_TIMEOUT};
use crate::status::{Status, StatusStream};

mod axis;
pub use axis::{AXIS_KINDS, AXIS_VALUE_KINDS};

/// Ring faults `mcc fault MEMBER KIND` injects on a member's send path.
pub const FAULT_KINDS: &[&str] = &[
    "drop-sync",
    "drop-packets",
    "corrupt",
    "byte-violation",
    "overrun",
    "underrun",
    "delay",
    "delay-us",
    "cut",
];
/// Process drills (`freeze` = SIGSTOP, `thaw`, `kill`, `restart`).
pub const DRILLS: &[&str] = &["freeze", "thaw", "kill", "restart"];

/// A card's hardware stop inputs `mcc fault CARD input KIND` (README "Card inputs").
pub const INPUT_KINDS: &[&str] = &["abort", "feed-hold"];

/// `mcc fault CARD input KIND [--cs N] [--cycles N]` arguments, every word checked first:
/// `cards` are the cluster's card members.
fn input_fault_args(
    cards: &[String],
    card: &str,
    kind: &str,
    cs: Option<u16>,
    cycles: Option<u64>,
) -> Result<Vec<String>> {
    if !cards.iter().any(|c| c == card) {
        return Err(Error::unknown("card", card, cards));
    }
    if !INPUT_KINDS.contains(&kind) {
        return Err(Error::unknown("card input", kind, INPUT_KINDS));
    }
    let mut args: Vec<String> = ["fault", card, "input", kind].map(String::from).to_vec();
    if let Some(n) = cs {
        args.extend(["--cs".into(), n.to_string()]);
    }
    if let Some(n) = cycles {
        args.extend(["--cycles".into(), n.to_string()]);
    }
    Ok(args)
}

/// Host-link fault kinds (`mcc fault CARD|chain|bus link KIND`; `bad-checksum` on the bus
/// only). Options: `cycles` (the next N replies), `probability` (per reply), `seed`,
/// `delay` (ms, `late` only).
pub const LINK_KINDS: &[&str] = &[
    "no-reply",
    "late",
    "short",
    "stray-cr",
    "stray-lf",
    "stray-bel",
    "stray-ctrl",
    "corrupt",
    "reset",
    "bad-checksum",
];

/// Options of a ring fault (`mcc fault --cycles/--probability/--seed/--delay`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FaultOptions {
    /// Apply for this many ring cycles (default: until cleared).
    pub cycles: Option<u64>,
    /// Probability per cycle/packet, 0–1.
    pub probability: Option<f64>,
    /// Random seed.
    pub seed: Option<u64>,
    /// Amount of `delay` (cycles) or `delay-us` (µs).
    pub delay: Option<u64>,
}

/// A cluster's layout and settings (see [`Cluster::builder`]).
#[derive(Debug, Clone)]
pub struct Builder {
    mcc: Option<PathBuf>,
    config: Option<String>,
    cards: u8,
    stations: u8,
    clock: Option<String>,
    rate_hz: Option<f64>,
    profiles: Vec<(Option<u8>, String)>,
    ivars: Vec<(Option<u8>, String, f64)>,
    plants: Vec<(Option<String>, Table)>,
    drives: Vec<Table>,
    extra: Table,
    tag: String,
    lock_timeout: Duration,
    env: Vec<(String, String)>,
    up_args: Vec<String>,
    owner: Option<u32>,
    run_dir: Option<PathBuf>,
}

static NAMES: AtomicU32 = AtomicU32::new(0);

/// A cluster name unique to this process: `rs<pid>-<tag>-<n>`.
pub(crate) fn unique_name(tag: &str) -> String {
    let n = NAMES.fetch_add(1, Ordering::Relaxed);
    format!("rs{}-{tag}-{n}", std::process::id())
}

impl Builder {
    /// The `mcc` binary (default: `$MCC_BIN`, next to the test executable, or on `PATH`).
    pub fn mcc(mut self, path: impl Into<PathBuf>) -> Self {
        self.mcc = Some(path.into());
        self
    }
    /// A whole config (TOML text) instead of the default layout; the options apply on top.
    pub fn config_toml(mut self, text: impl Into<String>) -> Self {
        self.config = Some(text.into());
        self
    }
    /// Cards in the default layout (default 2).
    pub fn cards(mut self, n: u8) -> Self {
        self.cards = n;
        self
    }
    /// Stations in the default layout (default 2).
    pub fn stations(mut self, n: u8) -> Self {
        self.stations = n;
        self
    }
    /// Clock mode (`paced`, `lockstep`, `realtime`).
    pub fn clock(mut self, mode: &str) -> Self {
        self.clock = Some(mode.to_string());
        self
    }
    /// Ring rate, Hz.
    pub fn rate_hz(mut self, hz: f64) -> Self {
        self.rate_hz = Some(hz);
        self
    }
    /// Profile of every card (`pmac2`, `turbo`).
    pub fn profile(mut self, profile: &str) -> Self {
        self.profiles.push((None, profile.to_string()));
        self
    }
    /// Profile of card `number`.
    pub fn card_profile(mut self, number: u8, profile: &str) -> Self {
        self.profiles.push((Some(number), profile.to_string()));
        self
    }
    /// A start-up I-variable on every card (`ivar("I130", 3000.0)`).
    pub fn ivar(mut self, name: &str, value: f64) -> Self {
        self.ivars.push((None, name.to_string(), value));
        self
    }
    /// A start-up I-variable on card `number`.
    pub fn card_ivar(mut self, number: u8, name: &str, value: f64) -> Self {
        self.ivars.push((Some(number), name.to_string(), value));
        self
    }
    /// Plant settings (`[stations.plant]` TOML) for every station, e.g.
    /// `"[nodes.0]\nhome_position = 12000"`. Panics on malformed TOML (a test's own text).
    pub fn plant(mut self, toml_text: &str) -> Self {
        self.plants.push((None, parse_table(toml_text)));
        self
    }
    /// Plant settings for station `name`.
    pub fn station_plant(mut self, name: &str, toml_text: &str) -> Self {
        self.plants
            .push((Some(name.to_string()), parse_table(toml_text)));
        self
    }
    /// A `[[drives]]` entry (EDB step drive), e.g. `"name = \"drive0\"\naddress = 1\nstation =
    /// \"station0\""`.
    pub fn drive(mut self, toml_text: &str) -> Self {
        self.drives.push(parse_table(toml_text));
        self
    }
    /// Another config key (e.g. `extra("rtf", 2.0.into())`), or a key of a table by its
    /// dotted path (`extra("ring.in_flight", 8.into())`; missing tables are created).
    pub fn extra(mut self, key: &str, value: Toml) -> Self {
        self.extra.insert(key.to_string(), value);
        self
    }
    /// A word in the cluster name (the name is unique per process anyway).
    pub fn tag(mut self, tag: &str) -> Self {
        self.tag = tag.to_string();
        self
    }
    /// How long the ring has to lock (default 120 s).
    pub fn lock_timeout(mut self, t: Duration) -> Self {
        self.lock_timeout = t;
        self
    }
    /// An environment variable for the cluster's processes.
    pub fn env(mut self, key: &str, value: &str) -> Self {
        self.env.push((key.to_string(), value.to_string()));
        self
    }
    /// The process the cluster lives with (`mcc up --owner-pid`; default: this process).
    pub fn owner(mut self, pid: u32) -> Self {
        self.owner = Some(pid);
        self
    }
    /// The `MCC_RUN_DIR` the cluster runs in (default: a private directory, removed at
    /// teardown). A directory given here is never removed: `mcc down` removes the cluster's
    /// own `<it>/<name>`, and a test can check that a refused start left nothing there.
    pub fn run_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.run_dir = Some(dir.into());
        self
    }
    /// An extra `mcc up` argument (e.g. `--pty`, `--chain-port`, `4001`).
    pub fn up_arg(mut self, arg: &str) -> Self {
        self.up_args.push(arg.to_string());
        self
    }

    /// The config the cluster will run.
    fn build_config(&self, runner: &Runner) -> Result<Table> {
        let text = match &self.config {
            Some(t) => t.clone(),
            None => runner.run(&[
                "up",
                "--print-config",
                "--cards",
                &self.cards.to_string(),
                "--stations",
                &self.stations.to_string(),
            ])?,
        };
        let mut doc: Table = text
            .parse()
            .map_err(|e| Error::new(ErrorKind::Config, format!("config: {e}")))?;
        if let Some(c) = &self.clock {
            doc.insert("clock".into(), Toml::String(c.clone()));
        }
        if let Some(r) = self.rate_hz {
            doc.insert("rate_hz".into(), Toml::Float(r));
        }
        let cards = table_array(&mut doc, "cards");
        let numbers: Vec<i64> = cards
            .iter()
            .filter_map(|c| c.get("number").and_then(Toml::as_integer))
            .collect();
        for (which, profile) in &self.profiles {
            for card in select(cards, *which, &numbers)? {
                card.insert("profile".into(), Toml::String(profile.clone()));
                // A Power card takes the config's I1001/I1004/I1005 as its ring check
                // (Macro.TestPeriod/TestMaxErrors/TestReqdSynchs); a Turbo card would refuse them.
                if profile == "turbo" {
                    strip_pmac2_ring_check(card);
                }
            }
        }
        for (which, name, value) in &self.ivars {
            for card in select(cards, *which, &numbers)? {
                let iv = card
                    .entry("ivars")
                    .or_insert_with(|| Toml::Table(Table::new()));
                if let Toml::Table(t) = iv {
                    t.retain(|k, _| !k.eq_ignore_ascii_case(name));
                    t.insert(name.clone(), number(*value));
                }
            }
        }
        let stations = table_array(&mut doc, "stations");
        let names: Vec<String> = stations
            .iter()
            .filter_map(|s| s.get("name").and_then(Toml::as_str).map(str::to_string))
            .collect();
        for (which, plant) in &self.plants {
            if let Some(w) = which.as_ref().filter(|w| !names.contains(w)) {
                return Err(Error::unknown("station", w, &names));
            }
            for st in stations.iter_mut().filter_map(Toml::as_table_mut) {
                let name = st.get("name").and_then(Toml::as_str).unwrap_or_default();
                if which.as_deref().is_none_or(|w| w == name) {
                    let t = st
                        .entry("plant")
                        .or_insert_with(|| Toml::Table(Table::new()));
                    if let Toml::Table(t) = t {
                        merge(t, plant);
                    }
                }
            }
        }
        if !self.drives.is_empty() {
            let drives = self.drives.iter().cloned().map(Toml::Table).collect();
            doc.insert("drives".into(), Toml::Array(drives));
        }
        for (k, v) in &self.extra {
            set_path(&mut doc, k, v.clone())?;
        }
        Ok(doc)
    }

    /// Start the cluster and wait until its ring is locked. A refused config is
    /// [`ErrorKind::Config`] with mcc's message; a ring that does not lock in time is
    /// [`ErrorKind::LockTimeout`] with the members' logs in [`Error::logs`]. Nothing is left
    /// running when it fails.
    pub fn start(self) -> Result<Cluster> {
        let mcc = match &self.mcc {
            Some(p) => p.clone(),
            None => find_mcc()?,
        };
        let name = unique_name(&self.tag);
        let dir = std::env::temp_dir().join(format!("mcc-{name}"));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir)
            .map_err(|e| Error::new(ErrorKind::Other, format!("{}: {e}", dir.display())))?;
        let runner = Runner {
            mcc,
            run_dir: self.run_dir.clone().unwrap_or_else(|| dir.join("run")),
            cluster: name.clone(),
            env: self.env.clone(),
        };
        let mut cluster = Cluster {
            name,
            dir,
            runner,
            tracked: Tracked::default(),
            stream: None,
            initial: Status(Value::Null),
            started: false,
        };
        let mut doc = self.build_config(&cluster.runner)?;
        doc.insert("cluster".into(), Toml::String(cluster.name.clone()));
        let path = cluster.dir.join("cluster.toml");
        std::fs::write(&path, doc.to_string())
            .map_err(|e| Error::new(ErrorKind::Other, format!("{}: {e}", path.display())))?;
        cluster.started = true;
        let secs = self.lock_timeout.as_secs().max(1).to_string();
        let pid = self.owner.unwrap_or_else(std::process::id).to_string();
        let path = path.display().to_string();
        let mut up = vec![
            "up",
            "--detach",
            "--json",
            "--config",
            &path,
            "--timeout",
            &secs,
            "--owner-pid",
            &pid,
        ];
        up.extend(self.up_args.iter().map(String::as_str));
        let st = cluster
            .runner
            .json(&up, self.lock_timeout + Duration::from_secs(90))?;
        cluster.initial = Status(st);
        let pids = cluster.initial.pids();
        for p in pids {
            cluster.tracked.add(p);
        }
        Ok(cluster)
    }
}

/// Set `path` (`key` or `table.key`) in `doc`; an error if a step of the path is a value that
/// is not a table.
fn set_path(doc: &mut Table, path: &str, value: Toml) -> Result<()> {
    let mut at = doc;
    let mut parts = path.split('.').peekable();
    while let Some(k) = parts.next() {
        if parts.peek().is_none() {
            at.insert(k.to_string(), value);
            return Ok(());
        }
        let next = at.entry(k).or_insert_with(|| Toml::Table(Table::new()));
        at = next.as_table_mut().ok_or_else(|| {
            Error::new(
                ErrorKind::Config,
                format!("config key {path:?}: {k:?} is not a table"),
            )
        })?;
    }
    Ok(())
}

fn parse_table(text: &str) -> Table {
    text.parse()
        .unwrap_or_else(|e| panic!("bad TOML in a test's cluster option: {e}\n{text}"))
}

fn number(v: f64) -> Toml {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        Toml::Integer(v as i64)
    } else {
        Toml::Float(v)
    }
}

fn table_array<'a>(doc: &'a mut Table, key: &str) -> &'a mut Vec<Toml> {
    let v = doc.entry(key).or_insert_with(|| Toml::Array(Vec::new()));
    if !v.is_array() {
        *v = Toml::Array(Vec::new());
    }
    match v {
        Toml::Array(a) => a,
        _ => unreachable!("just made an array"),
    }
}

fn select<'a>(
    cards: &'a mut [Toml],
    which: Option<u8>,
    numbers: &[i64],
) -> Result<Vec<&'a mut Table>> {
    if let Some(w) = which {
        if !numbers.contains(&i64::from(w)) {
            return Err(Error::unknown("card", w, numbers));
        }
    }
    Ok(cards
        .iter_mut()
        .filter_map(Toml::as_table_mut)
        .filter(|c| {
            which.is_none_or(|w| c.get("number").and_then(Toml::as_integer) == Some(i64::from(w)))
        })
        .collect())
}

/// The embedded default arms the PMAC2 ring check (I1001/I1004/I1005); a Turbo card refuses
/// those numbers, so a card switched to the Turbo profile starts without them (the config then
/// fills in its own I80/I81/I82; a Power card keeps them: they are its ring check, see
/// docs/power-pmac.md, "On the ring").
fn strip_pmac2_ring_check(card: &mut Table) {
    let default = [("I1001", 16), ("I1004", 2), ("I1005", 4)];
    if let Some(Toml::Table(iv)) = card.get_mut("ivars") {
        let is_default = iv.len() == default.len()
            && default
                .iter()
                .all(|(k, v)| iv.get(*k).and_then(Toml::as_integer) == Some(*v));
        if is_default {
            iv.clear();
        }
    }
}

fn merge(dst: &mut Table, src: &Table) {
    for (k, v) in src {
        match (dst.get_mut(k), v) {
            (Some(Toml::Table(d)), Toml::Table(s)) => merge(d, s),
            _ => {
                dst.insert(k.clone(), v.clone());
            }
        }
    }
}

/// One card's part of a synchronized start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CardStart {
    /// Card number.
    pub card: u8,
    /// Ring cycle it ran the line at.
    pub executed_cycle: Option<u64>,
    /// Its reply (control characters visible: `<ACK>`, `<BEL>`).
    pub reply: String,
    /// The line's refusal (`ERR003`, `error #20`), whether or not the reply shows it.
    pub refusal: Option<String>,
    /// Its program start cycle when the result was read.
    pub program_start_cycle: Option<u64>,
}

/// A synchronized start: every card ran the line in the tick of ring cycle `cycle`.
#[derive(Debug, Clone, PartialEq)]
pub struct SyncStart {
    /// The ring cycle.
    pub cycle: u64,
    /// Lead used, cycles.
    pub lead_cycles: u64,
    /// Attempts needed.
    pub attempts: u32,
    /// Per card.
    pub cards: Vec<CardStart>,
}

/// One card's recording (see [`Cluster::gather`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Card number.
    pub card: u8,
    /// Ring cycle of every sample.
    pub cycle: Vec<u64>,
    /// Commanded position per motor (in the order asked), counts.
    pub commanded: Vec<(u16, Vec<f64>)>,
    /// Actual position per motor, counts.
    pub actual: Vec<(u16, Vec<f64>)>,
}

impl Trace {
    /// Commanded positions of `motor`.
    pub fn commanded(&self, motor: u16) -> &[f64] {
        col(&self.commanded, motor)
    }
    /// Actual positions of `motor`.
    pub fn actual(&self, motor: u16) -> &[f64] {
        col(&self.actual, motor)
    }
    /// Ring cycle of the first sample where `motor`'s commanded position has left its first
    /// value by more than `threshold` counts.
    pub fn first_motion(&self, motor: u16, threshold: f64) -> Option<u64> {
        let c = self.commanded(motor);
        let start = *c.first()?;
        c.iter()
            .zip(&self.cycle)
            .find(|(v, _)| (**v - start).abs() > threshold)
            .map(|(_, k)| *k)
    }
}

fn col(cols: &[(u16, Vec<f64>)], motor: u16) -> &[f64] {
    cols.iter()
        .find(|(m, _)| *m == motor)
        .map(|(_, v)| v.as_slice())
        .unwrap_or_default()
}

/// A running cluster (see the crate documentation). Dropping it takes it down.
#[derive(Debug)]
pub struct Cluster {
    /// Cluster name (`--cluster`).
    pub name: String,
    dir: PathBuf,
    runner: Runner,
    tracked: Tracked,
    stream: Option<StatusStream>,
    initial: Status,
    started: bool,
}

impl Cluster {
    /// A builder for the default layout (2 cards, 2 stations, mcc's defaults).
    pub fn builder() -> Builder {
        Builder {
            mcc: None,
            config: None,
            cards: 2,
            stations: 2,
            clock: None,
            rate_hz: None,
            profiles: Vec::new(),
            ivars: Vec::new(),
            plants: Vec::new(),
            drives: Vec::new(),
            extra: Table::new(),
            tag: "t".into(),
            lock_timeout: Duration::from_secs(120),
            env: Vec::new(),
            up_args: Vec::new(),
            owner: None,
            run_dir: None,
        }
    }

    /// The status document `mcc up` printed once the ring locked.
    pub fn initial_status(&self) -> &Status {
        &self.initial
    }

    /// The `MCC_RUN_DIR` of this cluster (its run directory is `<it>/<name>`).
    pub fn run_base(&self) -> PathBuf {
        self.runner.run_dir.clone()
    }

    /// Member names in ring order.
    pub fn members(&self) -> Vec<String> {
        self.initial.member_names()
    }

    /// Card numbers in config order.
    pub fn card_numbers(&self) -> Vec<u8> {
        self.initial.0["cards"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|c| c["number"].as_u64().and_then(|n| u8::try_from(n).ok()))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// `mcc --cluster NAME args…` (bounded); its output, whatever the exit status.
    pub fn mcc(&self, args: &[&str]) -> std::process::Output {
        self.runner
            .output(args, VERB_TIMEOUT)
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// `mcc --cluster NAME args…` with `input` on its stdin (then closed), bounded.
    pub fn mcc_input(&self, args: &[&str], input: &[u8]) -> std::process::Output {
        crate::run::run_bounded(self.runner.command(args), Some(input), VERB_TIMEOUT)
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// `mcc status --json` now.
    pub fn status(&mut self) -> Result<Status> {
        let st = Status(self.runner.json(&["status", "--json"], VERB_TIMEOUT)?);
        for p in st.pids() {
            self.tracked.add(p);
        }
        Ok(st)
    }

    /// Host ports of card `number`: (ASCII terminal, PMAC Ethernet).
    pub fn ports(&mut self, number: u8) -> Result<(u16, u16)> {
        self.check_card(number)?;
        let row = self.status()?.card(number)?;
        let port = |k: &str| row[k].as_u64().and_then(|p| u16::try_from(p).ok());
        match (port("ascii"), port("pmac_eth")) {
            (Some(a), Some(e)) => Ok((a, e)),
            _ => Err(Error::new(
                ErrorKind::Other,
                format!("card {number} reports no ports"),
            )),
        }
    }

    /// The daisy chain's TCP address (`127.0.0.1:PORT`).
    pub fn daisy_chain(&self) -> Option<String> {
        self.initial.0["daisy_chain"].as_str().map(str::to_string)
    }

    fn check_card(&self, number: u8) -> Result<()> {
        let have = self.card_numbers();
        if have.contains(&number) {
            Ok(())
        } else {
            Err(Error::unknown("card", number, &have))
        }
    }

    fn check_member(&self, member: &str) -> Result<()> {
        let have = self.members();
        if have.iter().any(|m| m == member) {
            Ok(())
        } else {
            Err(Error::unknown("member", member, &have))
        }
    }

    /// Send lines on the daisy chain (`mcc send`), `@card` first if given; the reply text of
    /// each (no framing, no final line break). An error reply is [`ErrorKind::Card`].
    pub fn send(&self, lines: &[&str], card: Option<u8>) -> Result<Vec<String>> {
        if let Some(n) = card {
            self.check_card(n)?;
        }
        let n = card.map(|n| n.to_string());
        let mut args = vec!["send", "--json"];
        if let Some(n) = &n {
            args.extend(["--card", n.as_str()]);
        }
        args.push("--");
        args.extend_from_slice(lines);
        let doc = self.runner.json(&args, VERB_TIMEOUT)?;
        let mut out = Vec::new();
        for r in doc.as_array().cloned().unwrap_or_default() {
            let reply = r["reply"]
                .as_str()
                .unwrap_or_default()
                .trim_end_matches('\n');
            if let Some(code) = r["error"].as_str() {
                let line = r["line"].as_str().unwrap_or_default();
                return Err(Error::new(
                    ErrorKind::Card { code: code.into() },
                    format!("card refused {line:?}: {code}"),
                ));
            }
            out.push(reply.to_string());
        }
        Ok(out)
    }

    /// Run `line` on `cards` in the servo tick of the same ring cycle (`mcc start-sync`).
    pub fn start_sync(&self, line: &str, cards: &[u8]) -> Result<SyncStart> {
        for &n in cards {
            self.check_card(n)?;
        }
        let list: Vec<String> = cards.iter().map(u8::to_string).collect();
        let list = list.join(",");
        let args = ["start-sync", "--json", "--cards", &list, "--", line];
        let out = self.runner.output(&args, VERB_TIMEOUT)?;
        let docs = documents(&crate::run::text(&out.stdout));
        let Some(doc) = docs.into_iter().find(|d| d.get("cycle").is_some()) else {
            return Err(crate::run::error_from(&out));
        };
        let cards: Vec<CardStart> = doc["cards"]
            .as_array()
            .cloned()
            .unwrap_or_default()
            .iter()
            .map(|c| CardStart {
                card: c["card"]
                    .as_u64()
                    .and_then(|n| u8::try_from(n).ok())
                    .unwrap_or(0),
                executed_cycle: c["executed_cycle"].as_u64(),
                reply: c["reply"].as_str().unwrap_or_default().to_string(),
                refusal: c["refusal"].as_str().map(str::to_string),
                program_start_cycle: c["program_start_cycle"].as_u64(),
            })
            .collect();
        // The card's typed refusal (`ERR003`, `error #20`), whatever its reply shows.
        if let Some(bad) = cards.iter().find(|c| c.refusal.is_some()) {
            let code = bad.refusal.clone().unwrap_or_default();
            return Err(Error::new(
                ErrorKind::Card { code },
                format!("card {} refused {line:?}: {}", bad.card, bad.reply),
            ));
        }
        Ok(SyncStart {
            cycle: doc["cycle"].as_u64().unwrap_or(0),
            lead_cycles: doc["lead_cycles"].as_u64().unwrap_or(0),
            attempts: doc["attempts"]
                .as_u64()
                .and_then(|a| u32::try_from(a).ok())
                .unwrap_or(1),
            cards,
        })
    }

    /// Record commanded and actual positions of `motors` on `cards` for `cycles` servo cycles
    /// from one ring cycle (`mcc gather --json`); `run` runs in that same tick.
    pub fn gather(
        &self,
        motors: &[u16],
        cards: &[u8],
        cycles: u64,
        run: Option<&str>,
    ) -> Result<Vec<Trace>> {
        for &n in cards {
            self.check_card(n)?;
        }
        let c: Vec<String> = cards.iter().map(u8::to_string).collect();
        let m: Vec<String> = motors.iter().map(u16::to_string).collect();
        let (c, m, k) = (c.join(","), m.join(","), cycles.to_string());
        let mut args = vec![
            "gather", "--json", "--card", &c, "--motors", &m, "--cycles", &k,
        ];
        if let Some(r) = run {
            args.extend(["--run", r]);
        }
        let doc = self
            .runner
            .json(&args, VERB_TIMEOUT + Duration::from_millis(cycles * 10))?;
        let cols = |v: &Value| -> Vec<(u16, Vec<f64>)> {
            motors
                .iter()
                .map(|mm| {
                    let data = v[mm.to_string()]
                        .as_array()
                        .map(|a| a.iter().filter_map(Value::as_f64).collect())
                        .unwrap_or_default();
                    (*mm, data)
                })
                .collect()
        };
        Ok(doc["cards"]
            .as_array()
            .cloned()
            .unwrap_or_default()
            .iter()
            .map(|t| Trace {
                card: t["card"]
                    .as_u64()
                    .and_then(|n| u8::try_from(n).ok())
                    .unwrap_or(0),
                cycle: t["cycle"]
                    .as_array()
                    .map(|a| a.iter().filter_map(Value::as_u64).collect())
                    .unwrap_or_default(),
                commanded: cols(&t["commanded"]),
                actual: cols(&t["actual"]),
            })
            .collect())
    }

    /// Inject ring fault `kind` on `member` (or run a process drill: [`DRILLS`], with default
    /// options). Unknown members and kinds are refused at once with the valid choices.
    pub fn fault(&mut self, member: &str, kind: &str, opts: FaultOptions) -> Result<String> {
        self.check_member(member)?;
        let all: Vec<&str> = FAULT_KINDS.iter().chain(DRILLS).copied().collect();
        if !all.contains(&kind) {
            return Err(Error::unknown("fault kind", kind, &all));
        }
        if DRILLS.contains(&kind) && opts != FaultOptions::default() {
            return Err(Error::unknown("option of drill", kind, &[] as &[&str]));
        }
        let mut owned = Vec::new();
        if let Some(c) = opts.cycles {
            owned.push(("--cycles", c.to_string()));
        }
        if let Some(p) = opts.probability {
            owned.push(("--probability", p.to_string()));
        }
        if let Some(s) = opts.seed {
            owned.push(("--seed", s.to_string()));
        }
        if let Some(d) = opts.delay {
            owned.push(("--delay", d.to_string()));
        }
        let mut args = vec!["fault", member, kind];
        for (k, v) in &owned {
            args.extend([*k, v.as_str()]);
        }
        let out = self.runner.run(&args)?;
        if kind == "restart" {
            let _ = self.status();
        }
        Ok(out.trim().to_string())
    }

    /// Hold card `card`'s stop input `kind` ([`INPUT_KINDS`]) active (`mcc fault CARD input
    /// KIND`): on PMAC2/Turbo for the C.S. `cs` the FPD lines select (default 1), until
    /// [`Cluster::clear`] or for `cycles` ring cycles. Unknown cards and kinds are refused at
    /// once with the valid choices.
    pub fn input_fault(
        &self,
        card: &str,
        kind: &str,
        cs: Option<u16>,
        cycles: Option<u64>,
    ) -> Result<String> {
        let cards: Vec<String> = self.initial.0["cards"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|c| c["name"].as_str().map(str::to_string))
            .collect();
        let args = input_fault_args(&cards, card, kind, cs, cycles)?;
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        Ok(self.runner.run(&args)?.trim().to_string())
    }

    /// Inject host-link fault `kind` ([`LINK_KINDS`]) on `target`: a card (all its host
    /// ports), `chain` or `bus` (`mcc fault TARGET link KIND`). Unknown targets and kinds,
    /// and `bad-checksum` off the bus, are refused at once with the valid choices.
    pub fn link_fault(&self, target: &str, kind: &str, opts: FaultOptions) -> Result<String> {
        let mut targets: Vec<String> = self.initial.0["cards"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|c| c["name"].as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        targets.extend(["chain".to_string(), "bus".to_string()]);
        if !targets.iter().any(|t| t == target) {
            return Err(Error::unknown("link target", target, &targets));
        }
        if !LINK_KINDS.contains(&kind) {
            return Err(Error::unknown("link fault kind", kind, LINK_KINDS));
        }
        if kind == "bad-checksum" && target != "bus" {
            let here: Vec<&str> = LINK_KINDS
                .iter()
                .copied()
                .filter(|k| *k != "bad-checksum")
                .collect();
            return Err(Error::unknown(
                &format!("link fault kind on {target} (bad-checksum: the EMCL bus only)"),
                kind,
                &here,
            ));
        }
        let mut args: Vec<String> = ["fault", target, "link", kind].map(str::to_string).to_vec();
        for (k, v) in [
            ("--cycles", opts.cycles.map(|c| c.to_string())),
            ("--probability", opts.probability.map(|p| p.to_string())),
            ("--seed", opts.seed.map(|s| s.to_string())),
            ("--delay", opts.delay.map(|d| d.to_string())),
        ] {
            if let Some(v) = v {
                args.extend([k.to_string(), v]);
            }
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        Ok(self.runner.run(&args)?.trim().to_string())
    }

    /// Remove injected faults (`mcc fault clear [MEMBER]`).
    pub fn clear(&self, member: Option<&str>) -> Result<String> {
        let mut args = vec!["fault", "clear"];
        if let Some(m) = member {
            self.check_member(m)?;
            args.push(m);
        }
        Ok(self.runner.run(&args)?.trim().to_string())
    }

    /// Recover from a ring fault as a PMAC user does: once every member is alive and locked,
    /// `$$$` on every card, then the members' ring-fault latches (`mcc fault reset`) until the
    /// ring is healthy and no card reports its ring-fault bit. A card whose bit stays set (its
    /// `$$$` was lost to a slow chain, or the bit latched again while the ring came back) gets
    /// its `$$$` again, at most once a second. The healthy status.
    pub fn reset(&mut self, timeout: Duration) -> Result<Status> {
        let members = self.members();
        self.wait_until(None, timeout, |st| {
            members.iter().all(|m| {
                st.member(m)
                    .is_ok_and(|r| r["alive"] == true && r["locked"] == true)
            })
        })?;
        let cards = self.card_numbers();
        let runner = self.runner.clone();
        let clear_card = move |n: u8| {
            let _ = runner.output(&["send", "--card", &n.to_string(), "$$$"], VERB_TIMEOUT);
        };
        for &n in &cards {
            clear_card(n);
        }
        let mut sent: HashMap<u8, Instant> = cards.iter().map(|&n| (n, Instant::now())).collect();
        let runner = self.runner.clone();
        self.wait_until(None, timeout, move |st| {
            let ring_ok = st.locked() && !st.faulted();
            if !ring_ok {
                let _ = runner.output(&["fault", "reset"], VERB_TIMEOUT);
            }
            let latched = st.ring_faulted_cards();
            for &n in &latched {
                let due = sent
                    .get(&n)
                    .is_none_or(|t| t.elapsed() >= Duration::from_secs(1));
                if ring_ok && due {
                    clear_card(n);
                    sent.insert(n, Instant::now());
                }
            }
            // A card whose bit is unknown (its `info` query went unanswered) is not healthy yet.
            let known = cards
                .iter()
                .all(|&n| st.card(n).is_ok_and(|c| c["ring_fault"] == false));
            ring_ok && latched.is_empty() && known
        })
    }

    fn stream(&mut self) -> Result<&mut StatusStream> {
        let dead = self.stream.as_mut().is_none_or(|s| !s.alive());
        if dead {
            let cmd = self.runner.command(&["status", "--json", "--watch", "50"]);
            self.stream = Some(StatusStream::start(cmd)?);
        }
        self.stream
            .as_mut()
            .ok_or_else(|| Error::new(ErrorKind::Other, "no status stream"))
    }

    /// Wait until `pred` holds on a status document. Gives up ([`ErrorKind::WaitTimeout`])
    /// once the ring has run `cycles` cycles with it false, or after `timeout` of wall time
    /// (a generous bound for a ring that stopped). Returns the status it held on.
    pub fn wait_until(
        &mut self,
        cycles: Option<u64>,
        timeout: Duration,
        mut pred: impl FnMut(&Status) -> bool,
    ) -> Result<Status> {
        let deadline = Instant::now() + timeout;
        let mut st = self.stream()?.next(timeout)?;
        let start = st.cycle();
        loop {
            for p in st.pids() {
                self.tracked.add(p);
            }
            if pred(&st) {
                return Ok(st);
            }
            if cycles.is_some_and(|n| st.cycle() >= start + n) {
                let mut e = Error::new(
                    ErrorKind::WaitTimeout,
                    format!(
                        "the condition did not hold within {} ring cycles (from cycle {start} to {})",
                        cycles.unwrap_or(0),
                        st.cycle()
                    ),
                );
                e.logs.insert("status".into(), st.0.to_string());
                return Err(e);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            let next = if left.is_zero() {
                None
            } else {
                match self.stream()?.next(left) {
                    Ok(s) => Some(s),
                    Err(e) if e.kind == ErrorKind::WaitTimeout => None,
                    Err(e) => return Err(e),
                }
            };
            match next {
                Some(s) => st = s,
                None => {
                    let mut e = Error::new(
                        ErrorKind::WaitTimeout,
                        format!(
                            "the condition did not hold within {timeout:?} (ring cycle {start} to {})",
                            st.cycle()
                        ),
                    );
                    e.logs.insert("status".into(), st.0.to_string());
                    return Err(e);
                }
            }
        }
    }

    /// Let the ring run `cycles` more cycles.
    pub fn wait_cycles(&mut self, cycles: u64, timeout: Duration) -> Result<Status> {
        let target = self.stream()?.next(timeout)?.cycle() + cycles;
        self.wait_until(None, timeout, |st| st.cycle() >= target)
    }

    /// The last `lines` lines of every log (`supervisor` and members).
    pub fn logs(&self, lines: usize) -> Vec<(String, String)> {
        let dir = self.runner.run_dir.join(&self.name).join("logs");
        std::iter::once("supervisor".to_string())
            .chain(self.members())
            .map(|who| {
                let text =
                    std::fs::read_to_string(dir.join(format!("{who}.log"))).unwrap_or_default();
                let all: Vec<&str> = text.lines().collect();
                let tail = all[all.len().saturating_sub(lines)..].join("\n");
                (who, tail)
            })
            .collect()
    }

    /// Take the cluster down now (also done on drop); the pids that had to be killed.
    pub fn stop(&mut self) -> Vec<u32> {
        if let Some(mut s) = self.stream.take() {
            s.stop();
        }
        let mut killed = Vec::new();
        if std::mem::take(&mut self.started) {
            let _ = self
                .runner
                .output(&["down", "--timeout", "5"], Duration::from_secs(60));
            killed = self.tracked.kill_all(Duration::from_secs(5));
        }
        let _ = std::fs::remove_dir_all(&self.dir);
        killed
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Never panics (a test may be unwinding): errors are ignored.
        self.stop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = r#"
cluster = "mcc"
clock = "realtime"
[[cards]]
name = "card0"
number = 0
master = 0
profile = "pmac2"
ivars = { I1001 = 16, I1004 = 2, I1005 = 4 }
[[cards]]
name = "card1"
number = 1
master = 1
ivars = { I1001 = 16, I1004 = 2, I1005 = 4 }
[[stations]]
name = "station0"
master = 0
"#;

    fn runner() -> Runner {
        Runner {
            mcc: PathBuf::from("/nonexistent/mcc"),
            run_dir: PathBuf::from("/nonexistent"),
            cluster: "x".into(),
            env: Vec::new(),
        }
    }

    #[test]
    fn options_edit_the_config() {
        let doc = Cluster::builder()
            .config_toml(BASE)
            .clock("lockstep")
            .card_profile(0, "turbo")
            .ivar("i1001", 8.0)
            .card_ivar(1, "I130", 2500.5)
            .plant("coulomb = 0.0\n[nodes.1]\ninertia = 2e-5")
            .station_plant("station0", "[nodes.1]\nhome_position = 9000")
            .drive("name = \"drive0\"\naddress = 1\nstation = \"station0\"")
            .extra("rtf", Toml::Float(2.0))
            .extra("ring.in_flight", Toml::Integer(8))
            .build_config(&runner())
            .unwrap();
        assert_eq!(doc["clock"].as_str(), Some("lockstep"));
        assert_eq!(doc["rtf"].as_float(), Some(2.0));
        assert_eq!(doc["ring"]["in_flight"].as_integer(), Some(8));
        let cards = doc["cards"].as_array().unwrap();
        // The Turbo card drops the PMAC2 ring-check defaults; the caller's spelling replaces
        // the default's.
        assert_eq!(cards[0]["profile"].as_str(), Some("turbo"));
        assert_eq!(cards[0]["ivars"].to_string(), "{ i1001 = 8 }");
        let iv1 = cards[1]["ivars"].as_table().unwrap();
        assert_eq!(iv1.get("i1001").and_then(Toml::as_integer), Some(8));
        assert!(iv1.get("I1001").is_none());
        assert_eq!(iv1.get("I130").and_then(Toml::as_float), Some(2500.5));
        let plant = doc["stations"][0]["plant"].as_table().unwrap();
        assert_eq!(plant["coulomb"].as_float(), Some(0.0));
        assert_eq!(plant["nodes"]["1"]["inertia"].as_float(), Some(2e-5));
        assert_eq!(
            plant["nodes"]["1"]["home_position"].as_integer(),
            Some(9000)
        );
        assert_eq!(doc["drives"][0]["address"].as_integer(), Some(1));
    }

    #[test]
    fn a_power_card_keeps_the_ring_check() {
        // The ring check is what makes a Power sync master latch its own ring fault.
        let doc = Cluster::builder()
            .config_toml(BASE)
            .card_profile(1, "power")
            .build_config(&runner())
            .unwrap();
        let cards = doc["cards"].as_array().unwrap();
        assert_eq!(cards[1]["profile"].as_str(), Some("power"));
        assert_eq!(
            cards[1]["ivars"].to_string(),
            "{ I1001 = 16, I1004 = 2, I1005 = 4 }"
        );
    }

    #[test]
    fn input_faults_check_every_word_and_name_the_choices() {
        let cards = ["card0".to_string(), "card1".to_string()];
        assert_eq!(
            input_fault_args(&cards, "card1", "abort", Some(2), Some(50)).unwrap(),
            ["fault", "card1", "input", "abort", "--cs", "2", "--cycles", "50"]
        );
        let e = input_fault_args(&cards, "card0", "estop", None, None).unwrap_err();
        assert!(
            e.to_string().contains("estop") && e.to_string().contains("feed-hold"),
            "{e}"
        );
        let e = input_fault_args(&cards, "station0", "abort", None, None).unwrap_err();
        assert!(e.to_string().contains("card0, card1"), "{e}");
    }

    #[test]
    fn unknown_cards_and_stations_name_the_choices() {
        let e = Cluster::builder()
            .config_toml(BASE)
            .card_profile(5, "turbo")
            .build_config(&runner())
            .unwrap_err();
        assert_eq!(
            e.kind,
            ErrorKind::UnknownChoice {
                choices: vec!["0".into(), "1".into()]
            }
        );
        let e = Cluster::builder()
            .config_toml(BASE)
            .station_plant("station9", "coulomb = 0.0")
            .build_config(&runner())
            .unwrap_err();
        assert!(
            e.message.contains("station9") && e.message.contains("station0"),
            "{e}"
        );
        let e = Cluster::builder()
            .config_toml(BASE)
            .extra("cluster.name", Toml::Integer(1))
            .build_config(&runner())
            .unwrap_err();
        assert_eq!(e.kind, ErrorKind::Config);
        assert!(e.message.contains("\"cluster\" is not a table"), "{e}");
        let e = Cluster::builder()
            .config_toml("cards = [")
            .build_config(&runner())
            .unwrap_err();
        assert_eq!(e.kind, ErrorKind::Config);
    }
}
