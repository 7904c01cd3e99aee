//! The Power PMAC on-line command line: commands separated by white space (case ignored),
//! parsed whole before anything runs ([`parse_line`]). Expressions become `domain::ast`
//! expressions; variables of the families the model does not keep (L, R, D, C) and data-
//! structure elements become `VarKind::Ext` references resolved by the executor.

use super::catalog::{self, St};
use crate::domain::ast::{BinOp, Expr, ExprKind, MathFn, Number, Pos, VarIndex, VarKind, VarRef};
use crate::domain::PowerErr;

/// Deepest expression nesting the parser accepts.
const MAX_DEPTH: u32 = 64;

/// A syntax error at byte `at` of the line (error 20 unless stated).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct SyntaxError {
    /// Byte offset.
    pub at: usize,
    /// The refusal.
    pub code: PowerErr,
}

type P<T> = Result<T, SyntaxError>;

/// A variable family of the Power script.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fam {
    /// Global P.
    P,
    /// Per-C.S. Q.
    Q,
    /// Pointer M.
    M,
    /// Setup alias I.
    I,
    /// Thread-local L.
    L,
    /// Thread-local R.
    R,
    /// Argument D.
    D,
    /// Kinematic C.
    C,
}

impl Fam {
    /// Its letter as replies print it.
    pub(crate) fn letter(self) -> char {
        match self {
            Fam::P => 'P',
            Fam::Q => 'Q',
            Fam::M => 'M',
            Fam::I => 'I',
            Fam::L => 'L',
            Fam::R => 'R',
            Fam::D => 'D',
            Fam::C => 'C',
        }
    }

    pub(crate) fn of(c: u8) -> Option<Fam> {
        Some(match c {
            b'p' => Fam::P,
            b'q' => Fam::Q,
            b'm' => Fam::M,
            b'i' => Fam::I,
            b'l' => Fam::L,
            b'r' => Fam::R,
            b'd' => Fam::D,
            b'c' => Fam::C,
            _ => return None,
        })
    }

    /// The `VarKind` of the family in expressions: the model's own for P/Q/M, an extension
    /// family for the rest (I too: its numbers are the Power numbering).
    pub(crate) fn kind(self) -> VarKind {
        match self {
            Fam::P => VarKind::P,
            Fam::Q => VarKind::Q,
            Fam::M => VarKind::Ext(EXT_M),
            Fam::I => VarKind::Ext(EXT_I),
            Fam::L => VarKind::Ext(EXT_L),
            Fam::R => VarKind::Ext(EXT_R),
            Fam::D => VarKind::Ext(EXT_D),
            Fam::C => VarKind::Ext(EXT_C),
        }
    }
}

/// Extension family numbers (`VarKind::Ext`) of the dialect.
pub(crate) const EXT_I: u16 = 1;
/// L-variables.
pub(crate) const EXT_L: u16 = 2;
/// R-variables.
pub(crate) const EXT_R: u16 = 3;
/// D-variables.
pub(crate) const EXT_D: u16 = crate::domain::profile::POWER_READ_EXT;
/// C-variables.
pub(crate) const EXT_C: u16 = 5;
/// The conditional-execution flags of the thread's C.S. (`Coord[x].Cflags`, programs only).
pub(crate) const EXT_CFLAGS: u16 = 6;
/// M-variables (the dialect keeps their pointer definitions: `mvars`).
pub(crate) const EXT_M: u16 = 7;
/// An M-variable as the target of a synchronous assignment (`M1==1`: nothing happens when
/// it is self-referenced).
pub(crate) const EXT_M_SYNC: u16 = 8;
/// Element `k` of the line's element table is `Ext(EXT_ELEM + k)`.
pub(crate) const EXT_ELEM: u16 = 100;
/// The index of an element variable that stands for its address (`name.a`), not its value.
pub(crate) const ELEM_ADDRESS: u32 = 1;

/// Which variables a command names.

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Sel {
    /// One, constant or computed.
    One(VarIndex),
    /// `a..b[:n]`: n values per reply line (seed L38087-38089; 1 when absent).
    Range(u32, u32, u32),
    /// `start,count[,spacing]`
    List(u32, u32, u32),
}

/// A data-structure element as written (indices may be expressions).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ElemRef {
    /// Its structure.
    pub st: St,
    /// The structure name as written (alias), for replies.
    pub st_name: &'static str,
    /// Structure index (`Motor[3]`), `None` for `Sys`, `Gather`, `Ldata`.
    pub idx: Option<Expr>,
    /// Element index in the catalogue.
    pub def: usize,
    /// The element's own indices (`MacroInA[2][3]`).
    pub sub: Vec<Expr>,
    /// Bit range `.start.width` (`.k` = one bit).
    pub bits: Option<(u32, u32)>,
}

/// A motor command.
/// The post-trigger distance of a jog until trigger (`^{d}`, or `^*`: `Motor[x].JogOffset`,
/// seed L36040-36066).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum JogTrigger {
    /// `^{d}`
    Offset(f64),
    /// `^*`
    JogOffset,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum MotorCmd {
    /// A jog (`j+`, `j=…`, `j:…`, `j^…`, `j=*` …) with an optional trigger offset.
    Jog(crate::domain::ast::JogKind, Option<JogTrigger>),
    /// `k` / `kill`
    Kill,
    /// `dkill`
    DKill,
    /// `hm` / `home`
    Home,
    /// `hmz` / `homez`
    HomeZ,
    /// `$`
    Enable,
    /// `out{c}`
    Out(f64),
    /// `p`
    Position,
    /// `v`
    Velocity,
    /// `f`
    FollowingError,
    /// `d`
    DesPos,
    /// `?`
    Status,
}

