//! `mcc bench faults --campaign N --seed S [--clock paced|lockstep]`: a fault campaign on a
//! cluster of its own. While program 1 runs on every card, N faults of every kind (drop-sync,
//! drop-packets, corrupt, byte-violation, overrun, underrun, delay, delay-us, cut, freeze,
//! kill, restart) go to random members (the sync master included) at random times; each is
//! held to the ring-check rules ([`mcc_ring::expect`]):
//! - a fault the rules say must be detected is latched by every member they name within its
//!   bound in ring cycles (from `since_cycle` of a send-path fault, from the first dark cycle
//!   downstream of a dead or frozen member), by nobody else; `mcc status` names the link
//!   leaving the target; every card that latched has killed its motors and every station that
//!   latched dropped its amplifiers in the latching cycle; after clear (+ restart) and the
//!   usual reset (`$$$`, latch reset) program 2 ends at the same position as before the
//!   campaign on every card;
//! - a card's abort input (`input`, cards only; `--profiles` mixes PMAC2, Turbo and Power
//!   cards) latches nothing on the ring; the card's C.S. 1 program stops and motor 1 stays
//!   closed as its profile's expectation says ([`mcc_ring::expect_card`]); `mcc status`
//!   shows the input; after the clear and the usual recovery program 2 ends where it did;
//! - an amplifier fault on the servo node of a card's motor 1 (`axis`, stations only) latches
//!   nothing on the ring; that card kills motor 1 with its profile's amplifier-fault bit
//!   ([`mcc_ring::expect_card::amp_fault_effect`]), no other card loses a motor, `mcc status`
//!   shows the fault at the station; after the clear and the usual recovery program 2 ends
//!   where it did;
//! - a host-link fault on a card's text port (`link`, cards only: ASCII, a Power card's
//!   gpascii; one reply, of every kind a card's ports take) latches nothing on the ring; the
//!   host reads exactly what the link-fault model ([`mcc_ring::linkfault`]) makes of the
//!   card's true reply (nothing, late, cut short, with a stray byte, a flipped bit, or the
//!   connection reset), the next reply is whole, and what the faulted line wrote is stored;
//! - a fault below the thresholds (a burst no check can trip on, `delay-us`) latches nothing
//!   and kills no motor. (A SIGSTOP of any length is no tolerated stall: a stopped process is
//!   a fact the member downstream sees as loss of light, see the README's Clocks.)

pub mod link;
pub mod motion;
pub mod observe;
pub mod plan;
pub mod report;

use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use mcc_contracts::config::{ClockMode, ClusterConfig, MemberRef};
use mcc_ring::control::{ctl_key, FaultRequest};
use mcc_ring::expect::RingModel;

use self::observe::Snapshot;
use self::plan::{Action, PlanOptions, Planned};
use self::report::{Outcome, Report};
use crate::cli::BenchFaultsArgs;
use crate::cluster::ctl::query_ctl;
use crate::cluster::supervisor::Supervisor;
use crate::verbs::bench::syncstart::{reset_ring_faults, with_cluster};

