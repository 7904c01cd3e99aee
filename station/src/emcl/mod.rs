//! EDB step-motor drives speaking EMCL (spec emcl.md): the wire codec, the parameter tables,
//! the 1 kHz ramp generator, the stand-alone program interpreter, the drive model with its
//! EEPROM image, MACRO-node binding, and the set of drives a process hosts. Everything here
//! is pure (bytes and ring time in, bytes out); `crate::emcl_rt` does the I/O.

pub mod bound;
pub mod codec;
pub mod coords;
pub mod drive;
pub mod eeprom;
pub mod exec;
pub mod host;
pub mod io;
pub mod motion;
pub mod paramio;
pub mod params;
pub mod power;
pub mod program;
pub mod spec;
pub mod tick;

pub use codec::{Instr, Reply, Request};
pub use drive::{Answer, Ctx, Drive};
pub use host::{DriveHost, HostedDrive};
pub use spec::DriveSpec;

#[cfg(test)]
mod tests_drive;
#[cfg(test)]
mod tests_fuzz;
#[cfg(test)]
mod tests_program;
#[cfg(test)]
mod tests_step;
#[cfg(test)]
mod tests_vectors;
