//! mcc-card: a PMAC2-Ultralite-style controller card.
//!
//! Layers, lowest first (each uses only those below it; `tests/layering` checks the `use`
//! paths):
//! - `domain`: the vocabulary: profiles, error codes, motor/C.S./node numbers, the statement
//!   and expression forms programs are stored and run in, their evaluation (pure);
//! - `model`: the card data model: variables, memory and registers, status words, program
//!   buffers, run state, motion requests, gathered data, the SAVE image format (pure);
//! - `motion`, `coord`: per-motor servo and coordinate-system maths (pure);
//! - `lang`: the PMAC command language: lexer, parser, listing, interpreter, reply framing
//!   (pure; a second dialect sits beside it);
//! - `program`: the program engine: motion programs, PLCs, run control (pure);
//! - `servo`: the servo tick over all of the above (pure);
//! - `core`: the card core the servo thread owns: requests in, replies and effects out,
//!   host work served in bounded slices between ticks (pure);
//! - `service`: the servo thread's request channel and runner, the I/O thread for files;
//! - `host`: host ports (sockets);
//! - `runtime`: the card process: ring membership, start-up, standalone mode.

#![warn(missing_docs, unreachable_pub)]

//!
//! Modules are private; what other crates (the orchestrator, the scenario tests) use is
//! re-exported here.

mod coord;
mod core;
mod domain;
mod host;
mod lang;
mod model;
mod motion;
mod program;
mod runtime;
mod service;
mod servo;

#[cfg(test)]
#[allow(clippy::disallowed_methods, clippy::disallowed_types)] // reads the sources
mod layering;

pub use crate::core::inputs::{CardInputs, HeldInput, InputKind};
pub use crate::core::rig::{self, LoopbackPlant, Rig};
pub use crate::core::ring_io::{ResetLayer, RingIn, RingOut, RingVars, RingWanted};
pub use crate::core::{CardCore, HostReply, HostRequest, SLICE_UNITS};
pub use domain::{ast, CsNum, ErrCode, Limits, MotorNum, NodeNum, PowerErr, Profile, Refusal};
pub use host::bench::{run_host_bench, HostBenchOpts, HostBenchReport};
pub use lang::{
    Budget, Card, Dialect, Effect, EffectResult, HeldReply, LineRun, Session, Started, Step,
    Storage, WholeLine, MAX_LINE,
};
pub use model::{decode_fixed, Action, ActionKind, CardModel, CardState, Space};
pub use motion::flags::FlagInputs;
pub use motion::motor::{Motor, MotorCommand, TickInput, TripScope};
pub use motion::params::MotorParams;
pub use program::{Commands, NoCommands, ProgramEngine};
pub use runtime::bench_servo::{
    run_servo_bench, run_servo_load_bench, PhaseTiming, ServoBenchReport, ServoLoadReport,
};
pub use runtime::cli::run_process;
pub use runtime::input_fault::InputFaultRequest;
pub use runtime::ring_app::CardRingApp;
pub use runtime::standalone::{run_standalone, PowerHostOpts, StandaloneOpts};
pub use runtime::startup::{ring_startup, wire_macro_motors, StartupError};
pub use runtime::{apply_config_ivars, check_card_config, run_ring_card};
pub use service::handle::{spawn_card_thread, CardHandle, Request, Response};
pub use service::storage::FileStorage;
pub use servo::Servo;
