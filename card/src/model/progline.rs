//! The stored form of one program line: the statements parsed from one input line, with its
//! size (the domain's word-count model, spec §5.1 [DECISION]) and its structural role.

use serde::{Deserialize, Serialize};

use super::buffers::{StoredLine, Structure};
use crate::domain::ast::{Pos, Stmt, StmtKind};
use crate::domain::words::word_count;

/// One stored program line (one or more statements entered on one line).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProgLine {
    /// The statements, in order.
    pub stmts: Vec<Stmt>,
}

impl ProgLine {
    /// A line of statements.
    pub fn new(stmts: Vec<Stmt>) -> Self {
        ProgLine { stmts }
    }
}

impl StoredLine for ProgLine {
    fn words(&self) -> u32 {
        self.stmts.iter().map(word_count).sum::<u32>().max(1)
    }

    fn structure(&self) -> Structure {
        // The structural statement is the first of the line (a label may precede it).
        let first = self
            .stmts
            .iter()
            .find(|s| !matches!(s.kind, StmtKind::Label(_)));
        match first.map(|s| &s.kind) {
            Some(StmtKind::If(_)) => Structure::If,
            Some(StmtKind::IfLine(..)) => Structure::IfOneLine,
            Some(StmtKind::Else(body)) if body.is_empty() => Structure::Else,
            Some(StmtKind::Else(_)) => Structure::ElseOneLine,
            Some(StmtKind::EndIf) => Structure::EndIf,
            Some(StmtKind::While(_)) => Structure::While,
            Some(StmtKind::EndWhile) => Structure::EndWhile,
            _ => Structure::Plain,
        }
    }

    fn is_return(&self) -> bool {
        matches!(
            self.stmts.as_slice(),
            [Stmt {
                kind: StmtKind::Return,
                ..
            }]
        )
    }

    fn return_line() -> Self {
        ProgLine {
            stmts: vec![Stmt {
                kind: StmtKind::Return,
                pos: Pos(0),
            }],
        }
    }
}
