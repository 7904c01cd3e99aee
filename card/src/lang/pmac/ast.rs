//! On-line command syntax of the PMAC dialect (pmac-commands.md §3): [`Command`] and [`Item`].
//! The statement and expression forms stored in programs are the card's domain types
//! ([`crate::domain::ast`]), re-exported here so the parsers name one module.

use serde::{Deserialize, Serialize};

pub(crate) use crate::domain::ast::*;

// ---------------------------------------------------------------------------------------------
// Buffers, listings and definitions

/// Which program kind a buffer holds (what statements are legal in it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum BufferKind {
    /// A fixed motion program `PROG n`.
    Prog,
    /// The rotary buffers.
    Rotary,
    /// `PLC n` (0 = foreground).
    Plc(u8),
}

/// `OPEN` targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum OpenTarget {
    /// `OPEN PROG n`.
    Prog(u32),
    /// `OPEN PLC n`.
    Plc(u32),
    /// `OPEN ROT`.
    Rotary,
    /// `OPEN BIN ROT`.
    BinRotary,
}

/// `[,[start][,[len]]]` of LIST commands. `offsets` = a comma was given (prefix `{offset}:`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub(crate) struct ListSpan {
    /// A first comma was present.
    pub offsets: bool,
    /// Start offset (words), if given.
    pub start: Option<u32>,
    /// Length (words), if given.
    pub len: Option<u32>,
}

/// `LIST` targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum ListTarget {
    /// `LIST`: the open buffer.
    Open,
    /// `LIST PROG n[,...]`.
    Prog(u32, ListSpan),
    /// `LIST PLC n[,...]`.
    Plc(u32, ListSpan),
    /// `LIST ROT [start][,len]`.
    Rotary(ListSpan),
    /// `LIST GATHER [start][,len]`.
    Gather(ListSpan),
    /// `LIST PC[,[len]]` (`start` unused).
    Pc(ListSpan),
    /// `LIST PE[,[len]]`.
    Pe(ListSpan),
    /// `LIST COMP` (`true` = `LIST COMP DEF`).
    Comp(bool),
    /// `LIST BLCOMP [DEF]`.
    BlComp(bool),
    /// `LIST TCOMP [DEF]`.
    TComp(bool),
    /// `LIST LINK`.
    Link,
}

/// A motor of a `DEFINE COMP` source/target list: `#n` with optional `D` (desired position).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct CompMotor {
    /// Motor number.
    pub motor: u32,
    /// `D` suffix.
    pub desired: bool,
}

/// `DEFINE` targets.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) enum DefineTarget {
    /// `DEFINE ROT n`.
    Rotary(u32),
    /// `DEFINE GATHER [n]`.
    Gather(Option<u32>),
    /// `DEFINE TBUF n`.
    Tbuf(u32),
    /// `DEFINE UBUFFER n`.
    Ubuffer(u32),
    /// `DEFINE COMP rows[.cols],[motors...],span[,span]`.
    Comp {
        /// Entries (1-D) or rows (2-D).
        rows: u32,
        /// Columns (2-D only).
        cols: Option<u32>,
        /// `#n[D]` items in order.
        motors: Vec<CompMotor>,
        /// Span(s) in counts.
        spans: Vec<Number>,
    },
    /// `DEFINE BLCOMP n,span`.
    BlComp(u32, Number),
    /// `DEFINE TCOMP n,span`.
    TComp(u32, Number),
    /// `DEFINE LOOKAHEAD a,b` (not supported, parsed for ERR003).
    Lookahead(u32, u32),
}

/// `DELETE` targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum DeleteTarget {
    /// `DELETE ROT`.
    Rotary,
    /// `DELETE GATHER`.
    Gather,
    /// `DELETE TBUF`.
    Tbuf,
    /// `DELETE COMP`.
    Comp,
    /// `DELETE BLCOMP`.
    BlComp,
    /// `DELETE TCOMP`.
    TComp,
    /// `DELETE LOOKAHEAD`.
    Lookahead,
    /// `DELETE PLCC n`.
    Plcc(u32),
    /// `DELETE TRACE` (obsolete no-op).
    Trace,
}
/// Memory space of the register access commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum MemSpace {
    /// X
    X,
    /// Y
    Y,
    /// L (48-bit, X high)
    L,
}

