//! Issue 13 item 6: a Power card on the MACRO ring — a mixed lockstep ring of a Power card
//! (card0, the synchronizing master), a PMAC2 card (card1) and two stations. The Power card
//! is driven in Power syntax over its raw `gpascii` port (status `cards[0].gpascii`): its
//! `Motor[1]` runs station0's servo node 0 through the pointers the start-up layer set, its
//! `Gate3[0]` MACRO elements show the ring IC; the PMAC2 card runs its own node beside it; a
//! synchronized start on the PMAC2 card runs on the Power card's clock; and the fault drills
//! pass on this ring as on an all-PMAC2 one.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use mcc_testing::Cluster;
use mcc_tests::process::bin_dir;

/// Generous bound on a loaded machine, never what is asserted.
const WAIT: Duration = Duration::from_secs(90);

/// A raw `gpascii` connection (its own command thread).
struct Gpascii(TcpStream);

impl Gpascii {
    fn connect(port: u16) -> Gpascii {
        let s = TcpStream::connect(("127.0.0.1", port)).expect("gpascii connect");
        s.set_read_timeout(Some(WAIT)).unwrap();
        let mut g = Gpascii(s);
        let banner = g.read_until(b"ASCII Input\n");
        assert_eq!(banner, b"STDIN Open for ASCII Input\n");
        assert_eq!(g.ask("echo7"), "");
        g
    }

    fn read_until(&mut self, tail: &[u8]) -> Vec<u8> {
        let mut got = Vec::new();
        let mut b = [0u8; 1024];
        while !got.ends_with(tail) {
            let n = self.0.read(&mut b).expect("gpascii reply in time");
            assert!(
                n > 0,
                "gpascii closed; got {:?}",
                String::from_utf8_lossy(&got)
            );
            got.extend_from_slice(&b[..n]);
        }
        got
    }

    /// The reply text of `line` (value lines joined by `\n`), without the ACK.
    fn ask(&mut self, line: &str) -> String {
        self.0.write_all(format!("{line}\n").as_bytes()).unwrap();
        let r = self.read_until(b"\x06\r\n");
        let text = String::from_utf8(r).unwrap();
        let text = text.trim_end_matches("\x06\r\n").replace("\r\n", "\n");
        assert!(!text.contains("error #"), "{line}: {text}");
        text.trim_end_matches('\n').to_string()
    }

    fn num(&mut self, line: &str) -> f64 {
        let r = self.ask(line);
        r.parse()
            .unwrap_or_else(|_| panic!("{line}: not a number: {r:?}"))
    }
}

fn hex(s: &str) -> u64 {
    u64::from_str_radix(s.trim_start_matches('$'), 16).unwrap_or_else(|_| panic!("hex {s:?}"))
}

fn mixed_ring(tag: &str) -> mcc_testing::Builder {
    Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .tag(tag)
        .cards(2)
        .stations(2)
        .clock("lockstep")
        .card_profile(0, "power")
}

