//! Motion core of the card (pure: positions, times and register words in, outputs out).
//!
//! - [`ect`]: encoder conversion table entries for MACRO feedback, 24→48-bit rollover extension;
//! - [`pid`]: the PMAC PID filter (Ix30-Ix39, Ix63-Ix69);
//! - [`profile`]: S-curve ramps and jog/home plans (Ix19-Ix22);
//! - [`jog`]: per-motor trajectory with the I12 planning delay and jog commands;
//! - [`home`]: homing search / jog-until-trigger state machine (Ix23, Ix26);
//! - [`flags`]: flag image word → logical flag inputs (the one place for the bit layout);
//! - [`params`]: a motor's I-variables gathered for the servo cycle;
//! - [`motor`]: the per-motor servo pipeline, safety checks and `?` status bits.

pub(crate) mod ect;
pub(crate) mod flags;
pub(crate) mod home;
pub(crate) mod jog;
pub(crate) mod motor;
pub(crate) mod params;
pub(crate) mod pid;
pub(crate) mod profile;

#[cfg(test)]
mod tests_jog;
#[cfg(test)]
mod tests_loop;
