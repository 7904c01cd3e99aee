//! Rotary buffers of a Power card (seed L34322-34360, L37756-37780): lines entered while the
//! C.S.'s program 0 runs are executed as they arrive.

use super::tests_programs::T;

#[test]
fn rotary_lines_run_as_they_arrive() {
    let mut t = T::new();
    t.ready_cs1();
    // No buffer yet: nothing to open.
    assert!(t.send("&1 open rotary").contains("error #21:"));
    t.load(&["&1 define rotary 4096", "open rotary", "inc", "X1", "close"]);
    assert_eq!(t.send("&1 b0 r"), "");
    t.run(3000);
    let p: f64 = t.send("#1p").trim().parse().unwrap();
    assert!((p - 1000.0).abs() < 2.0, "{p}");
    // More lines while it runs (`open prog 0` is `open rotary`).
    t.load(&["open prog 0", "X2", "X-0.5", "close"]);
    t.run(6000);
    let p: f64 = t.send("#1p").trim().parse().unwrap();
    assert!((p - 2500.0).abs() < 2.0, "{p}");
    // Running: the buffer cannot be deleted or redefined.
    assert!(t.send("delete rotary").contains("error #26:"));
    assert!(t.send("define rotary 4096").contains("error #26:"));
    assert_eq!(t.send("&1 a"), "");
    t.run(10);
    assert_eq!(t.send("delete rotary"), "");
    assert!(t.send("open rotary").contains("error #21:"));
}

#[test]
fn rotary_buffer_rules() {
    let mut t = T::new();
    for (line, code) in [
        ("define rotary 1024", 21),      // below 2,048 bytes
        ("define rotary 4096,3000", 21), // look-ahead over half the buffer
        ("define rotary 4096,,512", 21), // stack offset other than 256
        ("define rotary x", 20),
        ("define rotary 4096,1,2,3", 20),
    ] {
        assert!(t.send(line).contains(&format!("error #{code}:")), "{line}");
    }
    t.load(&["define rotary 2048", "open rotary"]);
    // One buffer open at a time.
    assert!(t.send("open prog 3").contains("error #21:"));
    assert!(t.send("open forward").contains("error #21:"));
    // A line that opens a block another line would close cannot be a rotary line; it
    // closes the buffer.
    assert!(t.send("if (P1 == 0) {").contains("error #20:"));
    assert_eq!(
        t.send("P5=1"),
        "",
        "the buffer is closed: the line runs on-line"
    );
    assert_eq!(t.send("P5"), "P5=1\r\n");
    // Full: 2,048 bytes are 256 words.
    t.load(&["open rotary"]);
    let mut refused = false;
    for _ in 0..400 {
        let r = t.send("X1 Y2 Z3");
        if r.contains("error #21:") {
            refused = true;
            break;
        }
        assert_eq!(r, "");
    }
    assert!(refused, "a full rotary buffer refuses the line");
    assert_eq!(
        t.send("open prog 3"),
        "",
        "the refusal closed the rotary buffer"
    );
    assert_eq!(t.send("close"), "");
}