/// Poll `f` until it holds (bounded by [`WAIT`]).
fn until(what: &str, mut f: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !f() {
        assert!(t0.elapsed() < WAIT, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn power_sync_master_drives_its_nodes_beside_a_pmac2_card() {
    let mut c = mixed_ring("pwrmix")
        .start()
        .unwrap_or_else(|e| panic!("cluster up: {e}"));
    let st = c.status().expect("status").0;
    let card0 = &st["cards"][0];
    assert_eq!(card0["profile"], "power", "{card0:#}");
    assert_eq!(st["cards"][1]["profile"], "pmac2");
    let master = st["members"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["sync_master"] == true)
        .expect("a sync master");
    assert_eq!(master["name"], "card0", "{master:#}");
    let port = card0["gpascii"].as_u64().expect("gpascii port") as u16;
    let mut g = Gpascii::connect(port);
    // The ring IC: card0's servo nodes enabled, synchronizing master (MacroStationType 3).
    let enable = hex(&g.ask("Gate3[0].MacroEnableA"));
    assert_eq!((enable >> 8) & 0xFFFF, 0x3333, "nodes 0,1,4,5,8,9,12,13");
    let mode = hex(&g.ask("Gate3[0].MacroModeA"));
    assert_eq!((mode >> 12) & 3, 3, "synchronizing master: {mode:#x}");
    assert_eq!(g.ask("Motor[1].ServoCtrl Motor[0].ServoCtrl"), "$1\n$0");
    // Motor[1] drives station0's node 0; the feedback is the node's input register.
    g.ask("#1j=1000");
    until("Motor[1] at 1000", || (g.num("#1p") - 1000.0).abs() < 10.0);
    let fb = g.num("Gate3[0].MacroInA[0][0]");
    assert!(fb != 0.0, "node 0 feedback arrives in MacroInA");
    // The PMAC2 card runs its own first node meanwhile (daisy chain, PMAC syntax).
    c.send(&["#1J=-2000"], Some(1)).expect("card1 jog");
    until("card1 motor 1 at -2000", || {
        let r = c.send(&["#1P"], Some(1)).expect("card1 #1P");
        r[0].trim()
            .parse::<f64>()
            .is_ok_and(|p| (p + 2000.0).abs() < 10.0)
    });
    assert!((g.num("#1p") - 1000.0).abs() < 10.0, "Power motor stays");
    // A synchronized start on the PMAC2 card, on the Power card's ring clock.
    c.send(
        &["&1#1->1000X", "OPEN PROG 1 CLEAR", "DWELL 1", "CLOSE"],
        Some(1),
    )
    .expect("card1 program");
    let s = c.start_sync("&1B1R", &[1]).expect("start-sync on card1");
    assert!(
        s.cards.iter().all(|k| k.executed_cycle == Some(s.cycle)),
        "{s:?}"
    );
    c.stop();
}

/// The program every card starts in the drills, in Power syntax for the Power card (card0);
/// the PMAC2 card takes the drills' own PMAC set-up.
pub(crate) const POWER_SETUP: &[&str] = &["&1#1->1000X", "#1j/", "open prog 1", "dwell 1", "close"];

/// The fault drills of an all-PMAC2 ring on the mixed ring (issue 13 item 6): every cut,
/// dropped sync packet, kill and freeze is latched by every card the drill expects — the Power
/// sync master (card0) included — within the same cycle bounds, localised, and recovered with
/// `$$$`. (The card-side half, a Power sync master set up as the card
/// process does latching its own fault on loss of light, is the lockstep unit test
/// `a_power_sync_master_latches_its_ring_fault_on_loss_of_light`.)
#[test]
fn power_sync_master_ring_faults_are_detected_localised_and_recovered() {
    crate::drills::fault_drills_with(
        mixed_ring("pwrfault"),
        &[("power", POWER_SETUP), ("pmac2", crate::drills::SETUP)],
    );
}

/// Issue 13 item 6: the daisy chain reaches a Power card with Power syntax (`@0`): element
/// queries answered as gpascii writes them, byte for byte; a synchronized start across the
/// Power card and the PMAC2 card runs both programs in the tick of one ring cycle.
#[test]
fn the_daisy_chain_reaches_a_power_card_in_power_syntax() {
    let mut c = mixed_ring("pwrchain")
        .start()
        .unwrap_or_else(|e| panic!("cluster up: {e}"));
    let send = |c: &mut Cluster, card: &str, line: &str| -> serde_json::Value {
        let out = c.mcc(&["send", "--json", "--card", card, "--", line]);
        assert!(out.status.success(), "mcc send {line}: {out:?}");
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("send JSON");
        doc[0].clone()
    };
    let r = send(&mut c, "0", "Motor[1].ServoCtrl Gate3[0].MacroEnableA.8.16");
    assert_eq!(
        r["framed"],
        "Motor[1].ServoCtrl=$1<CR>\n<LF>Gate3[0].MacroEnableA.8.16=13107<CR>\n<LF><ACK><CR>\n<LF>",
        "{r:#}"
    );
    assert_eq!(r["error"], serde_json::Value::Null);
    // A PMAC-only line is a Power error there, named as such.
    let r = send(&mut c, "0", "OPEN PROG 1 CLEAR");
    assert_eq!(r["error"], "error #20", "{r:#}");
    // The PMAC2 card keeps PMAC syntax.
    let r = send(&mut c, "1", "I1001");
    assert_eq!(r["reply"], "16\n", "{r:#}");
    // Programs in each card's language, then one synchronized start of both.
    // One connection (a buffer its thread opened closes when the connection ends).
    c.send(POWER_SETUP, Some(0))
        .expect("card0 set-up in Power syntax");
    c.send(crate::drills::SETUP, Some(1)).expect("card1 set-up");
    std::thread::sleep(Duration::from_millis(500));
    let s = c.start_sync("&1b1r", &[0, 1]).expect("start-sync");
    assert_eq!(s.cards.len(), 2, "{s:?}");
    for k in &s.cards {
        assert_eq!(k.executed_cycle, Some(s.cycle), "{s:?}");
        assert_eq!(k.program_start_cycle, Some(s.cycle), "{s:?}");
    }
    // The Power card answered as gpascii does (an ACK line), the PMAC2 card in its framing.
    assert_eq!(s.cards[0].reply, "<ACK><CR><LF>", "{s:?}");
    assert_eq!(s.cards[1].reply, "<LF>", "{s:?}");
    c.stop();
}
