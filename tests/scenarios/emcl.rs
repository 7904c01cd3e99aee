//! The EMCL bus of a running cluster (issue 12): frames over TCP and the pty byte for byte,
//! reassembly of split frames, the silence timeout and resynchronisation, RS485 silence,
//! several hosts sharing the half-duplex line (a flood, a half frame and a host that never
//! reads do not stop the others), EEPROM images across `mcc down`/`up`, a corrupt image
//! reported, a stand-alone drive process, and the drives in `mcc status`.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use mcc_station::emcl::codec::{Instr, Reply, Request, FRAME_LEN};
use mcc_testing::{Builder, Cluster};
use mcc_tests::process::{bin_dir, run_base, text, unique};
use serde_json::Value;

/// A cluster of this test binary's `mcc`, named after `tag`.
fn builder(tag: &str) -> Builder {
    Cluster::builder().mcc(bin_dir().join("mcc")).tag(tag)
}

/// Start `b`; the test fails if the cluster does not come up.
fn start(b: Builder) -> Cluster {
    b.start().unwrap_or_else(|e| panic!("cluster up: {e}"))
}

/// The status document now.
fn status(c: &mut Cluster) -> Value {
    c.status().unwrap_or_else(|e| panic!("mcc status: {e}")).0
}

type Frame = [u8; FRAME_LEN];

fn f(addr: u8, op: u8, typ: u8, motor: u8, value: i32) -> Frame {
    Request {
        addr,
        instr: Instr::new(op, typ, motor, value),
    }
    .to_bytes()
}

fn hex(s: &str) -> Frame {
    let v: Vec<u8> = s
        .split_whitespace()
        .map(|h| u8::from_str_radix(h, 16).unwrap())
        .collect();
    v.try_into().unwrap()
}

/// Read exactly one frame within `timeout` (None: silence).
fn read_frame(s: &mut impl Read, timeout: Duration) -> Option<Frame> {
    let deadline = Instant::now() + timeout;
    let mut got = Vec::new();
    let mut buf = [0u8; FRAME_LEN];
    while got.len() < FRAME_LEN && Instant::now() < deadline {
        match s.read(&mut buf[..FRAME_LEN - got.len()]) {
            Ok(0) => break,
            Ok(k) => got.extend_from_slice(&buf[..k]),
            Err(_) => std::thread::sleep(Duration::from_millis(5)),
        }
    }
    got.try_into().ok()
}

/// A generous bound for a reply: the bus answers in milliseconds, the machine may be busy.
const REPLY: Duration = Duration::from_secs(20);

fn ask(s: &mut TcpStream, frame: Frame) -> Frame {
    s.write_all(&frame).unwrap();
    read_frame(s, REPLY).unwrap_or_else(|| panic!("no reply to {frame:02X?}"))
}

fn value(s: &mut TcpStream, frame: Frame) -> (u8, i32) {
    let r = Reply::parse(&ask(s, frame)).expect("reply checksum");
    (r.status, r.value)
}

fn connect(addr: &str) -> TcpStream {
    let s = TcpStream::connect(addr).expect("connect to the EMCL bus");
    s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    s.set_nodelay(true).unwrap();
    s
}

fn bus_addr(doc: &Value) -> String {
    doc["emcl_bus"].as_str().expect("emcl_bus").to_string()
}

