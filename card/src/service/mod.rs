//! The card as a service on its servo thread: the [`handle::CardHandle`] every other thread
//! uses to reach it (bounded request channel, replies back), the [`handle::Runner`] that owns
//! the card core on the servo thread, the I/O thread that performs SAVE / `$$$` file effects
//! ([`storage`]), and the two zenoh-facing request kinds the runner serves itself: the daisy
//! chain ([`chain`]) and synchronized start ([`sync_start`]).

#![allow(clippy::disallowed_methods, clippy::disallowed_types)] // an I/O edge: threads, clocks, files, sockets

pub(crate) mod chain;
pub(crate) mod handle;
pub(crate) mod storage;
pub(crate) mod sync_start;

#[cfg(test)]
mod tests_golden;
#[cfg(test)]
mod tests_save;
