//! mcc-station: a MACRO station on the ring.
//!
//! [`station_app::StationApp`] answers each activated servo node with a simulated amplifier,
//! motor and quadrature encoder ([`servo_node`], [`plant`]), configured by
//! [`config::PlantConfig`]. The station meets the card only through ring packets.

pub mod config;
pub mod macro_aux;
pub mod mi;
pub mod plant;
pub mod servo_node;
pub mod station_app;
pub mod station_mi;