/// A coordinate-system command.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum CsCmd {
    /// `r` / `run`
    Run,
    /// `s` / `step`
    Step,
    /// `q` / `pause`
    Quit,
    /// `a` / `abort`
    Abort,
    /// `h` / `hold`
    Hold,
    /// `resume`
    Resume,
    /// `b{n}` / `begin{n}`
    Begin(f64),
    /// `%{n}`
    Override(f64),
    /// `%`
    OverrideQuery,
    /// `?` after `&`
    Status,
    /// `p`, `d`, `f`, `v` after `&`: the C.S.'s axes in user units (seed L33912-33975,
    /// L34940-34962).
    Axes(AxisReport),
    /// `pmatch` (axis positions from motor positions; through the forward kinematic routine
    /// for a C.S. with `#n->I` motors).
    PMatch,
    /// `enable` / `disable` after `&` (no `plc`): every motor assigned to an axis of the
    /// C.S. closed-loop enabled / disabled (seed L412-416).
    Servo(bool),
    /// `adisable`: abort, then each motor disabled once its commanded stop is over (seed
    /// L33233-33264; the global abort of `Coord[x].AbortAllMode` = 2).
    ADisable,
    /// `ddisable`: the program stopped and every motor of the C.S. disabled (a `dkill` of
    /// each, seed L34204, L40610-40654).
    DDisable,
    /// `stop`: calculation stops after the moves already calculated and the program counter
    /// goes back to the top of the program (seed L445-446, L44192-44205).
    Stop,
    /// `start[{n}]`: `b[{n}]r` (seed L448-449, L38930-38948).
    Start(Option<f64>),
    /// `lh\`: quick stop in the look-ahead buffer (seed L966-967, L42511-42560).
    LhStop,
    /// `lh<`: move backward along the look-ahead buffer's path (seed L969).
    LhBack,
    /// `lh>`: move forward along it again (seed L971).
    LhForward,
    /// `g`: each axis's distance to go (seed L34990-35026).
    DistanceToGo,
}

/// What `&x p|d|f|v` reports of each axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum AxisReport {
    /// `p`: actual position.
    Pos,
    /// `d`: desired (commanded) position.
    Des,
    /// `f`: following error (desired − actual).
    Fe,
    /// `v`: actual velocity.
    Vel,
}

/// One parsed command.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Cmd {
    /// `#n` (modal) or `#list` (next command only).
    Motors(Vec<u16>, bool),
    /// `#`
    MotorQuery,
    /// `&n` / `&list`
    Coords(Vec<u16>, bool),
    /// `&`
    CoordQuery,
    /// A motor command for the addressed motor(s).
    Motor(MotorCmd),
    /// A C.S. command for the addressed C.S.(s).
    Cs(CsCmd),
    /// `?` alone: `Sys.Status`.
    GlobalStatus,
    /// Variable query.
    VarQuery(Fam, Sel),
    /// Variable assignment; a selection sets each of its variables to the value (seed
    /// L34166-34171: `D10..12=P1+5`, `D30,3=-7`, `D30,3,3=sqrt(P25)`).
    VarSet(Fam, Sel, Expr),
    /// `I{n}->`, `M{n}->`: the definition query.
    IDef(Fam, Sel),
    /// `M{n}->{definition}`; a selection defines each (`M80..89->*s.16`, `M0..16383->*`,
    /// seed L37461-37466).
    MDef(Sel, MDefSrc),
    /// Element query.
    ElemQuery(ElemRef),
    /// Element assignment.
    ElemSet(ElemRef, Expr),
    /// `name.a`
    ElemAddr(ElemRef),
    /// `echo` / `echo{n}`
    Echo(Option<u32>),
    /// `cid`, `vers`, `type`, `cpu`, `date`, `size`, `free`, `buffer`
    Info(&'static str),
    /// `#n->{definition}` (empty: the query `#n->`)
    AxisDef(u16, String),
    /// `#{list}->`: report the motors' axis definitions (seed L31655-31690).
    AxisQuery(Vec<u16>),
    /// `enable plc n` / `disable plc n` (`true`: enable)
    PlcCtl(
        crate::domain::ast::PlcVerb,
        Vec<crate::domain::ast::NumRange>,
    ),
    /// `step plc {list}`: each PLC runs one program line, then stays paused (seed
    /// L38993-39025).
    PlcStep(Vec<crate::domain::ast::NumRange>),
}

/// What an M-variable definition points at.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum MDefSrc {
    /// Address or self-referenced form.
    Ptr(super::mptr::Ptr),
    /// Element form.
    Elem(ElemRef),
}

/// A command with where it started.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Item {
    /// The command.
    pub cmd: Cmd,
    /// Byte offset.
    pub at: usize,
    /// Written in a short form `Sys.NoShortCmds = 1` refuses (seed L19994-20022: `a`, `b`,
    /// `h`, `hm`, `hmz`, `j…`, `k`, `q`, `r`, `s`).
    pub short: bool,
}

/// A parsed line: the commands before the first error, the error, and the element table of
/// the line's expressions (`Ext(EXT_ELEM + k)`).
#[derive(Debug, Default)]
pub(crate) struct Parsed {
    /// Commands in order.
    pub items: Vec<Item>,
    /// First syntax error.
    pub error: Option<SyntaxError>,
    /// Elements named inside expressions.
    pub elems: Vec<ElemRef>,
}

pub(crate) struct Cur<'a> {
    s: &'a [u8],
    pub(crate) i: usize,
    elems: Vec<ElemRef>,
    /// Program text: elements go into the card's program element table (`elems`, shared
    /// and interned), named `Ext(EXT_PELEM + k)`.
    prog: bool,
    /// The last on-line command was written in a short form ([`Item::short`]).
    short: bool,
}

fn err<T>(at: usize) -> P<T> {
    Err(SyntaxError {
        at,
        code: PowerErr::IllegalCmd,
    })
}

impl<'a> Cur<'a> {
    pub(crate) fn new(s: &'a [u8]) -> Self {
        Cur {
            s,
            i: 0,
            elems: Vec::new(),
            prog: false,
            short: false,
        }
    }

    /// A cursor over program text whose elements go into `table` (the card's program element
    /// table; take it back with [`Cur::into_table`]).
    pub(crate) fn for_program(s: &'a [u8], table: Vec<ElemRef>) -> Self {
        Cur {
            s,
            i: 0,
            elems: table,
            prog: true,
            short: false,
        }
    }

    /// The element table (see [`Cur::for_program`]).
    pub(crate) fn into_table(self) -> Vec<ElemRef> {
        self.elems
    }

