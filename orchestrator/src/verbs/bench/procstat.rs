//! CPU time and context switches of a process, from `/proc` (Linux).

use anyhow::{anyhow, Context, Result};

/// One reading of a process.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ProcSample {
    /// User + system CPU time, s (all threads, including ones that have exited).
    pub cpu_s: f64,
    /// Voluntary + involuntary context switches of the threads alive now.
    pub switches: u64,
}

impl ProcSample {
    /// The difference `self - earlier` (switches of threads that exited in between are lost).
    pub fn since(&self, earlier: &ProcSample) -> ProcSample {
        ProcSample {
            cpu_s: (self.cpu_s - earlier.cpu_s).max(0.0),
            switches: self.switches.saturating_sub(earlier.switches),
        }
    }
}

use mcc_ring::runtime::cpu::{cpu_from_stat, USER_HZ};

/// Context switches from the text of `/proc/<pid>/task/<tid>/status`.
pub fn switches_from_status(status: &str) -> u64 {
    status
        .lines()
        .filter(|l| {
            l.starts_with("voluntary_ctxt_switches:")
                || l.starts_with("nonvoluntary_ctxt_switches:")
        })
        .filter_map(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        .sum()
}

/// Read process `pid` now.
pub fn sample(pid: u32) -> Result<ProcSample> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .with_context(|| format!("process {pid} is gone"))?;
    let cpu_s =
        cpu_from_stat(&stat, USER_HZ).ok_or_else(|| anyhow!("unreadable /proc/{pid}/stat"))?;
    let mut switches = 0;
    if let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) {
        for t in tasks.flatten() {
            if let Ok(s) = std::fs::read_to_string(t.path().join("status")) {
                switches += switches_from_status(&s);
            }
        }
    }
    Ok(ProcSample { cpu_s, switches })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_and_status_are_parsed() {
        let status = "Name:\tx\nvoluntary_ctxt_switches:\t10\nnonvoluntary_ctxt_switches:\t5\n";
        assert_eq!(switches_from_status(status), 15);
        let a = ProcSample {
            cpu_s: 1.0,
            switches: 10,
        };
        let b = ProcSample {
            cpu_s: 1.5,
            switches: 4,
        };
        assert_eq!(
            b.since(&a),
            ProcSample {
                cpu_s: 0.5,
                switches: 0
            }
        );
    }

    #[test]
    fn this_process_can_be_sampled_and_a_missing_one_is_an_error() {
        let a = sample(std::process::id()).unwrap();
        let t = std::time::Instant::now();
        while t.elapsed() < std::time::Duration::from_millis(50) {
            std::hint::black_box(0u64);
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
        let b = sample(std::process::id()).unwrap();
        assert!(b.cpu_s >= a.cpu_s && b.switches > a.switches, "{a:?} {b:?}");
        assert!(sample(u32::MAX).is_err());
    }
}