/// Run the campaign `args` asks for; fails when a fault went against the rules.
pub fn run(args: &BenchFaultsArgs, n: u64) -> Result<()> {
    let clock = args.clock.unwrap_or(ClockMode::Paced);
    if !clock.is_stepped() {
        bail!("--clock: the campaign runs on the paced or lockstep clock (realtime judges scheduling delays as ring errors)");
    }
    let kinds = match &args.kinds {
        Some(l) => report::parse_kinds(l).map_err(|e| anyhow!("--kinds: {e}"))?,
        None => Vec::new(),
    };
    let mut cfg =
        ClusterConfig::default_cluster(usize::from(args.cards), usize::from(args.stations));
    cfg.cluster = format!("bench-campaign-{}", std::process::id());
    cfg.clock = clock;
    cfg.drives.clear();
    if let Some(list) = &args.profiles {
        let profiles: Vec<&str> = list.split(',').map(str::trim).collect();
        for (k, c) in cfg.cards.iter_mut().enumerate() {
            let p = profiles[k % profiles.len()];
            if mcc_ring::expect_card::CardProfile::parse(p).is_none() {
                bail!("--profiles: unknown profile {p:?} (pmac2, turbo, power)");
            }
            c.profile = p.to_string();
            // The ring check in the profile's own keys (filled in at resolve).
            c.ivars.clear();
        }
    }
    let opts = PlanOptions {
        below_share: 0.4,
        kinds,
    };
    let budget = args.minutes.map(|m| Duration::from_secs(60 * m));
    let report = with_cluster(cfg, |sup, cfg| {
        campaign(sup, cfg, n as usize, args.seed, &opts, budget)
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.text());
    }
    if report.failed > 0 {
        bail!(
            "{} of {} faults went against the rules",
            report.failed,
            report.faults
        );
    }
    Ok(())
}

/// The campaign on a running cluster.
fn campaign(
    sup: &mut Supervisor,
    cfg: &ClusterConfig,
    n: usize,
    seed: u64,
    opts: &PlanOptions,
    budget: Option<Duration>,
) -> Result<Report> {
    let model = RingModel::from_config(cfg).ok_or_else(|| anyhow!("no ring model"))?;
    let faults = plan::plan(&model, n, seed, opts);
    let s = sup.session().clone();
    reset_ring_faults(&s, cfg, Duration::from_secs(60))?;
    motion::setup(&s, cfg)?;
    let reference = motion::run_to_end(&s, cfg, Duration::from_secs(60))?;
    eprintln!(
        "campaign: {n} faults, seed {seed}, {} clock; program 2 ends at {reference:?}",
        cfg.clock.as_str()
    );
    motion::start_endless(&s, cfg)?;
    let started = Instant::now();
    let mut outcomes = Vec::new();
    for p in &faults {
        if budget.is_some_and(|b| started.elapsed() > b) {
            eprintln!(
                "campaign: the time budget is spent after {} faults",
                p.index
            );
            break;
        }
        let mut o = Outcome {
            index: p.index,
            kind: p.kind.to_string(),
            what: p.describe(&cfg.ring.order),
            sustained: p.sustained(),
            latencies: Vec::new(),
            detect_ms: None,
            recover_ms: None,
            violations: Vec::new(),
        };
        let r = one(sup, cfg, p, &reference, &mut o);
        if let Err(e) = &r {
            o.violations.push(format!("{e:#}"));
        }
        eprintln!(
            "[{}/{n}] {}: {}",
            p.index + 1,
            o.what,
            if o.violations.is_empty() {
                "ok".to_string()
            } else {
                o.violations.join("; ")
            }
        );
        outcomes.push(o);
        if r.is_err() {
            // Whatever happened, the next fault starts from a healthy ring or not at all.
            if let Err(e) = recover(sup, cfg, p, &reference, &mut Vec::new()) {
                eprintln!("campaign stopped: the cluster did not recover: {e:#}");
                break;
            }
        }
    }
    Ok(Report::new(
        cfg.clock.as_str(),
        seed,
        n,
        cfg.ring.order.clone(),
        &outcomes,
        started.elapsed().as_secs_f64(),
    ))
}

fn name(cfg: &ClusterConfig, i: usize) -> &str {
    cfg.ring.order.get(i).map(String::as_str).unwrap_or("?")
}

fn pid(sup: &Supervisor, member: &str) -> Result<u32> {
    sup.info()
        .members
        .iter()
        .find(|m| m.name == member)
        .map(|m| m.pid)
        .ok_or_else(|| anyhow!("{member} has no process"))
}

