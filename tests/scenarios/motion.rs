//! In-process motion scenarios (issue 4 items 2, 3, 4, 7, 8, 9): the default cluster's card 0
//! and station 0 on a deterministic lockstep `RingSim`, wired exactly as the processes are
//! (config ring settings, `wire_macro_motors`, the config's card I-variables). Commands go in
//! through `Card::command_line`; commands and feedback travel over the ring only.

use mcc_card::{decode_fixed, Card, CardRingApp, Profile, Session};
use mcc_contracts::config::ClusterConfig;
use mcc_ring::core::{RingApp, RingControl};
use mcc_ring::fault::{FaultKind, FaultSpec};
use mcc_ring::member::RingMember;
use mcc_ring::sim::RingSim;
use mcc_station::config::{NodePlantConfig, PlantConfig};
use mcc_station::station_app::StationApp;

/// Servo cycle of the default I10, ms.
const DT: f64 = 3_713_707.0 / 8_388_608.0;
/// 1/(Ix08·32) counts per count at the default Ix08 = 96.
const D_UNITS: f64 = 3072.0;

pub(crate) enum App {
    Card(Box<CardRingApp>),
    Station(Box<StationApp>),
}

impl RingApp for App {
    fn tick(&mut self, cycle: u64, time_ns: u64, regs: &mut RingMember, ring_fault: bool) {
        match self {
            App::Card(a) => a.tick(cycle, time_ns, regs, ring_fault),
            App::Station(a) => a.tick(cycle, time_ns, regs, ring_fault),
        }
    }
    fn take_ring_reset(&mut self) -> bool {
        match self {
            App::Card(a) => a.take_ring_reset(),
            App::Station(a) => a.take_ring_reset(),
        }
    }
    fn sync_ring(&mut self, ring: &mut RingControl<'_>) {
        match self {
            App::Card(a) => a.sync_ring(ring),
            App::Station(a) => a.sync_ring(ring),
        }
    }
}

pub(crate) struct Rig {
    pub(crate) sim: RingSim<App>,
    session: Session,
}

impl Rig {
    /// Card 0 (sync master) + station 0 with all 8 servo nodes, `plant` on every node.
    pub(crate) fn new(plant: NodePlantConfig) -> Rig {
        Rig::with_card(plant, ClusterConfig::default_cluster(1, 1), Profile::Pmac2)
    }

    /// As [`Rig::new`] with the card of `profile` and the cluster `cfg` (one card, one
    /// station).
    pub(crate) fn with_card(plant: NodePlantConfig, cfg: ClusterConfig, profile: Profile) -> Rig {
        let sim = mcc_tests::inproc::ring(
            &cfg,
            Card::new(profile),
            |sc| {
                let pc = PlantConfig {
                    defaults: plant.clone(),
                    ..PlantConfig::default()
                };
                App::Station(Box::new(StationApp::new(&sc.nodes, &[], &pc).unwrap()))
            },
            |c| App::Card(Box::new(c)),
        );
        Rig {
            sim,
            session: Session::default(),
        }
    }

    /// The card (its ring app owns it; the test drives it between ring cycles).
    pub(crate) fn card(&mut self) -> &mut Card {
        match self.sim.app_mut(0) {
            App::Card(a) => &mut a.core().card,
            App::Station(_) => panic!("member 0 is the card"),
        }
    }

    pub(crate) fn cmd(&mut self, line: &str) -> String {
        let mut s = self.session.clone();
        let r = mcc_tests::inproc::command(self.card(), &mut s, line);
        self.session = s;
        r
    }

    /// Run one line in Power syntax on a Power card (its gpascii dialect, as a gpascii
    /// thread would): the reply without framing characters.
    pub(crate) fn power(&mut self, line: &str) -> String {
        let App::Card(a) = self.sim.app_mut(0) else {
            panic!("member 0 is the card")
        };
        let core = a.core();
        let r = core
            .dialect
            .script_line(&mut core.card, 7, line.as_bytes())
            .expect("a Power card");
        String::from_utf8_lossy(&r)
            .trim_matches(|c: char| c.is_control() || c.is_whitespace())
            .to_string()
    }

