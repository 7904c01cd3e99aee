//! Direct program commands (seed 000, the buffer program command chapter): a motion program or
//! PLC acting on coordinate systems and motors as the matching on-line command does —
//! `abort`, `hold`, `run`, `step`, `pause`, `resume`, `enable`, `disable` on C.S. (L39280-39282,
//! L41566-41568, L43764-43767, L44159-44162, L43129-43132, L43651-43654, L41120-41122,
//! L40771-40773), `kill`, `dkill`, `home`, `homez`, `cout`, `jog…` on motors (L42440-42441,
//! L40897-40900, L41612-41667, L40392-40395, L41910-42387).
//!
//! [DECISION] Each becomes the on-line command for its list (`abort3,5..7` → `&3,5..7a`,
//! `kill1..3` → `#1..3k`, `jog1=(Q1)` → `#1j=` and the value when the statement runs) and is
//! run by the card's command thread after the program's pass, as a `cmd"…"` text is (its
//! outcome in the issuing thread's `Ldata.CmdStatus`). Without a list it acts on the issuing
//! thread's addressed C.S. or motor (`Ldata.Coord`/`Ldata.Motor`), filled in when it runs.

use super::parse::{Cur, SyntaxError};
use crate::domain::ast::{Expr, Message, StmtKind};
use crate::domain::PowerErr;

type P<T> = Result<T, SyntaxError>;

/// First byte of a command text whose `#`/`&` after it stands for the issuing thread's
/// addressed motor / C.S. (never in a host's or a `cmd` text: a control character).
pub(crate) const ADDRESSED: u8 = 0x01;

/// Format of a value computed when the statement runs (`jog1=(Q1)`).
const VALUE: &str = "%.15g";

fn err<T>(at: usize) -> P<T> {
    Err(SyntaxError {
        at,
        code: PowerErr::IllegalCmd,
    })
}

/// A list `n`, `a,b`, `a..b` and their mixtures (`1..3,5..7`), after optional blanks; `None`
/// when no number follows. The text is returned as the on-line command takes it.
fn list(c: &mut Cur<'_>) -> P<Option<String>> {
    let save = c.i;
    c.ws();
    if !c.peek().is_some_and(|d| d.is_ascii_digit()) {
        c.i = save;
        return Ok(None);
    }
    let mut text = String::new();
    loop {
        let at = c.i;
        let a = c.uint().ok_or(SyntaxError {
            at,
            code: PowerErr::IllegalCmd,
        })?;
        if a > 9999 {
            return Err(SyntaxError {
                at,
                code: PowerErr::IllegalParameter,
            });
        }
        text.push_str(&a.to_string());
        if c.eat_str("..") {
            let b = c.uint().ok_or(SyntaxError {
                at: c.i,
                code: PowerErr::IllegalCmd,
            })?;
            if b < a || b > 9999 {
                return Err(SyntaxError {
                    at,
                    code: PowerErr::IllegalParameter,
                });
            }
            text.push_str(&format!("..{b}"));
        }
        if c.peek() == Some(b',') && c.peek_at(1).is_some_and(|d| d.is_ascii_digit()) {
            c.i += 1;
            text.push(',');
        } else {
            return Ok(Some(text));
        }
    }
}

/// The target prefix: `&{list}` / `#{list}`, or the addressed one.
fn prefix(sign: char, list: Option<String>) -> Vec<u8> {
    match list {
        Some(l) => format!("{sign}{l}").into_bytes(),
        None => vec![ADDRESSED, sign as u8],
    }
}

/// A `{data}`: a constant goes into the text; an expression in parentheses (`(Q1)`) is
/// formatted when the statement runs. Only those two: a `^` after it is the trigger offset,
/// not an exclusive or.
fn value(c: &mut Cur<'_>, text: &mut Vec<u8>, args: &mut Vec<Expr>) -> P<()> {
    c.ws();
    if c.eat(b'(') {
        let e = c.expr(0)?;
        c.ws();
        if !c.eat(b')') {
            return err(c.i);
        }
        text.extend(VALUE.bytes());
        args.push(e);
        return Ok(());
    }
    let at = c.i;
    match c.signed_number() {
        Some(v) if v.is_finite() => {
            text.extend(crate::model::format_value(v).into_bytes());
            Ok(())
        }
        _ => err(at),
    }
}

fn command(text: Vec<u8>, args: Vec<Expr>) -> StmtKind {
    if args.is_empty() {
        StmtKind::Command(Message::Text(text))
    } else {
        StmtKind::CommandFormat { text, args }
    }
}

