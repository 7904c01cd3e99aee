//! The shared card test rig: a PMAC2 card with motors 1-8 on their MACRO nodes, a loopback
//! plant standing in for the ring and the stations, and helpers to run lines and ticks. Used
//! by the unit tests of the core and the servo loop, the scenario tests and the benchmarks, so
//! every test builds its card the same way. Pure.

use crate::domain::Profile;
use crate::lang::{Card, Session};
use crate::model::CardModel;
use crate::program::Commands;
use crate::servo::Servo;

/// Motors in the rig.
pub const MOTORS: usize = 8;
/// Servo nodes of motors 1-8.
pub const NODES: [usize; 8] = [0, 1, 4, 5, 8, 9, 12, 13];

/// A crude plant per node: one DAC bit accelerates 0.04 counts/cycle², like the default
/// station plant. Feeds register 0 (1/32 counts) and register 3 (healthy FAULT flag).
#[derive(Debug, Clone, Default)]
pub struct LoopbackPlant {
    pos: [f64; 16],
    vel: [f64; 16],
}

impl LoopbackPlant {
    /// One cycle: take the command registers of `nodes`, integrate, latch the feedback.
    pub fn step(&mut self, card: &mut CardModel, nodes: &[usize]) {
        for &n in nodes {
            let cmd = card.state.node_command(n);
            let dac = ((cmd[0] << 8) as i32 >> 8) as f64 / 256.0;
            let enabled = cmd[3] & crate::motion::flags::AMP_ENABLE_BIT != 0;
            let acc = if enabled { dac * 0.04 } else { 0.0 };
            let v = &mut self.vel[n % 16];
            *v = *v * 0.999 + acc;
            self.pos[n % 16] += *v;
            let r0 = ((self.pos[n % 16] * 32.0).round() as i64 as u32) & 0xFF_FFFF;
            card.state.set_node_feedback(
                n,
                [r0, 0, 0, crate::motion::flags::FlagInputs::healthy_image()],
            );
        }
    }

    /// Position of node `n`, counts.
    pub fn position(&self, n: usize) -> f64 {
        self.pos[n % 16]
    }
}

/// A PMAC2 card with motors 1-8 activated on their default MACRO nodes and the auxiliary
/// flag copy enabled for those nodes (what the ring start-up does).
pub fn bench_card() -> Card {
    let mut card = Card::new(Profile::Pmac2);
    let mut s = Session::default();
    let _ = card.command_line(&mut s, b"I1000=$3333 I1002=$3333");
    for m in 1..=MOTORS {
        let _ = card.command_line(&mut s, format!("I{m}00=1").as_bytes());
    }
    card
}

/// A card, its servo loop and the loopback plant, ticked together (no ring).
#[derive(Debug)]
pub struct Rig {
    /// The card (model and interpreter).
    pub card: Card,
    /// Its servo loop.
    pub servo: Servo,
    /// The plant behind its nodes.
    pub plant: LoopbackPlant,
    /// The session lines run in.
    pub session: Session,
    /// Ring cycle of the next tick.
    pub cycle: u64,
}

impl Default for Rig {
    fn default() -> Self {
        Rig::new()
    }
}

impl Rig {
    /// [`bench_card`] with its servo loop at cycle 0.
    pub fn new() -> Self {
        let card = bench_card();
        let servo = Servo::new(&card.model);
        Rig {
            card,
            servo,
            plant: LoopbackPlant::default(),
            session: Session::default(),
            cycle: 0,
        }
    }

    /// Run a command line; the reply as text.
    pub fn cmd(&mut self, line: &str) -> String {
        String::from_utf8_lossy(&self.card.command_line(&mut self.session, line.as_bytes()))
            .into_owned()
    }

    /// `n` servo cycles: plant step, then the servo tick.
    pub fn run(&mut self, n: u64) {
        for _ in 0..n {
            self.plant.step(&mut self.card.model, &NODES);
            let (model, mut cmds) = self.card.split();
            self.servo.tick(model, &mut cmds, self.cycle);
            self.cycle += 1;
        }
    }
}

/// Program commands run through a card's interpreter.
pub(crate) fn _assert_commands<C: Commands>() {}
