//! Who may use a host port (card ASCII and Ethernet ports, the daisy chain, the EMCL bus): the
//! connection limit, which connection makes room for a new one, and the idle and
//! stalled-request limits. Pure: the servers pass the time (any monotonic origin) and close
//! the connections this table names.
//!
//! \[DECISION\] A port serves at most `max_connections` hosts. A new host over the limit evicts
//! the connection that has been idle longest (no request under way, nothing sent for at least
//! `evict_idle_after`); if every connection is busy or recently active, the new host is
//! refused with a message naming the limit. So silent connections can never lock a
//! well-behaved host out, and a host that is actively polling is never evicted for a newcomer.

use std::collections::BTreeMap;
use std::time::Duration;

use serde::{Deserialize, Serialize};

/// Host-port limits (`[host]` in the cluster config).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HostLimits {
    /// Connections per port served at once (card ports; the daisy chain and EMCL bus use
    /// their own, smaller defaults unless this is set lower).
    pub max_connections: usize,
    /// A connection that sends nothing for this long is closed (0 = never).
    pub idle_timeout_s: u64,
    /// A request whose first byte has arrived must be complete within this (PMAC Ethernet
    /// packets, EMCL frames; an ASCII terminal line gets [`ASCII_LINE_FACTOR`] times this,
    /// because a person may be typing it).
    pub request_timeout_ms: u64,
    /// A connection idle at least this long may be evicted to make room for a new host.
    pub evict_idle_after_ms: u64,
}

/// An ASCII line may take this many request timeouts (a person types it).
pub const ASCII_LINE_FACTOR: u32 = 6;
/// Largest `max_connections` accepted.
pub const MAX_CONNECTIONS_LIMIT: usize = 4096;

impl Default for HostLimits {
    fn default() -> Self {
        HostLimits {
            max_connections: 64,
            idle_timeout_s: 600,
            request_timeout_ms: 10_000,
            evict_idle_after_ms: 5_000,
        }
    }
}

impl HostLimits {
    /// Idle timeout (`None`: never).
    pub fn idle_timeout(&self) -> Option<Duration> {
        (self.idle_timeout_s > 0).then(|| Duration::from_secs(self.idle_timeout_s))
    }

    /// Longest time from a request's first byte to its last.
    pub fn request_timeout(&self) -> Duration {
        Duration::from_millis(self.request_timeout_ms)
    }

    /// Longest time from an ASCII line's first byte to its `<CR>`.
    pub fn line_timeout(&self) -> Duration {
        self.request_timeout() * ASCII_LINE_FACTOR
    }

    /// Idle time that makes a connection evictable.
    pub fn evict_idle_after(&self) -> Duration {
        Duration::from_millis(self.evict_idle_after_ms)
    }

    /// These limits with at most `max` connections.
    pub fn with_max(mut self, max: usize) -> Self {
        self.max_connections = self.max_connections.min(max);
        self
    }

    /// Why these limits are unusable (`(key, problem)`), if they are.
    pub fn problem(&self) -> Option<(&'static str, String)> {
        if self.max_connections == 0 || self.max_connections > MAX_CONNECTIONS_LIMIT {
            return Some((
                "host.max_connections",
                format!(
                    "{} is not a connection count in 1..={MAX_CONNECTIONS_LIMIT}",
                    self.max_connections
                ),
            ));
        }
        if self.request_timeout_ms == 0 || self.request_timeout_ms > 3_600_000 {
            return Some((
                "host.request_timeout_ms",
                format!(
                    "{} is not a timeout in 1..=3600000 ms",
                    self.request_timeout_ms
                ),
            ));
        }
        if self.idle_timeout_s > 7 * 86_400 {
            return Some((
                "host.idle_timeout_s",
                format!(
                    "{} is longer than a week (0 = never close idle connections)",
                    self.idle_timeout_s
                ),
            ));
        }
        if self.evict_idle_after_ms > 3_600_000 {
            return Some((
                "host.evict_idle_after_ms",
                format!(
                    "{} is not a time in 0..=3600000 ms",
                    self.evict_idle_after_ms
                ),
            ));
        }
        None
    }
}

/// The answer to a new host.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Admission {
    /// Serve it as connection `id`.
    Accept(u64),
    /// Serve it as connection `id` after closing connection `evict` (idle for `idle`).
    Evict {
        /// The new connection.
        id: u64,
        /// The connection to close.
        evict: u64,
        /// How long the evicted connection had been idle.
        idle: Duration,
    },
    /// Refuse it: `open` connections, none idle long enough to make room.
    Refuse {
        /// Connections open.
        open: usize,
    },
}

#[derive(Debug, Clone, Copy)]
struct Conn {
    last: Duration,
    busy: bool,
}

/// The connections of one port (see the module docs).
#[derive(Debug, Clone)]
pub struct ConnTable {
    limits: HostLimits,
    conns: BTreeMap<u64, Conn>,
    next: u64,
}

impl ConnTable {
    /// An empty table under `limits`.
    pub fn new(limits: HostLimits) -> Self {
        ConnTable {
            limits,
            conns: BTreeMap::new(),
            next: 1,
        }
    }

    /// The limits.
    pub fn limits(&self) -> &HostLimits {
        &self.limits
    }