    /// The value a Power card answers for one element (`Motor[1].Status[0]=$…`).
    pub(crate) fn power_value(&mut self, elem: &str) -> u64 {
        let r = self.power(elem);
        let v = r.rsplit('=').next().unwrap_or_default();
        let v = match v.strip_prefix('$') {
            Some(h) => u64::from_str_radix(h, 16),
            None => v.parse(),
        };
        v.unwrap_or_else(|_| panic!("{elem}: not a number: {r:?}"))
    }

    pub(crate) fn num(&mut self, line: &str) -> f64 {
        let r = self.cmd(line);
        r.parse()
            .unwrap_or_else(|_| panic!("{line}: not a number: {r:?}"))
    }

    fn step(&mut self) {
        assert!(self.sim.step().completed || self.sim.cycle() > 0);
    }

    pub(crate) fn run(&mut self, n: usize) {
        for _ in 0..n {
            self.sim.step();
        }
    }

    /// Motor x's D: register at calculation-block offset `off` (D:$0028 commanded, $002B
    /// actual, $004B following error), counts.
    pub(crate) fn d_reg(&mut self, x: u16, off: u16) -> f64 {
        let c = self.card();
        decode_fixed(c.state.read_long(u32::from(0x0020 + (x - 1) * 0x3C + off))) / D_UNITS
    }

    pub(crate) fn station(&mut self) -> &mut StationApp {
        match self.sim.app_mut(1) {
            App::Station(s) => s,
            App::Card(_) => panic!("member 1 is the station"),
        }
    }

    pub(crate) fn node_position(&mut self, node: u8) -> f64 {
        self.station().node(node).unwrap().snapshot().position
    }

    /// `?` of motor x as (word 1, word 2).
    pub(crate) fn status(&mut self, x: u16) -> (u32, u32) {
        let r = self.cmd(&format!("#{x}?"));
        let w1 = u32::from_str_radix(&r[..6], 16).unwrap();
        let w2 = u32::from_str_radix(&r[6..12], 16).unwrap();
        (w1, w2)
    }
}

/// Exact S-curve / trapezoid position model of spec §5.2 for a move of `dist` counts from
/// rest that reaches speed `v` (counts/ms), with acceleration time `ta` = max(Ix20, 2·Ix21)
/// and S-curve time `ts` = Ix21: segments of constant jerk integrated in closed form.
struct Profile5_2 {
    segs: Vec<(f64, f64, f64)>, // (duration ms, start acceleration, jerk)
}

impl Profile5_2 {
    fn new(dist: f64, v: f64, ta: f64, ts: f64) -> Self {
        let a = v / (ta - ts);
        let cruise = (dist - v * ta) / v;
        assert!(cruise >= 0.0, "model covers moves that reach speed");
        let mut segs = Vec::new();
        let half = |sign: f64, segs: &mut Vec<(f64, f64, f64)>| {
            if ts > 0.0 {
                let j = a / ts;
                segs.push((ts, 0.0, sign * j));
                segs.push((ta - 2.0 * ts, sign * a, 0.0));
                segs.push((ts, sign * a, -sign * j));
            } else {
                segs.push((ta, sign * a, 0.0));
            }
        };
        half(1.0, &mut segs);
        segs.push((cruise, 0.0, 0.0));
        half(-1.0, &mut segs);
        Profile5_2 { segs }
    }

    fn total(&self) -> f64 {
        self.segs.iter().map(|s| s.0).sum()
    }

    fn position(&self, t: f64) -> f64 {
        let (mut p, mut v, mut left) = (0.0, 0.0, t.max(0.0));
        for &(d, a0, j) in &self.segs {
            let h = left.min(d);
            p += v * h + a0 * h * h / 2.0 + j * h * h * h / 6.0;
            v += a0 * h + j * h * h / 2.0;
            left -= h;
            if left <= 0.0 {
                break;
            }
        }
        p
    }
}

