//! Interpreter-side run state: coordinate-system program pointers and overrides, motor axis
//! definitions, minimal motor bookkeeping needed for the R/S refusal checks, PLC enable flags.
//! Motion itself is the motion code's (it consumes [`super::Action`]s).

use serde::{Deserialize, Serialize};

use crate::domain::ast::{Axis, AxisDef};
use crate::model::format_value;

/// Program-control state of one coordinate system.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CsRun {
    /// `B` target: (program, label N); program 0 = rotary buffer.
    pub pointer: Option<(u32, u32)>,
    /// Commanded feedrate override in percent (`%{v}`).
    pub override_pct: f64,
    /// Feed hold (`H`) in effect: `%` reports 0.
    pub held: bool,
    /// `PC` reply kept by the program engine while a program is under way (`P1:22`,
    /// `P1001:35>P3:12`); `None`: report the `B` pointer.
    pub pc_text: Option<String>,
    /// `PE` reply kept by the program engine (the move executing).
    pub pe_text: Option<String>,
    /// (program, word offset) of the next line to be calculated (`LIST PC`), kept with
    /// `pc_text`; program 0 = rotary buffer.
    pub pc_at: Option<(u32, u32)>,
    /// (program, word offset) of the line of the move executing (`LIST PE`).
    pub pe_at: Option<(u32, u32)>,
    /// `pc_at` when the program was last aborted (Power `list apc`).
    pub apc_at: Option<(u32, u32)>,
    /// Where a `/` stop left the motors (motor, commanded position in counts): R/S away from
    /// it is ERR017. Set and cleared by the program engine.
    pub stop_point: Option<Vec<(u16, f64)>>,
    /// Programmed axis positions (X Y Z A B C U V W) at the end of the move executing, as the
    /// program engine publishes them (Power `&x g`); `None` when no move executes.
    pub target: Option<[f64; 9]>,
    /// The sync line label (`N{n}` without a colon) last passed before the move executing
    /// (Power `Coord[x].Nsync`).
    pub nsync: u32,
}

/// Interpreter-side motor bookkeeping.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotorRun {
    /// A jog/home move was commanded and not stopped (for ERR011).
    pub moving: bool,
    /// Disable (kill) the motor once its commanded stop is over (Power `adisable`, the
    /// global abort input in `Coord[x].AbortAllMode` 2): the servo loop acts on it.
    pub disable_at_rest: bool,
}

/// PLC enable/pause flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PlcRun {
    /// Enabled.
    pub enabled: bool,
    /// Paused (resumable).
    pub paused: bool,
}

/// All run state of a card.
#[derive(Debug, Clone, PartialEq)]
pub struct RunState {
    /// Per C.S., index 0 = &1.
    pub cs: Vec<CsRun>,
    /// Per motor, index 0 = #1.
    pub motors: Vec<MotorRun>,
    /// Axis definitions per motor: (C.S., definition).
    pub axes: Vec<Option<(u16, AxisDef)>>,
    /// Interpreted PLCs 0..=31.
    pub plc: Vec<PlcRun>,
    /// Per motor: (position, velocity, following error) in counts, as the motion code last
    /// reported them (`P`, `V`, `F`, CTRL-P/V/F).
    pub report: Vec<(f64, f64, f64)>,
    /// Per PLC: word offset of the line its next scan executes first (`LIST PLC n,`), as the
    /// PLC runner last left it.
    pub plc_next: Vec<u32>,
    /// PLCs (bit n = PLC n) asked to run one program line and pause (Power `step plc`).
    pub plc_step: u32,
}

impl RunState {
    /// Power-up state for the given dimensions.
    pub fn new(motors: u16, coords: u16, plcs: usize) -> Self {
        RunState {
            cs: vec![
                CsRun {
                    override_pct: 100.0,
                    ..CsRun::default()
                };
                coords as usize
            ],
            motors: vec![MotorRun::default(); motors as usize],
            axes: vec![None; motors as usize],
            plc: vec![
                PlcRun {
                    enabled: true,
                    paused: false
                };
                plcs
            ],
            report: vec![(0.0, 0.0, 0.0); motors as usize],
            plc_next: vec![0; plcs],
            plc_step: 0,
        }
    }

    /// Whether PLC `n` is enabled and not paused.
    pub fn plc_active(&self, n: u8) -> bool {
        self.plc
            .get(n as usize)
            .is_some_and(|p| p.enabled && !p.paused)
    }