/// Poll GAP `ap` until `want` (ring time may run slower than wall time on a busy machine).
fn wait_ap(s: &mut TcpStream, addr: u8, ap: u8, want: i32) {
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        let (st, v) = value(s, f(addr, 6, ap, 0, 0));
        assert_eq!(st, 100);
        if v == want {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "AP {ap} stayed {v}, wanted {want}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn emcl_bus_frames_over_tcp_and_pty_byte_for_byte() {
    let mut c = start(
        builder("emcl")
            .clock("lockstep")
            .cards(1)
            .stations(1)
            .up_arg("--pty"),
    );
    let doc = status(&mut c);
    let addr = bus_addr(&doc);
    assert!(doc["emcl_bus_pty"].as_str().is_some(), "{doc:#}");
    let d0 = &doc["drives"][0];
    assert_eq!(d0["name"], "drive0");
    assert_eq!(d0["address"], 1);
    assert_eq!(d0["host"], "station0");
    assert_eq!(d0["mode"], "direct");
    assert_eq!(d0["program"], "stop");
    assert!(
        d0["eeprom"].as_str().unwrap().starts_with("factory"),
        "{d0:#}"
    );
    let mut s = connect(&addr);
    // Spec §15 vectors through the whole path.
    assert_eq!(
        ask(&mut s, hex("01 88 00 00 00 00 00 00 89")),
        hex("02 31 33 36 30 56 31 33 31")
    );
    assert_eq!(
        ask(&mut s, hex("01 88 01 00 00 00 00 00 8A")),
        hex("02 01 64 88 05 50 01 31 76")
    );
    assert_eq!(
        ask(&mut s, hex("01 0A 42 00 00 00 00 00 4D")),
        hex("02 01 64 0A 00 00 00 01 72")
    );
    assert_eq!(
        ask(&mut s, hex("01 01 00 00 00 00 27 10 39")),
        hex("02 01 64 01 00 00 27 10 9F")
    );
    assert_eq!(
        ask(&mut s, hex("01 01 00 00 00 00 27 10 38")),
        hex("02 01 01 01 00 00 00 00 05")
    );
    assert_eq!(
        ask(&mut s, f(1, 99, 0, 0, 0)),
        hex("02 01 02 63 00 00 00 00 68")
    );
    assert_eq!(
        ask(&mut s, f(1, 22, 0, 0, 20)),
        hex("02 01 06 16 00 00 00 00 1F")
    );
    assert_eq!(ask(&mut s, hex("01 03 00 00 00 00 00 00 04"))[2], 100);
    wait_ap(&mut s, 1, 3, 0);
    // A positioning move in ring time lands exactly on its target.
    assert_eq!(value(&mut s, f(1, 4, 0, 0, -5000)), (100, -5000));
    wait_ap(&mut s, 1, 8, 1);
    assert_eq!(value(&mut s, f(1, 6, 1, 0, 0)), (100, -5000));
    // RS485 silence for an address nobody has, and for a bad checksum elsewhere.
    s.write_all(&f(9, 6, 1, 0, 0)).unwrap();
    assert_eq!(read_frame(&mut s, Duration::from_millis(1500)), None);
    s.write_all(&[9, 6, 1, 0, 0, 0, 0, 0, 0]).unwrap();
    assert_eq!(read_frame(&mut s, Duration::from_millis(1500)), None);
    // A frame split byte by byte over TCP segments is reassembled.
    for b in f(1, 10, 66, 0, 0) {
        s.write_all(&[b]).unwrap();
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(
        read_frame(&mut s, REPLY),
        Some(hex("02 01 64 0A 00 00 00 01 72"))
    );
    // Half a frame, then a silence longer than the 500 ms timeout: discarded.
    s.write_all(&f(1, 6, 1, 0, 0)[..4]).unwrap();
    std::thread::sleep(Duration::from_millis(900));
    assert_eq!(value(&mut s, f(1, 10, 66, 0, 0)), (100, 1));
    // Garbage right before a frame misaligns it (the cut is every 9 bytes); the host hears
    // nothing, waits, and after the silence its retry is answered.
    s.write_all(&[0xEE, 0xEE, 0xEE]).unwrap();
    s.write_all(&f(1, 10, 66, 0, 0)).unwrap();
    assert_eq!(read_frame(&mut s, Duration::from_millis(1500)), None);
    assert_eq!(value(&mut s, f(1, 10, 66, 0, 0)), (100, 1));

    // The pty serves the same bus.
    let pty = doc["emcl_bus_pty"].as_str().unwrap();
    let mut p = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(pty)
        .expect("open the pty");
    p.write_all(&hex("01 88 01 00 00 00 00 00 8A")).unwrap();
    assert_eq!(
        read_frame(&mut p, REPLY),
        Some(hex("02 01 64 88 05 50 01 31 76"))
    );
    // Bytes that a cooked tty would eat (^C, ^Q, ^S, CR) pass: SGP 66,0,3 then back to 1.
    p.write_all(&hex("01 09 42 00 00 00 00 03 4F")).unwrap();
    let r = read_frame(&mut p, REPLY).unwrap();
    assert_eq!(
        (r[1], r[2]),
        (3, 100),
        "the reply already comes from address 3"
    );
    p.write_all(&f(3, 9, 66, 0, 1)).unwrap();
    assert_eq!(read_frame(&mut p, REPLY).map(|r| r[2]), Some(100));

    // `mcc emcl send` and the status table.
    let out = c.mcc(&["emcl", "send", "1", "6", "1", "0", "0"]);
    assert!(
        text(&out.stdout).contains("status 100 instruction 6"),
        "{}",
        text(&out.stdout)
    );
    let table = text(&c.mcc(&["status"]).stdout);
    assert!(table.contains("emcl bus 127.0.0.1:"), "{table}");
    assert!(
        table
            .lines()
            .any(|l| l.starts_with("drive0") && l.contains("station0")),
        "{table}"
    );
}

#[test]
fn hosts_share_the_line_a_flood_a_half_frame_and_a_deaf_host_stop_nobody() {
    let mut c = start(builder("emclshare").clock("lockstep").cards(1).stations(1));
    let addr = bus_addr(&status(&mut c));
    // A: floods 3000 frames and never reads its replies.
    let mut a = connect(&addr);
    let flood: Vec<u8> = (0..3000).flat_map(|_| f(1, 6, 1, 0, 0)).collect();
    let writer = std::thread::spawn(move || {
        let _ = a.set_write_timeout(Some(Duration::from_secs(30)));
        let _ = a.write_all(&flood);
        a
    });
    // B: half a frame, then nothing.
    let mut b = connect(&addr);
    b.write_all(&f(1, 6, 1, 0, 0)[..5]).unwrap();
    // C: ordinary round trips keep being served, in order, correctly.
    let mut cc = connect(&addr);
    for k in 0..40 {
        assert_eq!(value(&mut cc, f(1, 9, (k % 50) as u8, 2, k)), (100, k));
        assert_eq!(value(&mut cc, f(1, 10, (k % 50) as u8, 2, 0)), (100, k));
    }
    let a = writer.join().unwrap();
    drop(a);
    drop(b);
    // Still serving after the deaf host left.
    let mut d = connect(&addr);
    assert_eq!(value(&mut d, f(1, 10, 66, 0, 0)), (100, 1));
    let doc = status(&mut c);
    assert!(
        doc["drives"][0]["frames"].as_u64().unwrap() >= 81,
        "{doc:#}"
    );
}

const CONFIG: &str = r#"
clock = "lockstep"
[[cards]]
name = "card0"
number = 0
master = 0
[[stations]]
name = "station0"
master = 0
[[drives]]
name = "drive0"
address = 1
station = "station0"
[[drives]]
name = "solo"
address = 2
[drives.io]
inputs = [1, 0, 1]
analog = 1234
"#;

#[test]
fn eeprom_images_survive_down_and_up_and_a_corrupt_one_is_reported() {
    // Each `up` is a new cluster in a new run directory; the drives' images are where the
    // config says, so they outlive the clusters like a real drive's EEPROM.
    let dir = run_base().join("cfg").join(unique("emclpersist"));
    std::fs::create_dir_all(&dir).unwrap();
    let config = CONFIG
        .replace(
            "name = \"drive0\"\n",
            &format!(
                "name = \"drive0\"\nstate_file = {:?}\n",
                dir.join("drive0.eeprom")
            ),
        )
        .replace(
            "name = \"solo\"\n",
            &format!(
                "name = \"solo\"\nstate_file = {:?}\n",
                dir.join("solo.eeprom")
            ),
        );
    let up = || start(builder("emclpersist").config_toml(config.clone()));
    let mut c = up();
    let doc = status(&mut c);
    let addr = bus_addr(&doc);
    assert_eq!(doc["drives"][1]["name"], "solo");
    assert_eq!(doc["drives"][1]["host"], "solo");
    let members: Vec<&str> = doc["members"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        members,
        ["card0", "station0"],
        "the drive is not a ring member"
    );
    let mut s = connect(&addr);
    // Stand-alone drive: its own inputs.
    assert_eq!(value(&mut s, f(2, 15, 0, 0, 0)), (100, 1));
    assert_eq!(value(&mut s, f(2, 15, 0, 1, 0)), (100, 1234));
    // A bus collision: solo (secondary address 9) takes address 1 as well. Both answer a
    // frame to 1; the line carries the wired-AND, which is no valid reply.
    assert_eq!(value(&mut s, f(2, 9, 87, 0, 9)).0, 100);
    assert_eq!(ask(&mut s, f(2, 9, 66, 0, 1))[1], 1);
    let r = ask(&mut s, f(1, 15, 0, 1, 0));
    assert!(Reply::parse(&r).is_none(), "collision: {r:02X?}");
    assert_eq!(value(&mut s, f(9, 9, 66, 0, 2)).0, 100);
    assert_eq!(value(&mut s, f(2, 9, 87, 0, 0)).0, 100);
    assert_eq!(
        value(&mut s, f(1, 15, 0, 1, 0)),
        (100, 0),
        "drive0 alone again"
    );
    // Store settings on both drives; download a program into drive0.
    assert_eq!(value(&mut s, f(1, 5, 4, 0, 77777)).0, 100);
    assert_eq!(value(&mut s, f(1, 7, 4, 0, 0)).0, 100);
    assert_eq!(value(&mut s, f(1, 9, 10, 2, -5)).0, 100);
    assert_eq!(value(&mut s, f(1, 11, 10, 2, 0)).0, 100);
    assert_eq!(value(&mut s, f(1, 30, 4, 0, 4444)).0, 100);
    assert_eq!(value(&mut s, f(1, 30, 4, 255, 0)).0, 100);
    assert_eq!(value(&mut s, f(2, 9, 75, 0, 3)).0, 100);
    assert_eq!(value(&mut s, f(1, 132, 0, 0, 0)).0, 100);
    for (k, i) in [f(1, 19, 9, 0, 5), f(1, 35, 11, 2, 0), f(1, 28, 0, 0, 0)]
        .iter()
        .enumerate()
    {
        let r = Reply::parse(&ask(&mut s, *i)).unwrap();
        assert_eq!(r.status, 101, "slot {k}");
    }
    assert_eq!(value(&mut s, f(1, 133, 0, 0, 0)).0, 100);
    // Locked: the stored data cannot change, and says so.
    assert_eq!(value(&mut s, f(1, 9, 73, 0, 1234)).0, 100);
    let file = PathBuf::from(doc["drives"][0]["state_file"].as_str().unwrap());
    let before = std::fs::read(&file).unwrap();
    assert_eq!(value(&mut s, f(1, 5, 4, 0, 1)).0, 100);
    assert_eq!(value(&mut s, f(1, 7, 4, 0, 0)), (5, 0));
    assert_eq!(value(&mut s, f(1, 9, 66, 0, 7)), (5, 0));
    assert_eq!(
        std::fs::read(&file).unwrap(),
        before,
        "the image did not change"
    );
    drop(s);
    drop(c);

    let mut c = up();
    let doc = status(&mut c);
    assert_eq!(doc["drives"][0]["eeprom"], "loaded", "{doc:#}");
    assert_eq!(doc["drives"][0]["program_size"], 3);
    let mut s = connect(&bus_addr(&doc));
    assert_eq!(value(&mut s, f(1, 6, 4, 0, 0)), (100, 77777));
    assert_eq!(value(&mut s, f(1, 10, 10, 2, 0)), (100, -5));
    assert_eq!(
        value(&mut s, f(1, 31, 4, 0, 0)),
        (100, 0),
        "coordinates load only with GP 84"
    );
    assert_eq!(value(&mut s, f(1, 31, 4, 255, 0)), (100, 4444));
    assert_eq!(value(&mut s, f(1, 10, 73, 0, 0)), (100, 1), "still locked");
    assert_eq!(value(&mut s, f(2, 10, 75, 0, 0)), (100, 3));
    // The program runs: accu 5 into user variable 11.
    assert_eq!(value(&mut s, f(1, 129, 1, 0, 0)).0, 100);
    let deadline = Instant::now() + Duration::from_secs(60);
    while value(&mut s, f(1, 10, 11, 2, 0)).1 != 5 {
        assert!(
            Instant::now() < deadline,
            "the downloaded program did not run"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    drop(s);
    drop(c);

    // Corrupt drive0's image: reported, factory defaults, the bad file kept.
    std::fs::write(&file, b"EMCLEEP\0 not really").unwrap();
    let mut c = up();
    let doc = status(&mut c);
    let e = doc["drives"][0]["eeprom"].as_str().unwrap();
    assert!(e.starts_with("CORRUPT"), "{e}");
    let mut s = connect(&bus_addr(&doc));
    assert_eq!(value(&mut s, f(1, 6, 4, 0, 0)), (100, 51200));
    let mut kept = file.as_os_str().to_owned();
    kept.push(".corrupt");
    assert!(PathBuf::from(kept).exists());
    let logs = c.logs(100_000);
    let log = &logs
        .iter()
        .find(|(who, _)| who == "station0")
        .expect("station0 log")
        .1;
    assert!(log.contains("is corrupt"), "{log}");
    let table = text(&c.mcc(&["status"]).stdout);
    assert!(table.contains("CORRUPT"), "{table}");
}

#[test]
fn bad_drive_configs_are_refused_before_anything_starts() {
    for (body, want) in [
        (
            format!("{CONFIG}[[drives]]\nname = \"x\"\naddress = 2\n"),
            "address 2 is already used by \"solo\"",
        ),
        (
            format!("{CONFIG}[[drives]]\nname = \"x\"\naddress = 3\naxis = {{ \"3\" = 1 }}\n"),
            "axis parameter 3 is read-only",
        ),
        (
            format!("{CONFIG}[[drives]]\nname = \"x\"\naddress = 3\naxis = {{ \"6\" = 300 }}\n"),
            "axis parameter 6: 300 is out of range",
        ),
    ] {
        match builder("emclbad").config_toml(body).start() {
            Ok(_) => panic!("a config with {want:?} was accepted"),
            Err(e) => {
                assert_eq!(e.kind, mcc_testing::ErrorKind::Config, "{e}");
                assert!(e.to_string().contains(want), "{e}");
            }
        }
    }
}

#[test]
fn a_card_motor_moves_a_bound_drive_across_processes() {
    let body = r#"
clock = "lockstep"
[[cards]]
name = "card0"
number = 0
master = 0
ivars = { I1001 = 16, I1004 = 2, I1005 = 4, I202 = 49318, I230 = 20000, I231 = 0, I232 = 2800 }
[[stations]]
name = "station0"
master = 0
[[drives]]
name = "drive0"
address = 1
station = "station0"
node = 1
"#;
    let mut c = start(builder("emclbound").config_toml(body));
    let doc = status(&mut c);
    assert_eq!(doc["drives"][0]["mode"], "bound", "{doc:#}");
    assert_eq!(doc["drives"][0]["node"], 1);
    let mut s = connect(&bus_addr(&doc));
    assert_eq!(
        value(&mut s, f(1, 1, 0, 0, 1000)),
        (6, 0),
        "direct motion refused"
    );
    assert_eq!(value(&mut s, f(1, 6, 254, 0, 0)), (100, 1));
    // I202 = $C0A6: motor 2 commands node 1 register 2 (pulse frequency).
    let out = c.mcc(&["send", "@0#2$", "@0#2J=20000"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        let p = value(&mut s, f(1, 6, 209, 0, 0)).1;
        if (p - 20000).abs() <= 2 && value(&mut s, f(1, 6, 3, 0, 0)).1 == 0 {
            break;
        }
        assert!(Instant::now() < deadline, "the drive stayed at {p}");
        std::thread::sleep(Duration::from_millis(100));
    }
    let p = text(&c.mcc(&["send", "@0#2P"]).stdout);
    let p: f64 = p.trim().parse().unwrap_or_else(|_| panic!("#2P: {p:?}"));
    assert!((p - 20000.0).abs() <= 2.0, "card position {p}");
    let doc = status(&mut c);
    assert_eq!(doc["drives"][0]["motion"], "bound");
}
