//! Tests of on-line command parsing: exact ASTs, positions and error codes.

use super::ast::*;
use super::*;

fn kinds(line: &str) -> Vec<CmdKind> {
    parse_line(line.as_bytes())
        .unwrap_or_else(|e| panic!("{line}: {e}"))
        .into_iter()
        .map(|c| c.kind)
        .collect()
}

fn err(line: &[u8]) -> ParseError {
    parse_line(line).expect_err("should fail")
}

fn vl(kind: VarKind, sel: VarSel) -> VarList {
    VarList {
        kind,
        sel,
        pos: Pos(0),
    }
}

fn one(kind: VarKind, n: u32) -> VarList {
    vl(kind, VarSel::One(VarIndex::Const(n)))
}

#[test]
fn concatenation_without_separators() {
    assert_eq!(
        kinds("%#1?PVF"),
        vec![
            CmdKind::OverrideQuery,
            CmdKind::AddrMotor(1),
            CmdKind::MotorStatus,
            CmdKind::Position,
            CmdKind::Velocity,
            CmdKind::FollowingError
        ]
    );
    assert_eq!(
        kinds("p99#2?PVF"),
        vec![
            CmdKind::VarQuery(one(VarKind::P, 99)),
            CmdKind::AddrMotor(2),
            CmdKind::MotorStatus,
            CmdKind::Position,
            CmdKind::Velocity,
            CmdKind::FollowingError
        ]
    );
    let jog = |kind| CmdKind::Jog {
        kind,
        trigger: None,
    };
    assert_eq!(
        kinds("#1J+#2J-"),
        vec![
            CmdKind::AddrMotor(1),
            jog(JogKind::Plus),
            CmdKind::AddrMotor(2),
            jog(JogKind::Minus)
        ]
    );
    assert_eq!(
        kinds("&1B1R"),
        vec![
            CmdKind::AddrCoord(1),
            CmdKind::Begin(Number::dec(1.0)),
            CmdKind::Run
        ]
    );
    assert_eq!(
        kinds("#3HM#4HM"),
        vec![
            CmdKind::AddrMotor(3),
            CmdKind::Home,
            CmdKind::AddrMotor(4),
            CmdKind::Home
        ]
    );
    assert_eq!(
        kinds("@0&1B1R@1&1B7R"),
        vec![
            CmdKind::AddrCard(0),
            CmdKind::AddrCoord(1),
            CmdKind::Begin(Number::dec(1.0)),
            CmdKind::Run,
            CmdKind::AddrCard(1),
            CmdKind::AddrCoord(1),
            CmdKind::Begin(Number::dec(7.0)),
            CmdKind::Run
        ]
    );
}

#[test]
fn positions_are_byte_offsets() {
    let cmds = parse_line(b"  #1 J+  P5=3").unwrap();
    let pos: Vec<u32> = cmds.iter().map(|c| c.pos.0).collect();
    assert_eq!(pos, vec![2, 5, 9]);
    let CmdKind::VarAssign(v, e) = &cmds[2].kind else {
        panic!()
    };
    assert_eq!((v.pos.0, e.pos.0), (9, 12));
}

