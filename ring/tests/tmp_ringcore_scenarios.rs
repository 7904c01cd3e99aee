//! TEMPORARY (ringcore): runs tests/scenarios/ring_inprocess.rs while mcc-card does not build.
#[path = "../../tests/scenarios/ring_inprocess.rs"]
mod ring_inprocess;