/// Jog `#1J=dist` with Ix19-Ix22 and check every servo cycle's commanded position against
/// the model (I12 = 10 ms planning delay, starting at the tick that takes the command).
fn jog_follows_model(ix19: f64, ix20: f64, ix21: f64, ix22: f64, dist: f64) -> f64 {
    let mut rig = Rig::new(NodePlantConfig::default());
    rig.cmd("I3=2");
    rig.cmd(&format!("I119={ix19} I120={ix20} I121={ix21} I122={ix22}"));
    rig.run(20);
    rig.cmd(&format!("#1J={dist}"));
    let ta = ix20.max(2.0 * ix21);
    let model = Profile5_2::new(dist, ix22, ta, ix21);
    let cycles = ((model.total() + 10.0) / DT).ceil() as usize + 400;
    let mut worst: f64 = 0.0;
    for j in 0..cycles {
        rig.step();
        let want = model.position((j as f64 + 1.0) * DT - 10.0);
        let got = rig.d_reg(1, 0x08);
        assert!(
            (got - want).abs() <= 1.0,
            "cycle {j}: commanded {got}, model {want}"
        );
        worst = worst.max((got - want).abs());
    }
    // The motor got there through the station plant.
    let p = rig.num("#1P");
    assert!((p - dist).abs() <= 10.0, "P = {p}");
    assert!((rig.node_position(0) - p).abs() < 1.0);
    worst
}

#[test]
fn jog_s_curve_follows_spec_profile_and_arrives() {
    let worst = jog_follows_model(1.0, 100.0, 25.0, 32.0, 10_000.0);
    assert!(worst <= 1.0);
}

#[test]
fn jog_trapezoid_follows_spec_profile_and_arrives() {
    jog_follows_model(1.0, 100.0, 0.0, 20.0, 10_000.0);
    jog_follows_model(1.0, 60.0, 30.0, 10.0, 5_000.0);
}

/// Following-error bound with default gains and the default plant during the standard
/// 10,000-count jog (`#1J=10000` with the factory Ix19-Ix22): |FE| < 6 counts (measured 4.95).
pub const FE_BOUND: f64 = 6.0;

#[test]
fn default_jog_following_error_bound_and_reports() {
    let mut rig = Rig::new(NodePlantConfig::default());
    rig.cmd("I3=2");
    rig.run(20);
    rig.cmd("#1J=10000");
    let mut max_fe: f64 = 0.0;
    let mut saw_moving = false;
    for _ in 0..8000 {
        rig.step();
        max_fe = max_fe.max(rig.d_reg(1, 0x2B).abs());
        let (w1, _) = rig.status(1);
        saw_moving |= w1 & (1 << 17) != 0 && w1 & (1 << 13) == 0;
    }
    eprintln!("standard jog: max |FE| = {max_fe:.3} counts");
    assert!(max_fe < FE_BOUND, "max FE {max_fe}");
    assert!(max_fe > 0.1, "the plant lags a little");
    assert!(
        saw_moving,
        "move timer set, desired velocity not zero while moving"
    );
    let p = rig.num("#1P");
    assert!((p - 10_000.0).abs() < 10.0, "P {p}");
    assert_eq!(rig.num("#1V"), 0.0);
    assert!(rig.num("#1F").abs() < 10.0);
    // Activated, closed loop, integration mode, desired velocity zero; amp enabled, in position.
    assert_eq!(rig.status(1), (0x81_2000, 0x00_4001));
    // CTRL-P lists all 8 motors; motors 2-8 hold 0.
    let mut s = Session::default();
    let r = rig.card().control_char(&mut s, 0x10);
    let text = String::from_utf8_lossy(&r).trim().to_string();
    let vals: Vec<&str> = text.split(' ').collect();
    assert_eq!(vals.len(), 8);
    assert!((vals[0].parse::<f64>().unwrap() - p).abs() < 0.2);
    assert_eq!(&vals[1..], ["0"; 7]);
}

/// Word-1 / word-2 bits used below.
const W1_NEG_LIMIT: u32 = 1 << 22;
const W1_POS_LIMIT: u32 = 1 << 21;
const W1_OPEN_LOOP: u32 = 1 << 18;
const W2_AMP_ENABLED: u32 = 1 << 14;
const W2_STOPPED_ON_LIMIT: u32 = 1 << 11;
const W2_AMP_FAULT: u32 = 1 << 3;
const W2_FATAL_FE: u32 = 1 << 2;

/// Every motor is killed: loop open, amplifier off on the card and at the station.
fn assert_all_killed(rig: &mut Rig) {
    for x in 1..=8u16 {
        let (w1, w2) = rig.status(x);
        assert_ne!(w1 & W1_OPEN_LOOP, 0, "motor {x} open loop");
        assert_eq!(w2 & W2_AMP_ENABLED, 0, "motor {x} amp off");
    }
    for n in [0u8, 1, 4, 5, 8, 9, 12, 13] {
        assert!(
            !rig.station().node(n).unwrap().snapshot().flags.amp_enabled,
            "station node {n} amplifier off"
        );
    }
}

