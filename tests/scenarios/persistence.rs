//! Issue 26 item 1: SAVE on the default cluster (no `state_file` on the cards) is kept in the
//! run directory (`state/<card>.state`): `$$$` brings the saved values back, on a PMAC2 card
//! (ASCII port) and on a Power card (`save` over `gpascii`), and so does `mcc down` + `mcc up`
//! of the same cluster in the same run directory (`mcc down` leaves `state/` alone).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::Duration;

use mcc_testing::Cluster;
use mcc_tests::process::bin_dir;

/// Generous bound for one reply on a loaded machine, never what is asserted.
const WAIT: Duration = Duration::from_secs(60);

/// A TCP connection read until a reply's end.
struct Conn(TcpStream);

impl Conn {
    fn open(port: u16) -> Conn {
        let s = TcpStream::connect(("127.0.0.1", port)).expect("connect");
        s.set_read_timeout(Some(WAIT)).unwrap();
        Conn(s)
    }

    /// Write `bytes`, read until the reply ends with `tail`.
    fn ask(&mut self, bytes: &str, tail: &[u8]) -> String {
        self.0.write_all(bytes.as_bytes()).unwrap();
        let mut got = Vec::new();
        let mut b = [0u8; 1024];
        while !got.ends_with(tail) {
            let n = self.0.read(&mut b).expect("reply in time");
            assert!(n > 0, "{bytes:?}: closed; got {got:?}");
            got.extend_from_slice(&b[..n]);
        }
        String::from_utf8_lossy(&got).into_owned()
    }
}

/// Card 0's ASCII port (PMAC2) and card 1's `gpascii` port (Power), from the status.
fn ports(c: &mut Cluster) -> (Conn, Conn) {
    let st = c.status().expect("status").0;
    let ascii = st["cards"][0]["ascii"].as_u64().expect("ascii port") as u16;
    let gpascii = st["cards"][1]["gpascii"].as_u64().expect("gpascii port") as u16;
    let pmac = Conn::open(ascii);
    let mut power = Conn::open(gpascii);
    power.ask("", b"ASCII Input\n");
    assert_eq!(power.ask("echo7\n", b"\x06\r\n"), "\x06\r\n");
    (pmac, power)
}

/// What each card reads back for P1 (and the PMAC2 card's I130).
fn read_back(pmac: &mut Conn, power: &mut Conn) -> (String, String) {
    (
        pmac.ask("P1 I130\r", b"\x06"),
        power.ask("P1\n", b"\x06\r\n"),
    )
}

#[test]
fn save_on_the_default_cluster_survives_reset_and_down_up() {
    let run = std::env::temp_dir().join(format!("mcc-persist-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&run);
    let mut c = Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .tag("persist")
        .cards(2)
        .stations(0)
        .card_profile(1, "power")
        .run_dir(&run)
        .start()
        .unwrap_or_else(|e| panic!("mcc up: {e}"));
    let (mut pmac, mut power) = ports(&mut c);
    assert_eq!(
        pmac.ask("I3=2 I6=1 P1=4242 I130=5000 SAVE\r", b"\x06"),
        "\x06"
    );
    assert_eq!(pmac.ask("P1=1 I130=1\r", b"\x06"), "\x06");
    assert_eq!(power.ask("P1=4242\n", b"\x06\r\n"), "\x06\r\n");
    assert_eq!(power.ask("save\n", b"\x06\r\n"), "\x06\r\n");
    assert_eq!(power.ask("P1=1\n", b"\x06\r\n"), "\x06\r\n");
    // `$$$` answers nothing; the connection's next line reads the reloaded values.
    pmac.0.write_all(b"$$$\r").unwrap();
    power.0.write_all(b"$$$\n").unwrap();
    let want = (
        "4242\r5000\r\x06".to_string(),
        "4242\r\n\x06\r\n".to_string(),
    );
    assert_eq!(read_back(&mut pmac, &mut power), want, "after $$$");
    let dir = run.join(&c.name);
    let state = |card: &str| dir.join("state").join(format!("{card}.state"));
    for card in ["card0", "card1"] {
        assert!(state(card).is_file(), "{} missing", state(card).display());
    }
    // The same cluster again, in the same run directory.
    let config = run.join("persist.toml");
    std::fs::copy(dir.join("cluster.toml"), &config).expect("keep the resolved config");
    drop((pmac, power));
    let out = c.mcc(&["down"]);
    assert!(out.status.success(), "mcc down: {out:?}");
    for card in ["card0", "card1"] {
        assert!(
            state(card).is_file(),
            "mcc down removed {}",
            state(card).display()
        );
    }
    up_again(&c, &config);
    let (mut pmac, mut power) = ports(&mut c);
    assert_eq!(read_back(&mut pmac, &mut power), want, "after down and up");
    drop((pmac, power));
    c.stop();
    let _ = std::fs::remove_dir_all(&run);
}

/// `mcc up --detach` of `config` under `c`'s cluster name and run directory.
fn up_again(c: &Cluster, config: &Path) {
    let pid = std::process::id().to_string();
    let config = config.display().to_string();
    let out = c.mcc(&[
        "up",
        "--detach",
        "--config",
        &config,
        "--timeout",
        "90",
        "--owner-pid",
        &pid,
    ]);
    assert!(out.status.success(), "mcc up again: {out:?}");
}
