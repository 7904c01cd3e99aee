//! `cx {program statements}` and `cpx {program statements}` (seed L33727-33800): a program
//! line compiled and run at once, as a one-line PLC (`cx`) or a one-line motion program of
//! the thread's addressed C.S. (`cpx`). Single-line `if`/`while`, assignments to any variable
//! or element, `cmd`, PLC control run at once in the command thread's context (its L/D/C
//! locals, its addressed C.S. for Q-variables). [DECISION] Moves: `cpx` runs them as a
//! motion program through the C.S.'s rotary buffer (one line, then `stop`; `b0 r` with the
//! C.S.'s run checks, #25 when it cannot run); `cx` the same way in rapid mode (the seed
//! "forces the C.S. into rapid mode", L33747, so the C.S. stays in it as after a `rapid`;
//! `cx pmatch X10 Y20 Z30`, L33797).

use super::parse::SyntaxError;
use super::{exec, program, progvars, Thread};
use crate::domain::ast::{Message, Stmt, StmtKind};
use crate::domain::{CsNum, MotorNum, PowerErr};
use crate::lang::Card;
use crate::model::{CardModel, ExtAt, ProgLine, Thread as ExecThread};
use crate::program::env;
use crate::program::stmt::{exec_common, Common, Ctx, QueuedCmd};

/// Most loop iterations one `cx` line runs (a PLC's scan would end and continue; a one-line
/// command stops there).
const MAX_ITERATIONS: u32 = 100_000;

/// `cx …` / `cpx …`: `None` when `line` is neither. `cmds` receives `cmd"…"` texts to run.
pub(crate) fn command(
    card: &mut Card,
    conn: u64,
    th: &mut Thread,
    line: &[u8],
    cmds: &mut Vec<Vec<u8>>,
) -> Option<Vec<u8>> {
    let start = line.iter().position(|b| !b.is_ascii_whitespace())?;
    let word_end = line[start..]
        .iter()
        .position(|b| b.is_ascii_whitespace())
        .map_or(line.len(), |k| start + k);
    let word = line[start..word_end].to_ascii_lowercase();
    let motion = match word.as_slice() {
        b"cx" => false,
        b"cpx" => true,
        _ => return None,
    };
    th.lines += 1;
    let body = &line[word_end..];
    let at0 = word_end;
    let parsed = progvars::with(card, |_, pv| {
        let mut blocks = Vec::new();
        let r = program::parse_program_line(body, &mut blocks, &mut pv.elems);
        match r {
            Ok(_) if !blocks.is_empty() => Err(SyntaxError {
                at: 0,
                code: PowerErr::IllegalCmd,
            }),
            other => other,
        }
    });
    let stmts = match parsed {
        Ok(s) if !s.is_empty() => s,
        Ok(_) => {
            return Some(exec::frame(
                th,
                line,
                Some(SyntaxError {
                    at: 0,
                    code: PowerErr::IllegalCmd,
                }),
            ))
        }
        Err(e) => {
            let e = SyntaxError {
                at: e.at + at0,
                ..e
            };
            return Some(exec::frame(th, line, Some(e)));
        }
    };
    let r = if stmts.iter().any(|s| is_motion(&s.kind)) {
        if motion {
            run_motion(card, th, stmts)
        } else {
            // `cx` moves the addressed C.S.'s axes in rapid mode (L33747).
            let mut all = vec![Stmt {
                kind: StmtKind::Mode(crate::domain::ast::MoveMode::Rapid),
                pos: crate::domain::ast::Pos(0),
            }];
            all.extend(stmts);
            run_motion(card, th, all)
        }
    } else {
        run_now(card, conn, th, &stmts, cmds)
    };
    Some(exec::frame(
        th,
        line,
        r.err().map(|code| SyntaxError { at: start, code }),
    ))
}

/// Statements only a motion program can run.
fn is_motion(k: &StmtKind) -> bool {
    match k {
        StmtKind::Move(_)
        | StmtKind::Mode(_)
        | StmtKind::Abs(_)
        | StmtKind::Inc(_)
        | StmtKind::F(_)
        | StmtKind::Tm(_)
        | StmtKind::Ta(_)
        | StmtKind::Td(_)
        | StmtKind::Ts(_)
        | StmtKind::Pvt(_)
        | StmtKind::Spline(_)
        | StmtKind::Dwell(_)
        | StmtKind::Delay(_)
        | StmtKind::Home(_)
        | StmtKind::HomeZ(_)
        | StmtKind::Code(..)
        | StmtKind::Call(..)
        | StmtKind::Gosub(..)
        | StmtKind::CallSub(..)
        | StmtKind::Goto(_)
        | StmtKind::Read(_)
        | StmtKind::Pset(_)
        | StmtKind::Pmatch
        | StmtKind::Pstore
        | StmtKind::Pload => true,
        StmtKind::IfLine(_, b) | StmtKind::WhileLine(_, b) => b.iter().any(|s| is_motion(&s.kind)),
        _ => false,
    }
}