#[test]
fn keyword_tokenisation_table() {
    assert_eq!(kinds("P"), vec![CmdKind::Position]);
    assert_eq!(
        kinds("PR PC PE"),
        vec![
            CmdKind::RotaryRemaining,
            CmdKind::ProgCounter,
            CmdKind::ExecPointer
        ]
    );
    assert_eq!(kinds("Q"), vec![CmdKind::Quit]);
    assert_eq!(kinds("Q7"), vec![CmdKind::VarQuery(one(VarKind::Q, 7))]);
    assert_eq!(kinds("R"), vec![CmdKind::Run]);
    assert_eq!(
        kinds("RX:$10"),
        vec![CmdKind::ReadMem {
            hex: false,
            space: MemSpace::X,
            addr: 16,
            count: 1
        }]
    );
    assert_eq!(
        kinds("RHY$720,4"),
        vec![CmdKind::ReadMem {
            hex: true,
            space: MemSpace::Y,
            addr: 0x720,
            count: 4
        }]
    );
    assert_eq!(
        kinds("rl$0028"),
        vec![CmdKind::ReadMem {
            hex: false,
            space: MemSpace::L,
            addr: 0x28,
            count: 1
        }]
    );
    assert_eq!(
        kinds("S F V A H K Z"),
        vec![
            CmdKind::Step,
            CmdKind::FollowingError,
            CmdKind::Velocity,
            CmdKind::Abort,
            CmdKind::Hold,
            CmdKind::Kill,
            CmdKind::ZeroAxes
        ]
    );
    assert_eq!(
        kinds("X=0 A=5"),
        vec![
            CmdKind::AxisRename(Axis::X, 0.0),
            CmdKind::AxisRename(Axis::A, 5.0)
        ]
    );
    assert_eq!(kinds("B12.6"), vec![CmdKind::Begin(Number::dec(12.6))]);
    assert_eq!(
        kinds("O50 O-20"),
        vec![CmdKind::OpenLoop(50.0), CmdKind::OpenLoop(-20.0)]
    );
    assert_eq!(kinds("I5=*"), vec![CmdKind::VarDefault(one(VarKind::I, 5))]);
    assert_eq!(
        kinds("? ?? ??? ????"),
        vec![
            CmdKind::MotorStatus,
            CmdKind::CsStatus,
            CmdKind::GlobalStatus,
            CmdKind::GlobalStatus,
            CmdKind::MotorStatus
        ]
    );
    assert_eq!(
        kinds("$ $* $$$ $$$***"),
        vec![
            CmdKind::MotorInit,
            CmdKind::MotorAbsRead,
            CmdKind::Reset,
            CmdKind::Reinit
        ]
    );
    assert_eq!(
        kinds("% %50 %12.5"),
        vec![
            CmdKind::OverrideQuery,
            CmdKind::OverrideSet(50.0),
            CmdKind::OverrideSet(12.5)
        ]
    );
    assert_eq!(
        kinds("# #2 & &2 @ @3 @@ @a"),
        vec![
            CmdKind::ReportMotor,
            CmdKind::AddrMotor(2),
            CmdKind::ReportCoord,
            CmdKind::AddrCoord(2),
            CmdKind::ReportCard,
            CmdKind::AddrCard(3),
            CmdKind::AddrAllCards,
            CmdKind::AddrCard(10)
        ]
    );
    assert_eq!(kinds("25"), vec![CmdKind::BareNumber(Number::dec(25.0))]);
    assert_eq!(
        kinds("-2.5 $1F"),
        vec![
            CmdKind::BareNumber(Number::dec(-2.5)),
            CmdKind::BareNumber(Number {
                value: 31.0,
                hex: true
            })
        ]
    );
    assert_eq!(
        kinds("/ \\ < >"),
        vec![
            CmdKind::StopAtEnd,
            CmdKind::HoldJog,
            CmdKind::BackUp,
            CmdKind::Resume
        ]
    );
}

#[test]
fn short_and_long_forms_case_insensitive() {
    let pairs = [
        ("CHECKSUM", "chks", CmdKind::Checksum),
        ("CLEARFAULT", "clrf", CmdKind::ClearFault),
        ("CLEAR", "clr", CmdKind::Clear),
        ("CLOSE", "cls", CmdKind::Close),
        ("DATE", "dat", CmdKind::Date),
        ("EAVERSION", "eaver", CmdKind::EaVersion),
        ("VERSION", "ver", CmdKind::Version),
        ("HOMEZ", "hmz", CmdKind::HomeZ),
        ("ENDGATHER", "endg", CmdKind::EndGather),
        ("UNDEFINE ALL", "undef all", CmdKind::UndefineAll),
        ("UNDEFINE", "undef", CmdKind::Undefine),
        (
            "GATHER TRIGGER",
            "gat trig",
            CmdKind::Gather { trigger: true },
        ),
    ];
    for (long, short, k) in pairs {
        assert_eq!(kinds(long), vec![k.clone()], "{long}");
        assert_eq!(kinds(short), vec![k], "{short}");
    }
    assert_eq!(
        kinds("type size save cid pmatch mflush"),
        vec![
            CmdKind::Type,
            CmdKind::Size,
            CmdKind::Save,
            CmdKind::Cid,
            CmdKind::PMatch,
            CmdKind::MFlush
        ]
    );
}

