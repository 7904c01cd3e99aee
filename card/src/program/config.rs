//! Coordinate-system setup read from the card: I-variables into COORD's [`CsConfig`], axis
//! definitions (`card.run.axes`, kept by the interpreter) into COORD's [`CsAxes`].

use super::env::{cs_ivar, ivar};
use crate::coord::axes::{CsAxes, MotorAxisDef};
use crate::coord::moves::{CsConfig, MotorLimits};
use crate::domain::ast::AxisDef;
use crate::model::CardModel;

/// The axis definitions of C.S. `cs` as the interpreter holds them: (motor, definition).
pub(crate) fn axis_defs(card: &CardModel, cs: u16) -> Vec<(u16, AxisDef)> {
    card.run
        .axes
        .iter()
        .enumerate()
        .filter_map(|(k, a)| match a {
            Some((c, d)) if *c == cs => Some((k as u16 + 1, d.clone())),
            _ => None,
        })
        .collect()
}

/// COORD's axis map for the definitions `defs` (malformed ones are left out).
pub(crate) fn cs_axes(defs: &[(u16, AxisDef)]) -> CsAxes {
    let parsed: Vec<(u16, MotorAxisDef)> = defs
        .iter()
        .filter_map(|(m, d)| MotorAxisDef::from_ast(d).ok().map(|x| (*m, x)))
        .collect();
    let refs: Vec<(u16, &MotorAxisDef)> = parsed.iter().map(|(m, d)| (*m, d)).collect();
    CsAxes::build(&refs)
}

/// The C.S. I-variables and the limits of `motors` (in the C.S. motor order).
pub(crate) fn cs_config(card: &CardModel, cs: u16, motors: &[u16]) -> CsConfig {
    let d = CsConfig::default();
    let p = card.profile();
    let c = |nn: u32, dflt: f64| ivar(card, cs_ivar(p, cs, nn), dflt);
    let limits = motors
        .iter()
        .map(|&m| {
            let l = MotorLimits::default();
            let base = 100 * u32::from(m);
            let mv = |nn: u32, dflt: f64| ivar(card, base + nn, dflt);
            MotorLimits {
                ix15: mv(15, l.ix15),
                ix16: mv(16, l.ix16),
                ix17: mv(17, l.ix17),
                ix19: mv(19, l.ix19),
                ix20: mv(20, l.ix20),
                ix21: mv(21, l.ix21),
                ix22: mv(22, l.ix22),
            }
        })
        .collect();
    CsConfig {
        ix87: c(87, d.ix87),
        ix88: c(88, d.ix88),
        ix89: c(89, d.ix89),
        ix90: c(90, d.ix90),
        ix92: c(92, 0.0) != 0.0,
        ix94: c(94, d.ix94),
        ix95: c(95, d.ix95),
        ix96: c(96, d.ix96),
        ix98: c(98, d.ix98),
        i10: ivar(card, 10, d.i10),
        // Power's `Coord[x].SegMoveTime` (legacy Isx13, seed L4683): 0 makes circles linear
        // (L39636-39637).
        i13: if p == crate::domain::Profile::Power {
            c(13, 0.0)
        } else {
            ivar(card, 13, d.i13)
        },
        i50: ivar(card, 50, 1.0) != 0.0,
        i90: ivar(card, 90, d.i90),
        // Power's `Coord[x].Td` (legacy Isx80, seed L4995-5027); PMAC has no such time.
        td: (p == crate::domain::Profile::Power).then(|| c(80, c(87, d.ix87))),
        tm: (p == crate::domain::Profile::Power).then(|| c(89, d.ix89)),
        motors: limits,
    }
}
