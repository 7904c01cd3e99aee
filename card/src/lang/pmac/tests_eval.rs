//! Expression evaluation (`crate::domain::eval`) driven through the PMAC parser.

use crate::domain::ast::*;
use crate::domain::eval::*;
use crate::domain::ErrCode;
use crate::lang::pmac::ast::Item;
use crate::lang::pmac::{LineParser, Mode};
use std::collections::HashMap;

struct TestEnv {
    vars: HashMap<(VarKind, u32), f64>,
    radians: bool,
}

impl Env for TestEnv {
    fn var(&mut self, kind: VarKind, index: u32) -> Result<f64, EvalError> {
        if index > 1023 {
            return Err(EvalError {
                code: ErrCode::Data,
                msg: "no such variable",
            });
        }
        Ok(*self.vars.get(&(kind, index)).unwrap_or(&0.0))
    }
    fn radians(&self) -> bool {
        self.radians
    }
}

fn env() -> TestEnv {
    let mut vars = HashMap::new();
    vars.insert((VarKind::P, 1), 25.0);
    vars.insert((VarKind::P, 2), 2.0);
    vars.insert((VarKind::P, 5), 7.0);
    vars.insert((VarKind::Q, 0), -1.0);
    TestEnv {
        vars,
        radians: false,
    }
}

/// Evaluate the right-hand side of `P0=<text>` parsed by the real parser.
fn ev(text: &str, env: &mut TestEnv) -> f64 {
    let line = format!("P0={text}");
    let mut p = LineParser::new(line.as_bytes()).unwrap();
    match p.next_item(Mode::Online).unwrap().unwrap() {
        Item::Cmd(c) => match c.kind {
            crate::lang::pmac::ast::CmdKind::VarAssign(_, e) => eval(&e, env).unwrap(),
            k => panic!("{k:?}"),
        },
        i => panic!("{i:?}"),
    }
}

#[test]
fn modulo_examples_from_the_manual() {
    let cases = [
        (11.0, 4.0, 3.0),
        (-11.0, 4.0, 1.0),
        (11.0, -4.0, 3.0),
        (-11.0, -4.0, -3.0),
        (3.0, 2.5, 0.5),
        (-3.0, 2.5, 2.0),
        (3.0, -2.5, -2.0),
        (-3.0, -2.5, 2.0),
        (7.0, 0.0, 0.0),
    ];
    for (a, n, r) in cases {
        assert_eq!(modulo(a, n), r, "{a}%{n}");
    }
    assert_eq!(ev("-11%4", &mut env()), 1.0);
}

#[test]
fn bitwise_on_fixed_point() {
    let mut e = env();
    assert_eq!(ev("3&-3", &mut e), 1.0);
    assert_eq!(ev("0.875&1.75", &mut e), 0.75);
    assert_eq!(ev("0.875&-1.75", &mut e), 0.25);
    assert_eq!(ev("3|-3", &mut e), -1.0);
    assert_eq!(ev("$F0|$4", &mut e), 244.0);
    assert_eq!(ev("0.5|0.375", &mut e), 0.875);
    assert_eq!(ev("3^-3", &mut e), -2.0);
    assert_eq!(ev("0.5^0.875", &mut e), 0.375);
    assert_eq!(ev("3 & 4", &mut e), 0.0);
}

#[test]
fn precedence_division_and_saturation() {
    let mut e = env();
    assert_eq!(ev("1+2*3", &mut e), 7.0);
    assert_eq!(ev("2*3+1|8", &mut e), 15.0); // (2*3+1)|8, left to right on the low level
    assert_eq!(ev("1+6&3", &mut e), 3.0); // & binds tighter than +
    assert_eq!(ev("10-4-3", &mut e), 3.0);
    assert_eq!(ev("P1/0", &mut e), DIV_ZERO);
    assert_eq!(ev("-P1/0", &mut e), -DIV_ZERO);
    assert_eq!(ev("10*2/3", &mut e), 20.0 / 3.0);
    assert_eq!(to_integer(ev("10*2/3", &mut e)), 7.0);
    assert_eq!(ev("P(P2+3)*2", &mut e), 14.0);
    assert_eq!(ev("-(P1+P2)", &mut e), -27.0);
}

