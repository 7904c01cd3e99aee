//! Tests of program statement parsing, buffer-mode item classification and listing round trips.

use super::ast::*;
use super::*;

fn prog(line: &str) -> Vec<Stmt> {
    parse_program_line(line.as_bytes(), BufferKind::Prog).unwrap_or_else(|e| panic!("{line}: {e}"))
}

fn kinds(line: &str) -> Vec<StmtKind> {
    prog(line).into_iter().map(|s| s.kind).collect()
}

fn num(v: f64) -> Expr {
    Expr::num(v)
}

fn word(axis: Axis, v: f64) -> AxisWord {
    AxisWord {
        axis,
        value: num(v),
        extra: None,
    }
}

#[test]
fn moves_modes_and_words() {
    assert_eq!(
        kinds("X10 Y20 F5 M3"),
        vec![
            StmtKind::Move(vec![word(Axis::X, 10.0), word(Axis::Y, 20.0)]),
            StmtKind::F(num(5.0)),
            StmtKind::Code(CodeLetter::M, num(3.0), vec![]),
        ]
    );
    assert_eq!(
        kinds("X10Y10"),
        vec![StmtKind::Move(vec![
            word(Axis::X, 10.0),
            word(Axis::Y, 10.0)
        ])]
    );
    assert_eq!(kinds("LIN"), vec![StmtKind::Mode(MoveMode::Linear)]);
    assert_eq!(kinds("circle2"), vec![StmtKind::Mode(MoveMode::Circle2)]);
    assert_eq!(
        kinds("X10 Y5 I5 J0"),
        vec![StmtKind::Move(vec![
            word(Axis::X, 10.0),
            word(Axis::Y, 5.0),
            word(Axis::I, 5.0),
            word(Axis::J, 0.0)
        ])]
    );
    // B and I inside a motion buffer are an axis move / centre vector (§1.7)
    assert_eq!(kinds("B0"), vec![StmtKind::Move(vec![word(Axis::B, 0.0)])]);
    assert_eq!(kinds("I5"), vec![StmtKind::Move(vec![word(Axis::I, 5.0)])]);
    let s = prog("X(P1+2):-3 Y10^5");
    let StmtKind::Move(w) = &s[0].kind else {
        panic!()
    };
    assert_eq!(listing::expr(&w[0].value), "P1+2");
    assert_eq!(w[0].extra, Some(AxisExtra::Velocity(num(-3.0))));
    assert_eq!(w[1].extra, Some(AxisExtra::Trigger(num(5.0))));
    assert_eq!(kinds("DWELL100 DLY(P1)").len(), 2);
    assert_eq!(
        kinds("TA100TS50"),
        vec![StmtKind::Ta(num(100.0)), StmtKind::Ts(num(50.0))]
    );
}

#[test]
fn assignments() {
    let s = prog("P1=P1+1 M1==1 M2&=$FF Q3=-P1");
    let ops: Vec<AssignOp> = s
        .iter()
        .map(|x| match &x.kind {
            StmtKind::Assign { op, .. } => *op,
            k => panic!("{k:?}"),
        })
        .collect();
    assert_eq!(
        ops,
        vec![
            AssignOp::Set,
            AssignOp::SyncSet,
            AssignOp::SyncAnd,
            AssignOp::Set
        ]
    );
    assert_eq!(
        s.iter().map(|x| x.pos.0).collect::<Vec<_>>(),
        vec![0, 8, 14, 22]
    );
    let e = parse_program_line(b"P1==3", BufferKind::Prog).unwrap_err();
    assert_eq!(e.code, ERR_SYNTAX);
}