fn fault_request(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    member: &str,
    req: &FaultRequest,
) -> Result<()> {
    let r = query_ctl(
        s,
        &ctl_key(&cfg.cluster, member, "fault"),
        Some(serde_json::to_string(req)?),
        Duration::from_secs(5),
    )?;
    if !r.ok {
        bail!("{member} refused the fault request: {}", r.message);
    }
    Ok(())
}

/// Margin after a tolerated fault before the ring is judged: three of the longest check periods.
fn margin(model: &RingModel) -> u64 {
    let longest = model
        .members
        .iter()
        .map(|m| mcc_ring::expect::checks_per_period(&m.check) * u64::from(m.check.rti.max(1)))
        .max()
        .unwrap_or(8);
    3 * longest + 16
}

/// One fault: inject, judge, recover.
fn one(
    sup: &mut Supervisor,
    cfg: &ClusterConfig,
    p: &Planned,
    reference: &[f64],
    o: &mut Outcome,
) -> Result<()> {
    let s = sup.session().clone();
    std::thread::sleep(Duration::from_millis(p.wait_ms));
    let before = observe::snapshot(&s, cfg);
    if !before.healthy() {
        // Nobody asked for this: the worst defect there is.
        o.violations.push(format!(
            "the ring was not healthy before the fault: {}",
            unhealthy(cfg, &before)
        ));
        recover(sup, cfg, p, reference, &mut o.violations)?;
        return Ok(());
    }
    let target = name(cfg, p.target).to_string();
    let t0 = Instant::now();
    match &p.action {
        Action::Frames(spec) => fault_request(
            &s,
            cfg,
            &target,
            &FaultRequest::Inject { spec: spec.clone() },
        )?,
        Action::Freeze => {
            crate::cluster::sys::signal(pid(sup, &target)?, libc::SIGSTOP)?;
        }
        Action::Kill => {
            crate::cluster::sys::signal(pid(sup, &target)?, libc::SIGKILL)?;
        }
        Action::Restart => {
            sup.restart(&target)?;
        }
        Action::Input => {
            let r = judge_input(&s, cfg, p, &before, o);
            recover(sup, cfg, p, reference, &mut o.violations)?;
            return r;
        }
        Action::Axis => {
            let r = judge_axis(&s, cfg, p, &before, o);
            recover(sup, cfg, p, reference, &mut o.violations)?;
            return r;
        }
        Action::Link(spec) => {
            let r =
                link::judge(&s, cfg, p, spec, o).and_then(|()| judge_quiet(&s, cfg, p, &before, o));
            recover(sup, cfg, p, reference, &mut o.violations)?;
            return r;
        }
    }
    if p.sustained() {
        judge_detection(&s, cfg, p, &before, t0, o);
        let t1 = Instant::now();
        recover(sup, cfg, p, reference, &mut o.violations)?;
        o.recover_ms = Some(t1.elapsed().as_millis() as u64);
    } else {
        judge_quiet(&s, cfg, p, &before, o)?;
        if !o.violations.is_empty() {
            recover(sup, cfg, p, reference, &mut o.violations)?;
        }
    }
    Ok(())
}

fn unhealthy(cfg: &ClusterConfig, snap: &Snapshot) -> String {
    let mut parts = Vec::new();
    for (i, m) in snap.members.iter().enumerate() {
        match m {
            None => parts.push(format!("{} silent", name(cfg, i))),
            Some(m) if m.ring_fault => parts.push(format!(
                "{} latched at cycle {:?} ({})",
                m.name,
                m.ring_fault_cycle,
                m.fault_reason.as_deref().unwrap_or("?")
            )),
            Some(m) if !m.locked => parts.push(format!("{} unlocked", m.name)),
            _ => {}
        }
    }
    parts.join(", ")
}

