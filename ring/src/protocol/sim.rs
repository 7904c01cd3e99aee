//! A deterministic in-process lockstep ring: N [`MemberCore`]s and their [`RingApp`]s, frames
//! delivered hop by hop in one thread (architecture §3.3, `lockstep` clock).
//!
//! [`RingSim::step`] runs one ring cycle k at simulated time k × period: the synchronizing
//! master starts cycle k (sends, then ticks) and the frame travels member to member (each forwards, then ticks on the sync packet, or unlocked
//! on a frame without one: a dropped sync packet, a dark frame downstream of a cut) until it
//! returns. Members that got no frame at all run cycle k on their holdover clock three quarters
//! of a period later. Every tick runs the member's ring check, then its app.
//! A frame a `delay-us` fault holds lands in the cycle it was sent in, however long the hold:
//! the lockstep ring waits for it as the member processes' paced and lockstep clocks do, and
//! the simulator has no wall clock to lose (`docs/ring.md`, Faults). Same faults and seeds →
//! same run.

use std::collections::VecDeque;

use crate::check::CheckFault;
use crate::core::{MemberCore, RingApp};
use crate::fault::{FaultSpec, Outgoing};

/// How a member ran its tick in a cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TickKind {
    /// Synchronizing master starting the cycle.
    Start,
    /// On the sync packet's arrival.
    Sync,
    /// On a frame of a new cycle that carried no sync packet (dropped, or a dark frame).
    Unlocked,
    /// On its own holdover clock.
    Holdover,
}

/// What one [`RingSim::step`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StepReport {
    /// The ring cycle run.
    pub cycle: u64,
    /// The sync packet came back to the synchronizing master in this cycle.
    pub completed: bool,
    /// Per member: the cycle it ran and how, if it ran one.
    pub ticks: Vec<Option<(u64, TickKind)>>,
    /// Ring faults declared in this cycle: (member index, why).
    pub faults: Vec<(usize, CheckFault)>,
    /// Frames delivered in this cycle.
    pub hops: usize,
}

/// Most frames delivered in one cycle per member (guards against a routing loop).
pub const MAX_HOPS_PER_MEMBER: usize = 64;

/// The in-process lockstep ring.
pub struct RingSim<A: RingApp> {
    members: Vec<MemberCore>,
    apps: Vec<A>,
    period_ns: u64,
    next_cycle: u64,
    sync_master: Option<usize>,
}

impl<A: RingApp> RingSim<A> {
    /// A ring of these members in ring order (member i sends to member i+1 mod N); the
    /// first cycle run is cycle 1.
    pub fn new(members: Vec<(MemberCore, A)>, period_ns: u64) -> Self {
        let (members, apps): (Vec<_>, Vec<_>) = members.into_iter().unzip();
        let sync_master = members.iter().position(|m| m.is_sync_master());
        RingSim {
            members,
            apps,
            period_ns: period_ns.max(1),
            next_cycle: 1,
            sync_master,
        }
    }

    /// Number of members.
    pub fn len(&self) -> usize {
        self.members.len()
    }

    /// The ring has no member.
    pub fn is_empty(&self) -> bool {
        self.members.is_empty()
    }

    /// Index of the synchronizing master.
    pub fn sync_master(&self) -> Option<usize> {
        self.sync_master
    }

    /// The last cycle run (0 before the first step).
    pub fn cycle(&self) -> u64 {
        self.next_cycle - 1
    }

    /// Member core `i`. Panics if `i` is out of range (test harness API).
    pub fn member(&self, i: usize) -> &MemberCore {
        &self.members[i]
    }

    /// Member core `i`, mutable.
    pub fn member_mut(&mut self, i: usize) -> &mut MemberCore {
        &mut self.members[i]
    }

    /// App of member `i`.
    pub fn app(&self, i: usize) -> &A {
        &self.apps[i]
    }

    /// App of member `i`, mutable.
    pub fn app_mut(&mut self, i: usize) -> &mut A {
        &mut self.apps[i]
    }

    /// Inject a fault on member `i`'s send path.
    pub fn inject(&mut self, i: usize, spec: FaultSpec) -> Result<(), crate::fault::FaultError> {
        self.members
            .get_mut(i)
            .ok_or(crate::fault::FaultError::NoMember(i))?
            .inject_fault(spec)
    }

    /// Clear every fault of member `i`.
    pub fn clear_faults(&mut self, i: usize) {
        if let Some(m) = self.members.get_mut(i) {
            m.clear_faults();
        }
    }

    /// The broken link, from every member's last received cycle (see [`locate_break`]).
    pub fn locate_break(&self) -> Option<usize> {
        let last: Vec<Option<u64>> = self.members.iter().map(|m| m.last_rx_cycle()).collect();
        locate_break(&last, self.sync_master?, self.cycle())
    }

