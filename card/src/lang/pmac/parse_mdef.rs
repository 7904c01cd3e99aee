//! M-variable pointer definitions (`M{n}->...`, pmac-commands.md §3.2.3) and motor axis
//! definitions (`#{n}->...`, §3.3.1).

use super::ast::{Axis, AxisDef, AxisTerm, CmdKind, MDef, MFormat, XySpace};
use super::lexer::Cursor;
use super::ParseError;

/// After `#n->`: query, `0` (undefine) or a definition.
pub(crate) fn axis_def(c: &mut Cursor, motor: u32) -> Result<CmdKind, ParseError> {
    if motor == 0 {
        return Err(c.syntax("motor 0 does not exist"));
    }
    c.skip_ws();
    let starts = |k: &Cursor| match k.peek() {
        Some(b'-' | b'.' | b'0'..=b'9') => true,
        Some(l) => Axis::from_letter(l).is_some_and(|a| a.is_motion_axis()),
        None => false,
    };
    // `#n->I`: an inverse-kinematics motor, stored as a definition without terms.
    if c.peek() == Some(b'I') && !c.peek_at(1).is_some_and(|b| b.is_ascii_alphanumeric()) {
        c.bump();
        return Ok(CmdKind::AxisDefine(
            motor,
            AxisDef {
                terms: Vec::new(),
                offset: 0.0,
            },
        ));
    }
    if !starts(c) {
        return Ok(CmdKind::AxisDefQuery(motor));
    }
    let mut terms: Vec<AxisTerm> = Vec::new();
    let mut offset = 0.0;
    loop {
        let sign = if c.eat(b'-') {
            -1.0
        } else if terms.is_empty() || c.eat(b'+') {
            1.0
        } else {
            break;
        };
        let scale = c.unsigned_number()?;
        match c
            .peek()
            .and_then(Axis::from_letter)
            .filter(|a| a.is_motion_axis())
        {
            Some(axis) => {
                c.bump();
                terms.push(AxisTerm {
                    scale: sign * scale.map_or(1.0, |n| n.value),
                    axis,
                });
            }
            None => {
                let n = scale.ok_or_else(|| c.syntax("axis letter expected"))?;
                if terms.is_empty() {
                    if n.value == 0.0 {
                        return Ok(CmdKind::AxisUndefine(motor));
                    }
                    return Err(c.syntax("axis letter expected"));
                }
                offset = sign * n.value;
                break;
            }
        }
    }
    if terms.len() > 3 {
        return Err(c.syntax("at most three axes in a definition"));
    }
    if terms.len() > 1 {
        let xyz = terms
            .iter()
            .all(|t| matches!(t.axis, Axis::X | Axis::Y | Axis::Z));
        let uvw = terms
            .iter()
            .all(|t| matches!(t.axis, Axis::U | Axis::V | Axis::W));
        let distinct = terms
            .iter()
            .enumerate()
            .all(|(i, t)| terms[..i].iter().all(|u| u.axis != t.axis));
        if !(xyz || uvw) || !distinct {
            return Err(c.syntax("multi-axis definitions use distinct letters of XYZ or UVW"));
        }
    }
    Ok(CmdKind::AxisDefine(motor, AxisDef { terms, offset }))
}

/// A memory address: 24 bits at most here; the profile's own limit (PMAC2 $FFFF, Turbo
/// $7FFFF) is checked when the definition is stored.
fn addr16(c: &mut Cursor) -> Result<u32, ParseError> {
    let n = c.req_uint("address expected")?;
    Some(n)
        .filter(|&a| a <= 0xFF_FFFF)
        .ok_or_else(|| c.syntax("address above $FFFFFF"))
}

fn small(c: &mut Cursor, max: u32, what: &'static str) -> Result<u8, ParseError> {
    let n = c.req_uint(what)?;
    if n > max {
        return Err(c.syntax(what));
    }
    Ok(n as u8)
}

fn format(c: &mut Cursor, allowed: &[u8]) -> Result<MFormat, ParseError> {
    let mut k = c.clone();
    if !k.eat_ws(b',') {
        return Ok(MFormat::U);
    }
    k.skip_ws();
    let f = match k.peek() {
        Some(b'U') => MFormat::U,
        Some(b'S') => MFormat::S,
        Some(b'D') => MFormat::D,
        Some(b'C') => MFormat::C,
        _ => return Err(k.syntax("format U, S, D or C expected")),
    };
    if !allowed.contains(&k.peek().unwrap_or(0)) {
        return Err(k.syntax("format not allowed here"));
    }
    k.bump();
    *c = k;
    Ok(f)
}