    /// Motors (1-based) whose axis definition is in C.S. `cs`.
    pub fn motors_in(&self, cs: u16) -> Vec<u16> {
        self.axes
            .iter()
            .enumerate()
            .filter(|(_, a)| a.as_ref().is_some_and(|(c, _)| *c == cs))
            .map(|(k, _)| k as u16 + 1)
            .collect()
    }

    /// The C.S. motor `m` (1-based) belongs to.
    pub fn cs_of(&self, m: u16) -> Option<u16> {
        m.checked_sub(1)
            .and_then(|k| self.axes.get(k as usize))
            .and_then(|a| a.as_ref().map(|(c, _)| *c))
    }
}

/// Reply text of an axis definition: `1000X`, `8660X-5000Y`, `5000X+8660Y+5000`, `X`.
pub(crate) fn axis_def_text(d: &AxisDef) -> String {
    if d.terms.is_empty() {
        // `#n->I` (inverse kinematics).
        return "I".to_string();
    }
    let mut s = String::new();
    for (k, t) in d.terms.iter().enumerate() {
        let neg = t.scale < 0.0;
        if k > 0 {
            s.push(if neg { '-' } else { '+' });
        } else if neg {
            s.push('-');
        }
        let mag = t.scale.abs();
        if mag != 1.0 {
            s.push_str(&format_value(mag));
        }
        s.push(t.axis.letter());
    }
    if d.offset != 0.0 {
        s.push(if d.offset < 0.0 { '-' } else { '+' });
        s.push_str(&format_value(d.offset.abs()));
    }
    s
}

/// True when all terms use one triple (XYZ or UVW) — required for multi-term definitions.
pub(crate) fn axis_def_legal(d: &AxisDef) -> bool {
    if d.terms.is_empty() {
        // `#n->I`.
        return true;
    }
    if d.terms.is_empty() || d.terms.len() > 3 || d.terms.iter().any(|t| !t.axis.is_motion_axis()) {
        return false;
    }
    if d.terms.len() == 1 {
        return true;
    }
    let xyz = |a: Axis| matches!(a, Axis::X | Axis::Y | Axis::Z);
    let uvw = |a: Axis| matches!(a, Axis::U | Axis::V | Axis::W);
    d.terms.iter().all(|t| xyz(t.axis)) || d.terms.iter().all(|t| uvw(t.axis))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::ast::AxisTerm;

    fn def(terms: &[(f64, Axis)], offset: f64) -> AxisDef {
        AxisDef {
            terms: terms
                .iter()
                .map(|&(scale, axis)| AxisTerm { scale, axis })
                .collect(),
            offset,
        }
    }

    #[test]
    fn axis_definition_texts() {
        assert_eq!(axis_def_text(&def(&[(1000.0, Axis::X)], 0.0)), "1000X");
        assert_eq!(axis_def_text(&def(&[(1.0, Axis::X)], 0.0)), "X");
        assert_eq!(
            axis_def_text(&def(&[(8660.0, Axis::X), (-5000.0, Axis::Y)], 0.0)),
            "8660X-5000Y"
        );
        assert_eq!(
            axis_def_text(&def(&[(5000.0, Axis::X), (8660.0, Axis::Y)], 5000.0)),
            "5000X+8660Y+5000"
        );
        assert_eq!(
            axis_def_text(&def(&[(2000.0, Axis::A)], 500.0)),
            "2000A+500"
        );
        assert_eq!(axis_def_text(&def(&[(-0.5, Axis::U)], -3.0)), "-0.5U-3");
    }

    #[test]
    fn axis_definition_legality() {
        assert!(axis_def_legal(&def(&[(1.0, Axis::A)], 0.0)));
        assert!(axis_def_legal(&def(&[(1.0, Axis::X), (1.0, Axis::Z)], 0.0)));
        assert!(!axis_def_legal(&def(
            &[(1.0, Axis::X), (1.0, Axis::U)],
            0.0
        )));
        assert!(!axis_def_legal(&def(
            &[(1.0, Axis::A), (1.0, Axis::B)],
            0.0
        )));
        assert!(!axis_def_legal(&def(&[(1.0, Axis::I)], 0.0)));
    }

    #[test]
    fn membership() {
        let mut r = RunState::new(8, 8, 32);
        r.axes[0] = Some((1, def(&[(1.0, Axis::X)], 0.0)));
        r.axes[2] = Some((2, def(&[(1.0, Axis::Y)], 0.0)));
        assert_eq!(r.motors_in(1), [1]);
        assert_eq!(r.cs_of(3), Some(2));
        assert_eq!(r.cs_of(2), None);
        assert_eq!(r.cs_of(0), None);
        assert!(r.plc_active(5));
    }
}