    /// The extension family of element `e`: its place in the line's table (at most 64), or
    /// in program text its place in the card's table (interned).
    pub(crate) fn add_elem(&mut self, e: ElemRef) -> Option<u16> {
        if self.prog {
            use super::progvars::{EXT_PELEM, MAX_PELEMS};
            if !constant_indices_valid(&e) {
                return None;
            }
            if let Some(k) = self.elems.iter().position(|x| *x == e) {
                return Some(EXT_PELEM + k as u16);
            }
            if self.elems.len() >= MAX_PELEMS {
                return None;
            }
            self.elems.push(e);
            return Some(EXT_PELEM + (self.elems.len() - 1) as u16);
        }
        if self.elems.len() >= 64 {
            return None;
        }
        self.elems.push(e);
        Some(EXT_ELEM + (self.elems.len() - 1) as u16)
    }

    /// The bytes not yet parsed.
    pub(crate) fn rest(&self) -> &'a [u8] {
        self.s.get(self.i..).unwrap_or_default()
    }

    /// The rest of the line starts with `w` (case ignored).
    pub(crate) fn rest_starts(&self, w: &[u8]) -> bool {
        self.rest()
            .get(..w.len())
            .is_some_and(|s| s.eq_ignore_ascii_case(w))
    }

    /// `w` as a whole word (case ignored).
    pub(crate) fn eat_word(&mut self, w: &str) -> bool {
        let save = self.i;
        if self.eat_str(w)
            && !self
                .peek()
                .is_some_and(|c| c.is_ascii_alphanumeric() || c == b'_')
        {
            return true;
        }
        self.i = save;
        false
    }

    /// A word, lower-cased (letters, digits, underscore; starting with a letter).
    pub(crate) fn word_lower(&mut self) -> Option<String> {
        self.word()
    }

    /// A literal number with an optional sign.
    pub(crate) fn signed_number(&mut self) -> Option<f64> {
        signed(self)
    }

    pub(crate) fn peek(&self) -> Option<u8> {
        self.s.get(self.i).map(u8::to_ascii_lowercase)
    }

    pub(crate) fn peek_at(&self, k: usize) -> Option<u8> {
        self.s.get(self.i + k).map(u8::to_ascii_lowercase)
    }

    pub(crate) fn ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t')) {
            self.i += 1;
        }
    }

    pub(crate) fn eat(&mut self, c: u8) -> bool {
        if self.peek() == Some(c) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    pub(crate) fn eat_str(&mut self, t: &str) -> bool {
        let n = t.len();
        match self.s.get(self.i..self.i + n) {
            Some(w) if w.eq_ignore_ascii_case(t.as_bytes()) => {
                self.i += n;
                true
            }
            _ => false,
        }
    }

    pub(crate) fn at_end(&self) -> bool {
        self.i >= self.s.len()
    }

    /// A word of letters/digits/underscore starting with a letter (lower-cased).
    fn word(&mut self) -> Option<String> {
        let st = self.i;
        if !self.peek().is_some_and(|c| c.is_ascii_alphabetic()) {
            return None;
        }
        while self
            .peek()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == b'_')
        {
            self.i += 1;
        }
        Some(String::from_utf8_lossy(&self.s[st..self.i]).to_ascii_lowercase())
    }

    fn word_exact(&mut self) -> Option<&'a str> {
        let st = self.i;
        self.word()?;
        std::str::from_utf8(&self.s[st..self.i]).ok()
    }

    pub(crate) fn uint(&mut self) -> Option<u32> {
        let st = self.i;
        while self.peek().is_some_and(|c| c.is_ascii_digit()) {
            self.i += 1;
        }
        if st == self.i {
            return None;
        }
        std::str::from_utf8(&self.s[st..self.i])
            .ok()?
            .parse::<u32>()
            .ok()
            .or(Some(u32::MAX))
    }

    /// A literal number: decimal (with fraction and exponent) or `$hex`.
    fn number(&mut self) -> Option<f64> {
        let st = self.i;
        if self.eat(b'$') {
            let h = self.i;
            while self.peek().is_some_and(|c| c.is_ascii_hexdigit()) {
                self.i += 1;
            }
            if h == self.i {
                self.i = st;
                return None;
            }
            let t = std::str::from_utf8(&self.s[h..self.i]).ok()?;
            return Some(u64::from_str_radix(t, 16).map_or(f64::INFINITY, |v| v as f64));
        }
        while self.peek().is_some_and(|c| c.is_ascii_digit()) {
            self.i += 1;
        }
        if self.peek() == Some(b'.') && self.peek_at(1).is_some_and(|c| c.is_ascii_digit()) {
            self.i += 1;
            while self.peek().is_some_and(|c| c.is_ascii_digit()) {
                self.i += 1;
            }
        } else if self.peek() == Some(b'.') && self.i > st && self.peek_at(1) != Some(b'.') {
            self.i += 1;
        }
        if self.i == st {
            return None;
        }
        if self.peek() == Some(b'e') {
            let save = self.i;
            self.i += 1;
            if matches!(self.peek(), Some(b'+' | b'-')) {
                self.i += 1;
            }
            if self.peek().is_some_and(|c| c.is_ascii_digit()) {
                while self.peek().is_some_and(|c| c.is_ascii_digit()) {
                    self.i += 1;
                }
            } else {
                self.i = save;
            }
        }
        std::str::from_utf8(&self.s[st..self.i]).ok()?.parse().ok()
    }

    // ---- expressions -----------------------------------------------------------------------

    pub(crate) fn expr(&mut self, depth: u32) -> P<Expr> {
        self.binary(1, depth)
    }

    fn binary(&mut self, level: u8, depth: u32) -> P<Expr> {
        if depth > MAX_DEPTH {
            return err(self.i);
        }
        let mut l = if level == 1 {
            self.binary(2, depth + 1)?
        } else {
            self.unary(depth + 1)?
        };
        loop {
            let save = self.i;
            self.ws();
            let op = match (level, self.peek(), self.peek_at(1)) {
                (1, Some(b'+'), n) if n != Some(b'=') => BinOp::Add,
                (1, Some(b'-'), n) if n != Some(b'=') => BinOp::Sub,
                (1, Some(b'|'), n) if n != Some(b'|') && n != Some(b'=') => BinOp::Or,
                (1, Some(b'^'), n) if n != Some(b'=') => BinOp::Xor,
                (2, Some(b'*'), n) if n != Some(b'=') => BinOp::Mul,
                (2, Some(b'/'), n) if n != Some(b'=') && n != Some(b'/') => BinOp::Div,
                (2, Some(b'%'), n) if n != Some(b'=') => BinOp::Mod,
                (2, Some(b'&'), n) if n != Some(b'&') && n != Some(b'=') => BinOp::And,
                (2, Some(b'<'), Some(b'<')) => BinOp::Shl,
                (2, Some(b'>'), Some(b'>')) => BinOp::Shr,
                _ => {
                    self.i = save;
                    return Ok(l);
                }
            };
            self.i += if matches!(op, BinOp::Shl | BinOp::Shr) {
                2
            } else {
                1
            };
            self.ws();
            let r = if level == 1 {
                self.binary(2, depth + 1)?
            } else {
                self.unary(depth + 1)?
            };
            let pos = l.pos;
            l = Expr {
                kind: ExprKind::Bin(op, Box::new(l), Box::new(r)),
                pos,
            };
        }
    }

    fn unary(&mut self, depth: u32) -> P<Expr> {
        if depth > MAX_DEPTH {
            return err(self.i);
        }
        self.ws();
        let at = self.i;
        let pos = Pos(at as u32);
        let mk = |kind| Expr { kind, pos };
        match self.peek() {
            Some(b'-') => {
                self.i += 1;
                let e = self.unary(depth + 1)?;
                Ok(mk(ExprKind::Neg(Box::new(e))))
            }
            Some(b'~') => {
                self.i += 1;
                let e = self.unary(depth + 1)?;
                Ok(mk(ExprKind::BitNot(Box::new(e))))
            }
            Some(b'(') => {
                self.i += 1;
                let e = self.expr(depth + 1)?;
                self.ws();
                if !self.eat(b')') {
                    return err(self.i);
                }
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' || c == b'$' => match self.number() {
                Some(v) => Ok(mk(ExprKind::Num(Number::dec(v)))),
                None => err(at),
            },
            Some(c) if c.is_ascii_alphabetic() => self.primary_word(depth),
            _ => err(at),
        }
    }

    fn primary_word(&mut self, depth: u32) -> P<Expr> {
        let at = self.i;
        let pos = Pos(at as u32);
        // A variable: family letter then a number or a parenthesised index.
        if let Some(f) = self.peek().and_then(Fam::of) {
            if self
                .peek_at(1)
                .is_some_and(|c| c.is_ascii_digit() || c == b'(')
            {
                self.i += 1;
                let index = self.var_index(depth)?;
                return Ok(Expr {
                    kind: ExprKind::Var(VarRef {
                        kind: f.kind(),
                        index,
                        pos,
                    }),
                    pos,
                });
            }
        }
        let Some(w) = self.word_exact() else {
            return err(at);
        };
        if let Some(f) = math_fn(w) {
            self.ws();
            if !self.eat(b'(') {
                return err(self.i);
            }
            let mut args = Vec::new();
            self.ws();
            if !self.eat(b')') {
                loop {
                    args.push(self.expr(depth + 1)?);
                    self.ws();
                    if self.eat(b')') {
                        break;
                    }
                    if !self.eat(b',') || args.len() >= 3 {
                        return err(self.i);
                    }
                }
            }
            return Ok(Expr {
                kind: ExprKind::Math(f, args),
                pos,
            });
        }
        if catalog::structure(w).is_some() {
            self.i = at;
            let e = self.element(depth)?;
            // `name.a`: the element's address (not followed by more of a name).
            let save = self.i;
            let address = self.eat_str(".a")
                && !self
                    .peek()
                    .is_some_and(|c| c.is_ascii_alphanumeric() || c == b'_' || c == b'.');
            if !address {
                self.i = save;
            }
            let code = if self.prog {
                PowerErr::IllegalParameter
            } else {
                PowerErr::IllegalCmd
            };
            let fam = self.add_elem(e).ok_or(SyntaxError { at, code })?;
            return Ok(Expr {
                kind: ExprKind::Var(VarRef {
                    kind: VarKind::Ext(fam),
                    index: VarIndex::Const(if address { ELEM_ADDRESS } else { 0 }),
                    pos,
                }),
                pos,
            });
        }
        err(at)
    }

    /// `n` or `(expr)` after a family letter.
    pub(crate) fn var_index(&mut self, depth: u32) -> P<VarIndex> {
        if self.eat(b'(') {
            let e = self.expr(depth + 1)?;
            self.ws();
            if !self.eat(b')') {
                return err(self.i);
            }
            return Ok(VarIndex::Expr(Box::new(e)));
        }
        match self.uint() {
            Some(n) => Ok(VarIndex::Const(n)),
            None => err(self.i),
        }
    }

    /// `[expr]` (a bracketed index).
    fn bracket(&mut self, depth: u32) -> P<Expr> {
        if !self.eat(b'[') {
            return err(self.i);
        }
        let e = self.expr(depth + 1)?;
        self.ws();
        if !self.eat(b']') {
            return err(self.i);
        }
        Ok(e)
    }

    /// `Struct[idx].Name[.Name][i][j][.start[.width]]`.
    pub(crate) fn element(&mut self, depth: u32) -> P<ElemRef> {
        let at = self.i;
        let Some(w) = self.word() else {
            return err(at);
        };
        let Some((st, st_name)) = catalog::structure(&w) else {
            return err(at);
        };
        let idx = match st.count() {
            Some(_) => Some(self.bracket(depth)?),
            None => None,
        };
        let mut name = String::new();
        let mut sub = Vec::new();
        // A channel index inside the name (`Gate3[i].Chan[j].EncCtrl`, catalogued as
        // `Chan[].EncCtrl`): the element's first index.
        let mut mid = Vec::new();
        let mut bits = None;
        while self.peek() == Some(b'.') {
            let dot = self.i;
            self.i += 1;
            if self.peek().is_some_and(|c| c.is_ascii_digit()) {
                if name.is_empty() {
                    return err(self.i);
                }
                let start = self.uint().unwrap_or(u32::MAX);
                let width = if self.peek() == Some(b'.')
                    && self.peek_at(1).is_some_and(|c| c.is_ascii_digit())
                {
                    self.i += 1;
                    self.uint().unwrap_or(u32::MAX)
                } else {
                    1
                };
                if start > 63 || width == 0 || width > 64 || start + width > 64 {
                    return Err(SyntaxError {
                        at: dot,
                        code: PowerErr::IllegalParameter,
                    });
                }
                bits = Some((start, width));
                break;
            }
            let save = self.i;
            let Some(seg) = self.word_exact() else {
                return err(self.i);
            };
            // `.a` after a complete element name is the address query (handled by the caller).
            if seg.eq_ignore_ascii_case("a") && !name.is_empty() {
                self.i = dot;
                break;
            }
            if !sub.is_empty() {
                if sub.len() != 1 || !mid.is_empty() {
                    self.i = save;
                    return err(save);
                }
                mid.append(&mut sub);
                name.push_str("[]");
            }
            if !name.is_empty() {
                name.push('.');
            }
            name.push_str(seg);
            while self.peek() == Some(b'[') {
                if sub.len() >= 3 {
                    return err(self.i);
                }
                sub.push(self.bracket(depth)?);
            }
        }
        if name.is_empty() {
            return err(self.i);
        }
        // Some status words are catalogued with their index in the name (`Status[0]`).
        let literal = match sub.as_slice() {
            [Expr {
                kind: ExprKind::Num(n),
                ..
            }] if n.value >= 0.0 && n.value.fract() == 0.0 => Some(n.value as u32),
            _ => None,
        };
        // `Coord[x].Ldata.Motor`, `Plc[i].Ldata.L[2]` (seed L33832, L33907): the local data of
        // that C.S.'s motion program or of that PLC, an `Ldata` element with its owner's index.
        if matches!(st, St::Coord | St::Plc)
            && name.len() > 6
            && name[..6].eq_ignore_ascii_case("ldata.")
        {
            let def = catalog::find(St::Ldata, &name[6..]).ok_or(SyntaxError {
                at,
                code: PowerErr::IllegalParameter,
            })?;
            return Ok(ElemRef {
                st: St::Ldata,
                st_name,
                idx,
                def,
                sub: mid.into_iter().chain(sub).collect(),
                bits,
            });
        }
        let (def, sub) = match catalog::find(st, &name) {
            Some(d) => (d, mid.into_iter().chain(sub).collect()),
            None => match literal.and_then(|k| catalog::find(st, &format!("{name}[{k}]"))) {
                Some(d) => (d, Vec::new()),
                None => {
                    return Err(SyntaxError {
                        at,
                        code: PowerErr::IllegalParameter,
                    })
                }
            },
        };
        Ok(ElemRef {
            st,
            st_name,
            idx,
            def,
            sub,
            bits,
        })
    }

    // ---- commands --------------------------------------------------------------------------

    /// A list of motor/C.S. numbers after `#`/`&`: `n`, `a,b`, `a..b`, `*`.
    fn num_list(&mut self, all: u16) -> P<Option<(Vec<u16>, bool)>> {
        if self.eat(b'*') {
            return Ok(Some(((0..all).collect(), true)));
        }
        let Some(first) = self.uint() else {
            return Ok(None);
        };
        let mut v = Vec::new();
        let mut list = false;
        let mut cur = first;
        loop {
            if self.eat_str("..") {
                let Some(last) = self.uint() else {
                    return err(self.i);
                };
                if last < cur || last >= u32::from(all) {
                    return Err(SyntaxError {
                        at: self.i,
                        code: PowerErr::IllegalParameter,
                    });
                }
                v.extend((cur..=last).map(|n| n as u16));
                list = true;
            } else {
                if cur >= u32::from(all) {
                    return Err(SyntaxError {
                        at: self.i,
                        code: PowerErr::IllegalParameter,
                    });
                }
                v.push(cur as u16);
            }
            if self.peek() == Some(b',') && self.peek_at(1).is_some_and(|c| c.is_ascii_digit()) {
                self.i += 1;
                cur = self.uint().unwrap_or(u32::MAX);
                list = true;
            } else {
                break;
            }
        }
        Ok(Some((v, list)))
    }
}