#[test]
fn variables_ranges_and_strides() {
    assert_eq!(
        kinds("P1..10"),
        vec![CmdKind::VarQuery(vl(
            VarKind::P,
            VarSel::Range { first: 1, last: 10 }
        ))]
    );
    assert_eq!(
        kinds("I100..199=*"),
        vec![CmdKind::VarDefault(vl(
            VarKind::I,
            VarSel::Range {
                first: 100,
                last: 199
            }
        ))]
    );
    assert_eq!(
        kinds("I130,8,100"),
        vec![CmdKind::VarQuery(vl(
            VarKind::I,
            VarSel::Strided {
                first: 130,
                count: 8,
                step: 100
            }
        ))]
    );
    assert_eq!(
        kinds("P1,3"),
        vec![CmdKind::VarQuery(vl(
            VarKind::P,
            VarSel::Strided {
                first: 1,
                count: 3,
                step: 1
            }
        ))]
    );
    let v = vl(
        VarKind::I,
        VarSel::Strided {
            first: 130,
            count: 3,
            step: 100,
        },
    );
    assert_eq!(v.constant_indices(), Some(vec![130, 230, 330]));
    let c = kinds("P100..102=P1+1");
    let CmdKind::VarAssign(v, e) = &c[0] else {
        panic!()
    };
    assert_eq!(v.constant_indices(), Some(vec![100, 101, 102]));
    assert_eq!(listing::expr(e), "P1+1");
    let c = kinds("P(P1+1)=5");
    let CmdKind::VarAssign(v, _) = &c[0] else {
        panic!()
    };
    assert!(matches!(&v.sel, VarSel::One(VarIndex::Expr(_))));
    assert_eq!(
        kinds("M1..8->"),
        vec![CmdKind::MDefQuery(vl(
            VarKind::M,
            VarSel::Range { first: 1, last: 8 }
        ))]
    );
    assert_eq!(err(b"P10..5").code, ERR_SYNTAX);
    assert_eq!(err(b"P1,0").code, ERR_SYNTAX);
    // synchronous forms are program-only
    assert_eq!(err(b"M1==5").code, ERR_NEEDS_BUFFER);
}

#[test]
fn m_variable_definitions() {
    let def = |s: &str| match &kinds(s)[0] {
        CmdKind::MDefine(_, d) => *d,
        k => panic!("{k:?}"),
    };
    let bits = |space, addr, offset, width, format| MDef::Bits {
        space,
        addr,
        offset,
        width,
        format,
    };
    assert_eq!(
        def("M1->X:$C000,0,24,S"),
        bits(XySpace::X, 0xC000, 0, 24, MFormat::S)
    );
    assert_eq!(
        def("M1->X:$C003,24,S"),
        bits(XySpace::X, 0xC003, 0, 24, MFormat::S)
    );
    assert_eq!(
        def("M1->X$C003,24"),
        bits(XySpace::X, 0xC003, 0, 24, MFormat::U)
    );
    assert_eq!(
        def("m1->y:$ffc2,8"),
        bits(XySpace::Y, 0xFFC2, 8, 1, MFormat::U)
    );
    assert_eq!(
        def("M1->Y:$C003,8,16,S"),
        bits(XySpace::Y, 0xC003, 8, 16, MFormat::S)
    );
    assert_eq!(def("M162->D$2C"), MDef::D(0x2C));
    assert_eq!(def("M1->L:$1000"), MDef::L(0x1000));
    assert_eq!(def("M1->DP:$D000"), MDef::Dp(0xD000));
    assert_eq!(def("M1->F:$D001"), MDef::F(0xD001));
    assert_eq!(def("M1->*"), MDef::SelfRef);
    assert_eq!(
        def("M1->TWB:2,3,8,S"),
        MDef::Twb {
            mux: 2,
            offset: 3,
            size: 8,
            format: MFormat::S
        }
    );
    assert_eq!(
        def("M1->TWD:0,4,6.2"),
        MDef::Twd {
            mux: 0,
            offset: 4,
            digits: 6,
            decimals: 2,
            format: MFormat::U
        }
    );
    assert_eq!(def("M1->TWR:4,1"), MDef::Twr { mux: 4, offset: 1 });
    assert_eq!(def("M1->TWS:8"), MDef::Tws { mux: 8 });
    // comments after a definition (V1.17A)
    assert_eq!(
        def("M1->Y:$C000,0,24 ; the status word"),
        bits(XySpace::Y, 0xC000, 0, 24, MFormat::U)
    );
    for bad in [
        "M1->X:$C000,2,8",
        "M1->X:$C000,20,8",
        "M1->X:$C000,0,7",
        "M1->X:$1000000,0",
        "M1->TWR:3,0",
    ] {
        assert_eq!(err(bad.as_bytes()).code, ERR_SYNTAX, "{bad}");
    }
    // listing of definitions (the `Mn->` reply body)
    assert_eq!(def("M1->X:$C003,0,24,S").to_string(), "X:$C003,24,S");
    assert_eq!(def("M1->Y:$FFC2,8").to_string(), "Y:$FFC2,8");
    assert_eq!(def("M1->Y:$C003,8,16,S").to_string(), "Y:$C003,8,16,S");
    assert_eq!(def("M1->D:$2C").to_string(), "D:$002C");
    assert_eq!(def("M1->*").to_string(), "*");
}

