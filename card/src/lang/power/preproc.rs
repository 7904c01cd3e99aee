//! The Power PMAC preprocessor's substitutions (seed 000): `#define NAME text` and
//! `#define NAME(a,b) text` macros, `#undef NAME`, the names it provides inside kinematic
//! routines (`KinPosMotor3` → `L3`, `KinPosAxisX` → `C6`, `KinVelAxis(y)` → `C(y+32)` …,
//! L45436-45490), and PLC identifiers (`open plc Coolant_Control` takes the lowest unused PLC
//! buffer 1-31, `RtPlc` PLC 0, L45550-45572).
//!
//! [DECISION] On a real card the project manager runs the preprocessor before it downloads a
//! project through gpascii. Here every host line goes through it, so a host can send a
//! project's files as they are; the definitions are the card's (one table for every
//! connection, as one project is), saved with the buffers (a PLC identifier names the same
//! buffer after a restart) and cleared by `$$$***`. Identifiers are case sensitive (L45556)
//! and never replaced inside quoted text.

use crate::domain::PowerErr;
use std::collections::HashMap;

/// Longest text a line may grow to by substitution.
const MAX_EXPANDED: usize = 4096;
/// Deepest nesting of macros within macros.
const MAX_DEPTH: u32 = 16;
/// Most definitions kept.
const MAX_DEFINES: usize = 4096;
/// Most substitutions one line may take (macros that expand to nothing never reach
/// [`MAX_EXPANDED`], but may still multiply).
const MAX_SUBSTITUTIONS: u32 = 10_000;

/// One `#define`.
#[derive(Debug, Clone, PartialEq)]
struct Macro {
    /// Parameter names of a function-like macro.
    params: Option<Vec<String>>,
    /// The replacement text.
    body: String,
}

/// What the preprocessor made of a line.
#[derive(Debug, PartialEq)]
pub(crate) enum Pre {
    /// A directive (`#define`, `#undef`): consumed, nothing to run.
    Directive,
    /// The line runs as it is.
    Same,
    /// The line runs with these substitutions.
    Text(Vec<u8>),
    /// A directive or an expansion that cannot be taken: the error number.
    Error(PowerErr),
}

/// The card's preprocessor table.
#[derive(Debug, Default)]
pub(crate) struct Preproc {
    defs: HashMap<String, Macro>,
}

/// The axis index `y` of axis name `α` (L45470-45480): A B C U V W X Y Z, then AA … ZZ
/// without II JJ KK.
fn axis_index(name: &str) -> Option<u32> {
    const ONE: [&str; 9] = ["A", "B", "C", "U", "V", "W", "X", "Y", "Z"];
    const TWO: [&str; 23] = [
        "AA", "BB", "CC", "DD", "EE", "FF", "GG", "HH", "LL", "MM", "NN", "OO", "PP", "QQ", "RR",
        "SS", "TT", "UU", "VV", "WW", "XX", "YY", "ZZ",
    ];
    if let Some(k) = ONE.iter().position(|a| *a == name) {
        return Some(k as u32);
    }
    TWO.iter().position(|a| *a == name).map(|k| 9 + k as u32)
}

/// The kinematic names of L45438-45449 (object-like forms).
fn kinematic(name: &str) -> Option<String> {
    match name {
        "KinVelEna" | "KinAxisUsed" => return Some("D0".into()),
        _ => {}
    }
    for (prefix, var) in [("KinPosMotor", "L"), ("KinVelMotor", "R")] {
        if let Some(n) = name.strip_prefix(prefix) {
            if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) {
                let n: u32 = n.parse().ok()?;
                return (n <= 255).then(|| format!("{var}{n}"));
            }
        }
    }
    let axis = |prefix: &str| name.strip_prefix(prefix).and_then(axis_index);
    if let Some(y) = axis("KinPosAxis") {
        return Some(format!("C{y}"));
    }
    if let Some(y) = axis("KinVelAxis") {
        return Some(format!("C{}", y + 32));
    }
    if let Some(y) = axis("KinEnaAxis") {
        return Some(format!("{}", 1u64 << y));
    }
    axis("KinAxisIndex").map(|y| y.to_string())
}

