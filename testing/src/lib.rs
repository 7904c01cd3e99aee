//! Test your PMAC/MACRO host software against an mcc cluster from Rust: the same operations
//! as the Python package `pytest-mcc`, over the same `mcc` CLI and JSON contracts.
//!
//! ```no_run
//! use std::time::Duration;
//! use mcc_testing::{Cluster, FaultOptions};
//!
//! let mut c = Cluster::builder().cards(2).stations(2).clock("lockstep").start()?;
//! assert_eq!(c.send(&["I0"], Some(1))?, ["1"]);
//! let s = c.start_sync("&1B1R", &[0, 1]);
//! c.fault("station0", "cut", FaultOptions::default())?;
//! let st = c.wait_until(Some(20_000), Duration::from_secs(120), |st| st.faulted())?;
//! assert_eq!(st.broken_link(), Some("station0 → card1"));
//! c.clear(None)?;
//! c.reset(Duration::from_secs(120))?;
//! # let _ = s;
//! # Ok::<(), mcc_testing::Error>(())
//! ```
//!
//! A [`Cluster`] runs in a private run directory on free ports, is tied to the test process
//! (`mcc up --owner-pid`: a killed test never leaves it behind) and is taken down when
//! dropped. The `mcc` binary is `$MCC_BIN`, else the one next to the test executable
//! (`target/debug/mcc`), else `mcc` on `PATH`; `mcc` finds `mcc-card` and `mcc-station`
//! next to itself.

mod cluster;
mod error;
mod foreground;
pub mod netns;
pub mod procs;
pub mod run;
pub mod source;
mod status;

pub use cluster::{
    Builder, CardStart, Cluster, FaultOptions, SyncStart, Trace, AXIS_KINDS, AXIS_VALUE_KINDS,
    DRILLS, FAULT_KINDS, INPUT_KINDS, LINK_KINDS,
};
pub use error::{Error, ErrorKind, Result};
pub use foreground::Foreground;
pub use status::{Status, StatusStream};