/// The statement of direct command word `w` (lower case, its list not yet read), `None` when
/// `w` is not one (or is one of its forms handled elsewhere).
pub(super) fn statement(c: &mut Cur<'_>, w: &str) -> Option<P<StmtKind>> {
    let cs = match w {
        "abort" => Some("a"),
        "hold" => Some("h"),
        "run" => Some("r"),
        "step" => Some("s"),
        "pause" => Some("q"),
        "resume" => Some(" resume"),
        "enable" => Some(" enable"),
        "disable" => Some(" disable"),
        "adisable" => Some(" adisable"),
        "ddisable" => Some(" ddisable"),
        "stop" => Some(" stop"),
        _ => None,
    };
    if let Some(cmd) = cs {
        return Some(list(c).map(|l| {
            let mut t = prefix('&', l);
            t.extend(cmd.bytes());
            command(t, Vec::new())
        }));
    }
    let motor = match w {
        "kill" => Some("k"),
        "dkill" => Some(" dkill"),
        "home" => Some("hm"),
        "homez" => Some("hmz"),
        _ => None,
    };
    if let Some(cmd) = motor {
        return Some(list(c).map(|l| {
            let mut t = prefix('#', l);
            t.extend(cmd.bytes());
            command(t, Vec::new())
        }));
    }
    match w {
        "begin" => Some(begin(c, false)),
        "start" => Some(begin(c, true)),
        "lh" => Some(look_ahead(c)),
        "cout" => Some(cout(c)),
        "jog" => Some(jog(c)),
        "jogret" => Some(jogret(c)),
        _ => None,
    }
}

/// `begin{list}:{data}` / `start{list}:{data}` (L39658-39702, L44040-44069): the on-line
/// `b{data}` (and `r`); without `:{data}` the program the C.S. points at (`start`) or its top.
fn begin(c: &mut Cur<'_>, run: bool) -> P<StmtKind> {
    let l = list(c)?;
    let mut t = prefix('&', l);
    let mut args = Vec::new();
    c.ws();
    if c.eat(b':') {
        t.push(b'b');
        value(c, &mut t, &mut args)?;
        if run {
            t.push(b'r');
        }
    } else if run {
        t.extend(b" start");
    } else {
        return err(c.i);
    }
    Ok(command(t, args))
}

/// `lh\{list}`, `lh<{list}`, `lh>{list}` (L42511-42674): the look-ahead quick stop, backward
/// and forward.
fn look_ahead(c: &mut Cur<'_>) -> P<StmtKind> {
    let Some(k) = c.peek().filter(|k| matches!(k, b'\\' | b'<' | b'>')) else {
        return err(c.i);
    };
    c.i += 1;
    let l = list(c)?;
    let mut t = prefix('&', l);
    t.extend(b" lh");
    t.push(k);
    Ok(command(t, Vec::new()))
}

/// `jogret{list}` (to the pre-jog position), `jogret{list}={data}` (to the position, which
/// becomes the pre-jog position): the on-line `j=` / `j==` (L42245-42306).
fn jogret(c: &mut Cur<'_>) -> P<StmtKind> {
    let l = list(c)?;
    let mut t = prefix('#', l);
    t.extend(b"j=");
    let mut args = Vec::new();
    if c.eat(b'=') {
        t.push(b'=');
        value(c, &mut t, &mut args)?;
    }
    Ok(command(t, args))
}

/// `cout{list}:{data}`: open-loop output, percent (the on-line `out`).
fn cout(c: &mut Cur<'_>) -> P<StmtKind> {
    let l = list(c)?;
    c.ws();
    if !c.eat(b':') {
        return err(c.i);
    }
    let mut t = prefix('#', l);
    t.extend(b"out");
    let mut args = Vec::new();
    value(c, &mut t, &mut args)?;
    Ok(command(t, args))
}

/// `jog+{list}`, `jog-{list}`, `jog/{list}`, `jog{list}={data}|*`, `jog{list}:{data}|*`,
/// `jog{list}^{data}|*`, each with an optional `^{data}|*` trigger offset (L41910-42387).
fn jog(c: &mut Cur<'_>) -> P<StmtKind> {
    let before = list(c)?;
    let Some(k) = c.peek() else {
        return err(c.i);
    };
    let mut args = Vec::new();
    let (l, mut tail) = match k {
        b'+' | b'-' | b'/' => {
            c.i += 1;
            let after = list(c)?;
            if before.is_some() && after.is_some() {
                return err(c.i);
            }
            (before.or(after), vec![k])
        }
        b'=' | b':' | b'^' => {
            c.i += 1;
            let mut t = vec![k];
            if c.eat(b'*') {
                t.push(b'*');
            } else {
                value(c, &mut t, &mut args)?;
            }
            (before, t)
        }
        _ => return err(c.i),
    };
    if c.eat(b'^') {
        tail.push(b'^');
        if c.eat(b'*') {
            tail.push(b'*');
        } else {
            value(c, &mut tail, &mut args)?;
        }
    }
    let mut t = prefix('#', l);
    t.push(b'j');
    t.extend(tail);
    Ok(command(t, args))
}