    /// Connections open.
    pub fn open(&self) -> usize {
        self.conns.len()
    }

    /// A new host at time `now`.
    pub fn admit(&mut self, now: Duration) -> Admission {
        let mut evict = None;
        if self.conns.len() >= self.limits.max_connections.max(1) {
            let min_idle = self.limits.evict_idle_after();
            let victim = self
                .conns
                .iter()
                .filter(|(_, c)| !c.busy && now.saturating_sub(c.last) >= min_idle)
                .min_by_key(|(id, c)| (c.last, **id))
                .map(|(id, c)| (*id, now.saturating_sub(c.last)));
            match victim {
                Some(v) => evict = Some(v),
                None => {
                    return Admission::Refuse {
                        open: self.conns.len(),
                    }
                }
            }
        }
        let id = self.next;
        self.next += 1;
        self.conns.insert(
            id,
            Conn {
                last: now,
                busy: false,
            },
        );
        match evict {
            Some((victim, idle)) => {
                self.conns.remove(&victim);
                Admission::Evict {
                    id,
                    evict: victim,
                    idle,
                }
            }
            None => Admission::Accept(id),
        }
    }

    /// Connection `id` did something at `now` (bytes in or out); `busy` = a request of it is
    /// under way (partly received, being served or its reply being sent).
    pub fn touch(&mut self, id: u64, now: Duration, busy: bool) {
        if let Some(c) = self.conns.get_mut(&id) {
            c.last = now;
            c.busy = busy;
        }
    }

    /// Connection `id` is gone.
    pub fn close(&mut self, id: u64) {
        self.conns.remove(&id);
    }

    /// Is `id` still in the table (not evicted or closed)?
    pub fn contains(&self, id: u64) -> bool {
        self.conns.contains_key(&id)
    }
}

/// The line a refused host reads before the port closes.
pub fn refusal_message(what: &str, open: usize) -> String {
    format!(
        "mcc: {what} is full: {open} connections open, none idle; try again later (host.max_connections)\r\n"
    )
}

/// The line an evicted host reads before the port closes.
pub fn eviction_message(what: &str, idle: Duration) -> String {
    format!(
        "\r\nmcc: {what}: connection closed after {} s idle to let a new host in\r\n",
        idle.as_secs()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    fn limits(max: usize) -> HostLimits {
        HostLimits {
            max_connections: max,
            ..HostLimits::default()
        }
    }

    #[test]
    fn below_the_limit_every_host_is_accepted() {
        let mut t = ConnTable::new(limits(3));
        assert_eq!(t.admit(ms(0)), Admission::Accept(1));
        assert_eq!(t.admit(ms(1)), Admission::Accept(2));
        assert_eq!(t.admit(ms(2)), Admission::Accept(3));
        assert_eq!(t.open(), 3);
    }

    #[test]
    fn at_the_limit_the_longest_idle_connection_makes_room() {
        let mut t = ConnTable::new(limits(3));
        for i in 0..3 {
            t.admit(ms(i));
        }
        // 1 polls, 2 and 3 stay silent: 2 has been idle longest.
        t.touch(1, ms(9_000), false);
        let a = t.admit(ms(10_000));
        assert_eq!(
            a,
            Admission::Evict {
                id: 4,
                evict: 2,
                idle: ms(9_999)
            }
        );
        assert!(!t.contains(2) && t.contains(4));
        assert_eq!(t.open(), 3);
    }

    #[test]
    fn busy_and_recently_active_connections_are_never_evicted() {
        let mut t = ConnTable::new(limits(2));
        t.admit(ms(0));
        t.admit(ms(0));
        t.touch(1, ms(100), true); // a request under way for ages
        t.touch(2, ms(8_000), false); // polled 2 s ago
        assert_eq!(t.admit(ms(10_000)), Admission::Refuse { open: 2 });
        assert_eq!(t.open(), 2);
        // Once 2 has been quiet for the eviction time, it makes room.
        assert_eq!(
            t.admit(ms(13_000)),
            Admission::Evict {
                id: 3,
                evict: 2,
                idle: ms(5_000)
            }
        );
    }

    #[test]
    fn closed_connections_free_their_slot() {
        let mut t = ConnTable::new(limits(1));
        t.admit(ms(0));
        t.touch(1, ms(0), true);
        assert_eq!(t.admit(ms(1)), Admission::Refuse { open: 1 });
        t.close(1);
        assert_eq!(t.admit(ms(2)), Admission::Accept(2));
    }

    #[test]
    fn limits_are_checked_and_named() {
        assert_eq!(HostLimits::default().problem(), None);
        let bad = HostLimits {
            max_connections: 0,
            ..HostLimits::default()
        };
        assert_eq!(bad.problem().map(|p| p.0), Some("host.max_connections"));
        let bad = HostLimits {
            request_timeout_ms: 0,
            ..HostLimits::default()
        };
        assert_eq!(bad.problem().map(|p| p.0), Some("host.request_timeout_ms"));
        assert_eq!(
            HostLimits::default().line_timeout(),
            Duration::from_secs(60)
        );
        assert_eq!(HostLimits::default().with_max(16).max_connections, 16);
        assert!(refusal_message("card0 ASCII port", 64).contains("64 connections"));
    }
}
