//! mcc-card: a PMAC2-Ultralite-style controller card.
//!
//! Layout (pure cores first, I/O at the edges):
//! - [`lang`]: lexer, parser, AST and canonical listing of the PMAC command language (pure).
//! - [`state`]: the card's variables, I-variable tables per profile, register map, M-variable
//!   pointers, number printing, status words, persistence format (pure; file I/O only in `persist`).
//! - [`interp`]: executes parsed commands against the state and frames replies per I3/I4/I6/I9
//!   (pure: bytes in, bytes out).
//! - [`host`]: host ports (ASCII terminal, PMAC Ethernet protocol, zenoh queryable): the only
//!   socket code of the card's language side.
//! - [`runtime`]: the process: config, ring membership, threads.

pub mod coord;
pub mod host;
pub mod interp;
pub mod lang;
pub mod macro_aux;
pub mod motion;
pub mod program;
pub mod runtime;
pub mod servo;
pub mod state;