#[test]
fn logic_one_line_and_blocks() {
    let s = kinds("IF (P1>0) X10 ELSE X-10");
    assert!(matches!(&s[0], StmtKind::IfLine(_, b) if b.len() == 1));
    assert!(
        matches!(&s[1], StmtKind::Else(b) if b == &vec![Stmt { kind: StmtKind::Move(vec![word(Axis::X, -10.0)]), pos: Pos(0) }])
    );
    assert!(matches!(
        &kinds("IF (P1>0 AND P2<1)")[0],
        StmtKind::If(Cond::And(..))
    ));
    assert!(
        matches!(&kinds("WHILE (M11=0) WAIT")[0], StmtKind::WhileLine(_, b) if b[0].kind == StmtKind::Wait)
    );
    assert_eq!(
        kinds("ENDWHILE ENDW ENDIF ENDI"),
        vec![
            StmtKind::EndWhile,
            StmtKind::EndWhile,
            StmtKind::EndIf,
            StmtKind::EndIf
        ]
    );
    assert_eq!(
        kinds("N10 GOTO20"),
        vec![StmtKind::Label(10), StmtKind::Goto(num(20.0))]
    );
    assert_eq!(kinds("O5"), vec![StmtKind::Label(5)]);
    assert_eq!(
        parse_program_line(b"X10 N10", BufferKind::Prog)
            .unwrap_err()
            .code,
        ERR_SYNTAX
    );
    assert_eq!(
        kinds("CALL35.1 X10 D5"),
        vec![StmtKind::Call(
            num(35.1),
            vec![
                LetterArg {
                    letter: b'X',
                    value: num(10.0)
                },
                LetterArg {
                    letter: b'D',
                    value: num(5.0)
                }
            ]
        )]
    );
    assert_eq!(
        kinds("G01 X10"),
        vec![StmtKind::Code(
            CodeLetter::G,
            num(1.0),
            vec![LetterArg {
                letter: b'X',
                value: num(10.0)
            }]
        )]
    );
    assert_eq!(kinds("READ(X,Y,Z)"), vec![StmtKind::Read(b"XYZ".to_vec())]);
    assert_eq!(
        kinds("PRELUDE1 G71"),
        vec![StmtKind::Prelude(Some(PreludeCall::Code(
            CodeLetter::G,
            Number::dec(71.0)
        )))]
    );
    assert_eq!(
        kinds("CMD\"#1J+\" SEND^M"),
        vec![
            StmtKind::Command(Message::Text(b"#1J+".to_vec())),
            StmtKind::Send(SendPort::Any, Message::Ctrl(b'M'))
        ]
    );
    assert_eq!(
        parse_program_line(b"SEND\"abc", BufferKind::Prog)
            .unwrap_err()
            .code,
        ERR_SYNTAX
    );
}

#[test]
fn plc_rules() {
    let plc = |s: &str| parse_program_line(s.as_bytes(), BufferKind::Plc(1));
    // ELSE followed by statements in a PLC = ELSE + next line
    let s = plc("ELSE P1=1").unwrap();
    assert_eq!(s[0].kind, StmtKind::Else(vec![]));
    assert!(matches!(s[1].kind, StmtKind::Assign { .. }));
    assert!(matches!(
        plc("AND (P1=1)").unwrap()[0].kind,
        StmtKind::AndCond(_)
    ));
    assert!(matches!(
        plc("ADR#2&3").unwrap()[0].kind,
        StmtKind::Address {
            motor: Some(2),
            coord: Some(3)
        }
    ));
    // Issue 14 item 13, seed 10345: `ADDRESS &2#3` keeps the motor part.
    let s = plc("ADDRESS &2#3").unwrap();
    assert_eq!(s.len(), 1);
    assert!(matches!(
        s[0].kind,
        StmtKind::Address {
            motor: Some(3),
            coord: Some(2)
        }
    ));
    assert!(plc("ADR#2#3").is_err(), "one motor part only");
    // moves / sync assignment are not allowed in a PLC
    assert_eq!(plc("X10").unwrap_err().code, ERR_SYNTAX);
    assert_eq!(plc("M1==1").unwrap_err().code, ERR_SYNTAX);
    assert_eq!(plc("GOTO5").unwrap_err().code, ERR_SYNTAX);
    // labels: not in a PLC, and an O-label never becomes the on-line O (open loop) command
    let mut p = LineParser::new(b"O50").unwrap();
    assert_eq!(
        p.next_item(Mode::Buffer(BufferKind::Plc(1)))
            .unwrap()
            .unwrap_err()
            .code,
        ERR_SYNTAX
    );
    let mut p = LineParser::new(b"X10 O50").unwrap();
    let m = Mode::Buffer(BufferKind::Prog);
    assert!(matches!(p.next_item(m), Some(Ok(Item::Stmt(_)))));
    assert_eq!(
        p.next_item(m).unwrap().unwrap_err(),
        ParseError {
            pos: 4,
            code: ERR_SYNTAX,
            msg: "a label must start the line"
        }
    );
    // ADDRESS only in PLC 1-31
    assert_eq!(
        parse_program_line(b"ADDRESS#1", BufferKind::Plc(0))
            .unwrap_err()
            .code,
        ERR_SYNTAX
    );
    assert_eq!(
        parse_program_line(b"ADDRESS#1", BufferKind::Prog)
            .unwrap_err()
            .code,
        ERR_SYNTAX
    );
    // rotary: no block IF, no GOTO
    assert_eq!(
        parse_program_line(b"IF(P1>0)", BufferKind::Rotary)
            .unwrap_err()
            .code,
        ERR_SYNTAX
    );
    assert!(parse_program_line(b"IF(P1>0) X10", BufferKind::Rotary).is_ok());
}