/// An element whose indices are all literals names an existing element (program text is
/// checked at entry: seed §2.9 rejects a bad line when it is sent).
fn constant_indices_valid(e: &ElemRef) -> bool {
    literal_key(e).is_none_or(|k| k.is_ok())
}

/// The key of `e` when every index is a literal number (`None`: some index is computed).
pub(crate) fn literal_key(
    e: &ElemRef,
) -> Option<Result<super::elements::Key, super::elements::AccessError>> {
    let lit = |x: &Expr| match x.kind {
        ExprKind::Num(n) => Some(n.value),
        _ => None,
    };
    let idx = match &e.idx {
        Some(x) => Some(lit(x)?),
        None => None,
    };
    let sub: Option<Vec<f64>> = e.sub.iter().map(lit).collect();
    Some(super::elements::key(e, idx, &sub?))
}

/// The Power script's scalar functions.
fn math_fn(w: &str) -> Option<MathFn> {
    use MathFn as M;
    Some(match w.to_ascii_lowercase().as_str() {
        "abs" => M::Abs,
        "acos" => M::Acos,
        "acosd" => M::AcosD,
        "acosh" => M::Acosh,
        "asin" => M::Asin,
        "asind" => M::AsinD,
        "asinh" => M::Asinh,
        "atan" => M::Atan,
        "atand" => M::AtanD,
        "atanh" => M::Atanh,
        "atan2" => M::Atan2,
        "atan2d" => M::Atan2D,
        "cbrt" => M::Cbrt,
        "ceil" => M::Ceil,
        "cos" => M::Cos,
        "cosd" => M::CosD,
        "cosh" => M::Cosh,
        "exp" => M::Exp,
        "exp2" => M::Exp2,
        "floor" => M::Floor,
        "int" => M::Int,
        "isnan" => M::IsNan,
        "ln" | "log" => M::Ln,
        "log2" => M::Log2,
        "log10" => M::Log10,
        "madd" => M::Madd,
        "pow" => M::Pow,
        "qnrt" => M::Qnrt,
        "qrrt" => M::Qrrt,
        "rem" => M::Rem,
        "rint" => M::Rint,
        "rnd" => M::Rnd,
        "randx" => M::RandX,
        "seed" => M::Seed,
        "sgn" => M::Sgn,
        "sin" => M::Sin,
        "sind" => M::SinD,
        "sinh" => M::Sinh,
        "sincos" => M::SinCos,
        "sincosd" => M::SinCosD,
        "sqrt" => M::Sqrt,
        "tan" => M::Tan,
        "tand" => M::TanD,
        "tanh" => M::Tanh,
        _ => return None,
    })
}

