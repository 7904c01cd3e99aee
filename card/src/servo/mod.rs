//! The card's servo cycle (pmac-variables §4.2, §6.6-§6.8; architecture §4): pure — the ring
//! application calls [`Servo::tick`] once per ring cycle with the card locked, after latching
//! the node feedback registers and before sending the command registers.
//!
//! Order of one tick:
//! 1. a `$$$` since the last tick resets every motor (killed, fresh position history);
//!    otherwise the latched `?` bits a host or PLC wrote (`M145=0`) go into the motors
//!    ([`registers::take_host_writes`]);
//! 2. the encoder conversion table ([`ect_pass`]): node register 0 → X:$0721… results;
//! 3. the interpreter's actions ([`actions`]): the program engine takes the C.S. ones, the
//!    motors take jog/home/kill/enable/open-loop/abort, CTRL-A, CTRL-K;
//! 4. ring fault (the card's latched X:$0003 bit 4): on its rising edge every motor is killed
//!    and the engine aborts its programs; while it stays latched every motor is kept killed
//!    (no command can close a loop: "nothing moves until `$$$`");
//! 5. the engine's `servo_tick` (PLC 0, trajectories) → per-motor program setpoints;
//! 6. every activated motor (Ix00 = 1): feedback from its Ix03 ECT result, flags from its
//!    Ix25 image X:$0F7n, `Motor::tick`, output written to its Ix02 register (node register 0,
//!    DAC << 8) and amplifier enable into the Y:$0F7n image bit 14; trips kill per
//!    [`TripScope`] and go to `engine.on_trip`;
//! 7. reports and registers ([`registers`]): `P`/`V`/`F`, `?` flags, D:$0028 …;
//!    ERR011 bookkeeping (a jog/home still moving); data gathering ([`gather`]);
//! 8. background: auxiliary flag copy ([`aux_copy`], I1000/I1002) and `engine.background`.

mod actions;
mod aux_copy;
mod ect_pass;
mod registers;

use crate::domain::{CsNum, MotorNum};
use crate::model::CardModel;
use crate::model::Space;
use crate::model::{gather_tick, CardState};
use crate::motion::flags::{FlagInputs, AMP_ENABLE_BIT};
use crate::motion::motor::{Motor, TickInput, TickOutput, TripScope};
use crate::motion::params::MotorParams;
use crate::program::{Commands, ProgramEngine};

use ect_pass::EctPass;

/// Servo cycles after an amplifier enable during which the amp-fault input is ignored: the
/// enable and the fault flag each take a few ring cycles to travel (spec §6.7, firmware 1.16D
/// "flags are transferred every 2 cycles"; the ring adds 2-3).
pub(crate) const AMP_FAULT_DELAY: u32 = 8;

/// Default I10: servo interrupt time in 1/2^23 ms (2258.7 Hz).
pub(crate) const DEFAULT_I10: f64 = 3_713_707.0;

/// The servo side of one card: motors, ECT state, program engine.
#[derive(Debug)]
pub struct Servo {
    /// The motors, index 0 = motor 1.
    pub motors: Vec<Motor>,
    /// The program engine (motion programs, PLCs).
    pub engine: ProgramEngine,
    ect: EctPass,
    resets_seen: u64,
    ring_fault_seen: bool,
    params: Vec<MotorParams>,
    ix02: Vec<u32>,
    outs: Vec<TickOutput>,
    /// Per motor: servo cycles the amplifier has been enabled (saturating).
    amp_on: Vec<u32>,
}

/// A `%` command register written through memory (an M-variable from a PLC or a host, `W`)
/// since the last tick becomes that C.S.'s feedrate override, as `%` would make it (seed
/// 6645-6650: `M197=P1*I10/100` is `&1%(P1)`). Negative values command 0.
fn feed_registers(card: &mut CardModel) {
    let i10 = card.state.peek_ivar(10).unwrap_or(DEFAULT_I10);
    let i10 = if i10.is_finite() && i10 > 0.0 {
        i10
    } else {
        DEFAULT_I10
    };
    for cs in 1..=card.state.limits().coords {
        if let Some(w) = card.state.take_feed_write(cs) {
            let pct = (w.max(0) as f64) * 100.0 / i10;
            if let Some(r) = card.run.cs.get_mut(usize::from(cs) - 1) {
                r.override_pct = pct;
            }
            card.push_action(crate::model::Action {
                motor: MotorNum::of(1),
                coord: CsNum::of(cs),
                kind: crate::model::ActionKind::Override(pct),
            });
        }
    }
}

