//! Hosts for tests of clusters on several machines: three Linux network namespaces joined by
//! veth links and zenoh's router `zenohd` (the `mcc-netns` crate, which `mcc bench ring`
//! uses too).

use std::path::{Path, PathBuf};

pub use mcc_netns::{Lab, Link, Unavailable, AB, RA, RB};

/// The `zenohd` to use: `$MCC_ZENOHD`, else the one `tests/hosts/install-zenohd.sh` put in
/// `target/zenohd-<version>/bin` of the workspace this crate is in.
pub fn zenohd() -> Option<PathBuf> {
    mcc_netns::zenohd(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../target"))
}