#[test]
fn axis_definitions() {
    let d = |s: &str| kinds(s).remove(0);
    let term = |scale, axis| AxisTerm { scale, axis };
    assert_eq!(d("#1->"), CmdKind::AxisDefQuery(1));
    assert_eq!(d("#1->0"), CmdKind::AxisUndefine(1));
    assert_eq!(
        d("#1->10000X"),
        CmdKind::AxisDefine(
            1,
            AxisDef {
                terms: vec![term(10000.0, Axis::X)],
                offset: 0.0
            }
        )
    );
    let c = d("#2->5000X+8660Y+5000");
    let CmdKind::AxisDefine(2, def) = &c else {
        panic!()
    };
    assert_eq!(
        def.terms,
        vec![term(5000.0, Axis::X), term(8660.0, Axis::Y)]
    );
    assert_eq!(def.offset, 5000.0);
    assert_eq!(listing::axis_def(def), "5000X+8660Y+5000");
    let c = d("#1->8660X-5000Y");
    let CmdKind::AxisDefine(_, def) = &c else {
        panic!()
    };
    assert_eq!(listing::axis_def(def), "8660X-5000Y");
    let c = d("#3->A");
    let CmdKind::AxisDefine(_, def) = &c else {
        panic!()
    };
    assert_eq!(listing::axis_def(def), "A");
    assert_eq!(
        kinds("&1#1->#2->"),
        vec![
            CmdKind::AddrCoord(1),
            CmdKind::AxisDefQuery(1),
            CmdKind::AxisDefQuery(2)
        ]
    );
    assert_eq!(err(b"#1->1000X+1000U").code, ERR_SYNTAX);
    assert_eq!(err(b"#0").code, ERR_SYNTAX);
}

#[test]
fn buffer_commands() {
    assert_eq!(
        kinds("OPEN PROG 1 CLEAR"),
        vec![CmdKind::Open(OpenTarget::Prog(1)), CmdKind::Clear]
    );
    assert_eq!(kinds("open plc 5"), vec![CmdKind::Open(OpenTarget::Plc(5))]);
    assert_eq!(kinds("OPEN ROT"), vec![CmdKind::Open(OpenTarget::Rotary)]);
    assert_eq!(
        kinds("OPEN BIN ROT"),
        vec![CmdKind::Open(OpenTarget::BinRotary)]
    );
    let span = |offsets, start, len| ListSpan {
        offsets,
        start,
        len,
    };
    assert_eq!(
        kinds("LIST PROG 3"),
        vec![CmdKind::List(ListTarget::Prog(3, span(false, None, None)))]
    );
    assert_eq!(
        kinds("list program 3,10,5"),
        vec![CmdKind::List(ListTarget::Prog(
            3,
            span(true, Some(10), Some(5))
        ))]
    );
    assert_eq!(
        kinds("LIST PLC 2,"),
        vec![CmdKind::List(ListTarget::Plc(2, span(true, None, None)))]
    );
    assert_eq!(
        kinds("LIST PLC 2,,4"),
        vec![CmdKind::List(ListTarget::Plc(2, span(true, None, Some(4))))]
    );
    assert_eq!(kinds("LIST"), vec![CmdKind::List(ListTarget::Open)]);
    assert_eq!(
        kinds("LIST PC,"),
        vec![CmdKind::List(ListTarget::Pc(span(true, None, None)))]
    );
    assert_eq!(
        kinds("LIS GAT"),
        vec![CmdKind::List(ListTarget::Gather(span(false, None, None)))]
    );
    assert_eq!(
        kinds("LIST COMP DEF"),
        vec![CmdKind::List(ListTarget::Comp(true))]
    );
    assert_eq!(
        kinds("DEFINE ROT 100"),
        vec![CmdKind::Define(DefineTarget::Rotary(100))]
    );
    assert_eq!(
        kinds("DEF GAT"),
        vec![CmdKind::Define(DefineTarget::Gather(None))]
    );
    assert_eq!(
        kinds("DEFINE GATHER 5000"),
        vec![CmdKind::Define(DefineTarget::Gather(Some(5000)))]
    );
    assert_eq!(
        kinds("DEF UBUF 10"),
        vec![CmdKind::Define(DefineTarget::Ubuffer(10))]
    );
    assert_eq!(
        kinds("DEFINE COMP 100,#2,#2,100000"),
        vec![CmdKind::Define(DefineTarget::Comp {
            rows: 100,
            cols: None,
            motors: vec![
                CompMotor {
                    motor: 2,
                    desired: false
                },
                CompMotor {
                    motor: 2,
                    desired: false
                }
            ],
            spans: vec![Number::dec(100000.0)],
        })]
    );
    assert_eq!(
        kinds("DEL GAT DELETE ROT DEL PLCC 3"),
        vec![
            CmdKind::Delete(DeleteTarget::Gather),
            CmdKind::Delete(DeleteTarget::Rotary),
            CmdKind::Delete(DeleteTarget::Plcc(3))
        ]
    );
    assert_eq!(err(b"OPEN PROG 0").code, ERR_SYNTAX);
    assert_eq!(err(b"OPEN PLC 32").code, ERR_SYNTAX);
}

