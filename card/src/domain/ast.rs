//! The statement and expression forms of the card's programs and PLCs (pmac-commands.md §5,
//! §6), and the small value types they share with the data model: variable references, axis
//! letters and definitions, M-variable definitions, jog kinds. A command language parses its
//! text into these ([`Stmt`]); the program engine runs them; the model stores them. On-line
//! command syntax belongs to the dialect (`lang::ast`).
//!
//! Every node carries the byte position ([`Pos`]) where it started in its source line. `Pos`
//! compares equal to every other `Pos`, so `==` on these values is *structural* (a re-parsed
//! listing equals the original statement); read `.pos.0` when the position itself matters.

use serde::{Deserialize, Serialize};

/// Byte offset of a node in its source line. Always compares equal (see module docs).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct Pos(pub u32);

impl PartialEq for Pos {
    fn eq(&self, _other: &Pos) -> bool {
        true
    }
}

/// A literal number as written: decimal or `$`hex (hex is kept so listings reproduce it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Number {
    /// The value (a leading `-` is folded in).
    pub value: f64,
    /// Written as `$hex`.
    pub hex: bool,
}

impl Number {
    /// A decimal literal.
    pub fn dec(value: f64) -> Number {
        Number { value, hex: false }
    }
}

// ---------------------------------------------------------------------------------------------
// Variables

/// Variable family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum VarKind {
    /// I-variable (setup).
    I,
    /// P-variable (global user float).
    P,
    /// Q-variable (per coordinate system).
    Q,
    /// M-variable (pointer).
    M,
    /// A variable family the command language defines beyond I/P/Q/M (thread-local
    /// variables, named data-structure elements, ...), numbered by the language. The model's
    /// extension (`model::ExtVars`) reads and writes it.
    Ext(u16),
}

/// Index of a single variable: a constant number or a computed `P(expr)` index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum VarIndex {
    /// `P12`.
    Const(u32),
    /// `P(P1+2)`: evaluated, then rounded to the nearest integer.
    Expr(Box<Expr>),
}

/// One variable as used in an expression or as an assignment target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VarRef {
    /// Family.
    pub kind: VarKind,
    /// Number.
    pub index: VarIndex,
    /// Position of the family letter.
    pub pos: Pos,
}

/// Which variables an on-line command addresses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum VarSel {
    /// `P5`, or a computed `P(expr)`.
    One(VarIndex),
    /// `P1..10` (last ≥ first, checked by the parser).
    Range {
        /// First number.
        first: u32,
        /// Last number (inclusive).
        last: u32,
    },
    /// `I130,8,100`: `count` variables starting at `first`, `step` apart (step default 1).
    Strided {
        /// First number.
        first: u32,
        /// How many (≥ 1).
        count: u32,
        /// Distance between numbers (≥ 1).
        step: u32,
    },
}

/// A selection of variables of one family (on-line query / assignment / `=*` / `->`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VarList {
    /// Family.
    pub kind: VarKind,
    /// Selection.
    pub sel: VarSel,
    /// Position of the family letter.
    pub pos: Pos,
}

