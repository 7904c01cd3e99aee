//! Power PMAC move modes and output statements that differ from PMAC's (seed §2.10):
//!
//! * `pvt{t}` (L43340-43362): PVT mode, segment time t ms. Power sets it only here (`ta`/`tm`
//!   leave it alone). Moves `X{pos}:{vel}` give the end velocity in scaled units per
//!   `Coord[x].FeedTime` ms (L39467-39484; 1000 by default, so units per second), which is
//!   the motion core's Ix90 velocity unit. The core rounds the time to whole ms.
//! * `spline{t}` (L43937-43999): SPLINE mode with its own segment time. Power keeps three
//!   section times (`spline t0 spline t1 spline t2`, `Coord[x].T0Spline…`); the motion core's
//!   uniform B-spline has one, so a second time on the line (or a comma list) is refused with
//!   error 21 rather than run with different timing.
//! * `td{t}` (L44483-44520, `Coord[x].Td` L4995-5027): the final deceleration of blended
//!   moves; `ta` sets it too (`td` must follow `ta`).
//! * `send n[,]"fmt"[,expr…]` (L43796-43912): escapes resolved at entry, the printf format
//!   checked at entry (error 20: a malformed or unoffered conversion, or not one expression
//!   per conversion) and formatted when the statement runs ([`crate::program::printf`]).
//!
//! A constant time out of range (not ≥ 0.5 ms for `pvt`/`spline`, negative for `td`, or
//! beyond 2^23 ms) is refused with error 21; a computed one stops the program at run time.

use super::parse::{Cur, SyntaxError};
use crate::domain::ast::{Expr, ExprKind, Message, SendPort, StmtKind};
use crate::domain::PowerErr;
use crate::program::printf;

type P<T> = Result<T, SyntaxError>;

/// Longest time a mode statement may give (ms), as the core's other times.
const MAX_TIME: f64 = 8_388_607.0;

fn err<T>(at: usize, code: PowerErr) -> P<T> {
    Err(SyntaxError { at, code })
}

/// `{data}` and, when it is a literal, whether `ok` accepts it (else error 21).
fn time(c: &mut Cur<'_>, ok: impl Fn(f64) -> bool) -> P<Expr> {
    c.ws();
    let at = c.i;
    let e = c.expr(0)?;
    let literal = match &e.kind {
        ExprKind::Num(n) => Some(n.value),
        ExprKind::Neg(x) => match x.kind {
            ExprKind::Num(n) => Some(-n.value),
            _ => None,
        },
        _ => None,
    };
    if let Some(v) = literal {
        if !(v.is_finite() && ok(v) && v <= MAX_TIME) {
            return err(at, PowerErr::IllegalParameter);
        }
    }
    Ok(e)
}

/// `pvt{t}`.
pub(super) fn pvt(c: &mut Cur<'_>) -> P<StmtKind> {
    Ok(StmtKind::Pvt(time(c, |v| v.round() >= 1.0)?))
}

/// `td{t}`.
pub(super) fn td(c: &mut Cur<'_>) -> P<StmtKind> {
    Ok(StmtKind::Td(time(c, |v| v >= 0.0)?))
}

/// `spline{t}`; a list of section times is refused (see the module notes).
pub(super) fn spline(c: &mut Cur<'_>) -> P<StmtKind> {
    let e = time(c, |v| v.round() >= 1.0)?;
    let save = c.i;
    c.ws();
    if c.peek() == Some(b',') || c.eat_word("spline") {
        return err(c.i, PowerErr::IllegalParameter);
    }
    c.i = save;
    Ok(StmtKind::Spline(e))
}

/// `send n[,]"fmt"[,expr…]`.
pub(super) fn send(c: &mut Cur<'_>) -> P<StmtKind> {
    c.ws();
    let port = match c.uint() {
        Some(n) if n <= 4 => n as u8,
        _ => return err(c.i, PowerErr::IllegalParameter),
    };
    c.ws();
    c.eat(b',');
    c.ws();
    let at = c.i;
    let text = escaped(c)?;
    let pieces = printf::parse(&text).or(err(at, PowerErr::IllegalCmd))?;
    let args = printf_args(c, &pieces)?;
    if args.is_empty() {
        // Only literal text (`%%` made `%`): sent as it stands.
        return Ok(StmtKind::Send(
            SendPort::Any,
            Message::Text(printf::format(&pieces, &[])),
        ));
    }
    Ok(StmtKind::SendFormat { port, text, args })
}