#[test]
fn buffered_lines_mix_stored_and_immediate_items() {
    let items = |s: &str, k: BufferKind| -> Vec<Item> {
        let mut p = LineParser::new(s.as_bytes()).unwrap();
        let mut v = Vec::new();
        while let Some(i) = p.next_item(Mode::Buffer(k)) {
            v.push(i.unwrap());
        }
        v
    };
    let v = items("&2 X10 P1=3 P1 I5 M1->Y:$C000,0 CLOSE", BufferKind::Prog);
    let tags: Vec<&str> = v
        .iter()
        .map(|i| match i {
            Item::Stmt(_) => "S",
            Item::Cmd(_) => "C",
        })
        .collect();
    assert_eq!(tags, vec!["C", "S", "S", "C", "S", "C", "C"]);
    assert!(matches!(
        &v[6],
        Item::Cmd(Command {
            kind: CmdKind::Close,
            ..
        })
    ));
    // in a PLC, I5 is not a centre vector: it is the on-line query; ABS executes on-line
    let v = items("I5 ABS ENA PLC 3", BufferKind::Plc(2));
    assert!(matches!(
        &v[0],
        Item::Cmd(Command {
            kind: CmdKind::VarQuery(_),
            ..
        })
    ));
    assert!(matches!(
        &v[1],
        Item::Cmd(Command {
            kind: CmdKind::Abs(None),
            ..
        })
    ));
    assert!(matches!(
        &v[2],
        Item::Stmt(Stmt {
            kind: StmtKind::Plc(_),
            ..
        })
    ));
    // mode switches mid-line: OPEN then statements
    let mut p = LineParser::new(b"OPEN PROG 1 CLEAR X10 CLOSE").unwrap();
    assert!(matches!(p.next_item(Mode::Online), Some(Ok(Item::Cmd(_)))));
    let m = Mode::Buffer(BufferKind::Prog);
    assert!(matches!(
        p.next_item(m),
        Some(Ok(Item::Cmd(Command {
            kind: CmdKind::Clear,
            ..
        })))
    ));
    assert!(matches!(p.next_item(m), Some(Ok(Item::Stmt(_)))));
    assert!(matches!(
        p.next_item(m),
        Some(Ok(Item::Cmd(Command {
            kind: CmdKind::Close,
            ..
        })))
    ));
    assert!(p.next_item(Mode::Online).is_none());
    // HOME with a list is stored, bare HM runs now
    let v = items("HOME1,2 HM", BufferKind::Prog);
    assert!(matches!(
        &v[0],
        Item::Stmt(Stmt {
            kind: StmtKind::Home(_),
            ..
        })
    ));
    assert!(matches!(
        &v[1],
        Item::Cmd(Command {
            kind: CmdKind::Home,
            ..
        })
    ));
}

