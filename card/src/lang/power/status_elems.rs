//! Status elements a Power PMAC computes every servo cycle, read from the motion core's state
//! of that moment (issue 25 item 2): `Sys.ServoCount` / `Sys.Time`, the motor status bits
//! (each "equivalent to bit n of `Motor[x].Status[w]`", seed 000 L29397-30820), the motor's
//! positions and velocity, and the C.S. program and time-base state (L25827-25900,
//! L21512-21546, L26268).
//!
//! Units: positions in motor units (counts: the model's position scale is 1, as the seed's
//! `Motor[x].PosSf` default), velocities in motor units per servo cycle, `Sys.Time` in
//! seconds, time bases in ms of program time per servo cycle (`%100` = `Sys.ServoPeriod`).

use super::catalog::St;
use super::elements::Key;
use crate::model::CardModel;

/// Motor status bit elements: (element, word of `Motor[x].Status[]`, bit), seed 000.
const MOTOR_BITS: &[(&str, usize, u32)] = &[
    ("TriggerMove", 0, 31),    // L30815
    ("HomeInProgress", 0, 30), // L29961
    ("MinusLimit", 0, 29),     // L30303
    ("PlusLimit", 0, 28),      // L30388
    ("FeWarn", 0, 27),         // L29816
    ("FeFatal", 0, 26),        // L29797
    ("LimitStop", 0, 25),      // L30255
    ("AmpFault", 0, 24),       // L29421
    ("HomeComplete", 0, 15),   // L29940
    ("DesVelZero", 0, 14),     // L29762
    ("ClosedLoop", 0, 13),     // L29535
    ("AmpEna", 0, 12),         // L29397
    ("InPos", 0, 11),          // L30138
    ("BlockRequest", 0, 9),    // L29500
    ("BlDir", 1, 28),          // L29487
];

use super::elements::servo_period_ms;

/// The value of status element `name` of `k`, when it is one the motion core feeds.
pub(super) fn read(card: &CardModel, k: &Key, name: &str) -> Option<f64> {
    match k.st {
        St::Sys => sys(card, name),
        St::Motor => motor(card, k.idx as usize, name),
        St::Coord => coord(card, k.idx as usize, name),
        St::Plc => plc(card, k.idx as usize, name),
        _ => None,
    }
}

/// `Plc[i].Active` (enabled, also while paused) and `Plc[i].Running` (enabled and not paused)
/// [DECISION: the seed names them without an entry; the Power PMAC meanings].
fn plc(card: &CardModel, i: usize, name: &str) -> Option<f64> {
    let p = card.run.plc.get(i)?;
    match name {
        "Active" => Some(f64::from(u8::from(p.enabled))),
        "Running" => Some(f64::from(u8::from(p.enabled && !p.paused))),
        _ => None,
    }
}

fn sys(card: &CardModel, name: &str) -> Option<f64> {
    let n = card.state.servo_cycles;
    match name {
        // A 32-bit counter (seed L53880): it wraps.
        "ServoCount" => Some(f64::from(n as u32)),
        "Time" => Some(n as f64 * servo_period_ms(card) / 1000.0),
        _ => None,
    }
}

fn motor(card: &CardModel, x: usize, name: &str) -> Option<f64> {
    if let Some(&(_, w, bit)) = MOTOR_BITS.iter().find(|(n, _, _)| *n == name) {
        let words = super::exec::motor_status(card, u16::try_from(x).ok()?);
        return Some(f64::from((words[w] >> bit) & 1));
    }
    // (position, velocity, following error) in counts as the servo last reported them;
    // following error = commanded − actual.
    let (pos, vel, fe) = card.run.report.get(x).copied()?;
    match name {
        "ActPos" => Some(pos),
        "DesPos" => Some(pos + fe),
        "ActVel" => Some(vel),
        _ => None,
    }
}

fn coord(card: &CardModel, x: usize, name: &str) -> Option<f64> {
    let flags = card.state.coords.get(x)?;
    let run = card.run.cs.get(x)?;
    let b = |v: bool| Some(f64::from(u8::from(v)));
    // The motor bits over the C.S.'s motors sit where a motor's do in `Status[0]`
    // (seed L24916-25582).
    if let Some(&(_, 0, bit)) = MOTOR_BITS.iter().find(|(n, _, _)| *n == name) {
        let words = super::exec::coord_status(card, u16::try_from(x).ok()?);
        return Some(f64::from((words[0] >> bit) & 1));
    }
    match name {
        // Running: the program or its last moves execute, a hold included (seed
        // L25884-25897); active: also paused where it can resume.
        "ProgRunning" => b(flags.running || flags.moves_pending),
        "ProgActive" => b(flags.running || flags.moves_pending || run.stop_point.is_some()),
        "ProgProceeding" => {
            b((flags.running || flags.moves_pending) && !flags.program_hold && !run.held)
        }
        // `%n` sets DesTimeBase = n % of the servo period (L21533); a hold takes the time
        // base to 0.
        "DesTimeBase" => Some(run.override_pct / 100.0 * servo_period_ms(card)),
        // The sync label before the move executing (seed L35011-35014).
        "Nsync" => Some(f64::from(run.nsync)),
        "TimeBase" => Some(if run.held || flags.program_hold {
            0.0
        } else {
            run.override_pct / 100.0 * servo_period_ms(card)
        }),
        _ => None,
    }
}
