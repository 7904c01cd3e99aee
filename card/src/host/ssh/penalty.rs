//! Password guessing on a Power card's SSH port (pure: time is an argument): as sshd delays
//! failed logins and penalises the hosts they come from, each source host's failed logins
//! make its next attempts wait, longer after each failure. An attempt is judged only when its
//! host's turn comes (a guess answered at once when right would tell a client that cuts slow
//! replies short which one was right), and one host's attempts, on however many connections,
//! are judged one delay apart.

use std::collections::HashMap;
use std::net::IpAddr;
use std::time::{Duration, Instant};

/// A host without a failed login for this long starts afresh.
pub(crate) const FORGET: Duration = Duration::from_secs(600);
/// Source hosts remembered at most (the oldest is forgotten beyond).
const MAX_HOSTS: usize = 4096;

/// How long a host waits after failed logins.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Delays {
    /// After the first failure (doubling with each further one).
    pub(crate) first: Duration,
    /// At most.
    pub(crate) cap: Duration,
}

impl Default for Delays {
    /// 0.6 s after one failure, 1.2 s after two, … 10 s at most.
    fn default() -> Self {
        Delays {
            first: Duration::from_millis(600),
            cap: Duration::from_secs(10),
        }
    }
}

impl Delays {
    /// The wait between attempts of a host with `failures` failed logins.
    pub(crate) fn after(&self, failures: u32) -> Duration {
        if failures == 0 {
            return Duration::ZERO;
        }
        let doubled = self
            .first
            .checked_mul(1u32 << (failures - 1).min(16))
            .unwrap_or(self.cap);
        doubled.min(self.cap)
    }
}

#[derive(Debug, Clone, Copy)]
struct Host {
    failures: u32,
    /// The next attempt is judged no earlier.
    next: Instant,
    /// The last failure.
    last: Instant,
}

/// The failed logins of every source host.
#[derive(Debug, Default)]
pub(crate) struct Penalties {
    delays: Delays,
    hosts: HashMap<IpAddr, Host>,
}

impl Penalties {
    pub(crate) fn new(delays: Delays) -> Self {
        Penalties {
            delays,
            hosts: HashMap::new(),
        }
    }

    /// An attempt from `ip` arrived at `now`: when it may be judged. Its turn is taken (the
    /// host's next attempt comes one delay later).
    pub(crate) fn admit(&mut self, ip: IpAddr, now: Instant) -> Instant {
        if self
            .hosts
            .get(&ip)
            .is_some_and(|h| now.saturating_duration_since(h.last) >= FORGET)
        {
            self.hosts.remove(&ip);
        }
        let delays = self.delays;
        let Some(h) = self.hosts.get_mut(&ip) else {
            return now;
        };
        let at = h.next.max(now);
        h.next = at + delays.after(h.failures);
        at
    }

    /// The attempt from `ip` judged at `now` failed.
    pub(crate) fn failed(&mut self, ip: IpAddr, now: Instant) {
        if !self.hosts.contains_key(&ip) && self.hosts.len() >= MAX_HOSTS {
            self.hosts
                .retain(|_, h| now.saturating_duration_since(h.last) < FORGET);
            if self.hosts.len() >= MAX_HOSTS {
                let oldest = self
                    .hosts
                    .iter()
                    .min_by_key(|(_, h)| h.last)
                    .map(|(k, _)| *k);
                if let Some(k) = oldest {
                    self.hosts.remove(&k);
                }
            }
        }
        let h = self.hosts.entry(ip).or_insert(Host {
            failures: 0,
            next: now,
            last: now,
        });
        h.failures = h.failures.saturating_add(1);
        h.last = now;
        h.next = h.next.max(now + self.delays.after(h.failures));
    }

    /// A login from `ip` succeeded: its failures are forgotten.
    pub(crate) fn succeeded(&mut self, ip: IpAddr) {
        self.hosts.remove(&ip);
    }

    /// Hosts remembered.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.hosts.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: IpAddr = IpAddr::V4(std::net::Ipv4Addr::new(10, 0, 0, 1));
    const B: IpAddr = IpAddr::V4(std::net::Ipv4Addr::new(10, 0, 0, 2));
    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn each_failure_makes_the_hosts_next_attempt_wait_longer() {
        let d = Delays::default();
        assert_eq!(
            (1..=7).map(|n| d.after(n).as_millis()).collect::<Vec<_>>(),
            vec![600, 1200, 2400, 4800, 9600, 10_000, 10_000]
        );
        assert_eq!(d.after(u32::MAX), d.cap);
        let mut p = Penalties::new(d);
        let t0 = Instant::now();
        // A clean host is judged at once.
        assert_eq!(p.admit(A, t0), t0);
        let mut t = t0;
        let mut waits = Vec::new();
        for _ in 0..5 {
            p.failed(A, t);
            let now = t + 10 * MS;
            let at = p.admit(A, now);
            waits.push((at - now).as_millis());
            t = at;
        }
        assert_eq!(waits, vec![590, 1190, 2390, 4790, 9590]);
        // Another host is not held up.
        assert_eq!(p.admit(B, t), t);
    }

    #[test]
    fn a_hosts_attempts_on_several_connections_are_judged_one_delay_apart() {
        let mut p = Penalties::new(Delays::default());
        let t0 = Instant::now();
        p.failed(A, t0);
        p.failed(A, t0);
        // Eight connections ask at once: 1.2 s apart, the first after the 1.2 s wait.
        let turns: Vec<u128> = (0..8).map(|_| (p.admit(A, t0) - t0).as_millis()).collect();
        assert_eq!(turns, (1..=8).map(|k| k * 1200).collect::<Vec<_>>());
    }

    #[test]
    fn success_or_a_quiet_spell_forgets_a_host() {
        let mut p = Penalties::new(Delays::default());
        let t0 = Instant::now();
        p.failed(A, t0);
        p.failed(B, t0);
        p.succeeded(A);
        assert_eq!(p.admit(A, t0), t0);
        let later = t0 + FORGET;
        assert_eq!(p.admit(B, later), later);
        assert_eq!(p.len(), 0);
    }

    #[test]
    fn the_table_stays_bounded() {
        let mut p = Penalties::new(Delays::default());
        let t0 = Instant::now();
        for i in 0..(MAX_HOSTS as u32 + 10) {
            p.failed(IpAddr::V4(i.into()), t0 + i * MS);
        }
        assert_eq!(p.len(), MAX_HOSTS);
    }
}
