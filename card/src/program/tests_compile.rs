//! Tests of the flattener: jump targets of block and one-line structures, labels, offsets.

use super::compile::{compile, Op, Unlinked};
use crate::domain::ast::StmtKind;
use crate::lang::pmac::ast::BufferKind;
use crate::lang::pmac::parse_program_line;
use crate::model::ProgLine;

fn lines(text: &str, kind: BufferKind) -> Vec<ProgLine> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| ProgLine::new(parse_program_line(l.as_bytes(), kind).unwrap()))
        .collect()
}

/// A compact picture of the ops: `B>n` branch, `J>n` jump, `J<n` loop jump, `.` nop, `x` exec.
fn shape(text: &str, kind: BufferKind) -> String {
    let c = compile(&lines(text, kind), matches!(kind, BufferKind::Plc(_))).unwrap();
    c.ops
        .iter()
        .map(|i| match &i.op {
            Op::Branch { else_to, .. } => format!("B>{else_to}"),
            Op::Jump { to, back: false } => format!("J>{to}"),
            Op::Jump { to, back: true } => format!("J<{to}"),
            Op::Nop => ".".into(),
            Op::Exec(_) => "x".into(),
            Op::Switch { .. } => "S".into(),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn block_if_else_and_while() {
    let p = BufferKind::Prog;
    // 0:B 1:x 2:J 3:x 4:. (ENDIF)
    assert_eq!(
        shape("IF (P1=1)\nP2=1\nELSE\nP2=2\nENDIF", p),
        "B>3 x J>4 x ."
    );
    // 0:B 1:x 2:J<0 3:x
    assert_eq!(
        shape("WHILE (P1<3)\nP1=P1+1\nENDWHILE\nP3=1", p),
        "B>3 x J<0 x"
    );
    assert_eq!(
        shape("WHILE (P1<3)\nIF (P2=0)\nP2=1\nENDIF\nENDWHILE", p),
        "B>5 B>3 x . J<0"
    );
}

#[test]
fn one_line_if_else_on_one_or_two_lines_and_one_line_while() {
    let p = BufferKind::Prog;
    assert_eq!(shape("IF (P1=1) X1 ELSE X2", p), "B>3 x J>4 x");
    assert_eq!(shape("IF (P1=1) X1\nELSE X2\nP3=1", p), "B>3 x J>4 x x");
    // One-line IF followed by a block ELSE … ENDIF.
    assert_eq!(shape("IF (P1=1) X1\nELSE\nX2\nENDIF", p), "B>3 x J>4 x .");
    assert_eq!(shape("WHILE (M11=0) WAIT\nX1", p), "B>3 x J<0 x");
}

#[test]
fn labels_offsets_and_line_heads() {
    let c = compile(
        &lines("X1 Y1\nN10 X2\nN20 P1=1\nN10 P2=2", BufferKind::Prog),
        false,
    )
    .unwrap();
    assert_eq!(c.label(0, 0), Some(0));
    assert_eq!(c.label(10, 0), Some(1));
    assert_eq!(
        c.label(10, 2),
        Some(5),
        "duplicates: first at or after the search point"
    );
    assert_eq!(c.label(10, 6), Some(1), "then from the top");
    assert_eq!(c.label(99, 0), None);
    assert_eq!(c.line_offset[0], 0);
    assert_eq!(c.line_offset[1], 2, "X1 Y1 is two words");
    let heads: Vec<bool> = c.ops.iter().map(|i| i.head).collect();
    assert_eq!(heads, [true, false, true, false, true, false, true]);
    assert!(matches!(&c.ops[2].op, Op::Exec(s) if matches!(s.kind, StmtKind::Move(_))));
}

#[test]
fn plc_and_or_lines_fold_into_one_condition() {
    let k = BufferKind::Plc(1);
    let text = "IF (P11=1)\nAND (P12=0)\nOR (P11=0)\nAND (P12=1)\nP1=P1+1\nELSE\nP1=P1-1\nENDIF";
    assert_eq!(shape(text, k), "B>3 x J>4 x .");
    let c = compile(&lines(text, k), true).unwrap();
    let Op::Branch { cond, .. } = &c.ops[0].op else {
        panic!()
    };
    // (P11=1 AND P12=0) OR (P11=0 AND P12=1)
    use crate::domain::ast::Cond;
    assert!(matches!(cond, Cond::Or(a, b)
        if matches!(**a, Cond::And(..)) && matches!(**b, Cond::And(..))));
}

#[test]
fn unbalanced_structure_is_unlinked() {
    let p = BufferKind::Prog;
    assert_eq!(compile(&lines("IF (P1=1)\nX1", p), false), Err(Unlinked));
    assert_eq!(compile(&lines("ENDWHILE", p), false), Err(Unlinked));
}