#[test]
fn plc_control_and_lists() {
    let ctl = |verb, list: Vec<NumRange>| CmdKind::Plc(PlcControl { verb, list });
    let r = |first, last| NumRange { first, last };
    assert_eq!(
        kinds("ENABLE PLC 0..31"),
        vec![ctl(PlcVerb::Enable, vec![r(0, 31)])]
    );
    assert_eq!(
        kinds("DIS PLC 1,3..5"),
        vec![ctl(PlcVerb::Disable, vec![r(1, 1), r(3, 5)])]
    );
    assert_eq!(kinds("displc2"), vec![ctl(PlcVerb::Disable, vec![r(2, 2)])]);
    assert_eq!(
        kinds("ENA PLCC 4"),
        vec![ctl(PlcVerb::EnableCompiled, vec![r(4, 4)])]
    );
    assert_eq!(
        kinds("PAU PLC 7 RES PLC 7"),
        vec![
            ctl(PlcVerb::Pause, vec![r(7, 7)]),
            ctl(PlcVerb::Resume, vec![r(7, 7)])
        ]
    );
    assert_eq!(err(b"ENABLE PLC 32").code, ERR_SYNTAX);
    assert_eq!(
        kinds("SETPHASE1..3,5"),
        vec![CmdKind::SetPhase(vec![r(1, 3), r(5, 5)])]
    );
}

#[test]
fn jogs() {
    let j = |s: &str| match kinds(s).remove(0) {
        CmdKind::Jog { kind, trigger } => (kind, trigger),
        k => panic!("{k:?}"),
    };
    assert_eq!(j("J/"), (JogKind::Stop, None));
    assert_eq!(j("J!"), (JogKind::Round, None));
    assert_eq!(j("J="), (JogKind::PreJog, None));
    assert_eq!(j("J=1000"), (JogKind::To(1000.0), None));
    assert_eq!(j("J==-50"), (JogKind::ToAndSetPreJog(-50.0), None));
    assert_eq!(j("J:500"), (JogKind::RelCommanded(500.0), None));
    assert_eq!(j("J^-20"), (JogKind::RelActual(-20.0), None));
    assert_eq!(j("J=*"), (JogKind::VarTo, None));
    assert_eq!(j("J:*^100"), (JogKind::VarRelCommanded, Some(100.0)));
    assert_eq!(j("J=2000^-5"), (JogKind::To(2000.0), Some(-5.0)));
    assert_eq!(err(b"J").code, ERR_SYNTAX);
}

