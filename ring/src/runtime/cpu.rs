//! The CPU a member's process uses (issue 27 item 4): a sampler thread reads
//! `/proc/self/stat` once a second and keeps the percentage of one core used since the
//! previous reading, which the member reports in its status (`cpu_percent`). Started by the
//! first status report, so a process that never reports runs no sampler.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Clock ticks per second of `/proc/<pid>/stat` times (USER_HZ: 100 on every Linux
/// architecture mcc runs on).
pub const USER_HZ: f64 = 100.0;

/// CPU seconds from the text of `/proc/<pid>/stat`: utime + stime (fields 14 and 15; the
/// command name in parentheses may hold spaces, so fields are counted after its `)`).
pub fn cpu_from_stat(stat: &str, ticks_per_s: f64) -> Option<f64> {
    let rest = &stat[stat.rfind(')')? + 1..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    // After ")": state is field 3, so utime (14) is index 11 and stime (15) index 12.
    let ut: f64 = f.get(11)?.parse().ok()?;
    let st: f64 = f.get(12)?.parse().ok()?;
    Some((ut + st) / ticks_per_s)
}

/// This process's CPU seconds so far.
fn own_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    cpu_from_stat(&stat, USER_HZ)
}

/// The last measured percentage as f64 bits; `u64::MAX`: none yet.
static LAST: AtomicU64 = AtomicU64::new(u64::MAX);
static SAMPLER: OnceLock<()> = OnceLock::new();

/// Percent of one core this process used over the last second (null until the sampler has
/// measured one second, or when `/proc/self/stat` cannot be read).
pub fn percent_last_second() -> Option<f64> {
    SAMPLER.get_or_init(|| {
        let spawned = std::thread::Builder::new()
            .name("cpu-meter".into())
            .spawn(|| {
                let Some(mut prev) = own_cpu_s().map(|c| (Instant::now(), c)) else {
                    return;
                };
                loop {
                    std::thread::sleep(Duration::from_secs(1));
                    let Some(c) = own_cpu_s() else { return };
                    let now = Instant::now();
                    let dt = now.duration_since(prev.0).as_secs_f64();
                    if dt > 0.0 {
                        let pct = 100.0 * (c - prev.1).max(0.0) / dt;
                        LAST.store(pct.to_bits(), Ordering::Relaxed);
                    }
                    prev = (now, c);
                }
            });
        if let Err(e) = spawned {
            tracing::warn!("no CPU meter: {e}");
        }
    });
    match LAST.load(Ordering::Relaxed) {
        u64::MAX => None,
        bits => Some((f64::from_bits(bits) * 10.0).round() / 10.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_fields_are_counted_after_the_command_name() {
        let stat = "1234 (mcc card (x)) S 1 1234 1234 0 -1 4194560 100 0 0 0 250 50 0 0 20 0 3 0";
        assert_eq!(cpu_from_stat(stat, 100.0), Some(3.0));
        assert_eq!(cpu_from_stat("garbage", 100.0), None);
    }

    #[test]
    fn the_meter_reports_this_process_once_a_second_has_passed() {
        let before = own_cpu_s().expect("/proc/self/stat");
        // Burn 0.3 s of CPU: the process's own count grows by about that.
        let t0 = Instant::now();
        let mut x = 0u64;
        while t0.elapsed() < Duration::from_millis(300) {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        }
        std::hint::black_box(x);
        assert!(own_cpu_s().expect("/proc/self/stat") > before);
        // (Other tests of this binary may have started the sampler already.)
        let _ = percent_last_second();
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut pct = None;
        while pct.is_none() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(100));
            pct = percent_last_second();
        }
        let pct = pct.expect("a reading within 10 s");
        assert!(pct.is_finite() && pct >= 0.0, "{pct}");
    }
}
