//! mcc-card: a PMAC2-Ultralite-style controller card.
//!
//! Layers, lowest first (each uses only those below it; `tests/layering` checks the `use`
//! paths):
//! - [`domain`]: the vocabulary: profiles, error codes, motor/C.S./node numbers, the statement
//!   and expression forms programs are stored and run in, their evaluation (pure);
//! - [`model`]: the card data model: variables, memory and registers, status words, program
//!   buffers, run state, motion requests, gathered data, the SAVE image format (pure);
//! - [`motion`], [`coord`]: per-motor servo and coordinate-system maths (pure);
//! - [`lang`]: the PMAC command language: lexer, parser, listing, interpreter, reply framing
//!   (pure; a second dialect sits beside it);
//! - [`program`]: the program engine: motion programs, PLCs, run control (pure);
//! - [`servo`]: the servo tick over all of the above (pure);
//! - [`core`]: the card core the servo thread owns: requests in, replies and effects out,
//!   host work served in bounded slices between ticks (pure);
//! - [`runtime`], [`host`]: the process: ring membership, threads, channels, files, sockets.

pub mod coord;
pub mod core;
pub mod domain;
pub mod host;
pub mod lang;
pub mod model;
pub mod motion;
pub mod program;
pub mod runtime;
pub mod servo;