/// Nothing moves for `n` cycles: positions settle and stay.
fn assert_still(rig: &mut Rig, n: usize) {
    rig.run(200);
    let before: Vec<f64> = [0u8, 1].iter().map(|&k| rig.node_position(k)).collect();
    rig.run(n);
    let after: Vec<f64> = [0u8, 1].iter().map(|&k| rig.node_position(k)).collect();
    for (b, a) in before.iter().zip(&after) {
        assert!((a - b).abs() < 0.5, "moved from {b} to {a}");
    }
}

#[test]
fn fatal_following_error_kills_the_card_motors() {
    let mut rig = Rig::new(NodePlantConfig::default());
    rig.cmd("I3=2 I111=32");
    rig.run(20);
    rig.cmd("#2J/");
    rig.cmd("#1J=10000");
    rig.run(1500);
    let (w1, w2) = rig.status(1);
    assert_ne!(w2 & W2_FATAL_FE, 0, "fatal FE bit");
    assert_ne!(w1 & W1_OPEN_LOOP, 0);
    // Ix25 bits 21-22 = 0: every motor of the card is killed, motor 2 too.
    assert_all_killed(&mut rig);
    assert_eq!(rig.num("#1F"), 0.0, "no FE while open loop");
    assert_still(&mut rig, 500);
    // Commanded again: the loop closes where the motor stands and the trip bit clears.
    rig.cmd("#1J/");
    rig.run(5);
    let (w1, w2) = rig.status(1);
    assert_eq!(w1 & W1_OPEN_LOOP, 0);
    assert_eq!(w2 & W2_FATAL_FE, 0);
}

#[test]
fn hard_limit_stops_the_motor_and_blocks_that_direction() {
    let plant = NodePlantConfig {
        plus_limit: 3_000.0,
        ..NodePlantConfig::default()
    };
    let mut rig = Rig::new(plant);
    rig.cmd("I3=2 I122=16");
    rig.run(20);
    rig.cmd("#1J=10000");
    rig.run(4000);
    let (w1, w2) = rig.status(1);
    assert_ne!(w1 & W1_POS_LIMIT, 0, "+limit bit");
    assert_eq!(w1 & W1_NEG_LIMIT, 0);
    assert_ne!(w2 & W2_STOPPED_ON_LIMIT, 0, "stopped on limit");
    assert_eq!(
        w1 & W1_OPEN_LOOP,
        0,
        "limits decelerate, the loop stays closed"
    );
    let p = rig.num("#1P");
    // Switch at 3000; decelerating from 16 counts/ms at Ix15 = 0.25 counts/ms² takes 512
    // counts, plus the flag's few cycles of ring and copy latency.
    assert!(p > 3_000.0 && p < 3_000.0 + 512.0 + 100.0, "stopped at {p}");
    assert_still(&mut rig, 300);
    // J+ stays blocked; J- moves away.
    rig.cmd("#1J+");
    rig.run(300);
    assert!((rig.num("#1P") - p).abs() < 2.0);
    // J: is relative to the commanded position (where the Ix15 stop ended).
    let c = rig.d_reg(1, 0x08);
    rig.cmd("#1J:-1000");
    rig.run(3000);
    let q = rig.num("#1P");
    assert!(
        (q - (c - 1000.0)).abs() < 10.0,
        "{c} -> {q} {:?}",
        rig.status(1)
    );
    assert_eq!(rig.status(1).0 & W1_POS_LIMIT, 0);
}