/// What a member that latched unexpectedly saw: its receive errors by class since the fault,
/// the cycle its input link last delivered bad data, where its dark spells lie, and when the
/// members the rules name latched (for the next one to read).
fn unexpected_evidence(
    cfg: &ClusterConfig,
    p: &Planned,
    before: &Snapshot,
    last: &Snapshot,
    i: usize,
) -> String {
    let Some(m) = last.member(i) else {
        return "no status".into();
    };
    let e0 = before.member(i).map(|b| b.errors).unwrap_or_default();
    let e = m.errors;
    let mut s = format!(
        "errors since the fault bv+{} cs+{} ov+{} un+{} bad+{}, link error at {:?}, dark {:?}/{:?}, cycle {}",
        e.byte_violation.saturating_sub(e0.byte_violation),
        e.checksum.saturating_sub(e0.checksum),
        e.overrun.saturating_sub(e0.overrun),
        e.underrun.saturating_sub(e0.underrun),
        e.bad_frames.saturating_sub(e0.bad_frames),
        m.link_error_cycle,
        m.dark_since_cycle,
        m.last_dark_spell,
        m.cycle
    );
    for d in &p.expect.must {
        let c = last.member(d.member).and_then(|x| x.ring_fault_cycle);
        s.push_str(&format!("; {} latched at {c:?}", name(cfg, d.member)));
    }
    s
}

fn latched(snap: &Snapshot, i: usize, base: &[u64]) -> bool {
    snap.member(i).is_some_and(|m| {
        m.ring_fault
            && m.ring_fault_cycle.is_some()
            && m.ring_fault_count > base.get(i).copied().unwrap_or(0)
    })
}

