//! The campaign report: per kind, how many faults, how many had to be detected and how many
//! were tolerated, the detection latency distribution in ring cycles (against the rules' bound)
//! and in wall time, recovery times, and every violation.

use std::collections::BTreeMap;

use serde::Serialize;

use super::plan::{Kind, KINDS};
use crate::verbs::bench::stats::percentile;

/// What happened with one fault.
#[derive(Clone, Debug, Serialize)]
pub struct Outcome {
    /// Its place in the campaign.
    pub index: usize,
    /// The kind.
    pub kind: String,
    /// What was done (`cut on station0`, `freeze card1 for 120 ms`).
    pub what: String,
    /// The rules say it must be detected.
    pub sustained: bool,
    /// Each detecting member: (name, cycles from onset to its latch, the bound).
    pub latencies: Vec<(String, u64, u64)>,
    /// Wall time from injection until every member that must latch had, ms.
    pub detect_ms: Option<u64>,
    /// Wall time of the recovery (clear, restart, reset, programs back at their positions), ms.
    pub recover_ms: Option<u64>,
    /// What went against the rules.
    pub violations: Vec<String>,
}

/// Distribution of a set of values.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Dist {
    /// Samples.
    pub n: usize,
    /// Smallest.
    pub min: u64,
    /// Median.
    pub p50: u64,
    /// 90th percentile.
    pub p90: u64,
    /// Largest.
    pub max: u64,
}

impl Dist {
    fn of(mut v: Vec<u64>) -> Dist {
        v.sort_unstable();
        Dist {
            n: v.len(),
            min: v.first().copied().unwrap_or(0),
            p50: percentile(&v, 50.0),
            p90: percentile(&v, 90.0),
            max: v.last().copied().unwrap_or(0),
        }
    }

    fn text(&self) -> String {
        if self.n == 0 {
            "-".into()
        } else {
            format!("{}/{}/{}/{}", self.min, self.p50, self.p90, self.max)
        }
    }
}

/// One kind's row.
#[derive(Clone, Debug, Default, Serialize)]
pub struct KindRow {
    /// Faults injected.
    pub injected: usize,
    /// Of them, must be detected.
    pub sustained: usize,
    /// Of them, below the thresholds (must cause no shutdown).
    pub tolerated: usize,
    /// Faults with a violation.
    pub failed: usize,
    /// Detection latency, ring cycles from onset to each member's latch.
    pub latency_cycles: Dist,
    /// Largest bound the rules gave.
    pub bound_cycles: u64,
    /// Wall time until every member that must latch had, ms.
    pub detect_ms: Dist,
    /// Recovery wall time, ms.
    pub recover_ms: Dist,
}

/// The whole report.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Clock of the cluster.
    pub clock: String,
    /// Seed of the plan.
    pub seed: u64,
    /// Ring order.
    pub ring: Vec<String>,
    /// Faults planned (more than `faults` when a time budget stopped the campaign).
    pub planned: usize,
    /// Faults injected.
    pub faults: usize,
    /// Faults with a violation.
    pub failed: usize,
    /// Per kind.
    pub kinds: BTreeMap<String, KindRow>,
    /// Every violation, `#index what: problem`.
    pub violations: Vec<String>,
    /// Wall time of the campaign, s.
    pub seconds: f64,
}

impl Report {
    /// Summarise outcomes.
    pub fn new(
        clock: &str,
        seed: u64,
        planned: usize,
        ring: Vec<String>,
        outcomes: &[Outcome],
        seconds: f64,
    ) -> Self {
        let mut kinds = BTreeMap::new();
        for k in KINDS {
            let of: Vec<&Outcome> = outcomes
                .iter()
                .filter(|o| o.kind == k.to_string())
                .collect();
            if of.is_empty() {
                continue;
            }
            kinds.insert(k.to_string(), row(&of));
        }
        let violations: Vec<String> = outcomes
            .iter()
            .flat_map(|o| {
                o.violations
                    .iter()
                    .map(move |v| format!("#{} {}: {v}", o.index, o.what))
            })
            .collect();
        Report {
            clock: clock.to_string(),
            seed,
            ring,
            planned,
            faults: outcomes.len(),
            failed: outcomes.iter().filter(|o| !o.violations.is_empty()).count(),
            kinds,
            violations,
            seconds,
        }
    }