/// Parse one on-line command line.
pub(crate) fn parse_line(line: &[u8], motors: u16, coords: u16) -> Parsed {
    let mut c = Cur::new(line);
    let mut items = Vec::new();
    let mut error = None;
    // After `#list`/`&list` a `?`/`p` belongs to that address.
    let mut last_addr: Option<bool> = None;
    loop {
        c.ws();
        if c.at_end() || c.s[c.i..].starts_with(b"//") {
            break;
        }
        let at = c.i;
        match command(&mut c, motors, coords, last_addr) {
            Ok(cmd) => {
                let cmd_is_begin = matches!(cmd, Cmd::Cs(CsCmd::Begin(_)));
                last_addr = match &cmd {
                    Cmd::Motors(..) => Some(true),
                    Cmd::Coords(..) => Some(false),
                    _ => None,
                };
                items.push(Item {
                    cmd,
                    at,
                    short: std::mem::take(&mut c.short),
                });
                // Commands are separated by white space, or follow an address directly.
                let next = c.peek();
                let glued_start = cmd_is_begin && matches!(next, Some(b'r' | b's'));
                if !(c.at_end()
                    || matches!(next, Some(b' ' | b'\t' | b'#' | b'&'))
                    || glued_start
                    || (last_addr.is_some())
                    || c.s[c.i..].starts_with(b"//"))
                {
                    error = Some(SyntaxError {
                        at: c.i,
                        code: PowerErr::IllegalCmd,
                    });
                    break;
                }
            }
            Err(e) => {
                error = Some(e);
                break;
            }
        }
    }
    // A motor or C.S. list addresses the command right after it only (it does not change
    // the modal address): a list with no command is error 20 (seed L31649-31650, L31981).
    if let (
        None,
        Some(Item {
            cmd: Cmd::Motors(_, true) | Cmd::Coords(_, true),
            at,
            ..
        }),
    ) = (&error, items.last())
    {
        error = Some(SyntaxError {
            at: *at,
            code: PowerErr::IllegalCmd,
        });
        items.pop();
    }
    Parsed {
        items,
        error,
        elems: c.elems,
    }
}