/// A fault that must be detected: every member the rules name latches within its bound,
/// nobody else does, the link is named, cards' motors are killed and stations' amplifiers
/// went off in the latching cycle.
fn judge_detection(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    p: &Planned,
    before: &Snapshot,
    t0: Instant,
    o: &mut Outcome,
) {
    let counts = before.fault_counts();
    let base = &counts[..];
    let n = cfg.ring.order.len();
    let down = (p.target + 1) % n;
    let dead = matches!(p.action, Action::Freeze | Action::Kill | Action::Restart);
    // Every dark onset seen downstream (a restarted sync master may renumber the ring, so a
    // later spell can carry a smaller number): the onset is the latest one before the latch.
    let mut dark_onsets: Vec<u64> = Vec::new();
    let timeout = Duration::from_secs(30) + cfg.member_timeout();
    let found = observe::wait_for(
        s,
        cfg,
        "detection",
        timeout,
        |snap| {
            if let Some(m) = snap.member(down).filter(|m| m.dark) {
                dark_onsets.extend(m.dark_since_cycle.filter(|c| !dark_onsets.contains(c)));
            }
        },
        |snap| p.expect.must.iter().all(|d| latched(snap, d.member, base)),
    );
    let detected = match found {
        Ok(snap) => {
            o.detect_ms = Some(t0.elapsed().as_millis() as u64);
            snap
        }
        Err(_) => {
            let snap = observe::statuses(s, cfg);
            for d in &p.expect.must {
                if !latched(&snap, d.member, base) {
                    o.violations.push(format!(
                        "{} did not latch a ring fault within {} s",
                        name(cfg, d.member),
                        timeout.as_secs()
                    ));
                }
            }
            snap
        }
    };
    // Give anyone who should not latch the time to do it anyway.
    let longest = p.expect.must.iter().map(|d| d.within).max().unwrap_or(0);
    let _ = observe::wait_cycles(s, cfg, longest + 16, Duration::from_secs(10));
    let last = observe::snapshot(s, cfg);
    // The onset.
    let down_latch = detected.member(down).and_then(|m| m.ring_fault_cycle);
    // The cycle after the last frame the downstream member received is a dark onset too: a
    // poll can miss a short dark spell before a restarted sync master renumbers the ring, and
    // then the only spell seen is a later one in the new numbering (campaign seed 1000, #467
    // paced: onset 105 against a latch at 803,820).
    let after_last_rx = detected
        .member(down)
        .and_then(|m| m.last_rx_cycle)
        .map(|c| c + 1);
    let dark_onset = dark_onsets
        .iter()
        .copied()
        .chain(after_last_rx.filter(|_| dead))
        .filter(|&o| down_latch.is_none_or(|l| o <= l))
        .max()
        .or_else(|| dark_onsets.first().copied());
    // Best of all, the downstream member's own record of the spell it latched in (same
    // numbering as its latch whatever the ring did since).
    let latched_in = detected.member(down).and_then(|m| m.ring_fault_dark_since);
    let onset = if dead {
        latched_in.or(dark_onset).or(after_last_rx)
    } else {
        // The target's own record of when its fault began; a status poll that missed the
        // target (a loaded machine answers late) is asked again before the onset is called
        // unknown.
        let since = |snap: &Snapshot| {
            snap.member(p.target)
                .and_then(|m| m.faults.first())
                .and_then(|f| f.since_cycle)
        };
        since(&detected).or_else(|| since(&last)).or_else(|| {
            observe::wait_for(
                s,
                cfg,
                "onset",
                Duration::from_secs(10),
                |_| {},
                |snap| since(snap).is_some(),
            )
            .ok()
            .and_then(|snap| since(&snap))
        })
    };
    match onset {
        None => o.violations.push("the onset cycle is unknown".into()),
        Some(onset) => {
            for d in &p.expect.must {
                let Some(at) = detected.member(d.member).and_then(|m| m.ring_fault_cycle) else {
                    continue;
                };
                let lat = at.saturating_sub(onset);
                o.latencies
                    .push((name(cfg, d.member).to_string(), lat, d.within));
                if lat > d.within {
                    o.violations.push(format!(
                        "{} latched {lat} cycles after the onset (cycle {onset}), bound {}",
                        name(cfg, d.member),
                        d.within
                    ));
                }
            }
        }
    }
    for i in 0..n {
        if (dead && i == p.target) || p.expect.allows(i) || !latched(&last, i, base) {
            continue;
        }
        let m = last.member(i);
        o.violations.push(format!(
            "{} latched a ring fault the rules do not expect (cycle {:?}: {}; {})",
            name(cfg, i),
            m.and_then(|m| m.ring_fault_cycle),
            m.and_then(|m| m.fault_reason.clone()).unwrap_or_default(),
            unexpected_evidence(cfg, p, before, &last, i)
        ));
    }
    // The link.
    let want = format!("{} → {}", name(cfg, p.target), name(cfg, down));
    let threshold = crate::cluster::status::lag_threshold(cfg);
    let named = [&detected, &last]
        .iter()
        .map(|snap| crate::cluster::status::broken_link(cfg, &snap.members, &[], threshold))
        .collect::<Vec<_>>();
    if !named.iter().any(|l| l.as_deref() == Some(want.as_str())) {
        // What each member showed (for the diagnosis: which rule named the link).
        let seen = detected
            .members
            .iter()
            .enumerate()
            .map(|(i, m)| match m {
                Some(m) => format!(
                    "{}: cycle {} rx {:?} locked {} fault {} at {:?} link_error {:?} dark {} spell {:?} ({})",
                    name(cfg, i),
                    m.cycle,
                    m.last_rx_cycle,
                    m.locked,
                    m.ring_fault,
                    m.ring_fault_cycle,
                    m.link_error_cycle,
                    m.dark,
                    m.last_dark_spell,
                    m.fault_reason.clone().unwrap_or_default()
                ),
                None => format!("{}: no answer", name(cfg, i)),
            })
            .collect::<Vec<_>>()
            .join("; ");
        o.violations.push(format!(
            "mcc status names {:?}, not {want:?} (at detection: {seen})",
            named
        ));
    }
    // Cards kill their motors; stations drop their amplifiers in the latching cycle.
    for (k, c) in cfg.cards.iter().enumerate() {
        let Some(i) = cfg.position(&c.name) else {
            continue;
        };
        if (dead && i == p.target) || !latched(&last, i, base) {
            continue;
        }
        match last.cards.get(k).and_then(Option::as_ref) {
            Some(info) if info.motors_killed => {}
            Some(info) => o.violations.push(format!(
                "{} latched a ring fault but its motors are not killed (killed: {:?})",
                c.name, info.killed_motors
            )),
            None => o
                .violations
                .push(format!("{} did not report its motors", c.name)),
        }
        // The profile's own latch bit, as its host reads it ([`mcc_ring::expect_card`]).
        let profile = mcc_ring::expect_card::CardProfile::parse(&c.profile);
        let latch = profile.and_then(|p| mcc_ring::expect_card::ring_fault_effect(p).latch);
        if let Some(rb) = latch {
            match motion::send(s, cfg, c.number, rb.query) {
                Ok(r) if rb.bits(&r).is_some_and(|b| b != 0) => {}
                Ok(r) => o.violations.push(format!(
                    "{} ({}) latched a ring fault but {} answers {r:?}",
                    c.name, c.profile, rb.query
                )),
                Err(e) => o.violations.push(format!("{}: {e:#}", c.name)),
            }
        }
    }
    for (i, member) in cfg.ring.order.iter().enumerate() {
        if !matches!(cfg.member(member), Some(MemberRef::Station(_)))
            || (dead && i == p.target)
            || !latched(&last, i, base)
        {
            continue;
        }
        let Some(m) = last.member(i) else { continue };
        let off = m
            .extra
            .get("ring_shutdown_cycle")
            .and_then(serde_json::Value::as_u64);
        if off.is_none() || off != m.ring_fault_cycle {
            o.violations.push(format!(
                "{member} latched at cycle {:?} but its amplifiers went off at {off:?}",
                m.ring_fault_cycle
            ));
        }
    }
}