impl VarList {
    /// The constant variable numbers selected, in order (`None` for a computed index).
    pub fn constant_indices(&self) -> Option<Vec<u32>> {
        match &self.sel {
            VarSel::One(VarIndex::Const(n)) => Some(vec![*n]),
            VarSel::One(VarIndex::Expr(_)) => None,
            VarSel::Range { first, last } => Some((*first..=*last).collect()),
            VarSel::Strided { first, count, step } => Some(
                (0..*count)
                    .map(|k| first.saturating_add(k.saturating_mul(*step)))
                    .collect(),
            ),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// M-variable definitions

/// Memory space of an X/Y bit-field definition.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum XySpace {
    /// X memory.
    X,
    /// Y memory.
    Y,
}

/// Format letter of a multi-bit field or thumbwheel definition.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MFormat {
    /// Unsigned (default).
    U,
    /// Signed two's complement.
    S,
    /// BCD.
    D,
    /// Complemented BCD.
    C,
}

/// An M-variable pointer definition (`M{n}->...`), pmac-commands.md §3.2.3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MDef {
    /// `->*`: self-referenced; the value lives in the definition word.
    SelfRef,
    /// `X:`/`Y:{addr},{offset}[,{width}[,{format}]]`. Offset 24 in the source is normalised to
    /// offset 0, width 24. Width 1 always has format U.
    Bits {
        /// X or Y.
        space: XySpace,
        /// Address 0..=$FFFF (PMAC2), 0..=$7FFFF (Turbo).
        addr: u32,
        /// Lowest bit, 0..=23.
        offset: u8,
        /// 1, 4, 8, 12, 16, 20 or 24.
        width: u8,
        /// U/S/D/C.
        format: MFormat,
    },
    /// `D:{addr}`: 48-bit signed fixed point, X high.
    D(u32),
    /// `L:{addr}`: 48-bit PMAC floating point.
    L(u32),
    /// `F:{addr}`: 32-bit IEEE float in DPRAM layout.
    F(u32),
    /// `DP:{addr}`: 32-bit signed integer in DPRAM layout.
    Dp(u32),
    /// `TWB:{mux},{offset},{size}[,{U|S}]`.
    Twb {
        /// Multiplexer address 0..=255.
        mux: u8,
        /// Bit offset 0..=7.
        offset: u8,
        /// Bits 1..=32.
        size: u8,
        /// U or S.
        format: MFormat,
    },
    /// `TWD:{mux},{offset},{digits}[.{dp}][,{U|S}]`.
    Twd {
        /// Multiplexer address 0..=255.
        mux: u8,
        /// 0 or 4.
        offset: u8,
        /// BCD digits 1..=12.
        digits: u8,
        /// Decimal places 0..=8.
        decimals: u8,
        /// U or S.
        format: MFormat,
    },
    /// `TWR:{mux},{offset}`.
    Twr {
        /// Multiplexer address (even).
        mux: u8,
        /// 0..=7.
        offset: u8,
    },
    /// `TWS:{mux}`.
    Tws {
        /// Multiplexer address 0..=127.
        mux: u8,
    },
}

impl MDef {
    /// The memory address the definition points at (`None` for `*` and thumbwheel forms).
    pub fn address(&self) -> Option<u32> {
        match *self {
            MDef::Bits { addr, .. } => Some(addr),
            MDef::D(a) | MDef::L(a) | MDef::F(a) | MDef::Dp(a) => Some(a),
            _ => None,
        }
    }
}