/// `MS{cmd}{node}` station commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) enum SlaveCmd {
    /// `MS$$$n`
    Reset,
    /// `MS$$$***n`
    Reinit,
    /// `MS CLRFn`
    ClearFault,
    /// `MS CONFIGn` (with `Some(v)`: `MS CONFIGn=v`)
    Config(Option<u32>),
    /// `MS DATEn`
    Date,
    /// `MS SAVEn`
    Save,
    /// `MS VERn`
    Version,
}

// ---------------------------------------------------------------------------------------------
// On-line commands

/// An on-line command with its position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Command {
    /// What it is.
    pub kind: CmdKind,
    /// Where it starts in the line.
    pub pos: Pos,
}

/// On-line command kinds (pmac-commands.md §3). Control characters are not lexed from lines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) enum CmdKind {
    // --- addressing (§3.0, §8)
    /// `#n`
    AddrMotor(u32),
    /// `#`
    ReportMotor,
    /// `&n`
    AddrCoord(u32),
    /// `&`
    ReportCoord,
    /// `@n` (hex digit)
    AddrCard(u8),
    /// `@@`
    AddrAllCards,
    /// `@`
    ReportCard,

    // --- global (§3.2.1, §3.2.2)
    /// `$$$`
    Reset,
    /// `$$$***`
    Reinit,
    /// `SAVE`
    Save,
    /// `PASSWORD={string}` (bytes as typed, case kept, up to end of line).
    Password(Vec<u8>),
    /// `UNDEFINE ALL`
    UndefineAll,
    /// `CLEARFAULT`
    ClearFault,
    /// `TYPE`
    Type,
    /// `VERSION`
    Version,
    /// `DATE`
    Date,
    /// `EAVERSION`
    EaVersion,
    /// `CHECKSUM`
    Checksum,
    /// `SIZE`
    Size,
    /// `CID` (turbo profile)
    Cid,
    /// `CPU` (turbo profile: the DSP type)
    Cpu,
    /// `???`
    GlobalStatus,

    // --- variables (§3.2.3)
    /// `P5`, `I100..199`, `M1,4,2` ...
    VarQuery(VarList),
    /// `P5=expr`
    VarAssign(VarList, Expr),
    /// `I5=*`
    VarDefault(VarList),
    /// `M1->` / `M1..8->`
    MDefQuery(VarList),
    /// `M1->X:$C000,0,24,S` / `M1->*`
    MDefine(VarList, MDef),
    /// A bare number: `P0={n}` or a table entry.
    BareNumber(Number),

    // --- register access (§3.2.4)
    /// `R[H]{X|Y|L}[:]{addr}[,{count}]`
    ReadMem {
        /// `RH` form.
        hex: bool,
        /// Space.
        space: MemSpace,
        /// Address.
        addr: u32,
        /// 1..=16.
        count: u32,
    },
    /// `W{X|Y|L}[:]{addr},{value}[,...]`
    WriteMem {
        /// Space.
        space: MemSpace,
        /// Address.
        addr: u32,
        /// Values.
        values: Vec<Number>,
    },

    // --- PLC control (§3.2.5)
    /// `ENABLE PLC 1..3` etc.
    Plc(PlcControl),
    /// `DELETE PLCC n` is [`CmdKind::Delete`]; this is kept for symmetry of `SETPHASE`.
    SetPhase(Vec<NumRange>),

    // --- buffers (§3.2.6)
    /// `OPEN ...`
    Open(OpenTarget),
    /// `CLOSE`
    Close,
    /// `CLEAR`
    Clear,
    /// `LIST ...`
    List(ListTarget),
    /// `DEFINE ...`
    Define(DefineTarget),
    /// `DELETE ...`
    Delete(DeleteTarget),
    /// `GATHER [TRIGGER]`
    Gather {
        /// `TRIGGER` given.
        trigger: bool,
    },
    /// `ENDGATHER`
    EndGather,

    // --- coordinate system (§3.3)
    /// `#n->`
    AxisDefQuery(u32),
    /// `#n->{def}`
    AxisDefine(u32, AxisDef),
    /// `#n->0`
    AxisUndefine(u32),
    /// `UNDEFINE`
    Undefine,
    /// `??`
    CsStatus,
    /// `%`
    OverrideQuery,
    /// `%{v}`
    OverrideSet(f64),
    /// `B{v}`
    Begin(Number),
    /// `R`
    Run,
    /// `S`
    Step,
    /// `Q`
    Quit,
    /// `A`
    Abort,
    /// `H`
    Hold,
    /// `/`
    StopAtEnd,
    /// `\`
    HoldJog,
    /// `<`
    BackUp,
    /// `>`
    Resume,
    /// `MFLUSH`
    MFlush,
    /// `PMATCH`
    PMatch,
    /// `{axis}={constant}`
    AxisRename(Axis, f64),
    /// `Z`
    ZeroAxes,
    /// `ABS[(...)]`
    Abs(Option<Vec<Axis>>),
    /// `INC[(...)]`
    Inc(Option<Vec<Axis>>),
    /// `FRAX[(...)]`
    Frax(Option<Vec<Axis>>),
    /// `PC`
    ProgCounter,
    /// `PE`
    ExecPointer,
    /// `PR`
    RotaryRemaining,
    /// `LEARN[(...)]`
    Learn(Option<Vec<Axis>>),

    // --- motor (§3.4)
    /// `$`
    MotorInit,
    /// `$*`
    MotorAbsRead,
    /// `HOME` / `HM`
    Home,
    /// `HOMEZ` / `HMZ`
    HomeZ,
    /// `K`
    Kill,
    /// `O{v}`
    OpenLoop(f64),
    /// `J...[^{d}]`
    Jog {
        /// Which jog.
        kind: JogKind,
        /// `^{d}` jog-until-trigger distance.
        trigger: Option<f64>,
    },
    /// `P`
    Position,
    /// `V`
    Velocity,
    /// `F`
    FollowingError,
    /// `?`
    MotorStatus,

    // --- MACRO (§3.5)
    /// `MX{node},{param}[={value}]`
    MacroAux {
        /// Node 0..=15.
        node: u32,
        /// Parameter.
        param: u32,
        /// Write value.
        value: Option<Number>,
    },
    /// `MXR{node},{param},{var}`
    MacroAuxRead {
        /// Node.
        node: u32,
        /// Parameter.
        param: u32,
        /// Destination variable.
        var: MacroVar,
    },
    /// `MXW{node},{param},{var}`
    MacroAuxWrite {
        /// Node.
        node: u32,
        /// Parameter.
        param: u32,
        /// Source variable.
        var: MacroVar,
    },
    /// `MS{cmd}{node}`
    MacroSlaveCmd {
        /// Command.
        cmd: SlaveCmd,
        /// Node 0..=15.
        node: u32,
    },
    /// `MS{node},{slavevar}[={value}]`
    MacroSlaveVar {
        /// Node.
        node: u32,
        /// Station variable.
        var: SlaveVar,
        /// Write value.
        value: Option<Number>,
    },
    /// `MS{node},MI{first}..{last}`: report a range of station variables.
    MacroSlaveRange {
        /// Node.
        node: u32,
        /// First MI-variable.
        first: u32,
        /// Last MI-variable.
        last: u32,
    },
    /// `MSR{node},{slavevar},{var}`
    MacroSlaveRead {
        /// Node.
        node: u32,
        /// Station variable.
        var: SlaveVar,
        /// Destination.
        dest: MacroVar,
    },
    /// `MSW{node},{slavevar},{var}`
    MacroSlaveWrite {
        /// Node.
        node: u32,
        /// Station variable.
        var: SlaveVar,
        /// Source.
        src: MacroVar,
    },
}

/// One item of a line typed while a buffer is open: stored statement or immediate command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) enum Item {
    /// Store into the open buffer.
    Stmt(Stmt),
    /// Execute now.
    Cmd(Command),
}