    /// Run `n` cycles; the reports of every cycle.
    pub fn run(&mut self, n: u64) -> Vec<StepReport> {
        (0..n).map(|_| self.step()).collect()
    }

    /// Run one ring cycle.
    pub fn step(&mut self) -> StepReport {
        let k = self.next_cycle;
        self.next_cycle += 1;
        let t = k.saturating_mul(self.period_ns);
        let n = self.members.len();
        let mut rep = StepReport {
            cycle: k,
            ticks: vec![None; n],
            ..Default::default()
        };
        let mut queue = VecDeque::new();
        if let Some(sm) = self.sync_master {
            let outs = self.members[sm].start_cycle(k, t);
            self.deliver(sm, outs, &mut queue);
            self.tick(sm, k, TickKind::Start, &mut rep);
            self.run_hops(&mut queue, k, t, &mut rep);
        }
        let late = t + self.period_ns * 3 / 4;
        for i in 0..n {
            if let Some(c) = self.members[i].on_holdover(late) {
                self.tick(i, c, TickKind::Holdover, &mut rep);
            }
        }
        rep
    }

    fn tick(&mut self, i: usize, c: u64, kind: TickKind, rep: &mut StepReport) {
        let time = c.saturating_mul(self.period_ns);
        if let Some(f) = self.members[i].tick_app(&mut self.apps[i], c, time) {
            rep.faults.push((i, f));
        }
        rep.ticks[i] = Some((c, kind));
    }

    /// Put `from`'s frames on its link. A `delay-us` hold (`o.delay_us`) changes nothing here:
    /// the lockstep ring waits for the frame, which lands in this cycle in its order.
    fn deliver(
        &mut self,
        from: usize,
        outs: Vec<Outgoing>,
        queue: &mut VecDeque<(usize, Vec<u8>)>,
    ) {
        let to = (from + 1) % self.members.len();
        queue.extend(outs.into_iter().map(|o| (to, o.frame_bytes)));
    }

    fn run_hops(
        &mut self,
        queue: &mut VecDeque<(usize, Vec<u8>)>,
        k: u64,
        t: u64,
        rep: &mut StepReport,
    ) {
        let limit = MAX_HOPS_PER_MEMBER * self.members.len();
        while let Some((to, bytes)) = queue.pop_front() {
            if rep.hops >= limit {
                queue.clear();
                break;
            }
            rep.hops += 1;
            let ev = self.members[to].on_frame(&bytes, t);
            self.deliver(to, ev.outgoing, queue);
            if ev.cycle_complete == Some(k) {
                rep.completed = true;
            }
            if let Some(c) = ev.sync {
                self.tick(to, c, TickKind::Sync, rep);
            } else if let Some(c) = ev.unlocked {
                self.tick(to, c, TickKind::Unlocked, rep);
            }
        }
    }
}

/// Name the broken ring link from what each member last received.
///
/// `last_rx_cycle[i]` is the ring cycle of the last frame member i received from its upstream
/// neighbour (i-1 mod N). Walking the ring from the synchronizing master's downstream
/// neighbour around to the sync master itself, the first member that did not receive cycle
/// `cycle` is the first one cut off; the broken link is the one its upstream neighbour sends
/// on. Returns that link's index (= the sending member's position), or None if everybody got
/// the current cycle.
pub fn locate_break(
    last_rx_cycle: &[Option<u64>],
    sync_master: usize,
    cycle: u64,
) -> Option<usize> {
    let n = last_rx_cycle.len();
    if n == 0 || sync_master >= n {
        return None;
    }
    (1..=n)
        .map(|d| (sync_master + d) % n)
        .find(|i| !matches!(last_rx_cycle[*i], Some(c) if c >= cycle))
        .map(|i| (i + n - 1) % n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn break_location() {
        // 4 members, sync master 0, cycle 10; members 2 and 3 and 0 cut off: link 1 broken.
        assert_eq!(
            locate_break(&[Some(9), Some(10), Some(7), Some(7)], 0, 10),
            Some(1)
        );
        assert_eq!(
            locate_break(&[Some(10), Some(10), Some(10), Some(10)], 0, 10),
            None
        );
        // only the sync master misses the return: the last link (3 -> 0) is broken.
        assert_eq!(
            locate_break(&[Some(9), Some(10), Some(10), Some(10)], 0, 10),
            Some(3)
        );
        // sync master at 2: walk 3, 0, 1, 2
        assert_eq!(locate_break(&[None, None, None, Some(10)], 2, 10), Some(3));
        assert_eq!(locate_break(&[], 0, 1), None);
    }
}