/// The card a planned fault goes to: its name and config.
fn target_card<'c>(
    cfg: &'c ClusterConfig,
    p: &Planned,
) -> Result<(String, &'c mcc_contracts::config::CardConfig)> {
    let target = name(cfg, p.target).to_string();
    match cfg.cards.iter().find(|c| c.name == target) {
        Some(card) => Ok((target, card)),
        None => bail!("{target} is not a card"),
    }
}

/// A card's abort input: the card stops its C.S. 1 program with motor 1 closed as its
/// profile's [`mcc_ring::expect_card::abort_input_effect`] says, its status shows the input,
/// and the ring latches nothing ([`judge_quiet`]). The recovery clears the input.
fn judge_input(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    p: &Planned,
    before: &Snapshot,
    o: &mut Outcome,
) -> Result<()> {
    use mcc_ring::expect_card::{abort_input_effect, CardProfile};
    let (target, card) = target_card(cfg, p)?;
    let profile = CardProfile::parse(&card.profile).unwrap_or(CardProfile::Pmac2);
    let eff = abort_input_effect(profile);
    for line in eff.wiring {
        motion::send(s, cfg, card.number, line)?;
    }
    let fault = serde_json::json!({"family": "input", "kind": "abort", "select": 1});
    fault_request(s, cfg, &target, &FaultRequest::App { fault })?;
    // Ix15 deceleration from F20 takes ~200 cycles.
    observe::wait_cycles(s, cfg, 400, Duration::from_secs(30))?;
    let passes = motion::number(s, cfg, card.number, "P101")?;
    observe::wait_cycles(s, cfg, 600, Duration::from_secs(30))?;
    if eff.aborts_program && motion::number(s, cfg, card.number, "P101")? != passes {
        o.violations.push(format!(
            "{target}: program 1 still runs after its abort input"
        ));
    }
    let reply = motion::send(s, cfg, card.number, eff.motor1.query)?;
    if eff.motor1.bits(&reply) != Some(eff.closed_value) {
        o.violations.push(format!(
            "{target} ({}): motor 1 not closed after the abort input: {} answered {reply:?}",
            card.profile, eff.motor1.query
        ));
    }
    let snap = observe::snapshot(s, cfg);
    let held = snap
        .member(p.target)
        .and_then(|m| m.extra.get("inputs"))
        .and_then(|i| i["held"].as_array().map(Vec::len));
    if held != Some(1) {
        o.violations.push(format!(
            "{target}: mcc status does not show the input ({held:?})"
        ));
    }
    judge_quiet(s, cfg, p, before, o)
}