/// The `,expr` arguments after a printf format: one per conversion of `pieces` (error 20
/// otherwise, or beyond `printf::MAX_ARGS`).
fn printf_args(c: &mut Cur<'_>, pieces: &[printf::Piece]) -> P<Vec<Expr>> {
    let mut args = Vec::new();
    loop {
        let save = c.i;
        c.ws();
        if !c.eat(b',') {
            c.i = save;
            break;
        }
        if args.len() >= printf::MAX_ARGS {
            return err(c.i, PowerErr::IllegalCmd);
        }
        c.ws();
        args.push(c.expr(0)?);
    }
    if args.len() != printf::conversions(pieces) {
        return err(c.i, PowerErr::IllegalCmd);
    }
    Ok(args)
}

/// `cmd"text"` (the text as it stands, run on the command thread) or `cmd"fmt",expr…`
/// (seed L40310-40316: printf-style, formatted when the statement runs). [DECISION] Without
/// arguments the text is not a format (`cmd"&1%50"` is an override command).
pub(super) fn cmd(c: &mut Cur<'_>, text: Vec<u8>) -> P<StmtKind> {
    let save = c.i;
    c.ws();
    let more = c.peek() == Some(b',');
    c.i = save;
    if !more {
        return Ok(StmtKind::Command(Message::Text(text)));
    }
    let pieces = printf::parse(&text).or(err(c.i, PowerErr::IllegalCmd))?;
    let args = printf_args(c, &pieces)?;
    Ok(StmtKind::CommandFormat { text, args })
}

/// A `"…"` string with the C escapes of the seed's list (`\a \b \t \n \v \f \r \\ \? \' \"`,
/// `\ooo`, `\xhh`); an unterminated string or an unknown escape is error 20.
fn escaped(c: &mut Cur<'_>) -> P<Vec<u8>> {
    if !c.eat(b'"') {
        return err(c.i, PowerErr::IllegalCmd);
    }
    let r = c.rest();
    let mut out = Vec::new();
    let mut k = 0;
    loop {
        let Some(&b) = r.get(k) else {
            return err(c.i + k, PowerErr::IllegalCmd);
        };
        k += 1;
        match b {
            b'"' => break,
            b'\\' => {
                let Some(&e) = r.get(k) else {
                    return err(c.i + k, PowerErr::IllegalCmd);
                };
                k += 1;
                let v = match e {
                    b'a' => 7,
                    b'b' => 8,
                    b't' => 9,
                    b'n' => 10,
                    b'v' => 11,
                    b'f' => 12,
                    b'r' => 13,
                    b'\\' | b'?' | b'\'' | b'"' => e,
                    b'0'..=b'7' => {
                        let mut v = u32::from(e - b'0');
                        for _ in 0..2 {
                            match r.get(k) {
                                Some(&d @ b'0'..=b'7') => {
                                    v = v * 8 + u32::from(d - b'0');
                                    k += 1;
                                }
                                _ => break,
                            }
                        }
                        u8::try_from(v).or(err(c.i + k, PowerErr::IllegalCmd))?
                    }
                    b'x' => {
                        let mut v = 0u8;
                        let mut n = 0;
                        while let Some(d) = r.get(k).and_then(|d| (*d as char).to_digit(16)) {
                            if n == 2 {
                                break;
                            }
                            v = v * 16 + d as u8;
                            k += 1;
                            n += 1;
                        }
                        if n == 0 {
                            return err(c.i + k, PowerErr::IllegalCmd);
                        }
                        v
                    }
                    _ => return err(c.i + k - 1, PowerErr::IllegalCmd),
                };
                out.push(v);
            }
            _ => out.push(b),
        }
    }
    c.i += k;
    Ok(out)
}
