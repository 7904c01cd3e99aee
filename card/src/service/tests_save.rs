//! SAVE through the card's service (servo thread, I/O thread, a real state file): what is
//! acknowledged is on disk and comes back with `$$$`; a SAVE that cannot be kept answers an
//! error and leaves the card's values alone (issue 26 item 1).

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use super::handle::{channel, CardHandle};
use super::storage::FileStorage;
use crate::core::{CardCore, HostRequest};
use crate::domain::Profile;
use crate::lang::Card;

/// A fresh directory of this test process.
fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mcc-save-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A card of `profile` on its own thread, saving to `state` (none: no state file).
fn card(profile: Profile, state: Option<PathBuf>) -> (CardHandle, Arc<AtomicBool>) {
    let (mut runner, handle) = channel(
        CardCore::new(Card::new(profile)),
        state.map(FileStorage::new),
    );
    let stop = Arc::new(AtomicBool::new(false));
    let s = Arc::clone(&stop);
    std::thread::spawn(move || runner.run_until(&s));
    (handle, stop)
}

fn send(h: &CardHandle, line: &str) -> String {
    let r = h.host(7, HostRequest::Line(line.as_bytes().to_vec()));
    String::from_utf8_lossy(&r.bytes).into_owned()
}

/// A state file that cannot be written: its directory is a regular file.
fn unwritable(tag: &str) -> PathBuf {
    let d = tmpdir(tag);
    std::fs::write(d.join("file"), b"not a directory").unwrap();
    d.join("file").join("card.state")
}

#[test]
fn a_save_that_cannot_be_written_answers_err003_and_keeps_the_values() {
    let (h, _stop) = card(Profile::Pmac2, Some(unwritable("pmac")));
    assert_eq!(send(&h, "I3=2 I6=1 P1=4242 I130=5000 SAVE"), "\x07ERR003\r");
    assert_eq!(send(&h, "P1 I130"), "4242\r5000\r\x06");
}

#[test]
fn a_power_save_that_cannot_be_written_answers_its_error_and_keeps_the_values() {
    let (h, _stop) = card(Profile::Power, Some(unwritable("power")));
    assert_eq!(send(&h, "echo7 P1=4242"), "\x06\r\n");
    assert_eq!(
        send(&h, "save"),
        "stdin:2:1: error #21: ILLEGAL PARAMETER: save\r\n\x06\r\n"
    );
    assert_eq!(send(&h, "P1"), "4242\r\n\x06\r\n");
}

#[test]
fn a_card_with_nowhere_to_save_refuses_save() {
    let (h, _stop) = card(Profile::Pmac2, None);
    assert_eq!(send(&h, "I3=2 I6=1 P1=4242 SAVE"), "\x07ERR003\r");
    let (h, _stop) = card(Profile::Power, None);
    assert_eq!(
        send(&h, "save"),
        "stdin:1:1: error #21: ILLEGAL PARAMETER: save\r\n\x06\r\n"
    );
}

#[test]
fn what_save_acknowledges_comes_back_after_a_reset() {
    let d = tmpdir("reset");
    let (h, _stop) = card(Profile::Pmac2, Some(d.join("pmac.state")));
    assert_eq!(send(&h, "I3=2 I6=1 P1=4242 I130=5000 SAVE"), "\x06");
    assert_eq!(send(&h, "P1=1 I130=1"), "\x06");
    assert_eq!(send(&h, "$$$"), "");
    assert_eq!(send(&h, "P1 I130"), "4242\r5000\r\x06");
    // A Power card: `$$$` holds the connection's next line until the image is back.
    let (h, _stop) = card(Profile::Power, Some(d.join("power.state")));
    assert_eq!(send(&h, "echo7 P1=4242"), "\x06\r\n");
    assert_eq!(send(&h, "save"), "\x06\r\n");
    assert_eq!(send(&h, "P1=1"), "\x06\r\n");
    let _ = h.submit(super::handle::Request::Host {
        conn: 7,
        req: HostRequest::Line(b"$$$".to_vec()),
    });
    assert_eq!(send(&h, "P1"), "4242\r\n\x06\r\n");
    let _ = std::fs::remove_dir_all(&d);
}