const CORPUS: &[&str] = &[
    "LINEAR",
    "RAPID",
    "CIRCLE1",
    "CIRCLE2",
    "SPLINE1",
    "PVT100",
    "ABS",
    "ABS(X,Y,R)",
    "INC(U)",
    "FRAX(X,Y)",
    "TA100 TS(P5*2) TM50.5 F(P1)",
    "DWELL1000",
    "DELAY(P1+1)",
    "HOME1,3..5",
    "HOMEZ2",
    "PSET X0 Y(P2)",
    "CC1 CCR0.25",
    "NORMAL K-1",
    "TSEL2 TINIT ADIS10 IDIS20 AROT30 IROT40",
    "X10 Y20 Z-0.5 A$10 B(P1) C1 U2 V3 W4",
    "X10:5 Y20:-3",
    "X10^-2",
    "X10 Y5 I2.5 J-1 K0 R3",
    "P1=P1+1",
    "P1=-P2*(P3-4)/SIN(P4)%3&$FF|1^2",
    "P(P1+1)=ATAN2(P2)+INT(-2.5)+ABS(-(P3+1))",
    "Q100=Q100|8 I130=$C000",
    "M1==1 M2&=3 M3|=4 M4^=5",
    "M5=M5&$20",
    "P1=1-(2-3) P2=(1-2)-3 P3=2/(4*2) P4=-P5",
    "P1=1--2 P2=3*-4",
    "P1=0.000001 P2=123456789.125 P3=-0",
    "IF (P1>0) X10 ELSE X-10",
    "IF (P1>0 AND P2<1 OR P3=2)",
    "IF ((P1>0 OR P2<1) AND P3!=2)",
    "IF (P1!>0 AND (P2!<1 AND P3~4) OR P5!~6)",
    "IF ((P1+1)*2>3)",
    "WHILE (P1<1000)",
    "WHILE (M11=0) WAIT",
    "ELSE",
    "ENDIF",
    "ENDWHILE",
    "N1000 GOTO20",
    "GOSUB(P1)",
    "CALL35.1 X10 Y(P2)",
    "G01 X10 Y10",
    "M3",
    "T115",
    "D5",
    "READ(A,B,X)",
    "PRELUDE1 CALL100",
    "PRELUDE0",
    "S1800",
    "BLOCKSTART X1 BLOCKSTOP",
    "CMD\"#1J+\" CMD^K",
    "SEND\"Hello World\" SENDS^M SENDP\"x\"",
    "DISPLAY 10 \"TEXT\"",
    "DISPLAY \"TEXT\"",
    "DISPLAY 0,8.3,P1",
    "ENABLE PLC 1..3,7",
    "DISABLE PLC 4 PAUSE PLC 5 RESUME PLC 6",
    "ENABLE PLCC 2 DISABLE PLCC 3",
    "SETPHASE1,2",
    "GATHER TRIGGER ENDGATHER",
    "STOP RETURN",
];

#[test]
fn listing_round_trip_short_and_long() {
    for src in CORPUS {
        let stmts = prog(src);
        for long in [false, true] {
            let text = listing::line(&stmts, long);
            let again = parse_program_line(text.as_bytes(), BufferKind::Prog)
                .unwrap_or_else(|e| panic!("{src} → {text}: {e}"));
            assert_eq!(again, stmts, "{src} → {text}");
        }
    }
}

#[test]
fn listing_text_is_canonical() {
    let l = |s: &str, long| listing::line(&prog(s), long);
    assert_eq!(l("lin dwe1000 ret", false), "LIN DWE1000 RET");
    assert_eq!(l("lin dwe1000 ret", true), "LINEAR DWELL1000 RETURN");
    assert_eq!(l("o50 x10y10", false), "N50 X10 Y10");
    assert_eq!(l("p1 = p1 + 1", false), "P1=P1+1");
    assert_eq!(l("p1=(p2*3)+(4)", false), "P1=P2*3+4");
    assert_eq!(l("p1=p2-(p3-p4)", false), "P1=P2-(P3-P4)");
    assert_eq!(l("i130=$c000", false), "I130=$C000");
    assert_eq!(l("if(p1>0)", false), "IF (P1>0)");
    assert_eq!(l("endif endwhile", false), "ENDI ENDW");
    assert_eq!(l("ena plc 3", true), "ENABLE PLC 3");
    assert_eq!(l("ena plc 3", false), "ENA PLC 3");
    // `DIS PLC` / `DISPLC` is DISABLE (not DISPLAY), with or without the space.
    assert_eq!(l("dis plc 3", true), "DISABLE PLC 3");
    assert_eq!(l("displc3", true), "DISABLE PLC 3");
    assert_eq!(l("x(p1)", false), "X(P1)");
    assert_eq!(l("x(10)", false), "X10");
    assert_eq!(l("cmd\"#1j+\"", true), "COMMAND\"#1j+\"");
    let plc = parse_program_line(b"ADDRESS#1&2", BufferKind::Plc(1)).unwrap();
    assert_eq!(listing::line(&plc, true), "ADDRESS#1&2");
}

#[test]
fn word_counts_match_the_manual_examples() {
    let w = |s: &str| {
        prog(s)
            .iter()
            .map(crate::domain::words::word_count)
            .sum::<u32>()
    };
    assert_eq!(w("LINEAR"), 1);
    assert_eq!(w("F10"), 1);
    assert_eq!(w("X10Y10"), 2);
    assert_eq!(w("RETURN"), 1);
    assert_eq!(w("P1=0"), 1);
    assert_eq!(w("WHILE (P1<1000)"), 2);
    assert_eq!(w("P1=P1+1"), 3);
    assert_eq!(w("ENDWHILE"), 1);
}