impl MDef {
    /// Thumbwheel forms (no synchronous assignment allowed).
    pub fn is_thumbwheel(&self) -> bool {
        matches!(
            self,
            MDef::Twb { .. } | MDef::Twd { .. } | MDef::Twr { .. } | MDef::Tws { .. }
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Expressions and conditions

/// Binary operators (pmac-commands.md §5.6). High level: `*` `/` `%` `&`; low: `+` `-` `|` `^`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BinOp {
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `%`
    Mod,
    /// `&` (bitwise)
    And,
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `|` (bitwise)
    Or,
    /// `^` (bitwise)
    Xor,
    /// `<<`: shift left (multiply by 2^n, n rounded)
    Shl,
    /// `>>`: shift right (divide by 2^n, n rounded)
    Shr,
    /// `%` with C `fmod` semantics: the result takes the dividend's sign, `x % 0` is NaN.
    FMod,
}

impl BinOp {
    /// 2 for the high level, 1 for the low level.
    pub fn precedence(self) -> u8 {
        match self {
            BinOp::Mul
            | BinOp::Div
            | BinOp::Mod
            | BinOp::And
            | BinOp::Shl
            | BinOp::Shr
            | BinOp::FMod => 2,
            BinOp::Add | BinOp::Sub | BinOp::Or | BinOp::Xor => 1,
        }
    }
}

/// Built-in functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Func {
    /// `SIN`
    Sin,
    /// `COS`
    Cos,
    /// `TAN`
    Tan,
    /// `ASIN`
    Asin,
    /// `ACOS`
    Acos,
    /// `ATAN`
    Atan,
    /// `ATAN2` (cosine part from Q0 of the C.S.)
    Atan2,
    /// `LN`
    Ln,
    /// `EXP`
    Exp,
    /// `SQRT`
    Sqrt,
    /// `ABS`
    Abs,
    /// `INT`
    Int,
}

/// Functions with IEEE double semantics whatever the card's I15 (the name says radians or
/// degrees), taking one or more arguments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum MathFn {
    /// |x|
    Abs,
    /// arc cosine, radians
    Acos,
    /// arc cosine, degrees
    AcosD,
    /// inverse hyperbolic cosine
    Acosh,
    /// arc sine, radians
    Asin,
    /// arc sine, degrees
    AsinD,
    /// inverse hyperbolic sine
    Asinh,
    /// arc tangent, radians
    Atan,
    /// arc tangent, degrees
    AtanD,
    /// inverse hyperbolic tangent
    Atanh,
    /// atan2(y, x), radians
    Atan2,
    /// atan2(y, x), degrees
    Atan2D,
    /// cube root
    Cbrt,
    /// round toward +∞
    Ceil,
    /// cosine, radians
    Cos,
    /// cosine, degrees
    CosD,
    /// hyperbolic cosine
    Cosh,
    /// e^x
    Exp,
    /// 2^x
    Exp2,
    /// round toward −∞
    Floor,
    /// integer part toward −∞ (`int(-2.5)` is −3)
    Int,
    /// 1 if NaN, else 0
    IsNan,
    /// natural logarithm
    Ln,
    /// base-2 logarithm
    Log2,
    /// base-10 logarithm
    Log10,
    /// a·b + c
    Madd,
    /// x^y
    Pow,
    /// fifth root
    Qnrt,
    /// fourth root
    Qrrt,
    /// remainder with the classic (floored) rule
    Rem,
    /// round to nearest, ties to even
    Rint,
    /// random number in [0, 1) (`rnd(n)`: n selects the seed pair)
    Rnd,
    /// random number between 0 and the argument
    RandX,
    /// set (argument > 0) or read a random seed
    Seed,
    /// sine of radians; the cosine goes to the variable of the second argument
    SinCos,
    /// sine of degrees; the cosine goes to the variable of the second argument
    SinCosD,
    /// −1, 0 or 1
    Sgn,
    /// sine, radians
    Sin,
    /// sine, degrees
    SinD,
    /// hyperbolic sine
    Sinh,
    /// square root (NaN for negatives)
    Sqrt,
    /// tangent, radians
    Tan,
    /// tangent, degrees
    TanD,
    /// hyperbolic tangent
    Tanh,
}

/// Expression node kinds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ExprKind {
    /// Literal (a unary minus on a literal is folded into it).
    Num(Number),
    /// Variable value.
    Var(VarRef),
    /// Unary minus of a non-literal.
    Neg(Box<Expr>),
    /// Binary operation.
    Bin(BinOp, Box<Expr>, Box<Expr>),
    /// Function call.
    Call(Func, Box<Expr>),
    /// Function call with IEEE semantics and any number of arguments.
    Math(MathFn, Vec<Expr>),
    /// Bitwise NOT (`~x`, two's complement on the fixed-point value).
    BitNot(Box<Expr>),
    /// A condition used as a value: 1 when true, 0 when false.
    Test(Box<Cond>),
    /// A flattened multi-dimensional index: Σ round(e)·stride over the parts (the index of a
    /// variable family with several subscripts).
    Strided(Vec<(Expr, u32)>),
}

/// An expression with its position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Expr {
    /// What it is.
    pub kind: ExprKind,
    /// Where it starts.
    pub pos: Pos,
}

impl Expr {
    /// A decimal literal expression (position 0).
    pub fn num(v: f64) -> Expr {
        Expr {
            kind: ExprKind::Num(Number::dec(v)),
            pos: Pos(0),
        }
    }
}

/// Comparators.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CmpOp {
    /// `=`
    Eq,
    /// `!=`
    Ne,
    /// `>`
    Gt,
    /// `!>`
    NotGt,
    /// `<`
    Lt,
    /// `!<`
    NotLt,
    /// `~` (approximately equal, |a−b| ≤ 1, project decision)
    Approx,
    /// `!~`
    NotApprox,
    /// `~` with |a−b| < 0.5 (Power PMAC)
    Near,
    /// `!~` with |a−b| ≥ 0.5 (Power PMAC)
    NotNear,
}