impl Servo {
    /// A servo loop for `card` (one motor per profile motor, all killed).
    pub fn new(card: &CardModel) -> Self {
        let n = card.state.limits().motors as usize;
        Servo {
            motors: vec![Motor::new(); n],
            engine: ProgramEngine::new(),
            ect: EctPass::default(),
            resets_seen: card.resets(),
            ring_fault_seen: false,
            params: Vec::with_capacity(n),
            ix02: Vec::with_capacity(n),
            outs: Vec::with_capacity(n),
            amp_on: vec![0; n],
        }
    }

    /// Trajectory time of one servo cycle at 100 %, ms (I10 / 2^23).
    pub fn cycle_ms(card: &CardModel) -> f64 {
        let i10 = card.state.peek_ivar(10).unwrap_or(DEFAULT_I10);
        let i10 = if i10.is_finite() && i10 > 0.0 {
            i10
        } else {
            DEFAULT_I10
        };
        i10 / 8_388_608.0
    }

    /// One servo cycle at ring cycle `cycle` (see the module doc for the order). Program
    /// `CMD`s run through `cmd` (the card's command language).
    pub fn tick(&mut self, card: &mut CardModel, cmd: &mut dyn Commands, cycle: u64) {
        if card.resets() != self.resets_seen {
            self.resets_seen = card.resets();
            self.motors.iter_mut().for_each(|m| *m = Motor::new());
            self.ect = EctPass::default();
            self.ring_fault_seen = false;
        } else {
            registers::take_host_writes(card, &mut self.motors);
        }
        self.ect.run(&mut card.state);
        self.params.clear();
        self.ix02.clear();
        for x in 1..=self.motors.len() as u16 {
            self.params.push(MotorParams::from_state(&card.state, x));
            let ix02 = card.state.vars.i(100 * u32::from(x) + 2).unwrap_or(0.0);
            self.ix02.push(ix02.max(0.0) as u32);
        }
        feed_registers(card);
        for a in card.take_actions() {
            actions::apply_action(card, &mut self.motors, &self.params, &mut self.engine, &a);
        }
        actions::apply_updates(&mut self.engine, &mut self.motors);
        actions::disable_at_rest(card, &mut self.motors);
        let ring_fault = card.state.global.ring_fault;
        if ring_fault {
            if !self.ring_fault_seen {
                self.engine.on_ring_fault(card);
            }
            for m in self.motors.iter_mut().filter(|m| m.flags.amp_enabled) {
                m.kill();
            }
        }
        self.ring_fault_seen = ring_fault;
        let dt_ms = Self::cycle_ms(card);
        let setpoints = self
            .engine
            .servo_tick(card, cmd, &self.motors, cycle, dt_ms);
        actions::apply_updates(&mut self.engine, &mut self.motors);
        let mut trips = Vec::new();
        self.outs.clear();
        self.outs.resize(self.motors.len(), TickOutput::default());
        for k in 0..self.motors.len() {
            let (p, ix02) = (self.params[k], self.ix02[k]);
            if !p.active {
                continue;
            }
            let st = &mut card.state;
            let mut flags = FlagInputs::from_image(st.memory.read(Space::X, p.flag_addr), p.ix25);
            let on = &mut self.amp_on[k];
            *on = if self.motors[k].flags.amp_enabled {
                on.saturating_add(1)
            } else {
                0
            };
            if *on <= AMP_FAULT_DELAY {
                flags.amp_fault = false;
            }
            let inp = TickInput {
                feedback: st.read(Space::X, p.feedback_addr),
                flags,
                dt_ms,
                program: setpoints.get(k).copied().flatten(),
                background: true,
                capture: node_capture(st, ix02),
            };
            let out = self.motors[k].tick(&p, &inp);
            write_output(&mut card.state, &p, ix02, &out);
            self.outs[k] = out;
            if let Some(t) = out.trip {
                trips.push((k, t.scope));
            }
        }
        for (k, scope) in trips {
            self.trip(card, k, scope);
        }
        for (k, m) in self.motors.iter().enumerate() {
            if let Some(r) = card.run.motors.get_mut(k) {
                r.moving = m.closed_loop() && !m.trajectory().finished();
            }
        }
        registers::report(card, &self.motors);
        for (k, m) in self.motors.iter().enumerate() {
            let p = &self.params[k];
            if p.active {
                registers::write_motor_registers(
                    &mut card.state,
                    k as u16 + 1,
                    m,
                    p,
                    &self.outs[k],
                );
            }
        }
        gather_tick(card);
        registers::count_cycle(&mut card.state);
        registers::count_timers(&mut card.state);
        aux_copy::aux_copy(&mut card.state);
        self.engine.background(card, cmd, &self.motors);
        actions::apply_updates(&mut self.engine, &mut self.motors);
        let out = self.engine.take_output();
        card.push_output(&out);
    }