/// Fill in the addressed motor / C.S. (`Ldata.Motor`, `Ldata.Coord` of the issuing thread,
/// Power numbers) of a command text from [`statement`]; other texts are returned as they are.
pub(crate) fn resolve(line: &[u8], motor: u16, coord: u16) -> Vec<u8> {
    match line {
        [ADDRESSED, b'#', rest @ ..] => [format!("#{motor}").as_bytes(), rest].concat(),
        [ADDRESSED, b'&', rest @ ..] => [format!("&{coord}").as_bytes(), rest].concat(),
        _ => line.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text_of(src: &str) -> Option<(String, usize)> {
        let mut table = Vec::new();
        let mut c = Cur::for_program(src.as_bytes(), std::mem::take(&mut table));
        let w = c.word_lower()?;
        // As the program parser does: a number glued to the word is its list.
        let (w, _) = match w.find(|ch: char| ch.is_ascii_digit()) {
            Some(k) => {
                c.i -= w.len() - k;
                (w[..k].to_string(), ())
            }
            None => (w, ()),
        };
        match statement(&mut c, &w)?.ok()? {
            StmtKind::Command(Message::Text(t)) => Some((String::from_utf8_lossy(&t).into(), 0)),
            StmtKind::CommandFormat { text, args } => {
                Some((String::from_utf8_lossy(&text).into(), args.len()))
            }
            _ => None,
        }
    }

    #[test]
    fn direct_commands_become_the_on_line_commands_of_their_lists() {
        let t = |s: &str| text_of(s).map(|(t, n)| (t.replace('\u{1}', "@"), n));
        assert_eq!(t("abort3,5..7"), Some(("&3,5..7a".into(), 0)));
        assert_eq!(t("abort"), Some(("@&a".into(), 0)));
        assert_eq!(t("run 2"), Some(("&2r".into(), 0)));
        assert_eq!(t("disable5..8"), Some(("&5..8 disable".into(), 0)));
        assert_eq!(t("kill1..3,5..7"), Some(("#1..3,5..7k".into(), 0)));
        assert_eq!(t("dkill"), Some(("@# dkill".into(), 0)));
        assert_eq!(t("jog+1"), Some(("#1j+".into(), 0)));
        assert_eq!(t("jog/"), Some(("@#j/".into(), 0)));
        assert_eq!(t("jog=5000"), Some(("@#j=5000".into(), 0)));
        assert_eq!(t("jog1=(Q1)"), Some(("#1j=%.15g".into(), 1)));
        assert_eq!(t("jog1:-50000^(P10)"), Some(("#1j:-50000^%.15g".into(), 1)));
        assert_eq!(t("jog1..3=*^0"), Some(("#1..3j=*^0".into(), 0)));
        assert_eq!(t("cout1,2,3:-15"), Some(("#1,2,3out-15".into(), 0)));
        assert_eq!(t("homez1,2,3"), Some(("#1,2,3hmz".into(), 0)));
        assert_eq!(t("jogret1"), Some(("#1j=".into(), 0)));
        assert_eq!(t("jogret=5000"), Some(("@#j==5000".into(), 0)));
        assert_eq!(t("adisable3,5..7"), Some(("&3,5..7 adisable".into(), 0)));
        assert_eq!(t("ddisable"), Some(("@& ddisable".into(), 0)));
        assert_eq!(t("stop 1..16"), Some(("&1..16 stop".into(), 0)));
        assert_eq!(t("begin:2"), Some(("@&b2".into(), 0)));
        assert_eq!(t("start3:75.001"), Some(("&3b75.001r".into(), 0)));
        assert_eq!(t("start8:(P1+P2/1000000)"), Some(("&8b%.15gr".into(), 1)));
        assert_eq!(t("start"), Some(("@& start".into(), 0)));
        assert_eq!(t("lh\\1"), Some(("&1 lh\\".into(), 0)));
        assert_eq!(t("lh<"), Some(("@& lh<".into(), 0)));
        assert_eq!(t("begin"), None, "begin needs a program");
        assert_eq!(t("jog*"), None);
        assert_eq!(t("frob"), None);
    }

    #[test]
    fn the_addressed_target_is_filled_in_when_it_runs() {
        assert_eq!(resolve(b"\x01#k", 3, 1), b"#3k");
        assert_eq!(resolve(b"\x01&a", 3, 1), b"&1a");
        assert_eq!(resolve(b"&2r", 3, 1), b"&2r");
    }
}