/// A condition (inside the parentheses of IF/WHILE/AND/OR). AND binds tighter than OR.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Cond {
    /// `lhs op rhs`.
    Cmp {
        /// Left side.
        lhs: Expr,
        /// Comparator.
        op: CmpOp,
        /// Right side.
        rhs: Expr,
    },
    /// Both.
    And(Box<Cond>, Box<Cond>),
    /// Either.
    Or(Box<Cond>, Box<Cond>),
    /// True when the value is non-zero (and not NaN).
    Value(Expr),
    /// Negation.
    Not(Box<Cond>),
}

// ---------------------------------------------------------------------------------------------
// Shared small types

/// Axis letters and the circle-centre / radius letters of a move line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Axis {
    /// X
    X,
    /// Y
    Y,
    /// Z
    Z,
    /// A
    A,
    /// B
    B,
    /// C
    C,
    /// U
    U,
    /// V
    V,
    /// W
    W,
    /// Circle centre X component.
    I,
    /// Circle centre Y component.
    J,
    /// Circle centre Z component.
    K,
    /// Circle radius (and in `ABS(R)`/`INC(R)`: the centre-vector mode).
    R,
}

impl Axis {
    /// One of the nine motion axes X Y Z A B C U V W.
    pub fn is_motion_axis(self) -> bool {
        !matches!(self, Axis::I | Axis::J | Axis::K | Axis::R)
    }
    /// The upper-case letter.
    pub fn letter(self) -> char {
        match self {
            Axis::X => 'X',
            Axis::Y => 'Y',
            Axis::Z => 'Z',
            Axis::A => 'A',
            Axis::B => 'B',
            Axis::C => 'C',
            Axis::U => 'U',
            Axis::V => 'V',
            Axis::W => 'W',
            Axis::I => 'I',
            Axis::J => 'J',
            Axis::K => 'K',
            Axis::R => 'R',
        }
    }
    /// From an upper- or lower-case letter.
    pub fn from_letter(c: u8) -> Option<Axis> {
        Some(match c.to_ascii_uppercase() {
            b'X' => Axis::X,
            b'Y' => Axis::Y,
            b'Z' => Axis::Z,
            b'A' => Axis::A,
            b'B' => Axis::B,
            b'C' => Axis::C,
            b'U' => Axis::U,
            b'V' => Axis::V,
            b'W' => Axis::W,
            b'I' => Axis::I,
            b'J' => Axis::J,
            b'K' => Axis::K,
            b'R' => Axis::R,
            _ => return None,
        })
    }
}

/// A number list item: `5` or `1..3` (PLC lists, HOME lists, SETPHASE lists).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct NumRange {
    /// First.
    pub first: u32,
    /// Last (inclusive, = first for a single number).
    pub last: u32,
}

impl NumRange {
    /// All numbers of a list, in order.
    pub fn expand(list: &[NumRange]) -> Vec<u32> {
        list.iter().flat_map(|r| r.first..=r.last).collect()
    }
}

/// One term of a motor axis definition: `[scale]axis`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxisTerm {
    /// Counts per user unit.
    pub scale: f64,
    /// Axis letter (motion axes only).
    pub axis: Axis,
}

/// `#n->{def}` right-hand side.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisDef {
    /// 1..=3 terms (one triple XYZ or UVW when more than one).
    pub terms: Vec<AxisTerm>,
    /// Offset in counts.
    pub offset: f64,
}

/// Jog commands `J...` (pmac-commands.md §3.4.2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum JogKind {
    /// `J+`
    Plus,
    /// `J-`
    Minus,
    /// `J/`
    Stop,
    /// `J!`
    Round,
    /// `J=`: back to the pre-jog position.
    PreJog,
    /// `J={v}`
    To(f64),
    /// `J=={v}`
    ToAndSetPreJog(f64),
    /// `J:{v}` relative to commanded.
    RelCommanded(f64),
    /// `J^{v}` relative to actual.
    RelActual(f64),
    /// `J=*`
    VarTo,
    /// `J:*`
    VarRelCommanded,
    /// `J^*`
    VarRelActual,
    /// Power `jog`: an indefinite jog at the motor's present velocity, typically taking an
    /// open-loop (`out`) motion into closed loop (seed 000 L36069-36083).
    Present,
}