    /// Motor `k` (0-based) tripped: kill the motors its scope names, zero their outputs and
    /// tell the engine (which aborts the C.S. program).
    fn trip(&mut self, card: &mut CardModel, k: usize, scope: TripScope) {
        let victims: Vec<usize> = match scope {
            TripScope::Card => (0..self.motors.len()).collect(),
            TripScope::CoordSystem => match card.run.cs_of(k as u16 + 1) {
                Some(cs) => card
                    .run
                    .motors_in(cs)
                    .into_iter()
                    .map(|m| usize::from(m) - 1)
                    .collect(),
                None => vec![k],
            },
            TripScope::Motor | TripScope::ProgramOnly => Vec::new(),
        };
        for v in victims {
            if let (Some(m), Some(p)) = (self.motors.get_mut(v), self.params.get(v)) {
                if m.flags.amp_enabled || !m.flags.open_loop {
                    m.kill();
                }
                if p.active {
                    let ix02 = self.ix02.get(v).copied().unwrap_or(0);
                    write_output(&mut card.state, p, ix02, &TickOutput::default());
                    if let Some(o) = self.outs.get_mut(v) {
                        *o = TickOutput::default();
                    }
                }
            }
        }
        self.engine.on_trip(card, k, scope);
    }
}

/// Register 3 bit (station → card) saying register 1 holds a hardware capture (the station's
/// `ST_CAPTURED`, register bit 12: card and station share only the ring register layout). The
/// card keeps the 16-bit registers 1-3 in the upper 16 bits of its 24-bit words.
const NODE_CAPTURED: u32 = 1 << (12 + 8);

/// The hardware capture of the MACRO node a motor outputs to (Ix02): node register 1 (low 16
/// bits of the encoder count at the last capture-flag edge) when register 3 bit 12 is set.
fn node_capture(st: &CardState, ix02: u32) -> Option<u16> {
    let (space, addr) = output_addr(ix02, st.map().max_addr);
    let regs = st.node_feedback(st.node_at(space, addr)?);
    (regs[3] & NODE_CAPTURED != 0).then_some(((regs[1] >> 8) & 0xFFFF) as u16)
}

/// Ix02 target of a motor: (space, address). Bit 19 selects an X register; the address is
/// bits 0-15 (PMAC2) or 0-18 (Turbo, `max_addr`).
fn output_addr(ix02: u32, max_addr: u32) -> (Space, u32) {
    let space = if ix02 & (1 << 19) != 0 {
        Space::X
    } else {
        Space::Y
    };
    (space, ix02 & max_addr)
}

/// Write a motor's output: register 0 at Ix02, amplifier enable into its Ix25 image.
fn write_output(st: &mut CardState, p: &MotorParams, ix02: u32, out: &TickOutput) {
    let (space, addr) = output_addr(ix02, st.map().max_addr);
    st.write(space, addr, out.reg0);
    let flag_addr = p.flag_addr;
    let img = st.memory.read(Space::Y, flag_addr);
    let img = if out.amp_enable {
        img | AMP_ENABLE_BIT
    } else {
        img & !AMP_ENABLE_BIT
    };
    st.memory.write(Space::Y, flag_addr, img);
}
