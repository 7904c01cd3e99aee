//! `MS SAVE` as an effect: the station's pure core never writes its state file. A SAVE hands
//! the runtime a [`SaveJob`] (the setup as it was at the SAVE, and where it goes); the runtime
//! writes it off the tick ([`crate::save_io`]) and feeds the [`SaveDone`] back at a later tick,
//! when the held reply is answered: Done, or `SAVE_FAILED` as before.
//!
//! One save is in flight at a time [DECISION, issue 24]: until its result is back the station
//! is busy, and every other auxiliary request (a second SAVE included) is refused with
//! [`slave_error::BUSY`]. The master of the SAVE
//! itself is not refused: it keeps waiting (the station streams `WORKING`). A request can only
//! arrive meanwhile once that master gave up (its card's `$$$`, or a write longer than the
//! master's wait), so the station never reads or writes its state file while a write is
//! still going on.

use std::path::PathBuf;

use mcc_ring::aux_channel::{slave_error, Reply};

use crate::mi::Setup;

/// A write the runtime performs for the core: `setup` to `path`, atomically.
#[derive(Clone, Debug, PartialEq)]
pub struct SaveJob {
    /// Which save this is (its result carries it back).
    pub token: u64,
    /// The station's state file.
    pub path: PathBuf,
    /// The setup at the moment of the SAVE.
    pub setup: Setup,
}

/// How a [`SaveJob`] ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SaveDone {
    /// The job's token.
    pub token: u64,
    /// Ok, or why the write failed.
    pub result: Result<(), String>,
}

/// The save in flight: the master's transaction tag its reply is held for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct InFlight {
    token: u64,
    tag: u8,
}

/// The core's side of the SAVE effect: at most one job waiting to be taken, and the save in
/// flight.
#[derive(Clone, Debug, Default)]
pub struct SaveEffects {
    next_token: u64,
    outbox: Option<SaveJob>,
    in_flight: Option<InFlight>,
}

impl SaveEffects {
    /// A save is in flight: the station is busy.
    pub fn busy(&self) -> bool {
        self.in_flight.is_some()
    }

    /// Start a save of `setup` to `path`, its reply held for transaction `tag`. The caller
    /// checks [`SaveEffects::busy`] first; a second start while busy is refused (false).
    pub fn start(&mut self, path: PathBuf, setup: Setup, tag: u8) -> bool {
        if self.busy() {
            return false;
        }
        self.next_token += 1;
        let token = self.next_token;
        self.outbox = Some(SaveJob { token, path, setup });
        self.in_flight = Some(InFlight { token, tag });
        true
    }

    /// The job to hand to the runtime (once).
    pub fn take_job(&mut self) -> Option<SaveJob> {
        self.outbox.take()
    }

    /// The runtime finished a job: the transaction tag and the reply its master waits for.
    /// None for a result that belongs to no save in flight (a stale or unknown token).
    pub fn finish(&mut self, done: &SaveDone) -> Option<(u8, Reply)> {
        let f = self.in_flight.filter(|f| f.token == done.token)?;
        self.in_flight = None;
        if self.outbox.as_ref().is_some_and(|j| j.token == done.token) {
            self.outbox = None;
        }
        let reply = match done.result {
            Ok(()) => Reply::Done,
            Err(_) => Reply::Error(slave_error::SAVE_FAILED),
        };
        Some((f.tag, reply))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mi::Globals;

    fn setup(n: u32) -> Setup {
        Setup {
            globals: Globals {
                config_number: n,
                ..Globals::from_check(8, 4, 4)
            },
            nodes: Default::default(),
        }
    }

    #[test]
    fn one_save_in_flight_answered_by_its_own_result() {
        let mut e = SaveEffects::default();
        assert!(!e.busy());
        assert!(e.start("a.state".into(), setup(3), 5));
        assert!(e.busy());
        assert!(!e.start("a.state".into(), setup(4), 6), "busy");
        let job = e.take_job().unwrap();
        assert_eq!(job.setup, setup(3), "the setup as it was at the SAVE");
        assert_eq!(e.take_job(), None, "handed over once");
        let stale = SaveDone {
            token: job.token + 1,
            result: Ok(()),
        };
        assert_eq!(e.finish(&stale), None);
        assert!(e.busy());
        let ok = SaveDone {
            token: job.token,
            result: Ok(()),
        };
        assert_eq!(e.finish(&ok), Some((5, Reply::Done)));
        assert!(!e.busy());
        assert_eq!(e.finish(&ok), None, "answered once");
        assert!(e.start("a.state".into(), setup(4), 6));
        let job = e.take_job().unwrap();
        let failed = SaveDone {
            token: job.token,
            result: Err("disk full".into()),
        };
        assert_eq!(
            e.finish(&failed),
            Some((6, Reply::Error(slave_error::SAVE_FAILED)))
        );
    }
}