#[test]
fn macro_commands() {
    assert_eq!(
        kinds("MS0,MI910"),
        vec![CmdKind::MacroSlaveVar {
            node: 0,
            var: SlaveVar::Mi(910),
            value: None
        }]
    );
    assert_eq!(
        kinds("ms0,i910"),
        vec![CmdKind::MacroSlaveVar {
            node: 0,
            var: SlaveVar::Mi(910),
            value: None
        }]
    );
    assert_eq!(
        kinds("MACROSLAVE8,C2=0"),
        vec![CmdKind::MacroSlaveVar {
            node: 8,
            var: SlaveVar::Mc(2),
            value: Some(Number::dec(0.0))
        }]
    );
    assert_eq!(
        kinds("MS$$$0"),
        vec![CmdKind::MacroSlaveCmd {
            cmd: SlaveCmd::Reset,
            node: 0
        }]
    );
    assert_eq!(
        kinds("MS CLRF8"),
        vec![CmdKind::MacroSlaveCmd {
            cmd: SlaveCmd::ClearFault,
            node: 8
        }]
    );
    assert_eq!(
        kinds("MS CONFIG12=37"),
        vec![CmdKind::MacroSlaveCmd {
            cmd: SlaveCmd::Config(Some(37)),
            node: 12
        }]
    );
    assert_eq!(
        kinds("MS VER8"),
        vec![CmdKind::MacroSlaveCmd {
            cmd: SlaveCmd::Version,
            node: 8
        }]
    );
    assert_eq!(
        kinds("MX4,20=$100"),
        vec![CmdKind::MacroAux {
            node: 4,
            param: 20,
            value: Some(Number {
                value: 256.0,
                hex: true
            })
        }]
    );
    let c = kinds("MSW4,MC4,P0");
    let CmdKind::MacroSlaveWrite {
        node: 4,
        var: SlaveVar::Mc(4),
        src,
    } = &c[0]
    else {
        panic!("{c:?}")
    };
    assert_eq!((src.kind, &src.index), (VarKind::P, &VarIndex::Const(0)));
    assert_eq!(err(b"MS16,MI910").code, ERR_SYNTAX);
}

#[test]
fn password_takes_rest_of_line_verbatim() {
    assert_eq!(
        kinds("PASSWORD=MyPass 1;x"),
        vec![CmdKind::Password(b"MyPass 1;x".to_vec())]
    );
}

#[test]
fn comments_and_spaces() {
    assert_eq!(
        kinds("#1 J+ ; jog it"),
        vec![
            CmdKind::AddrMotor(1),
            CmdKind::Jog {
                kind: JogKind::Plus,
                trigger: None
            }
        ]
    );
    assert_eq!(kinds(""), vec![]);
    assert_eq!(kinds("   ;only a comment"), vec![]);
    assert_eq!(kinds("P1 = 5"), kinds("P1=5"));
    assert_eq!(
        kinds("ABS (X,Y)"),
        vec![CmdKind::Abs(Some(vec![Axis::X, Axis::Y]))]
    );
    assert_eq!(kinds("INC(R)"), vec![CmdKind::Inc(Some(vec![Axis::R]))]);
}

#[test]
fn error_codes_and_positions() {
    // TAB is <CTRL-I>, never white space; non-ASCII → ERR004 at its position
    assert_eq!(
        err(b"P1\t=5"),
        ParseError {
            pos: 2,
            code: ERR_ILLEGAL_CHAR,
            msg: "illegal character"
        }
    );
    assert_eq!(err(b"P1=5\xC3").pos, 4);
    assert_eq!(err(b"P1=5\xC3").code, ERR_ILLEGAL_CHAR);
    // program-only statements on-line → ERR005 at the statement
    let e = err(b"#1 LINEAR");
    assert_eq!((e.code, e.pos), (ERR_NEEDS_BUFFER, 3));
    assert_eq!(err(b"X10Y20").code, ERR_NEEDS_BUFFER);
    assert_eq!(err(b"DWELL100").code, ERR_NEEDS_BUFFER);
    assert_eq!(err(b"IF(P1>0)").code, ERR_NEEDS_BUFFER);
    // garbage → ERR003 at the offending byte
    let e = err(b"#1J+ UUU");
    assert_eq!((e.code, e.pos), (ERR_SYNTAX, 5));
    assert_eq!(err(b"P1=+P2").code, ERR_SYNTAX);
    assert_eq!(err(b"P1=(P2").code, ERR_SYNTAX);
    assert_eq!(err(b"P1=1E3").code, ERR_SYNTAX);
    let long = vec![b'P'; MAX_LINE_LEN + 1];
    assert_eq!(err(&long).code, ERR_SYNTAX);
    // deep nesting is bounded
    let deep = format!("P1={}1{}", "(".repeat(40), ")".repeat(40));
    assert_eq!(err(deep.as_bytes()).code, ERR_SYNTAX);
    let ok = format!("P1={}1{}", "(".repeat(20), ")".repeat(20));
    assert!(parse_line(ok.as_bytes()).is_ok());
}