/// The function-like kinematic names (`KinPosMotor(x)` → `L(x)`, `KinVelAxis(y)` →
/// `C(y+32)`): the text replacing the name and its opening parenthesis.
fn kinematic_call(name: &str) -> Option<&'static str> {
    Some(match name {
        "KinPosMotor" => "L(",
        "KinVelMotor" => "R(",
        "KinPosAxis" => "C(",
        "KinVelAxis" => "C(32+",
        _ => return None,
    })
}

fn is_ident_start(b: u8) -> bool {
    b.is_ascii_alphabetic() || b == b'_'
}

fn is_ident(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

/// The arguments of a call whose `(` is at `s[at]`: their texts and the index after `)`.
fn call_args(s: &[u8], at: usize) -> Option<(Vec<String>, usize)> {
    let mut depth = 0u32;
    let mut args = Vec::new();
    let mut start = at + 1;
    let mut i = at;
    while i < s.len() {
        match s[i] {
            b'(' => depth += 1,
            b')' => {
                depth -= 1;
                if depth == 0 {
                    args.push(String::from_utf8_lossy(&s[start..i]).trim().to_string());
                    return Some((args, i + 1));
                }
            }
            b',' if depth == 1 => {
                args.push(String::from_utf8_lossy(&s[start..i]).trim().to_string());
                start = i + 1;
            }
            _ => {}
        }
        i += 1;
    }
    None
}

impl Preproc {
    /// Every definition as the `#define` line that makes it (the saved image keeps them, so
    /// a PLC identifier names the same buffer after a restart), in name order.
    pub(crate) fn export(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .defs
            .iter()
            .map(|(name, m)| match &m.params {
                Some(p) => format!("#define {name}({}) {}", p.join(","), m.body),
                None => format!("#define {name} {}", m.body),
            })
            .collect();
        v.sort();
        v
    }

    /// Definitions from [`Preproc::export`] lines (a line that is not one is passed over).
    pub(crate) fn import(lines: &[String]) -> Self {
        let mut p = Preproc::default();
        for l in lines {
            if let Some(rest) = l.strip_prefix("#define") {
                let _ = p.define(rest);
            }
        }
        p
    }

    /// The value `name` is defined to as a constant, if it is.
    fn constant(&self, name: &str) -> Option<u32> {
        self.defs
            .get(name)
            .filter(|m| m.params.is_none())
            .and_then(|m| m.body.trim().parse().ok())
    }

    /// Take line `line`; `plc_used(n)` says whether PLC buffer n holds a program (for
    /// `open plc {identifier}`).
    pub(crate) fn line(&mut self, line: &[u8], plc_used: &dyn Fn(u32) -> bool) -> Pre {
        let text = String::from_utf8_lossy(line);
        let t = text.trim_start();
        if let Some(rest) = t.strip_prefix("#define") {
            return self.define(rest);
        }
        if let Some(rest) = t.strip_prefix("#undef") {
            let name = rest.trim();
            if name.is_empty() || !name.bytes().all(is_ident) {
                return Pre::Error(PowerErr::IllegalCmd);
            }
            self.defs.remove(name);
            return Pre::Directive;
        }
        if let Some(p) = self.name_plc(t, plc_used) {
            return p;
        }
        if self.defs.is_empty() && !t.contains("Kin") {
            return Pre::Same;
        }
        let mut budget = MAX_SUBSTITUTIONS;
        match self.expand(line, 0, &mut budget) {
            Ok(Some(v)) => Pre::Text(v),
            Ok(None) => Pre::Same,
            Err(code) => Pre::Error(code),
        }
    }

    /// `#define NAME text` / `#define NAME(a,b) text`.
    fn define(&mut self, rest: &str) -> Pre {
        if !rest.starts_with([' ', '\t']) {
            return Pre::Error(PowerErr::IllegalCmd);
        }
        let rest = rest.trim_start();
        let end = rest.bytes().take_while(|&b| is_ident(b)).count();
        let name = &rest[..end];
        if name.is_empty() || !is_ident_start(name.as_bytes()[0]) {
            return Pre::Error(PowerErr::IllegalCmd);
        }
        let mut after = &rest[end..];
        let mut params = None;
        if let Some(p) = after.strip_prefix('(') {
            let Some(close) = p.find(')') else {
                return Pre::Error(PowerErr::IllegalCmd);
            };
            let list: Vec<String> = p[..close]
                .split(',')
                .map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty())
                .collect();
            if list
                .iter()
                .any(|s| !s.bytes().all(is_ident) || !is_ident_start(s.as_bytes()[0]))
            {
                return Pre::Error(PowerErr::IllegalCmd);
            }
            params = Some(list);
            after = &p[close + 1..];
        }
        // A `//` comment after the text is not part of it.
        let body = after.split("//").next().unwrap_or("").trim().to_string();
        if !self.defs.contains_key(name) && self.defs.len() >= MAX_DEFINES {
            return Pre::Error(PowerErr::IllegalParameter);
        }
        self.defs.insert(name.to_string(), Macro { params, body });
        Pre::Directive
    }

    /// `open plc {identifier}` with an identifier not defined yet: the lowest unused buffer
    /// 1-31 (`RtPlc`: 0) becomes its number.
    fn name_plc(&mut self, t: &str, plc_used: &dyn Fn(u32) -> bool) -> Option<Pre> {
        let code = t.split("//").next().unwrap_or("");
        let mut w = code
            .split(|c: char| c.is_whitespace() || c == ';')
            .filter(|w| !w.is_empty());
        if !w.next()?.eq_ignore_ascii_case("open") || !w.next()?.eq_ignore_ascii_case("plc") {
            return None;
        }
        let name = w.next()?;
        if w.next().is_some()
            || !is_ident_start(name.as_bytes()[0])
            || !name.bytes().all(is_ident)
            || self.defs.contains_key(name)
        {
            return None;
        }
        let taken: Vec<u32> = self.defs.keys().filter_map(|k| self.constant(k)).collect();
        let n = if name == "RtPlc" {
            0
        } else {
            match (1..32).find(|n| !plc_used(*n) && !taken.contains(n)) {
                Some(n) => n,
                None => return Some(Pre::Error(PowerErr::IllegalParameter)),
            }
        };
        self.defs.insert(
            name.to_string(),
            Macro {
                params: None,
                body: n.to_string(),
            },
        );
        Some(Pre::Text(format!("open plc {n}").into_bytes()))
    }

    /// `s` with every defined name replaced; `None` when nothing was.
    fn expand(&self, s: &[u8], depth: u32, budget: &mut u32) -> Result<Option<Vec<u8>>, PowerErr> {
        if depth > MAX_DEPTH {
            return Err(PowerErr::IllegalParameter);
        }
        let mut out = Vec::with_capacity(s.len());
        let mut changed = false;
        let mut i = 0;
        let mut quote = false;
        while i < s.len() {
            let b = s[i];
            if b == b'"' {
                quote = !quote;
            }
            let starts = is_ident_start(b) && (i == 0 || !is_ident(s[i - 1]));
            if quote || !starts {
                out.push(b);
                i += 1;
                continue;
            }
            let end = i + s[i..].iter().take_while(|&&c| is_ident(c)).count();
            let name = String::from_utf8_lossy(&s[i..end]);
            let call = s.get(end) == Some(&b'(');
            let mut piece: Option<(Vec<u8>, usize)> = None;
            if let Some(m) = self.defs.get(name.as_ref()) {
                match &m.params {
                    None => piece = Some((m.body.clone().into_bytes(), end)),
                    Some(params) if call => {
                        let (args, after) = call_args(s, end).ok_or(PowerErr::IllegalCmd)?;
                        if args.len() != params.len() && !(params.is_empty() && args == [""]) {
                            return Err(PowerErr::IllegalCmd);
                        }
                        let body = self
                            .substitute(&m.body, params, &args)
                            .ok_or(PowerErr::IllegalParameter)?;
                        piece = Some((body.into_bytes(), after));
                    }
                    Some(_) => {}
                }
            } else if call {
                if let Some(r) = kinematic_call(&name) {
                    piece = Some((r.as_bytes().to_vec(), end + 1));
                }
            } else if let Some(r) = kinematic(&name) {
                piece = Some((r.into_bytes(), end));
            }
            match piece {
                Some((text, next)) => {
                    *budget = budget.checked_sub(1).ok_or(PowerErr::IllegalParameter)?;
                    let text = self.expand(&text, depth + 1, budget)?.unwrap_or(text);
                    out.extend_from_slice(&text);
                    changed = true;
                    i = next;
                }
                None => {
                    out.extend_from_slice(&s[i..end]);
                    i = end;
                }
            }
            if out.len() > MAX_EXPANDED {
                return Err(PowerErr::IllegalParameter);
            }
        }
        Ok(changed.then_some(out))
    }

    /// `body` with each parameter replaced by its argument.
    fn substitute(&self, body: &str, params: &[String], args: &[String]) -> Option<String> {
        let s = body.as_bytes();
        let mut out = String::new();
        // Text between names is copied as it stands (names are ASCII, so every cut is at a
        // character boundary).
        let mut lit = 0;
        let mut i = 0;
        while i < s.len() {
            if is_ident_start(s[i]) && (i == 0 || !is_ident(s[i - 1])) {
                let end = i + s[i..].iter().take_while(|&&c| is_ident(c)).count();
                out.push_str(&body[lit..i]);
                let name = &body[i..end];
                match params.iter().position(|p| p == name) {
                    Some(k) => out.push_str(args.get(k)?),
                    None => out.push_str(name),
                }
                i = end;
                lit = end;
                if out.len() > MAX_EXPANDED {
                    return None;
                }
            } else {
                i += 1;
            }
        }
        out.push_str(&body[lit..]);
        (out.len() <= MAX_EXPANDED).then_some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(p: &mut Preproc, line: &str) -> String {
        match p.line(line.as_bytes(), &|n| n == 1) {
            Pre::Text(t) => String::from_utf8(t).unwrap(),
            Pre::Same => line.to_string(),
            other => format!("{other:?}"),
        }
    }

    #[test]
    fn kinematic_names_are_the_seeds_variables() {
        let mut p = Preproc::default();
        assert_eq!(
            run(&mut p, "KinPosAxisX = KinPosMotor3 / 1000"),
            "C6 = L3 / 1000"
        );
        assert_eq!(
            run(&mut p, "KinVelMotor4 = 1000 * KinVelAxisY"),
            "R4 = 1000 * C39"
        );
        assert_eq!(
            run(&mut p, "KinAxisUsed = KinEnaAxisX + KinEnaAxisY"),
            "D0 = 64 + 128"
        );
        assert_eq!(
            run(&mut p, "if (KinVelEna) callsub 100"),
            "if (D0) callsub 100"
        );
        assert_eq!(run(&mut p, "KinPosAxisZZ=KinVelAxis(P1)"), "C31=C(32+P1)");
        assert_eq!(run(&mut p, "KinPosMotor(P2)=KinAxisIndexAA"), "L(P2)=9");
        assert_eq!(
            run(&mut p, "KinPosMotor256=1"),
            "KinPosMotor256=1",
            "0 .. 255 only"
        );
        assert_eq!(run(&mut p, "cmd\"KinPosMotor3\""), "cmd\"KinPosMotor3\"");
    }

    #[test]
    fn defines_replace_names_and_calls() {
        let mut p = Preproc::default();
        assert_eq!(
            p.line(b"#define Gain P100  // loop gain", &|_| false),
            Pre::Directive
        );
        assert_eq!(
            p.line(b"#define Scale(a,b) ((a)*(b))", &|_| false),
            Pre::Directive
        );
        assert_eq!(run(&mut p, "Gain=Scale(Gain,2)+1"), "P100=((P100)*(2))+1");
        assert_eq!(
            run(&mut p, "Gains=1 send1\"Gain\""),
            "Gains=1 send1\"Gain\""
        );
        assert_eq!(run(&mut p, "gain=1"), "gain=1", "case sensitive");
        assert_eq!(run(&mut p, "Scale(1)"), "Error(IllegalCmd)");
        assert_eq!(
            p.line(b"#define 5x 1", &|_| false),
            Pre::Error(PowerErr::IllegalCmd)
        );
        assert_eq!(
            p.line(b"#defineX 1", &|_| false),
            Pre::Error(PowerErr::IllegalCmd)
        );
        assert_eq!(p.line(b"#undef Gain", &|_| false), Pre::Directive);
        assert_eq!(run(&mut p, "Gain=1"), "Gain=1");
        // A definition that refers to itself stops at the nesting bound.
        assert_eq!(p.line(b"#define Loop Loop+1", &|_| false), Pre::Directive);
        assert_eq!(run(&mut p, "P1=Loop"), "Error(IllegalParameter)");
    }

    #[test]
    fn expansions_are_bounded_and_keep_other_text() {
        let mut p = Preproc::default();
        assert_eq!(
            p.line(b"#define T(a) send1\"\xc2\xb0C\" a", &|_| false),
            Pre::Directive
        );
        assert_eq!(run(&mut p, "T(1)"), "send1\"\u{b0}C\" 1");
        // Macros that expand to nothing but multiply: stopped by the substitution budget.
        assert_eq!(p.line(b"#define E()", &|_| false), Pre::Directive);
        let calls = |name: &str| format!("{name}() ").repeat(40);
        assert_eq!(
            p.line(format!("#define A1() {}", calls("E")).as_bytes(), &|_| {
                false
            }),
            Pre::Directive
        );
        for k in 2..=6 {
            let def = format!("#define A{k}() {}", calls(&format!("A{}", k - 1)));
            assert_eq!(p.line(def.as_bytes(), &|_| false), Pre::Directive);
        }
        assert_eq!(run(&mut p, "P1=1 A6()"), "Error(IllegalParameter)");
        assert_eq!(run(&mut p, "P1=1 A1()").trim_end(), "P1=1");
    }

    #[test]
    fn definitions_export_and_import() {
        let mut p = Preproc::default();
        let _ = p.line(b"#define Scale(a,b) ((a)*(b))", &|_| false);
        let _ = p.line(b"#define Gain P100", &|_| false);
        let _ = run(&mut p, "open plc Lube");
        let lines = p.export();
        assert_eq!(
            lines,
            [
                "#define Gain P100",
                "#define Lube 2",
                "#define Scale(a,b) ((a)*(b))"
            ]
        );
        let mut q = Preproc::import(&lines);
        assert_eq!(run(&mut q, "Gain=Scale(2,3)"), "P100=((2)*(3))");
        assert_eq!(run(&mut q, "enable plc Lube"), "enable plc 2");
    }

    #[test]
    fn named_plcs_take_the_lowest_unused_buffer() {
        let mut p = Preproc::default();
        // PLC 1 holds a program: the first name takes 2, the next 3.
        assert_eq!(run(&mut p, "open plc Coolant_Control"), "open plc 2");
        assert_eq!(run(&mut p, "enable plc Coolant_Control"), "enable plc 2");
        assert_eq!(run(&mut p, "open plc Lube"), "open plc 3");
        assert_eq!(run(&mut p, "open plc Coolant_Control"), "open plc 2");
        assert_eq!(run(&mut p, "open plc RtPlc"), "open plc 0");
        assert_eq!(p.line(b"#define Spindle 4", &|_| false), Pre::Directive);
        assert_eq!(run(&mut p, "open plc Spindle"), "open plc 4");
        assert_eq!(
            run(&mut p, "open plc Other"),
            "open plc 5",
            "4 is taken by a define"
        );
    }
}