#[test]
fn amp_fault_kills_and_sets_the_bit() {
    let mut rig = Rig::new(NodePlantConfig::default());
    rig.cmd("I3=2");
    rig.run(20);
    rig.cmd("#1J=2000");
    rig.cmd("#2J/");
    rig.run(300);
    rig.station().node_mut(0).unwrap().inject_amp_fault();
    rig.run(20);
    let (_, w2) = rig.status(1);
    assert_ne!(w2 & W2_AMP_FAULT, 0, "amp fault bit");
    assert_eq!(rig.status(2).1 & W2_AMP_FAULT, 0, "only motor 1 faulted");
    assert_all_killed(&mut rig);
    assert_still(&mut rig, 300);
    // Re-enabling clears the bit (the station cleared its latch when enable went low).
    rig.cmd("#1J/");
    rig.run(50);
    let (w1, w2) = rig.status(1);
    assert_eq!((w1 & W1_OPEN_LOOP, w2 & W2_AMP_FAULT), (0, 0));
}

#[test]
fn ring_fault_kills_everything_until_reset() {
    let mut rig = Rig::new(NodePlantConfig::default());
    rig.cmd("I3=2");
    rig.run(20);
    rig.cmd("#1J=20000");
    rig.cmd("#2J/");
    rig.run(200);
    rig.sim
        .inject(1, FaultSpec::always(FaultKind::Cut))
        .unwrap();
    rig.run(100);
    // `???` word 1 bit 4: MACRO ring fault.
    let g = rig.cmd("???");
    let w1 = u32::from_str_radix(&g[..6], 16).unwrap();
    assert_ne!(w1 & (1 << 4), 0, "ring-fault bit in {g}");
    assert_all_killed(&mut rig);
    rig.sim.clear_faults(1);
    rig.run(100);
    // Ring healthy again, the fault stays latched: commands close no loop, nothing moves.
    rig.cmd("#1J=0");
    assert_still(&mut rig, 200);
    assert_ne!(rig.status(1).0 & W1_OPEN_LOOP, 0);
    assert_ne!(
        u32::from_str_radix(&rig.cmd("???")[..6], 16).unwrap() & 0x10,
        0
    );
    // `$$$` clears the latch; motors are killed and come back only when commanded.
    rig.cmd("$$$");
    rig.cmd("I3=2");
    rig.run(50);
    assert_eq!(
        u32::from_str_radix(&rig.cmd("???")[..6], 16).unwrap() & 0x10,
        0
    );
    assert_all_killed(&mut rig);
    let p0 = rig.num("#2P");
    rig.cmd("#2J:500");
    rig.run(1500);
    let p = rig.num("#2P");
    assert!((p - (p0 + 500.0)).abs() < 10.0, "{p0} -> {p}");
    assert_eq!(
        rig.status(2).0 & W1_OPEN_LOOP,
        0,
        "motor 2 (re-wired after $$$) runs"
    );
}

#[test]
fn gathering_records_a_jog() {
    let mut rig = Rig::new(NodePlantConfig::default());
    rig.cmd("I3=2");
    rig.run(20);
    // Commanded (D:$0028) and actual (D:$002B) position of motor 1 every 20 servo cycles.
    rig.cmd("I19=20 I20=3 I21=$800028 I22=$80002B DEFINE GATHER 400");
    rig.cmd("GATHER");
    rig.cmd("#1J=1000");
    rig.run(2000);
    rig.cmd("ENDGATHER");
    let listing = rig.cmd("LIST GATHER");
    let words: Vec<i64> = listing
        .split(['\r', ' '])
        .filter(|w| w.len() == 12)
        .map(|w| {
            let v = i64::from_str_radix(w, 16).unwrap();
            if v & (1 << 47) != 0 {
                v - (1 << 48)
            } else {
                v
            }
        })
        .collect();
    assert_eq!(words.len(), 200, "100 samples of 2 words");
    assert!(listing.lines().count() >= 1);
    let cmd: Vec<f64> = words
        .iter()
        .step_by(2)
        .map(|&w| w as f64 / D_UNITS)
        .collect();
    let act: Vec<f64> = words
        .iter()
        .skip(1)
        .step_by(2)
        .map(|&w| w as f64 / D_UNITS)
        .collect();
    assert_eq!(cmd[0], 0.0);
    assert!(
        cmd.windows(2).all(|w| w[1] >= w[0]),
        "monotonic commanded jog"
    );
    assert!((cmd[99] - 1000.0).abs() < 1e-3, "ends at 1000: {}", cmd[99]);
    assert!((act[99] - 1000.0).abs() < 10.0);
    // 16 words per line, 12 hex digits each.
    let first = listing.split('\r').next().unwrap();
    assert_eq!(first.split(' ').count(), 16);
}