fn command(c: &mut Cur<'_>, motors: u16, coords: u16, last: Option<bool>) -> P<Cmd> {
    let at = c.i;
    let Some(ch) = c.peek() else {
        return err(at);
    };
    match ch {
        b'#' => {
            c.i += 1;
            let l = c.num_list(motors)?;
            if let Some((v, _)) = &l {
                let query = c.rest().starts_with(b"->")
                    && c.rest()
                        .get(2)
                        .is_none_or(|d| matches!(d, b' ' | b'\t' | b'#' | b'&'));
                if query {
                    c.i += 2;
                    return Ok(Cmd::AxisQuery(v.clone()));
                }
            }
            if let Some((v, false)) = &l {
                if c.eat_str("->") {
                    let st = c.i;
                    while c
                        .peek()
                        .is_some_and(|d| !matches!(d, b' ' | b'\t' | b'#' | b'&'))
                    {
                        c.i += 1;
                    }
                    let text = String::from_utf8_lossy(&c.s[st..c.i]).into_owned();
                    return Ok(Cmd::AxisDef(v[0], text));
                }
            }
            return Ok(match l {
                Some((v, list)) => Cmd::Motors(v, list),
                None => Cmd::MotorQuery,
            });
        }
        b'&' => {
            c.i += 1;
            return Ok(match c.num_list(coords)? {
                Some((v, list)) => Cmd::Coords(v, list),
                None => Cmd::CoordQuery,
            });
        }
        b'?' => {
            c.i += 1;
            return Ok(match last {
                Some(true) => Cmd::Motor(MotorCmd::Status),
                Some(false) => Cmd::Cs(CsCmd::Status),
                None => Cmd::GlobalStatus,
            });
        }
        b'%' => {
            c.i += 1;
            return Ok(match c.number() {
                Some(v) => Cmd::Cs(CsCmd::Override(v)),
                None => Cmd::Cs(CsCmd::OverrideQuery),
            });
        }
        b'$' => {
            c.i += 1;
            return Ok(Cmd::Motor(MotorCmd::Enable));
        }
        _ => {}
    }
    if !ch.is_ascii_alphabetic() {
        return err(at);
    }
    // Variables: a family letter followed by a number or `(`.
    if let Some(f) = Fam::of(ch) {
        if c.peek_at(1)
            .is_some_and(|d| d.is_ascii_digit() || d == b'(')
        {
            c.i += 1;
            return variable(c, f);
        }
    }
    if c.peek() == Some(b'j') && !c.peek_at(1).is_some_and(|d| d.is_ascii_alphabetic()) {
        c.i += 1;
        c.short = true;
        return jog(c);
    }
    // The long forms `jog+`, `jog-`, `jog/`, `jog=…`, `jog:…`, `jog^…` (seed L565-624,
    // L877-908, the short/long table at L20017-20019).
    if c.rest_starts(b"jog")
        && c.peek_at(3)
            .is_some_and(|d| matches!(d, b'+' | b'-' | b'/' | b'=' | b':' | b'^'))
    {
        c.i += 3;
        return jog(c);
    }
    // `jogret`: back to the pre-jog position; `jogret={data}`: to the position, which becomes
    // the pre-jog position (seed L912-917).
    if c.rest_starts(b"jogret") && !c.peek_at(6).is_some_and(|d| d.is_ascii_alphanumeric()) {
        c.i += 6;
        let kind = if c.eat(b'=') {
            match signed(c) {
                Some(v) => crate::domain::ast::JogKind::ToAndSetPreJog(v),
                None => return err(c.i),
            }
        } else {
            crate::domain::ast::JogKind::PreJog
        };
        return Ok(Cmd::Motor(MotorCmd::Jog(kind, None)));
    }
    // `jog` alone: an indefinite jog at the present velocity (seed L598-599, L36069-36083).
    if c.rest_starts(b"jog") && !c.peek_at(3).is_some_and(|d| d.is_ascii_alphanumeric()) {
        c.i += 3;
        return Ok(Cmd::Motor(MotorCmd::Jog(
            crate::domain::ast::JogKind::Present,
            None,
        )));
    }
    // `lh\`, `lh<`, `lh>`: the look-ahead stop, backward and forward commands.
    if c.rest_starts(b"lh") {
        let k = match c.peek_at(2) {
            Some(b'\\') => Some(CsCmd::LhStop),
            Some(b'<') => Some(CsCmd::LhBack),
            Some(b'>') => Some(CsCmd::LhForward),
            _ => None,
        };
        if let Some(k) = k {
            c.i += 3;
            return Ok(Cmd::Cs(k));
        }
    }
    let mut w = c.word().unwrap_or_default();
    // Commands that take a number glued on (`echo7`, `b10`, `out5`, `start2`).
    for kw in ["echo", "out", "begin", "start", "b"] {
        let tail = w.as_bytes().get(kw.len()..).unwrap_or_default();
        // `b1r` / `b1s`: a program start glued on (`&1b1r`).
        let digits = match tail.last() {
            Some(b'r' | b's') if kw.starts_with('b') => &tail[..tail.len() - 1],
            _ => tail,
        };
        if w.len() > kw.len()
            && w.starts_with(kw)
            && !digits.is_empty()
            && digits.iter().all(u8::is_ascii_digit)
        {
            c.i -= w.len() - kw.len();
            w.truncate(kw.len());
            break;
        }
    }
    let motor = |m| Ok(Cmd::Motor(m));
    let cs = |m| Ok(Cmd::Cs(m));
    c.short = matches!(
        w.as_str(),
        "k" | "hm" | "hmz" | "r" | "s" | "q" | "a" | "h" | "b"
    );
    match w.as_str() {
        "k" | "kill" => motor(MotorCmd::Kill),
        "dkill" => motor(MotorCmd::DKill),
        "hm" | "home" => motor(MotorCmd::Home),
        "hmz" | "homez" => motor(MotorCmd::HomeZ),
        "p" if last == Some(false) => cs(CsCmd::Axes(AxisReport::Pos)),
        "d" if last == Some(false) => cs(CsCmd::Axes(AxisReport::Des)),
        "f" if last == Some(false) => cs(CsCmd::Axes(AxisReport::Fe)),
        "v" if last == Some(false) => cs(CsCmd::Axes(AxisReport::Vel)),
        "p" => motor(MotorCmd::Position),
        "v" => motor(MotorCmd::Velocity),
        "f" => motor(MotorCmd::FollowingError),
        "d" => motor(MotorCmd::DesPos),
        "out" => {
            c.ws();
            match signed(c) {
                Some(v) => motor(MotorCmd::Out(v)),
                None => err(c.i),
            }
        }
        "r" | "run" => cs(CsCmd::Run),
        "step" if followed_by(c, "plc") => {
            c.ws();
            let _ = c.eat_word("plc");
            c.ws();
            Ok(Cmd::PlcStep(plc_list(c)?))
        }
        "s" | "step" => cs(CsCmd::Step),
        "pause" | "resume" if followed_by(c, "plc") => plc_control(c, &w),
        "q" | "pause" => cs(CsCmd::Quit),
        "a" | "abort" => cs(CsCmd::Abort),
        "h" | "hold" => cs(CsCmd::Hold),
        "resume" => cs(CsCmd::Resume),
        "pmatch" => cs(CsCmd::PMatch),
        "b" | "begin" => {
            c.ws();
            cs(CsCmd::Begin(c.number().unwrap_or(0.0)))
        }
        "g" => cs(CsCmd::DistanceToGo),
        "adisable" => cs(CsCmd::ADisable),
        "ddisable" => cs(CsCmd::DDisable),
        "stop" => cs(CsCmd::Stop),
        "start" => {
            let save = c.i;
            c.ws();
            let n = c.number();
            if n.is_none() {
                c.i = save;
            }
            cs(CsCmd::Start(n))
        }
        "enable" | "disable" if followed_by(c, "plc") => plc_control(c, &w),
        "enable" | "disable" if followed_by(c, "bgcplc") => {
            // Compiled background C PLCs (seed L34473-34478, L34875-34878): this controller
            // runs none (27: not supported).
            Err(SyntaxError {
                at: c.i,
                code: PowerErr::NotSupported,
            })
        }
        // The C.S. form: `&1 enable`, `&2 disable` (seed L412-416).
        "enable" | "disable" => cs(CsCmd::Servo(w == "enable")),
        "echo" => {
            let save = c.i;
            c.ws();
            let n = c.uint();
            if n.is_none() {
                c.i = save;
            }
            Ok(Cmd::Echo(n))
        }
        "cid" | "vers" | "type" | "cpu" | "date" | "size" | "free" | "buffer" => {
            Ok(Cmd::Info(match w.as_str() {
                "cid" => "cid",
                "vers" => "vers",
                "type" => "type",
                "cpu" => "cpu",
                "date" => "date",
                "size" => "size",
                "free" => "free",
                _ => "buffer",
            }))
        }
        _ if catalog::structure(&w).is_some() => {
            c.i = at;
            element_cmd(c)
        }
        _ => err(at),
    }
}

