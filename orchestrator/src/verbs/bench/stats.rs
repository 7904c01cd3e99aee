//! The statistics the ring benchmark reports from timing records.

use std::collections::BTreeMap;

/// Percentile `p` (0–100) of sorted values (nearest rank); 0 when empty.
pub fn percentile(sorted: &[u64], p: f64) -> u64 {
    if sorted.is_empty() {
        return 0;
    }
    let rank = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Cycles every member sent in: cycle → send time per member (first send of that cycle).
pub fn complete_cycles(logs: &[Vec<(u64, u64)>]) -> BTreeMap<u64, Vec<u64>> {
    let n = logs.len();
    let mut by_cycle: BTreeMap<u64, Vec<Option<u64>>> = BTreeMap::new();
    for (k, log) in logs.iter().enumerate() {
        for &(c, t) in log {
            let row = by_cycle.entry(c).or_insert_with(|| vec![None; n]);
            if let Some(slot @ None) = row.get_mut(k) {
                *slot = Some(t);
            }
        }
    }
    by_cycle
        .into_iter()
        .filter_map(|(c, row)| {
            row.into_iter()
                .collect::<Option<Vec<u64>>>()
                .map(|r| (c, r))
        })
        .collect()
}

/// Realtime lateness of member `k` (k > 0): its sync-packet arrival of cycle c minus the
/// sync master's (member 0's) scheduled start of cycle c. Sorted.
pub fn lateness(cycles: &BTreeMap<u64, Vec<u64>>, k: usize, skip: usize) -> Vec<u64> {
    let mut v: Vec<u64> = cycles
        .values()
        .skip(skip)
        .filter_map(|row| Some(row.get(k)?.saturating_sub(*row.first()?)))
        .collect();
    v.sort_unstable();
    v
}

/// µs with one decimal.
pub fn us(ns: u64) -> String {
    format!("{:.1}", ns as f64 / 1000.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_are_nearest_rank() {
        let v: Vec<u64> = (1..=100).collect();
        assert_eq!(percentile(&v, 50.0), 50);
        assert_eq!(percentile(&v, 99.0), 99);
        assert_eq!(percentile(&v, 99.9), 100);
        assert_eq!(percentile(&[], 50.0), 0);
        assert_eq!(percentile(&[7], 0.0), 7);
    }

    #[test]
    fn complete_cycles_and_lateness_from_logs() {
        // 3 members, cycles 1..=3, 10 µs apart, 100 µs per cycle; member 2 missed cycle 2.
        let logs = vec![
            vec![(1, 0), (2, 100_000), (3, 200_000)],
            vec![(1, 10_000), (2, 110_000), (3, 210_000)],
            vec![(1, 20_000), (3, 220_000)],
        ];
        let cycles = complete_cycles(&logs);
        assert_eq!(cycles.keys().copied().collect::<Vec<_>>(), [1, 3]);
        // Realtime: member 1 arrives 10 µs after the scheduled start, member 2 20 µs.
        assert_eq!(lateness(&cycles, 1, 0), [10_000, 10_000]);
        assert_eq!(lateness(&cycles, 2, 1), [20_000]);
    }
}