#[test]
fn functions_degrees_and_radians() {
    let mut e = env();
    assert!((ev("SIN(30)", &mut e) - 0.5).abs() < 1e-12);
    assert!((ev("COS(60)", &mut e) - 0.5).abs() < 1e-12);
    assert!((ev("ASIN(1)", &mut e) - 90.0).abs() < 1e-12);
    assert!((ev("ACOS(-1)", &mut e) - 180.0).abs() < 1e-12);
    assert!((ev("ATAN(1)", &mut e) - 45.0).abs() < 1e-12);
    // ATAN2(sin) with Q0 = -1 as the cosine part → 180°
    assert!((ev("ATAN2(0)", &mut e) - 180.0).abs() < 1e-12);
    assert_eq!(ev("INT(-2.5)", &mut e), -3.0);
    assert_eq!(ev("INT(2.5)", &mut e), 2.0);
    assert_eq!(ev("LN(0)", &mut e), 0.0);
    assert_eq!(ev("SQRT(-4)", &mut e), 0.0);
    assert_eq!(ev("SQRT(P1)", &mut e), 5.0);
    assert_eq!(ev("ABS(-P1)", &mut e), 25.0);
    e.radians = true;
    assert!((ev("SIN(3.14159265358979/2)", &mut e) - 1.0).abs() < 1e-12);
    assert!((ev("ATAN(1)", &mut e) - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
}

#[test]
fn variable_errors_propagate() {
    let mut e = env();
    let line = b"P0=P2000+1";
    let mut p = LineParser::new(line).unwrap();
    let Some(Ok(Item::Cmd(c))) = p.next_item(Mode::Online) else {
        panic!()
    };
    let crate::lang::pmac::ast::CmdKind::VarAssign(_, x) = c.kind else {
        panic!()
    };
    assert_eq!(eval(&x, &mut e).unwrap_err().code, ErrCode::Data);
}

#[test]
fn pmac48_rounding() {
    assert_eq!(to_pmac48(0.5), 0.5);
    assert_eq!(to_pmac48(-3.0), -3.0);
    let third = to_pmac48(1.0 / 3.0);
    assert!((third - 1.0 / 3.0).abs() < 2f64.powi(-36));
    assert_ne!(third, 1.0 / 3.0); // precision really is reduced
    assert_eq!(to_pmac48(f64::NAN), 0.0);
    assert_eq!(to_pmac48(2f64.powi(47)), 2f64.powi(47));
}

#[test]
fn conditions_and_binds_tighter_than_or() {
    let mut e = env();
    let line = b"IF (P1=25 OR P2=0 AND P5=0)";
    let stmts =
        crate::lang::pmac::parse_program_line(line, crate::lang::pmac::ast::BufferKind::Prog)
            .unwrap();
    let crate::lang::pmac::ast::StmtKind::If(c) = &stmts[0].kind else {
        panic!()
    };
    assert!(eval_cond(c, &mut e).unwrap());
    let line = b"IF ((P1=25 OR P2=0) AND P5=0)";
    let stmts =
        crate::lang::pmac::parse_program_line(line, crate::lang::pmac::ast::BufferKind::Prog)
            .unwrap();
    let crate::lang::pmac::ast::StmtKind::If(c) = &stmts[0].kind else {
        panic!()
    };
    assert!(!eval_cond(c, &mut e).unwrap());
    assert!(compare(CmpOp::Approx, 1.0, 2.0));
    assert!(compare(CmpOp::NotGt, 2.0, 2.0));
    assert!(!compare(CmpOp::NotLt, 1.0, 2.0));
}