/// After the family letter: query, list query, assignment or `->` definition query.
fn variable(c: &mut Cur<'_>, f: Fam) -> P<Cmd> {
    let index = c.var_index(0)?;
    let sel = match &index {
        VarIndex::Const(a) => {
            if c.eat_str("..") {
                let b = match c.uint() {
                    Some(b) if b >= *a => b,
                    _ => return err(c.i),
                };
                let per_line =
                    if c.peek() == Some(b':') && c.peek_at(1).is_some_and(|d| d.is_ascii_digit()) {
                        c.i += 1;
                        match c.uint() {
                            Some(n) if n >= 1 => n,
                            _ => return err(c.i),
                        }
                    } else {
                        1
                    };
                Sel::Range(*a, b, per_line)
            } else if c.peek() == Some(b',') && c.peek_at(1).is_some_and(|d| d.is_ascii_digit()) {
                c.i += 1;
                let n = c.uint().unwrap_or(0);
                let step =
                    if c.peek() == Some(b',') && c.peek_at(1).is_some_and(|d| d.is_ascii_digit()) {
                        c.i += 1;
                        c.uint().unwrap_or(1)
                    } else {
                        1
                    };
                Sel::List(*a, n, step)
            } else {
                Sel::One(index.clone())
            }
        }
        VarIndex::Expr(_) => Sel::One(index.clone()),
    };
    if c.eat_str("->") {
        let defines = c.peek().is_some_and(|b| !b.is_ascii_whitespace());
        if f == Fam::M && defines {
            let at = c.i;
            return match super::mptr::parse(c.rest()) {
                Err(e) => Err(SyntaxError {
                    at: at + e.at,
                    code: e.code,
                }),
                Ok(Some((p, len))) => {
                    c.i += len;
                    Ok(Cmd::MDef(sel, MDefSrc::Ptr(p)))
                }
                Ok(None) => Ok(Cmd::MDef(sel, MDefSrc::Elem(c.element(0)?))),
            };
        }
        return Ok(Cmd::IDef(f, sel));
    }
    let save = c.i;
    c.ws();
    if c.peek() == Some(b'=') && c.peek_at(1) != Some(b'=') {
        c.i += 1;
        // `a..b:n=` (a per-line count) is a query form only.
        if matches!(sel, Sel::Range(_, _, n) if n != 1) {
            return err(save);
        }
        c.ws();
        let e = c.expr(0)?;
        return Ok(Cmd::VarSet(f, sel, e));
    }
    c.i = save;
    Ok(Cmd::VarQuery(f, sel))
}