/// An amplifier fault on the station's servo node of its card's motor 1 (its first node):
/// that card kills motor 1 with the amplifier-fault bit its profile shows
/// ([`mcc_ring::expect_card::amp_fault_effect`]), `mcc status` shows the fault at the
/// station, and otherwise the ring stays quiet ([`judge_quiet`], the card's motor 1 excused).
/// The recovery clears it.
fn judge_axis(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    p: &Planned,
    before: &Snapshot,
    o: &mut Outcome,
) -> Result<()> {
    use mcc_ring::expect_card::{amp_fault_effect, CardProfile};
    let target = name(cfg, p.target).to_string();
    let Some(st) = cfg.stations.iter().find(|st| st.name == target) else {
        bail!("{target} is not a station");
    };
    let Some((k, card)) = cfg
        .cards
        .iter()
        .enumerate()
        .find(|(_, c)| c.master == st.master)
    else {
        bail!("{target} serves no card (master {})", st.master);
    };
    let Some(&node) = st.nodes.first() else {
        bail!("{target} has no servo node");
    };
    let eff = amp_fault_effect(CardProfile::parse(&card.profile).unwrap_or(CardProfile::Pmac2));
    let fault = serde_json::json!({"op": "axis", "node": node, "kind": "amp-fault"});
    fault_request(s, cfg, &target, &FaultRequest::App { fault })?;
    // The FAULT line reaches the card in the next cycle; a generous bound in ring time.
    observe::wait_cycles(s, cfg, 200, Duration::from_secs(30))?;
    let reply = motion::send(s, cfg, card.number, eff.fault_bit.query)?;
    if eff.fault_bit.bits(&reply) != Some(eff.fault_bit.mask)
        || eff.killed.bits(&reply) != Some(eff.killed_value)
    {
        o.violations.push(format!(
            "{} ({}): motor 1 not killed by its amplifier fault: {} answered {reply:?}",
            card.name, card.profile, eff.fault_bit.query
        ));
    }
    let snap = observe::snapshot(s, cfg);
    let shown = snap
        .member(p.target)
        .and_then(|m| m.extra.get("axis_faults"))
        .and_then(|f| f.as_array().cloned())
        .unwrap_or_default();
    if !shown
        .iter()
        .any(|f| f["node"] == serde_json::json!(node) && f["kind"] == "amp-fault")
    {
        o.violations.push(format!(
            "{target}: mcc status does not show the amplifier fault on node {node} ({shown:?})"
        ));
    }
    // Motor 1 of that card was killed by the fault: excused from the quiet judgement.
    let mut excused = before.clone();
    if let Some(Some(info)) = excused.cards.get_mut(k) {
        if !info.killed_motors.contains(&eff.reported_as) {
            info.killed_motors.push(eff.reported_as);
        }
    }
    judge_quiet(s, cfg, p, &excused, o)
}