#[test]
fn prefix_keeps_commands_before_the_error() {
    let (cmds, e) = parse_line_prefix(b"P1=5 #2 UUU P2=3");
    assert_eq!(cmds.len(), 2);
    assert_eq!(e.map(|e| (e.code, e.pos)), Some((ERR_SYNTAX, 8)));
}

mod fuzz {
    use super::super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]
        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
            let _ = parse_line(&bytes);
            let _ = parse_program_line(&bytes, ast::BufferKind::Prog);
            let _ = parse_program_line(&bytes, ast::BufferKind::Plc(3));
            let _ = parse_program_line(&bytes, ast::BufferKind::Rotary);
        }

        #[test]
        fn command_alphabet_never_panics(s in "[A-Z0-9#&@$%?=()+*/.,:;^<>!~| -]{0,80}") {
            let _ = parse_line(s.as_bytes());
            if let Ok(stmts) = parse_program_line(s.as_bytes(), ast::BufferKind::Prog) {
                // whatever parses must list and re-parse to the same statements
                let text = listing::line(&stmts, false);
                let again = parse_program_line(text.as_bytes(), ast::BufferKind::Prog);
                prop_assert_eq!(again.as_ref().ok(), Some(&stmts), "listing {:?}", text);
            }
        }
    }
}

#[test]
#[ignore = "timing probe: cargo test --release -- --ignored parse_throughput --nocapture"]
#[allow(clippy::disallowed_methods)] // a timing probe, not a test
fn parse_throughput() {
    let lines: [&[u8]; 6] = [b"P1", b"#1J+", b"P1=P2+5", b"I130", b"%#1?PVF", b"M1..8->"];
    let n = 200_000;
    let t = std::time::Instant::now();
    let mut count = 0usize;
    for i in 0..n {
        count += parse_line(lines[i % lines.len()])
            .map(|v| v.len())
            .unwrap_or(0);
    }
    let dt = t.elapsed();
    println!(
        "{} lines ({count} commands) in {:?}: {:.0} lines/s",
        n,
        dt,
        n as f64 / dt.as_secs_f64()
    );
}

#[test]
fn dls_client_lines_parse() {
    assert_eq!(
        kinds("i6=1 i3=2 ver"),
        vec![
            CmdKind::VarAssign(one(VarKind::I, 6), Expr::num(1.0)),
            CmdKind::VarAssign(one(VarKind::I, 3), Expr::num(2.0)),
            CmdKind::Version
        ]
    );
    assert_eq!(kinds("i20 i21 i22 i23 ").len(), 4);
    assert_eq!(
        kinds("&2q1..3"),
        vec![
            CmdKind::AddrCoord(2),
            CmdKind::VarQuery(vl(VarKind::Q, VarSel::Range { first: 1, last: 3 }))
        ]
    );
    assert_eq!(
        kinds("&1#5->"),
        vec![CmdKind::AddrCoord(1), CmdKind::AxisDefQuery(5)]
    );
    assert_eq!(
        kinds("&1%50"),
        vec![CmdKind::AddrCoord(1), CmdKind::OverrideSet(50.0)]
    );
    assert_eq!(
        kinds("list plc5,0,1"),
        vec![CmdKind::List(ListTarget::Plc(
            5,
            ListSpan {
                offsets: true,
                start: Some(0),
                len: Some(1)
            }
        ))]
    );
    assert_eq!(
        kinds("i124=$20001"),
        vec![CmdKind::VarAssign(
            one(VarKind::I, 124),
            Expr {
                kind: ExprKind::Num(Number {
                    value: 131073.0,
                    hex: true
                }),
                pos: Pos(5)
            }
        )]
    );
    assert_eq!(kinds("#1k"), vec![CmdKind::AddrMotor(1), CmdKind::Kill]);
    assert_eq!(
        kinds("m5000..5031"),
        vec![CmdKind::VarQuery(vl(
            VarKind::M,
            VarSel::Range {
                first: 5000,
                last: 5031
            }
        ))]
    );
}