/// The next word (after blanks) is `word`; nothing is consumed.
fn followed_by(c: &mut Cur<'_>, word: &str) -> bool {
    let save = c.i;
    c.ws();
    let yes = c.eat_word(word);
    c.i = save;
    yes
}

/// `enable|disable|pause|resume plc {list}` (seed L34500-34506, L34905-34910, L38175-38178).
fn plc_control(c: &mut Cur<'_>, verb: &str) -> P<Cmd> {
    c.ws();
    let _ = c.eat_word("plc");
    c.ws();
    Ok(Cmd::PlcCtl(plc_verb(verb), plc_list(c)?))
}

/// The PLC verb of `enable`, `disable`, `pause`, `resume`.
pub(crate) fn plc_verb(w: &str) -> crate::domain::ast::PlcVerb {
    use crate::domain::ast::PlcVerb;
    match w {
        "enable" => PlcVerb::Enable,
        "disable" => PlcVerb::Disable,
        "pause" => PlcVerb::Pause,
        _ => PlcVerb::Resume,
    }
}

/// A list of PLC numbers (0-31), on-line and in programs: `a`, `a,b`, `a..b` and their
/// mixtures (`11,13..16,20`, seed L34500-34506, L38716-38720); anything else is 21.
pub(crate) fn plc_list(c: &mut Cur<'_>) -> P<Vec<crate::domain::ast::NumRange>> {
    let mut list = Vec::new();
    loop {
        let a = match c.uint() {
            Some(n) if n <= 31 => n,
            _ => {
                return Err(SyntaxError {
                    at: c.i,
                    code: PowerErr::IllegalParameter,
                })
            }
        };
        let b = if c.eat_str("..") {
            match c.uint() {
                Some(b) if b <= 31 && b >= a => b,
                _ => {
                    return Err(SyntaxError {
                        at: c.i,
                        code: PowerErr::IllegalParameter,
                    })
                }
            }
        } else {
            a
        };
        list.push(crate::domain::ast::NumRange { first: a, last: b });
        if !c.eat(b',') {
            return Ok(list);
        }
    }
}

fn element_cmd(c: &mut Cur<'_>) -> P<Cmd> {
    let e = c.element(0)?;
    if c.eat_str(".a") {
        return Ok(Cmd::ElemAddr(e));
    }
    let save = c.i;
    c.ws();
    if c.peek() == Some(b'=') && c.peek_at(1) != Some(b'=') {
        c.i += 1;
        c.ws();
        let v = c.expr(0)?;
        return Ok(Cmd::ElemSet(e, v));
    }
    c.i = save;
    Ok(Cmd::ElemQuery(e))
}

/// After `j`: `+ - / = ={c} =={c} :{c} ^{c} =* :* ^*`, then an optional `^{c}` trigger offset.
fn jog(c: &mut Cur<'_>) -> P<Cmd> {
    use crate::domain::ast::JogKind as J;
    let at = c.i;
    let kind = match c.peek() {
        Some(b'+') => {
            c.i += 1;
            J::Plus
        }
        Some(b'-') => {
            c.i += 1;
            J::Minus
        }
        Some(b'/') => {
            c.i += 1;
            J::Stop
        }
        Some(b'=') => {
            c.i += 1;
            if c.eat(b'*') {
                J::VarTo
            } else if c.eat(b'=') {
                match signed(c) {
                    Some(v) => J::ToAndSetPreJog(v),
                    None => return err(c.i),
                }
            } else {
                match signed(c) {
                    Some(v) => J::To(v),
                    None => J::PreJog,
                }
            }
        }
        Some(b':') => {
            c.i += 1;
            if c.eat(b'*') {
                J::VarRelCommanded
            } else {
                match signed(c) {
                    Some(v) => J::RelCommanded(v),
                    None => return err(c.i),
                }
            }
        }
        Some(b'^') => {
            c.i += 1;
            if c.eat(b'*') {
                J::VarRelActual
            } else {
                match signed(c) {
                    Some(v) => J::RelActual(v),
                    None => return err(c.i),
                }
            }
        }
        _ => return err(at),
    };
    let trigger = if !c.eat(b'^') {
        None
    } else if c.eat(b'*') {
        Some(JogTrigger::JogOffset)
    } else {
        match signed(c) {
            Some(v) => Some(JogTrigger::Offset(v)),
            None => return err(c.i),
        }
    };
    Ok(Cmd::Motor(MotorCmd::Jog(kind, trigger)))
}

fn signed(c: &mut Cur<'_>) -> Option<f64> {
    let save = c.i;
    let neg = c.eat(b'-');
    match c.number() {
        Some(v) => Some(if neg { -v } else { v }),
        None => {
            c.i = save;
            None
        }
    }
}
