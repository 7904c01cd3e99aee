//! The MI core's `MS SAVE` as an effect, driven by a real master ([`AuxMaster`], the card's
//! side, timeout 32 cycles) through a ring member: the reply is held until the write's result
//! is handed back, and the core itself never writes.

use super::*;
use crate::config::NodePlantConfig;
use crate::mi::Globals;
use mcc_ring::aux_channel::{AuxMaster, Outcome};
use mcc_ring::packet::{NodeRegs, Packet};
use mcc_ring::settings::RingSettings;

const TIMEOUT: u32 = 32;

struct Rig {
    mi: StationMi,
    member: RingMember,
    nodes: Vec<ServoNode>,
    master: AuxMaster,
    back: AuxWord,
}

impl Rig {
    fn new(state_file: Option<PathBuf>) -> Self {
        let factory = Setup {
            globals: Globals::from_check(8, 4, 4),
            nodes: [(0u8, NodePlantConfig::default())].into(),
        };
        Rig {
            mi: StationMi::new(factory, state_file),
            member: RingMember::new(RingSettings::new(0x80, 0x0F_0001)),
            nodes: vec![ServoNode::new(0, &NodePlantConfig::default())],
            master: AuxMaster::default(),
            back: AuxWord::IDLE,
        }
    }

    /// One ring cycle: the master's node-15 word passes the station (which puts in its armed
    /// reply word) and comes back; then the station ticks.
    fn cycle(&mut self) -> Option<Outcome> {
        let (out, (r2, r3)) = self.master.tick(self.back);
        let regs = NodeRegs {
            r2,
            r3,
            ..NodeRegs::default()
        };
        let fwd = self
            .member
            .route(Packet::new(0, AUX_NODE, regs))
            .forward
            .expect("the station forwards node 15");
        self.back = AuxWord::decode(fwd.regs.r2, fwd.regs.r3);
        self.mi.tick(&mut self.member, false, &mut self.nodes);
        out
    }

    /// Run up to `cycles` cycles; the outcome if the transaction ended.
    fn run(&mut self, cycles: u32) -> Option<Outcome> {
        (0..cycles).find_map(|_| self.cycle())
    }

    fn ask(&mut self, req: Request) -> Outcome {
        assert!(self.master.start(0, req, TIMEOUT));
        self.run(4 * TIMEOUT).expect("the transaction ends")
    }

    /// Start a SAVE and run until the core asks for its write.
    fn start_save(&mut self, req: Request) -> SaveJob {
        assert!(self.master.start(0, req, TIMEOUT));
        for _ in 0..TIMEOUT {
            assert_eq!(self.cycle(), None);
            if let Some(job) = self.mi.take_save_job() {
                return job;
            }
        }
        panic!("no save job");
    }
}

fn state_path(name: &str) -> PathBuf {
    std::env::temp_dir()
        .join(format!("mcc-station-mi-{}-{name}", std::process::id()))
        .join("station0.state")
}

#[test]
fn save_reply_is_held_until_the_result_and_the_tick_never_writes() {
    let path = state_path("held");
    let mut r = Rig::new(Some(path.clone()));
    assert_eq!(
        r.ask(Request::ConfigWrite(37.0)),
        Outcome::Reply(Reply::Done)
    );
    let job = r.start_save(Request::Command(StationCmd::Save));
    assert_eq!(job.path, path);
    assert_eq!(&job.setup, r.mi.setup(), "the setup at the SAVE");
    assert_eq!(job.setup.globals.config_number, 37);
    assert!(r.mi.saving());
    // ten times the master's timeout: it keeps waiting, and nothing is written
    assert_eq!(r.run(10 * TIMEOUT), None, "the reply is held");
    assert!(r.master.busy());
    assert!(!path.exists(), "the core wrote the file");
    assert_eq!(r.mi.take_save_job(), None, "one job per SAVE");
    r.mi.save_done(SaveDone {
        token: job.token,
        result: Ok(()),
    });
    assert!(!r.mi.saving());
    assert_eq!(r.run(TIMEOUT), Some(Outcome::Reply(Reply::Done)));
    assert!(!path.exists());
    assert_eq!(r.mi.status_extra()["mi"]["saving"], false);
}

#[test]
fn a_failed_write_answers_save_failed() {
    let mut r = Rig::new(Some(state_path("failed")));
    // `MS{node},C4` is SAVE as well
    let job = r.start_save(Request::CCommand(4, 0.0));
    assert_eq!(r.mi.status_extra()["mi"]["saving"], true);
    assert_eq!(r.run(3 * TIMEOUT), None);
    r.mi.save_done(SaveDone {
        token: job.token,
        result: Err("No space left on device".into()),
    });
    assert_eq!(
        r.run(TIMEOUT),
        Some(Outcome::Reply(Reply::Error(slave_error::SAVE_FAILED)))
    );
    // the station is usable again
    assert_eq!(
        r.ask(Request::ReadMi(8)),
        Outcome::Reply(Reply::Value(8.0, ValueFormat::Decimal))
    );
}

#[test]
fn requests_while_saving_are_busy_and_a_late_result_is_dropped() {
    let mut r = Rig::new(Some(state_path("busy")));
    let job = r.start_save(Request::Command(StationCmd::Save));
    // the card gives up on the SAVE (its `$$$`) and asks something else, a SAVE included
    r.master.abort();
    r.run(3);
    for req in [
        Request::ReadMi(8),
        Request::WriteMi(8, 16.0),
        Request::Command(StationCmd::Reset),
        Request::Command(StationCmd::Save),
    ] {
        assert_eq!(
            r.ask(req),
            Outcome::Reply(Reply::Error(slave_error::BUSY)),
            "{req:?}"
        );
        r.run(2);
    }
    assert_eq!(r.mi.take_save_job(), None, "no second write meanwhile");
    assert_eq!(
        r.mi.setup().globals.check_period,
        8,
        "the write was refused"
    );
    // the result arrives with nobody waiting: dropped; a stale token changes nothing
    r.mi.save_done(SaveDone {
        token: job.token,
        result: Ok(()),
    });
    r.mi.save_done(SaveDone {
        token: job.token,
        result: Ok(()),
    });
    assert!(!r.mi.saving());
    assert_eq!(
        r.ask(Request::ReadMi(8)),
        Outcome::Reply(Reply::Value(8.0, ValueFormat::Decimal))
    );
}

#[test]
fn a_station_without_a_state_file_refuses_save_at_once() {
    let mut r = Rig::new(None);
    assert_eq!(
        r.ask(Request::Command(StationCmd::Save)),
        Outcome::Reply(Reply::Error(slave_error::SAVE_FAILED))
    );
    assert_eq!(r.mi.take_save_job(), None);
    assert!(!r.mi.saving());
}