/// Run `stmts` now on the command thread of `conn` (its locals as a program thread's).
fn run_now(
    card: &mut Card,
    conn: u64,
    th: &mut Thread,
    stmts: &[Stmt],
    cmds: &mut Vec<Vec<u8>>,
) -> Result<(), PowerErr> {
    let at = ExtAt {
        thread: ExecThread::Host(conn),
        coord: th.coord + 1,
        motor: th.motor + 1,
        ..ExtAt::default()
    };
    progvars::with(card, |_, pv| pv.enter(at.thread, th.clone()));
    let saved = card.model.exec;
    card.model.exec = at;
    let mut queued = Vec::new();
    let mut out = Vec::new();
    let mut budget = MAX_ITERATIONS;
    let r = run(
        &mut card.model,
        &at,
        stmts,
        &mut queued,
        &mut out,
        &mut budget,
    );
    card.model.exec = saved;
    if let Some(t) = progvars::with(card, |_, pv| pv.leave(at.thread)) {
        *th = t;
    }
    card.model.push_output(&out);
    for q in queued {
        if let Message::Text(t) = q.msg {
            cmds.push(t);
        }
    }
    r
}

fn run(
    card: &mut CardModel,
    at: &ExtAt,
    stmts: &[Stmt],
    queued: &mut Vec<QueuedCmd>,
    out: &mut Vec<u8>,
    budget: &mut u32,
) -> Result<(), PowerErr> {
    for s in stmts {
        match &s.kind {
            StmtKind::IfLine(c, body) => {
                if env::test(card, at.coord, c).map_err(|_| PowerErr::IllegalParameter)? {
                    run(card, at, body, queued, out, budget)?;
                }
            }
            StmtKind::WhileLine(c, body) => {
                while env::test(card, at.coord, c).map_err(|_| PowerErr::IllegalParameter)? {
                    if *budget == 0 {
                        return Ok(());
                    }
                    *budget -= 1;
                    run(card, at, body, queued, out, budget)?;
                }
            }
            StmtKind::Label(_) | StmtKind::SyncLabel(_) => {}
            k => {
                let mut none = crate::program::NoCommands;
                let mut ctx = Ctx {
                    motor: at.motor,
                    coord: at.coord,
                    cmds: queued,
                    out,
                    cmd: &mut none,
                    plc: None,
                };
                match exec_common(card, &mut ctx, k) {
                    Common::BadVariable => return Err(PowerErr::IllegalParameter),
                    Common::NotMine | Common::MacroRefused | Common::AuxWait => {
                        return Err(PowerErr::NotSupported)
                    }
                    _ => {}
                }
            }
        }
    }
    Ok(())
}

/// `cpx` with moves: the line (then `stop`) into the addressed C.S.'s rotary buffer, run
/// from its start.
fn run_motion(card: &mut Card, th: &Thread, mut stmts: Vec<Stmt>) -> Result<(), PowerErr> {
    let cs = th.coord + 1;
    let Ok(k) = u8::try_from(cs) else {
        return Err(PowerErr::IllegalParameter);
    };
    if card.model.cs_running(cs) {
        return Err(PowerErr::ProgramRunning);
    }
    stmts.push(Stmt {
        kind: StmtKind::Stop,
        pos: crate::domain::ast::Pos(0),
    });
    let size = card
        .model
        .bufs
        .rotary
        .get(&k)
        .map_or(1024, |r| r.size.max(1024));
    card.model.bufs.rotary.insert(
        k,
        crate::model::Rotary {
            size,
            lines: vec![ProgLine::new(stmts)],
        },
    );
    let mut s = crate::lang::Session {
        motor: MotorNum::of(th.motor + 1),
        coord: CsNum::of(cs),
        ..crate::lang::Session::with_id(0)
    };
    use crate::lang::CmdKind;
    for cmd in [
        CmdKind::Begin(crate::domain::ast::Number::dec(0.0)),
        CmdKind::Run,
    ] {
        if card.exec_pmac(&mut s, &cmd).is_err() {
            card.model.bufs.rotary.remove(&k);
            return Err(PowerErr::NotReadyToRun);
        }
    }
    Ok(())
}