/// A MACRO station variable: `MI{n}` (also plain `I{n}` as DLS clients send) or `C{n}`/`MC{n}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SlaveVar {
    /// `MI{n}`
    Mi(u32),
    /// `MC{n}` / `C{n}`
    Mc(u32),
}

/// PLC control verbs (on-line and in programs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PlcVerb {
    /// `ENABLE PLC`
    Enable,
    /// `DISABLE PLC`
    Disable,
    /// `PAUSE PLC`
    Pause,
    /// `RESUME PLC`
    Resume,
    /// `ENABLE PLCC`
    EnableCompiled,
    /// `DISABLE PLCC`
    DisableCompiled,
}

/// A PLC control statement / command: verb + list.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlcControl {
    /// What to do.
    pub verb: PlcVerb,
    /// Which PLCs (0..=31).
    pub list: Vec<NumRange>,
}

/// Register-address operand of the MACRO copy commands (`MXR`, `MSW` ...): a PMAC variable.
pub type MacroVar = VarRef;

// ---------------------------------------------------------------------------------------------
// Program / PLC statements

/// A program or PLC statement with its position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stmt {
    /// What it is.
    pub kind: StmtKind,
    /// Where it starts in its source line.
    pub pos: Pos,
}

/// Assignment operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AssignOp {
    /// `=` (at processing time)
    Set,
    /// `==` (M only, at next move start)
    SyncSet,
    /// `&=` (M only)
    SyncAnd,
    /// `|=` (M only)
    SyncOr,
    /// `^=` (M only)
    SyncXor,
    /// Compound assignment applied at once: `+=`, `-=`, `*=`, `/=`, `%=`, `&=`, `|=`, `^=`,
    /// `<<=`, `>>=` (and `++`/`--` as `+= 1`/`-= 1`).
    Op(BinOp),
    /// Synchronous compound assignment (applied when the next move starts): `+==`, `-==`, ...
    SyncOp(BinOp),
}

/// Extra part of an axis word: `:vel` (PVT) or `^dist` (move until trigger).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum AxisExtra {
    /// `X10:20` PVT end velocity.
    Velocity(Expr),
    /// `X10^5` distance past the trigger.
    Trigger(Expr),
}

/// One word of a move line: `X10`, `Y(P1)`, `I5`, `R2`, `X10:3`, `X10^-5`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisWord {
    /// Letter.
    pub axis: Axis,
    /// `{data}`: a literal or a parenthesised expression.
    pub value: Expr,
    /// PVT velocity / trigger distance.
    pub extra: Option<AxisExtra>,
}

/// Move modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MoveMode {
    /// `LINEAR`
    Linear,
    /// `RAPID`
    Rapid,
    /// `CIRCLE1`
    Circle1,
    /// `CIRCLE2`
    Circle2,
    /// `SPLINE1`
    Spline1,
    /// `SPLINE2`
    Spline2,
}

/// Letter codes that call subroutine programs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CodeLetter {
    /// G-code → PROG 10n0
    G,
    /// M-code → PROG 10n1
    M,
    /// T-code → PROG 10n2
    T,
    /// D-code → PROG 10n3
    D,
}

/// A `{letter}{data}` argument after CALL / G / M / T / D (for READ).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LetterArg {
    /// Upper-case letter A..Z (not N, O).
    pub letter: u8,
    /// Value.
    pub value: Expr,
}

/// What `PRELUDE1` calls.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum PreludeCall {
    /// `CALL{const}`
    Call(Number),
    /// `G/M/T/D{const}`
    Code(CodeLetter, Number),
}

/// `SEND` channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SendPort {
    /// `SEND`
    Any,
    /// `SENDS` (serial)
    Serial,
    /// `SENDP` (bus)
    Bus,
}

