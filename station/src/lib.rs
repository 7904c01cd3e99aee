//! mcc-station: a MACRO station on the ring.
//!
//! For now a station answers each activated servo node with an echo of the command it latched
//! ([`echo::EchoStation`]); the simulated amplifier/motor/encoder plant replaces it in the
//! motion work. The station meets the card only through ring packets.

pub mod echo;
