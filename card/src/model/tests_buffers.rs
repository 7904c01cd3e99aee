use super::*;

/// A test line: (text, words, structure).
#[derive(Debug, Clone, PartialEq)]
struct T(&'static str, u32, Structure);

impl StoredLine for T {
    fn words(&self) -> u32 {
        self.1
    }
    fn structure(&self) -> Structure {
        self.2
    }
    fn is_return(&self) -> bool {
        self.0 == "RET"
    }
    fn return_line() -> Self {
        T("RET", 1, Structure::Plain)
    }
}

impl T {
    fn render(&self, long: bool) -> String {
        if long && self.0 == "RET" {
            "RETURN".into()
        } else {
            self.0.into()
        }
    }
}

fn plain(s: &'static str, w: u32) -> T {
    T(s, w, Structure::Plain)
}

#[test]
fn open_append_close_list_with_offsets() {
    let mut b: Buffers<T> = Buffers::new(1000);
    b.open(BufId::Prog(1)).unwrap();
    b.append(BufId::Prog(1), plain("LIN", 1)).unwrap();
    b.append(BufId::Prog(1), plain("F10", 1)).unwrap();
    b.append(BufId::Prog(1), plain("X10Y10", 2)).unwrap();
    b.close(BufId::Prog(1)).unwrap();
    let p = b.program(BufId::Prog(1)).unwrap();
    assert_eq!(
        list_lines(&p.lines, |l: &T| l.render(false), None),
        ["LIN", "F10", "X10Y10", "RET"]
    );
    assert_eq!(
        list_lines(&p.lines, |l: &T| l.render(true), None)[3],
        "RETURN"
    );
    assert_eq!(
        list_lines(&p.lines, |l: &T| l.render(false), Some((0, None))),
        ["0:LIN", "1:F10", "2:X10Y10", "4:RET"]
    );
    // Start in the middle of X10Y10 restarts at the line containing it.
    assert_eq!(
        list_lines(&p.lines, |l: &T| l.render(false), Some((3, Some(1)))),
        ["2:X10Y10"]
    );
    assert_eq!(
        list_lines(&p.lines, |l: &T| l.render(false), Some((2, Some(3)))),
        ["2:X10Y10", "4:RET"]
    );
    assert_eq!(
        list_lines(&p.lines, |l: &T| l.render(false), Some((1, Some(1)))),
        ["1:F10"]
    );
    assert_eq!(b.used(), 5);
    assert_eq!(b.free(), 995);
    // Re-open strips the trailing RETURN so there is only one after the next CLOSE.
    b.open(BufId::Prog(1)).unwrap();
    b.append(BufId::Prog(1), plain("DWE10", 1)).unwrap();
    b.close(BufId::Prog(1)).unwrap();
    let p = b.program(BufId::Prog(1)).unwrap();
    assert_eq!(
        list_lines(&p.lines, |l: &T| l.render(false), None),
        ["LIN", "F10", "X10Y10", "DWE10", "RET"]
    );
}

#[test]
fn structural_errors() {
    let mut b: Buffers<T> = Buffers::new(1000);
    b.open(BufId::Plc(1)).unwrap();
    assert_eq!(
        b.append(BufId::Plc(1), T("ENDIF", 1, Structure::EndIf)),
        Err(BufErr(ErrCode::Structure))
    );
    assert_eq!(
        b.append(BufId::Plc(1), T("ENDW", 1, Structure::EndWhile)),
        Err(BufErr(ErrCode::Structure))
    );
    assert_eq!(
        b.append(BufId::Plc(1), T("ELSE", 1, Structure::Else)),
        Err(BufErr(ErrCode::Structure))
    );
    b.append(BufId::Plc(1), T("IF(P1=1)", 2, Structure::If))
        .unwrap();
    assert_eq!(
        b.append(BufId::Plc(1), T("ENDW", 1, Structure::EndWhile)),
        Err(BufErr(ErrCode::Structure))
    );
    b.append(BufId::Plc(1), T("ELSE", 1, Structure::Else))
        .unwrap();
    assert_eq!(
        b.append(BufId::Plc(1), T("ELSE", 1, Structure::Else)),
        Err(BufErr(ErrCode::Structure))
    );
    // Unclosed IF: CLOSE reports ERR003 and marks the program invalid.
    assert_eq!(b.close(BufId::Plc(1)), Err(BufErr(ErrCode::Data)));
    assert!(!b.program(BufId::Plc(1)).unwrap().valid);
    // Fix it: re-open, add ENDIF, close.
    b.open(BufId::Plc(1)).unwrap();
    b.append(BufId::Plc(1), T("ENDIF", 1, Structure::EndIf))
        .unwrap();
    assert_eq!(b.close(BufId::Plc(1)), Ok(()));
    assert!(b.program(BufId::Plc(1)).unwrap().valid);
    // One-line IF followed by ELSE is legal in a motion program.
    b.open(BufId::Prog(2)).unwrap();
    b.append(BufId::Prog(2), T("IF(P1>0)X10", 3, Structure::IfOneLine))
        .unwrap();
    b.append(BufId::Prog(2), T("ELSE X-10", 2, Structure::ElseOneLine))
        .unwrap();
    assert_eq!(b.close(BufId::Prog(2)), Ok(()));
}

#[test]
fn buffer_space_exhaustion_keeps_stored_lines() {
    let mut b: Buffers<T> = Buffers::new(10);
    b.open(BufId::Prog(1)).unwrap();
    for _ in 0..9 {
        b.append(BufId::Prog(1), plain("X1", 1)).unwrap();
    }
    assert_eq!(
        b.append(BufId::Prog(1), plain("X1Y1", 2)),
        Err(BufErr(ErrCode::NoRoom))
    );
    b.append(BufId::Prog(1), plain("X1", 1)).unwrap();
    assert_eq!(
        b.append(BufId::Prog(1), plain("X1", 1)),
        Err(BufErr(ErrCode::NoRoom))
    );
    assert_eq!(b.program(BufId::Prog(1)).unwrap().lines.len(), 10);
    assert_eq!(b.free(), 0);
}

#[test]
fn rotary_buffer_fills_up() {
    let mut b: Buffers<T> = Buffers::new(1000);
    assert_eq!(
        b.append_rotary(1, plain("X1", 1)),
        Err(BufErr(ErrCode::NeedsBuffer))
    );
    b.rotary.insert(
        1,
        Rotary {
            size: 3,
            lines: vec![],
        },
    );
    b.append_rotary(1, plain("X1Y1", 2)).unwrap();
    assert_eq!(
        b.append_rotary(1, plain("X1Y1", 2)),
        Err(BufErr(ErrCode::NoRoom))
    );
    b.append_rotary(1, plain("X1", 1)).unwrap();
    assert_eq!(b.used(), 3);
    b.clear(BufId::Rot, 1);
    assert!(b.rotary[&1].lines.is_empty());
}

#[test]
fn protection_ranges() {
    assert!(BufId::Prog(1000).protected());
    assert!(!BufId::Prog(999).protected());
    assert!(BufId::Plc(15).protected());
    assert!(!BufId::Plc(16).protected());
}