/// After `M{n}->`: `Some(def)` or `None` for a query.
pub(crate) fn mdef(c: &mut Cursor) -> Result<Option<MDef>, ParseError> {
    let mut k = c.clone();
    k.skip_ws();
    if k.eat(b'*') {
        *c = k;
        return Ok(Some(MDef::SelfRef));
    }
    const TYPES: &[(&str, u8)] = &[
        ("TWB", 1),
        ("TWD", 2),
        ("TWR", 3),
        ("TWS", 4),
        ("DP", 5),
        ("D", 6),
        ("L", 7),
        ("F", 8),
        ("X", 9),
        ("Y", 10),
    ];
    let Some(t) = k.eat_longest(TYPES) else {
        return Ok(None);
    };
    k.skip_ws();
    k.eat(b':');
    k.skip_ws();
    if !k.at_unsigned_number() {
        return Ok(None); // e.g. `M1->` followed by another command
    }
    *c = k;
    let comma = |c: &mut Cursor| -> Result<(), ParseError> {
        if c.eat_ws(b',') {
            Ok(())
        } else {
            Err(c.syntax("',' expected"))
        }
    };
    let def = match t {
        1 => {
            let mux = small(c, 255, "multiplexer address 0..255")?;
            comma(c)?;
            let offset = small(c, 7, "bit offset 0..7")?;
            comma(c)?;
            let size = small(c, 32, "size 1..32")?;
            if size == 0 {
                return Err(c.syntax("size 1..32"));
            }
            MDef::Twb {
                mux,
                offset,
                size,
                format: format(c, b"US")?,
            }
        }
        2 => {
            let mux = small(c, 255, "multiplexer address 0..255")?;
            comma(c)?;
            let offset = small(c, 4, "offset 0 or 4")?;
            comma(c)?;
            let digits = small(c, 12, "digits 1..12")?;
            let decimals = if c.eat(b'.') {
                small(c, 8, "decimals 0..8")?
            } else {
                0
            };
            if (offset != 0 && offset != 4) || digits == 0 {
                return Err(c.syntax("bad TWD definition"));
            }
            MDef::Twd {
                mux,
                offset,
                digits,
                decimals,
                format: format(c, b"US")?,
            }
        }
        3 => {
            let mux = small(c, 254, "multiplexer address 0..254")?;
            comma(c)?;
            let offset = small(c, 7, "offset 0..7")?;
            if mux % 2 != 0 {
                return Err(c.syntax("TWR multiplexer address must be even"));
            }
            MDef::Twr { mux, offset }
        }
        4 => MDef::Tws {
            mux: small(c, 127, "multiplexer address 0..127")?,
        },
        5 => MDef::Dp(addr16(c)?),
        6 => MDef::D(addr16(c)?),
        7 => MDef::L(addr16(c)?),
        8 => MDef::F(addr16(c)?),
        _ => {
            let space = if t == 9 { XySpace::X } else { XySpace::Y };
            let addr = addr16(c)?;
            comma(c)?;
            let mut offset = small(c, 24, "bit offset 0..24")?;
            let mut width = 1;
            if offset == 24 {
                offset = 0;
                width = 24;
            } else {
                let mut k = c.clone();
                if k.eat_ws(b',') {
                    k.skip_ws();
                    if let Some(w) = k.uint()? {
                        width = u8::try_from(w).map_err(|_| k.syntax("bad width"))?;
                        *c = k;
                    }
                }
            }
            let legal = match width {
                1 => offset <= 23,
                4 | 8 | 12 | 16 | 20 | 24 => offset % 4 == 0 && offset + width <= 24,
                _ => false,
            };
            if !legal {
                return Err(c.syntax("illegal offset/width combination"));
            }
            let fmt = format(c, b"USDC")?;
            MDef::Bits {
                space,
                addr,
                offset,
                width,
                format: if width == 1 { MFormat::U } else { fmt },
            }
        }
    };
    Ok(Some(def))
}