/// Text or control character of CMD/SEND.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Message {
    /// `"text"` (bytes as typed, case kept).
    Text(Vec<u8>),
    /// `^X`: the control character (letter − 64), stored as the letter byte (`b'A'` = CTRL-A).
    Ctrl(u8),
}

/// `DISPLAY` forms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Display {
    /// `DISPLAY [{pos}] "{text}"`
    Text {
        /// LCD position.
        pos: Option<u32>,
        /// Text.
        text: Vec<u8>,
    },
    /// `DISPLAY {pos},{width}.{decimals},{variable}`
    Var {
        /// LCD position.
        pos: u32,
        /// Field width.
        width: u32,
        /// Decimals.
        decimals: u32,
        /// Variable.
        var: VarRef,
    },
}

/// Statement kinds (pmac-commands.md §5, §6).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum StmtKind {
    /// `N{n}` / `O{n}` label (O is stored as N).
    Label(u32),
    /// `P1=...`, `M1==...`, `M1&=...`
    Assign {
        /// Target variable.
        target: VarRef,
        /// Operator.
        op: AssignOp,
        /// Value.
        value: Expr,
    },
    /// Consecutive axis / centre words of one move: `X10 Y20 I5`.
    Move(Vec<AxisWord>),
    /// `LINEAR`, `RAPID`, `CIRCLE1` ...
    Mode(MoveMode),
    /// `PVT{data}`
    Pvt(Expr),
    /// `ABS[(...)]`
    Abs(Option<Vec<Axis>>),
    /// `INC[(...)]`
    Inc(Option<Vec<Axis>>),
    /// `FRAX[(...)]`
    Frax(Option<Vec<Axis>>),
    /// `TA{data}`
    Ta(Expr),
    /// `TS{data}`
    Ts(Expr),
    /// `TM{data}`
    Tm(Expr),
    /// `F{data}`
    F(Expr),
    /// `DWELL{data}`
    Dwell(Expr),
    /// `DELAY{data}`
    Delay(Expr),
    /// `HOME{list}`
    Home(Vec<NumRange>),
    /// `HOMEZ{list}`
    HomeZ(Vec<NumRange>),
    /// `PSET X.. Y..`
    Pset(Vec<AxisWord>),
    /// Power `pmatch` in a program: the axis start positions from the motors' present
    /// positions (seed 000 L545, L705).
    Pmatch,
    /// Power `pstore`: keep the C.S. motors' `pset` offsets (seed 000 L43316).
    Pstore,
    /// Power `pload`: put back the offsets `pstore` kept (seed 000 L43188).
    Pload,
    /// `CC0` / `CC1` / `CC2`
    CutterComp(u8),
    /// `CCR{data}`
    CutterRadius(Expr),
    /// `NORMAL I.. J.. K..`
    Normal(Vec<AxisWord>),
    /// `TSEL{n}`
    Tsel(u32),
    /// `TINIT`
    Tinit,
    /// `ADIS{q}`
    Adis(u32),
    /// `IDIS{q}`
    Idis(u32),
    /// `AROT{q}`
    Arot(u32),
    /// `IROT{q}`
    Irot(u32),
    /// `IF ({cond})` opening a block.
    If(Cond),
    /// `IF ({cond}) stmt...` on one line.
    IfLine(Cond, Vec<Stmt>),
    /// `ELSE` (empty: block ELSE) or `ELSE stmt...` on one line.
    Else(Vec<Stmt>),
    /// `ENDIF`
    EndIf,
    /// `WHILE ({cond})` opening a block.
    While(Cond),
    /// `WHILE ({cond}) stmt...` on one line.
    WhileLine(Cond, Vec<Stmt>),
    /// `ENDWHILE`
    EndWhile,
    /// `AND ({cond})` PLC continuation line.
    AndCond(Cond),
    /// `OR ({cond})` PLC continuation line.
    OrCond(Cond),
    /// `WAIT`
    Wait,
    /// `STOP`
    Stop,
    /// `RETURN`
    Return,
    /// `GOTO{data}`
    Goto(Expr),
    /// `GOSUB{data}`; Power `gosub{data} [args]` (seed 000 L41477).
    Gosub(Expr, Vec<LetterArg>),
    /// `CALL{data} [args]`
    Call(Expr, Vec<LetterArg>),
    /// `G/M/T/D{data} [args]`
    Code(CodeLetter, Expr, Vec<LetterArg>),
    /// `READ(A,B,...)`: upper-case letters.
    Read(Vec<u8>),
    /// `PRELUDE1 {call}` (Some) / `PRELUDE0` (None)
    Prelude(Option<PreludeCall>),
    /// `S{data}`: spindle value to Q127.
    Spindle(Expr),
    /// `BLOCKSTART`
    BlockStart,
    /// `BLOCKSTOP`
    BlockStop,
    /// `COMMAND"..."` / `COMMAND^x`
    Command(Message),
    /// `SEND"..."`, `SENDS`, `SENDP`, `SEND^x`
    Send(SendPort, Message),
    /// `DISPLAY ...`
    Display(Display),
    /// `ENABLE/DISABLE/PAUSE/RESUME PLC(C) list`
    Plc(PlcControl),
    /// `ADDRESS [#m][&c]`
    Address {
        /// `#m`
        motor: Option<u32>,
        /// `&c`
        coord: Option<u32>,
    },
    /// `SETPHASE{list}`
    SetPhase(Vec<NumRange>),
    /// `GATHER [TRIGGER]`
    Gather {
        /// `TRIGGER` given.
        trigger: bool,
    },
    /// `ENDGATHER`
    EndGather,
    /// `MXR{node},{param},{var}`
    MacroAuxRead {
        /// Node.
        node: u32,
        /// Parameter.
        param: u32,
        /// Destination.
        var: VarRef,
    },
    /// `MXW{node},{param},{var}`
    MacroAuxWrite {
        /// Node.
        node: u32,
        /// Parameter.
        param: u32,
        /// Source.
        var: VarRef,
    },
    /// `MSR{node},{slavevar},{var}`
    MacroSlaveRead {
        /// Node.
        node: u32,
        /// Station variable.
        var: SlaveVar,
        /// Destination.
        dest: VarRef,
    },
    /// `do` opening a loop whose condition is tested at its end ([`StmtKind::DoWhile`]).
    Do,
    /// End of a `do` loop: jump back to its top while the condition is true.
    DoWhile(Cond),
    /// Leave the innermost loop or `switch`.
    Break,
    /// Jump to the next test of the innermost loop.
    Continue,
    /// `switch (expr)` opening a block of [`StmtKind::Case`] labels.
    Switch(Expr),
    /// `case c:` label of the innermost switch (execution falls through to the next case).
    Case(f64),
    /// `default:` label of the innermost switch.
    Default,
    /// End of a switch block.
    EndSwitch,
    /// `callsub{data}`: a subroutine call in the same program that passes the local stack.
    CallSub(Expr, Vec<LetterArg>),
    /// `N{n}` without a colon: a synchronous line label (reported, not a jump target).
    SyncLabel(u32),
    /// Power `spline{data}`: SPLINE mode with its own segment time (ms), apart from TA.
    Spline(Expr),
    /// Power `td{data}`: the final deceleration time of blended moves (ms).
    Td(Expr),
    /// Power `send n,"fmt",expr,…`: printf-style text (escapes already resolved) formatted
    /// with the values of `args` when the statement runs.
    SendFormat {
        /// Software port 0-4.
        port: u8,
        /// Format text.
        text: Vec<u8>,
        /// One expression per conversion of `text`.
        args: Vec<Expr>,
    },
    /// Power `cmd"fmt",expr,…`: a command text formatted printf-style with the values of
    /// `args` when the statement runs.
    CommandFormat {
        /// Format text.
        text: Vec<u8>,
        /// One expression per conversion of `text`.
        args: Vec<Expr>,
    },
    /// `MSW{node},{slavevar},{var}`
    MacroSlaveWrite {
        /// Node.
        node: u32,
        /// Station variable.
        var: SlaveVar,
        /// Source.
        src: VarRef,
    },
}