/// A fault below the thresholds: once it is over and the ring has run three check periods,
/// nobody latched and no motor was killed.
fn judge_quiet(
    s: &zenoh::Session,
    cfg: &ClusterConfig,
    p: &Planned,
    before: &Snapshot,
    o: &mut Outcome,
) -> Result<()> {
    let base = before.fault_counts();
    let model = RingModel::from_config(cfg).ok_or_else(|| anyhow!("no ring model"))?;
    if let Action::Frames(_) = p.action {
        observe::wait_for(
            s,
            cfg,
            "the burst to end",
            Duration::from_secs(60),
            |_| {},
            |snap| snap.member(p.target).is_some_and(|m| m.faults.is_empty()),
        )?;
    }
    observe::wait_cycles(s, cfg, margin(&model), Duration::from_secs(30))?;
    let last = observe::snapshot(s, cfg);
    for (i, &before) in base.iter().enumerate() {
        if last.member(i).is_some_and(|m| m.ring_fault_count > before) {
            let m = last.member(i);
            o.violations.push(format!(
                "{} latched a ring fault below the thresholds (cycle {:?}: {})",
                name(cfg, i),
                m.and_then(|m| m.ring_fault_cycle),
                m.and_then(|m| m.fault_reason.clone()).unwrap_or_default()
            ));
        }
        if last.member(i).is_none() {
            o.violations
                .push(format!("{} stopped answering", name(cfg, i)));
        }
    }
    for (k, c) in cfg.cards.iter().enumerate() {
        let was: &[u16] = before
            .cards
            .get(k)
            .and_then(Option::as_ref)
            .map_or(&[], |i| i.killed_motors.as_slice());
        match last.cards.get(k).and_then(Option::as_ref) {
            Some(info) => {
                let newly: Vec<u16> = info
                    .killed_motors
                    .iter()
                    .copied()
                    .filter(|m| !was.contains(m))
                    .collect();
                if !newly.is_empty() {
                    o.violations.push(format!(
                        "{}: motors {newly:?} killed by a fault below the thresholds",
                        c.name
                    ));
                }
            }
            None => o
                .violations
                .push(format!("{} did not report its motors", c.name)),
        }
    }
    Ok(())
}

/// Clear, restart what is dead or frozen, wait for the ring, the usual reset, programs back
/// at their end positions, program 1 running again.
fn recover(
    sup: &mut Supervisor,
    cfg: &ClusterConfig,
    p: &Planned,
    reference: &[f64],
    violations: &mut Vec<String>,
) -> Result<()> {
    let s = sup.session().clone();
    let target = name(cfg, p.target).to_string();
    if matches!(p.action, Action::Freeze | Action::Kill) {
        sup.restart(&target)?;
    }
    let everyone_back = |snap: &Snapshot| snap.members.iter().all(Option::is_some);
    observe::wait_for(
        &s,
        cfg,
        "every member back",
        Duration::from_secs(120),
        |_| {},
        everyone_back,
    )?;
    for m in &cfg.ring.order {
        fault_request(&s, cfg, m, &FaultRequest::Clear)?;
    }
    observe::wait_for(
        &s,
        cfg,
        "the ring locked again",
        Duration::from_secs(120),
        |_| {},
        |snap| {
            snap.members
                .iter()
                .all(|m| m.as_ref().is_some_and(|m| m.locked))
        },
    )?;
    // A check period that still holds cycles from before the clear may trip once more: let
    // every such period end before the reset, as an operator waits before `$$$`.
    let model = RingModel::from_config(cfg).ok_or_else(|| anyhow!("no ring model"))?;
    observe::wait_cycles(&s, cfg, margin(&model), Duration::from_secs(60))?;
    reset_ring_faults(&s, cfg, Duration::from_secs(60))?;
    let state = |s: &zenoh::Session| {
        let snap = observe::statuses(s, cfg);
        format!("ring: {}", unhealthy(cfg, &snap))
    };
    motion::setup(&s, cfg).with_context(|| state(&s))?;
    let ends = motion::run_to_end(&s, cfg, Duration::from_secs(60)).with_context(|| state(&s))?;
    for ((c, end), want) in cfg.cards.iter().zip(&ends).zip(reference) {
        if (end - want).abs() > motion::END_TOLERANCE {
            violations.push(format!(
                "after recovery program 2 ended at {end} on {}, before the campaign at {want}",
                c.name
            ));
        }
    }
    motion::start_endless(&s, cfg)
}