    /// The readable report.
    pub fn text(&self) -> String {
        let mut out = format!(
            "fault campaign: {} faults{} on a {} ring ({}), seed {}, {:.0} s\n",
            self.faults,
            if self.planned > self.faults {
                format!(" of {} planned (time budget)", self.planned)
            } else {
                String::new()
            },
            self.clock,
            self.ring.join(" → "),
            self.seed,
            self.seconds
        );
        out.push_str(&format!(
            "  {:<15} {:>5} {:>5} {:>5} {:>5}  {:<19} {:>5}  {:<19} {:<19}\n",
            "kind",
            "n",
            "must",
            "below",
            "fail",
            "cycles min/50/90/max",
            "bound",
            "detect ms 50/90/max",
            "recover ms 50/90/max"
        ));
        for k in KINDS {
            let Some(r) = self.kinds.get(&k.to_string()) else {
                continue;
            };
            let ms = |d: &Dist| {
                if d.n == 0 {
                    "-".into()
                } else {
                    format!("{}/{}/{}", d.p50, d.p90, d.max)
                }
            };
            out.push_str(&format!(
                "  {:<15} {:>5} {:>5} {:>5} {:>5}  {:<19} {:>5}  {:<19} {:<19}\n",
                k.to_string(),
                r.injected,
                r.sustained,
                r.tolerated,
                r.failed,
                r.latency_cycles.text(),
                if r.sustained > 0 {
                    r.bound_cycles.to_string()
                } else {
                    "-".into()
                },
                ms(&r.detect_ms),
                ms(&r.recover_ms),
            ));
        }
        if self.violations.is_empty() {
            out.push_str("  every fault detected within its bound by every member the rules name, the broken link named, motors killed and amplifiers off in the latching cycle, programs back at their end positions after recovery; no fault below the thresholds caused a shutdown\n");
        } else {
            out.push_str(&format!(
                "  {} fault(s) went against the rules:\n",
                self.failed
            ));
            for v in &self.violations {
                out.push_str(&format!("    {v}\n"));
            }
        }
        out
    }
}

fn row(of: &[&Outcome]) -> KindRow {
    let lat: Vec<u64> = of
        .iter()
        .flat_map(|o| o.latencies.iter().map(|l| l.1))
        .collect();
    KindRow {
        injected: of.len(),
        sustained: of.iter().filter(|o| o.sustained).count(),
        tolerated: of.iter().filter(|o| !o.sustained).count(),
        failed: of.iter().filter(|o| !o.violations.is_empty()).count(),
        latency_cycles: Dist::of(lat),
        bound_cycles: of
            .iter()
            .flat_map(|o| o.latencies.iter().map(|l| l.2))
            .max()
            .unwrap_or(0),
        detect_ms: Dist::of(of.iter().filter_map(|o| o.detect_ms).collect()),
        recover_ms: Dist::of(of.iter().filter_map(|o| o.recover_ms).collect()),
    }
}

/// The kinds of a comma-separated list (`cut,kill`), or a message naming the bad one.
pub fn parse_kinds(list: &str) -> Result<Vec<Kind>, String> {
    list.split(',')
        .filter(|w| !w.trim().is_empty())
        .map(|w| {
            Kind::parse(w).ok_or_else(|| {
                let all: Vec<String> = KINDS.iter().map(ToString::to_string).collect();
                format!(
                    "unknown fault kind {:?} (one of: {})",
                    w.trim(),
                    all.join(", ")
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_rows_and_violations() {
        let o = |i, kind: &str, sustained, lat: &[(u64, u64)], v: &[&str]| Outcome {
            index: i,
            kind: kind.into(),
            what: format!("{kind} on x"),
            sustained,
            latencies: lat.iter().map(|&(l, b)| ("card1".into(), l, b)).collect(),
            detect_ms: sustained.then_some(5),
            recover_ms: sustained.then_some(900),
            violations: v.iter().map(|s| s.to_string()).collect(),
        };
        let r = Report::new(
            "paced",
            3,
            3,
            vec!["card0".into(), "station0".into()],
            &[
                o(0, "cut", true, &[(4, 8), (6, 9)], &[]),
                o(1, "cut", false, &[], &[]),
                o(
                    2,
                    "kill",
                    true,
                    &[(12, 8)],
                    &["card1 latched 12 cycles after the onset, bound 8"],
                ),
            ],
            10.0,
        );
        assert_eq!((r.faults, r.failed), (3, 1));
        let cut = &r.kinds["cut"];
        assert_eq!(
            (cut.injected, cut.sustained, cut.tolerated, cut.failed),
            (2, 1, 1, 0)
        );
        assert_eq!(
            (
                cut.latency_cycles.min,
                cut.latency_cycles.max,
                cut.bound_cycles
            ),
            (4, 6, 9)
        );
        assert_eq!(
            r.violations,
            vec!["#2 kill on x: card1 latched 12 cycles after the onset, bound 8"]
        );
        let t = r.text();
        assert!(
            t.contains("3 faults on a paced ring (card0 → station0)"),
            "{t}"
        );
        assert!(t.contains("1 fault(s) went against the rules"), "{t}");
        assert!(parse_kinds("cut, kill").unwrap() == vec![Kind::Cut, Kind::Kill]);
        assert!(parse_kinds("cut,melt").unwrap_err().contains("\"melt\""));
    }
}