mod generated {
    use super::super::ast::*;
    use super::super::*;
    use proptest::prelude::*;

    fn leaf() -> impl Strategy<Value = Expr> {
        let num = (any::<bool>(), -100_000i64..100_000, 0u32..4).prop_map(|(hex, v, frac)| {
            let value = if hex {
                v as f64
            } else {
                v as f64 / 10f64.powi(frac as i32)
            };
            Expr {
                kind: ExprKind::Num(Number { value, hex }),
                pos: Pos(0),
            }
        });
        let var = (0u8..4, 0u32..1024).prop_map(|(k, n)| {
            let kind = [VarKind::I, VarKind::P, VarKind::Q, VarKind::M][k as usize];
            Expr {
                kind: ExprKind::Var(VarRef {
                    kind,
                    index: VarIndex::Const(n),
                    pos: Pos(0),
                }),
                pos: Pos(0),
            }
        });
        prop_oneof![num, var]
    }

    fn expr() -> impl Strategy<Value = Expr> {
        leaf().prop_recursive(6, 48, 2, |inner| {
            let ops = [
                BinOp::Mul,
                BinOp::Div,
                BinOp::Mod,
                BinOp::And,
                BinOp::Add,
                BinOp::Sub,
                BinOp::Or,
                BinOp::Xor,
            ];
            let funcs = [
                Func::Sin,
                Func::Atan2,
                Func::Ln,
                Func::Sqrt,
                Func::Abs,
                Func::Int,
            ];
            let mk = |kind| Expr { kind, pos: Pos(0) };
            prop_oneof![
                (0usize..8, inner.clone(), inner.clone())
                    .prop_map(move |(o, l, r)| mk(ExprKind::Bin(ops[o], Box::new(l), Box::new(r)))),
                inner
                    .clone()
                    .prop_map(move |e| mk(ExprKind::Neg(Box::new(e)))),
                (0usize..6, inner.clone())
                    .prop_map(move |(f, e)| mk(ExprKind::Call(funcs[f], Box::new(e)))),
                inner.prop_map(move |e| mk(ExprKind::Var(VarRef {
                    kind: VarKind::P,
                    index: VarIndex::Expr(Box::new(e)),
                    pos: Pos(0)
                }))),
            ]
        })
    }

    fn cond() -> impl Strategy<Value = Cond> {
        let cmps = [
            CmpOp::Eq,
            CmpOp::Ne,
            CmpOp::Gt,
            CmpOp::NotGt,
            CmpOp::Lt,
            CmpOp::NotLt,
            CmpOp::Approx,
        ];
        let atom = (0usize..7, expr(), expr()).prop_map(move |(o, lhs, rhs)| Cond::Cmp {
            lhs,
            op: cmps[o],
            rhs,
        });
        atom.prop_recursive(3, 12, 2, |inner| {
            prop_oneof![
                (inner.clone(), inner.clone())
                    .prop_map(|(a, b)| Cond::And(Box::new(a), Box::new(b))),
                (inner.clone(), inner).prop_map(|(a, b)| Cond::Or(Box::new(a), Box::new(b))),
            ]
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1500))]
        #[test]
        fn expressions_round_trip(e in expr()) {
            let s = Stmt {
                kind: StmtKind::Assign {
                    target: VarRef { kind: VarKind::P, index: VarIndex::Const(1), pos: Pos(0) },
                    op: AssignOp::Set,
                    value: e,
                },
                pos: Pos(0),
            };
            let text = listing::stmt(&s, false);
            let again = parse_program_line(text.as_bytes(), BufferKind::Prog);
            prop_assert_eq!(again, Ok(vec![s]), "{}", text);
        }

        #[test]
        fn conditions_round_trip(c in cond()) {
            let s = Stmt { kind: StmtKind::While(c), pos: Pos(0) };
            let text = listing::stmt(&s, true);
            if text.len() <= MAX_LINE_LEN {
                let again = parse_program_line(text.as_bytes(), BufferKind::Prog);
                prop_assert_eq!(again, Ok(vec![s]), "{}", text);
            }
        }
    }
}
