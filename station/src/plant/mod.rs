//! The simulated plant behind a servo node: amplifier, motor, encoder and flag switches. Pure
//! cores: time comes in as an argument, nothing reads a clock.

pub mod amplifier;
pub mod encoder;
pub mod flags;
pub mod motor;
