//! M-variable pointer definitions (seed L36823-37075) and `backup` (L33339-33404): transcripts
//! from the seed's examples, the user buffer they share with `Sys.Idata…`, programs reading
//! and writing through them, the saved image, bad input.

use super::tests_programs::T;
use crate::lang::EffectResult;

/// The seed's examples of `Mn->` queries (L36855-36866) and definitions (L36975-36980,
/// L37010-37019, L37066-37072).
#[test]
fn the_seed_s_definitions_and_queries() {
    let mut t = T::new();
    t.load(&[
        "echo0",
        "M162->Motor[1].ActPos",
        "P1=0",
        "M(P1)->u.io:$A00000.8.1",
        "M80->s.user:0",
        "M(P1+1)->d.user:$100",
        "M5000->u.io:$A10000.8.8",
        "M5187->Coord[1].InPos",
        "M70->*u",
        "M80->*s.16",
        "M8000->*f",
        "M9000->*",
    ]);
    assert_eq!(t.send("M162->"), "M162->Motor[1].ActPos\r\n");
    assert_eq!(t.send("M(P1)->"), "M0->u.io:$A00000.8.1\r\n");
    assert_eq!(t.send("M1->"), "M1->d.user:$100\r\n");
    assert_eq!(t.send("M5000->"), "M5000->u.io:$A10000.8.8\r\n");
    assert_eq!(t.send("M5187->"), "M5187->Coord[1].InPos\r\n");
    assert_eq!(
        t.send("M70-> M80-> M8000-> M9000-> M9001->"),
        "M70->*u\r\nM80->*s.16\r\nM8000->*f\r\nM9000->*\r\nM9001->*\r\n"
    );
    assert_eq!(t.send("echo7"), "");
    assert_eq!(t.send("M162->"), "Motor[1].ActPos\r\n");
    assert_eq!(t.send("M70..71->"), "*u\r\n*\r\n");
}

#[test]
fn element_definitions_read_and_write_the_element() {
    let mut t = T::new();
    t.load(&["M5->Motor[1].JogSpeed", "M6->Motor[2].JogSpeed", "M5=7"]);
    assert_eq!(t.send("Motor[1].JogSpeed"), "Motor[1].JogSpeed=7\r\n");
    assert_eq!(t.send("Motor[2].JogSpeed=12.5 M6"), "M6=12.5\r\n");
    // A status element through an M-variable reads, and refuses a write (#23).
    t.load(&["M7->Motor[1].ActPos"]);
    assert_eq!(t.send("M7"), "M7=0\r\n");
    assert!(t.send("M7=5").contains("error #23: READ ONLY"));
    // A bit range of an element.
    t.load(&["Motor[3].JogSpeed=0", "M8->Motor[3].JogSpeed.2.2", "M8=3"]);
    assert_eq!(t.send("Motor[3].JogSpeed"), "Motor[3].JogSpeed=12\r\n");
    assert_eq!(t.send("M8->"), "M8->Motor[3].JogSpeed.2.2\r\n");
    // `Sys.M[n]` is M`n`.
    assert_eq!(t.send("Sys.M[5]"), "Sys.M[5]=7\r\n");
    t.load(&["Sys.M[5]=9"]);
    assert_eq!(t.send("Motor[1].JogSpeed"), "Motor[1].JogSpeed=9\r\n");
}

#[test]
fn the_user_bank_is_the_memory_of_sys_idata_udata_fdata_ddata() {
    let mut t = T::new();
    t.load(&[
        "M80->s.user:0",
        "M81->u.user:$0.8.8",
        "M82->d.user:$100",
        "M83->f.user:$8",
        "M84->i.user:$C.0.16",
        "M80=-5",
    ]);
    assert_eq!(t.send("Sys.Idata[0]"), "Sys.Idata[0]=-5\r\n");
    assert_eq!(t.send("Sys.Udata[0]"), "Sys.Udata[0]=4294967291\r\n");
    assert_eq!(t.send("M81"), "M81=255\r\n");
    t.load(&["M81=1"]);
    assert_eq!(t.send("Sys.Udata[0]"), "Sys.Udata[0]=4294902267\r\n");
    t.load(&["Sys.Ddata[32]=2.5", "M83=0.25"]);
    assert_eq!(t.send("M82"), "M82=2.5\r\n");
    assert_eq!(t.send("Sys.Fdata[2]"), "Sys.Fdata[2]=0.25\r\n");
    // Saturating and wrapping integer formats.
    t.load(&["M80=1e12", "M84=70000"]);
    assert_eq!(t.send("M80"), "M80=2147483647\r\n");
    assert_eq!(t.send("M84"), "M84=4464\r\n");
    // Self-referenced forms keep their own format.
    t.load(&[
        "M70->*u",
        "M71->*s.16",
        "M72->*f",
        "M70=-1",
        "M71=40000",
        "M72=0.1",
    ]);
    assert_eq!(
        t.send("M70..72"),
        "M70=4294967295\r\nM71=32767\r\nM72=0.100000001490116\r\n"
    );
}

#[test]
fn bad_definitions_are_refused_and_keep_the_old_one() {
    let mut t = T::new();
    t.load(&["M1->s.user:$10"]);
    for (line, code) in [
        ("M1->s.user:2", 21),         // misaligned
        ("M1->d.user:$104", 21),      // d needs 8
        ("M1->u.user:$100000", 21),   // past the user buffer
        ("M1->u.io:$1000000", 21),    // past the io window
        ("M1->u.user:0.30.3", 21),    // bit field past bit 31
        ("M1->f.user:0.1", 21),       // a bit field of a float
        ("M1->*s.40", 21),            // width
        ("M1->Motor[99].ActPos", 21), // index out of range
        ("M1->Sys.M[2]", 21),         // a pointer at an M-variable
        ("M1->Coord[1].Ldata", 21),   // a substructure
        ("M1->Motor[1].NoSuch", 21),  // no such element
        ("M1->frob", 20),             // no such form
        ("M1->u.user:", 20),          // no offset
        ("M16384->*", 21),            // no such M-variable
        ("M16380..16390->*", 21),     // a range past the M-variables defines nothing
    ] {
        let r = t.send(line);
        assert!(r.contains(&format!("error #{code}:")), "{line}: {r}");
    }
    assert_eq!(t.send("M1->"), "M1->s.user:$10\r\n");
    assert_eq!(t.send("M16380->"), "M16380->*\r\n");
    assert!(t.send("M16384").contains("error #21:"));
    assert!(t.send("M16384->").contains("error #21:"));
}

/// Programs see the same M-variables; a synchronous assignment to a self-referenced one does
/// nothing (seed L37058-37064), to an address one it happens with the move.
#[test]
fn programs_read_and_write_through_definitions() {
    let mut t = T::new();
    t.load(&[
        "M100->*s.16",
        "M101->s.user:$40",
        "M102->Motor[1].JogSpeed",
        "open prog 5",
        "M100 = 40000",
        "M101 = M100 + 1",
        "M102 = 4",
        "P1 = Sys.Idata[16]",
        "M100 == 7",
        "M101 == 9",
        "X1",
        "dwell 10",
        "close",
    ]);
    t.ready_cs1();
    assert_eq!(t.send("&1 b5 r"), "");
    t.run(3000);
    assert_eq!(t.send("P1"), "P1=32768\r\n");
    assert_eq!(t.send("M100"), "M100=32767\r\n");
    assert_eq!(t.send("M101"), "M101=9\r\n");
    assert_eq!(t.send("Motor[1].JogSpeed"), "Motor[1].JogSpeed=4\r\n");
}

/// `save` keeps definitions and self-referenced values; a reset reloads them; a reset with
/// no saved image forgets them.
#[test]
fn definitions_survive_save_and_reset() {
    let mut t = T::new();
    t.load(&[
        "M1->u.user:$10.4.4",
        "M2->Motor[2].JogSpeed.0.1",
        "M3->*s.16",
        "M3=-12",
        "M4->*",
        "M4=0.5",
    ]);
    let image = t.card.save_image();
    let mut u = T::new();
    assert_eq!(
        u.card.apply_loaded(EffectResult::Loaded(Ok(Some(image)))),
        Ok(())
    );
    assert_eq!(
        u.send("M1..4->"),
        "M1->u.user:$10.4.4\r\nM2->Motor[2].JogSpeed.0.1\r\nM3->*s.16\r\nM4->*\r\n"
    );
    assert_eq!(u.send("M3..4"), "M3=-12\r\nM4=0.5\r\n");
    let _ = u.card.apply_loaded(EffectResult::Loaded(Ok(None)));
    assert_eq!(u.send("M1->"), "M1->*\r\n");
    assert_eq!(u.send("M3"), "M3=0\r\n");
}

/// `backup` lines are `name=value` whatever the echo mode, and sent back they restore.
#[test]
fn backup_lists_saved_elements_that_feed_back() {
    let mut t = T::new();
    t.load(&["echo7", "Motor[3].JogSpeed=33", "Motor[3].Servo.Kp=25"]);
    let b = t.send("backup Motor[3].");
    let lines: Vec<&str> = b.split("\r\n").filter(|l| !l.is_empty()).collect();
    assert!(lines.len() > 50, "{}", lines.len());
    assert!(lines
        .iter()
        .all(|l| l.starts_with("Motor[3].") && l.contains('=')));
    assert!(lines.contains(&"Motor[3].JogSpeed=33"), "{b}");
    assert!(lines.contains(&"Motor[3].Servo.Kp=25"), "{b}");
    // Status elements are not setup.
    assert!(!b.contains("Motor[3].ActPos="));
    let servo = t.send("backup Motor[3].Servo.");
    assert!(servo
        .split("\r\n")
        .filter(|l| !l.is_empty())
        .all(|l| l.starts_with("Motor[3].Servo.")));
    assert!(servo.contains("Motor[3].Servo.Kp=25\r\n"));
    // Fed back, the text restores what changed since.
    t.load(&["Motor[3].JogSpeed=1", "Motor[3].Servo.Kp=9"]);
    for l in &lines {
        assert_eq!(t.send(l), "", "{l}");
    }
    assert_eq!(t.send("echo0"), "");
    assert_eq!(t.send("Motor[3].JogSpeed"), "Motor[3].JogSpeed=33\r\n");
    assert_eq!(t.send("Motor[3].Servo.Kp"), "Motor[3].Servo.Kp=25\r\n");
    // `..`: this index and every higher one.
    let two = t.send("backup Motor[30]..");
    assert!(two.contains("Motor[30].JogSpeed=") && two.contains("Motor[31].JogSpeed="));
    assert!(!two.contains("Motor[29]."));
    // Status lists, the global ones, M-variable definitions.
    assert!(t
        .send("backup Motor[1].Status")
        .contains("Motor[1].ActPos="));
    assert!(t.send("backup Coord[0].").contains("Coord[0]."));
    let sys = t.send("backup Sys.");
    assert!(sys
        .split("\r\n")
        .filter(|l| !l.is_empty())
        .all(|l| l.starts_with("Sys.")));
    t.load(&["M10->Motor[1].JogSpeed", "M11->*u"]);
    assert_eq!(
        t.send("backup Mdefs"),
        "M10->Motor[1].JogSpeed\r\nM11->*u\r\n"
    );
    let gates = t.send("backup Gates");
    assert!(gates.contains("Gate3[0].MacroEnableA="), "{gates}");
    // Everything: within what one line may report (8,192 values).
    let all = t.send("backup");
    let n = all.matches("\r\n").count();
    assert!((5_000..=8_192).contains(&n), "{n} lines");
    for part in [
        "Sys.",
        "Motor[0].",
        "Motor[31].",
        "Coord[15].",
        "Gate3[0].",
        "M10->",
    ] {
        assert!(all.contains(part), "{part}");
    }
}

#[test]
fn backup_refuses_what_it_cannot_list() {
    let mut t = T::new();
    for line in [
        "backup Motor[32].",
        "backup Motor[x].",
        "backup Motor[1]",
        "backup Frob.",
        "backup EncTable[0].",
        "backup CompTables",
        "backup Gate3[1].Status",
    ] {
        assert!(t.send(line).contains("error #21:"), "{line}");
    }
    // `backupx` is not `backup`.
    assert!(t.send("backupx").contains("error #20:"));
}

/// Seed L40290-40325: a program sets `Ldata.CmdStatus`/`CmdCount`, issues `cmd` texts and
/// watches them run: status 0 after a good one, minus the error number after a bad one, the
/// count of texts run; each program thread has its own.
#[test]
fn ldata_cmd_status_and_count_follow_the_thread_s_cmd_texts() {
    let mut t = T::new();
    t.load(&[
        "open plc 3",
        // States in reverse order: a `cmd` text runs after the scan that issued it.
        "if (P1 == 2) {",
        "P4 = Ldata.CmdStatus P5 = Ldata.CmdCount P1 = 3",
        "}",
        "if (P1 == 1) {",
        "P2 = Ldata.CmdStatus P3 = Ldata.CmdCount",
        "Ldata.CmdStatus = 1",
        "cmd \"Motor[99].JogSpeed=1\"",
        "P1 = 2",
        "}",
        "if (P1 == 0) {",
        "Ldata.CmdStatus = 1 Ldata.CmdCount = 0",
        "cmd \"P10=5\"",
        "cmd \"P11=6\"",
        "P1 = 1",
        "}",
        "close",
        "open plc 4",
        "P6 = Ldata.CmdCount",
        "close",
        "enable plc 3",
        "enable plc 4",
    ]);
    t.run(200);
    assert_eq!(t.send("P1"), "P1=3\r\n");
    assert_eq!(t.send("P10..11"), "P10=5\r\nP11=6\r\n");
    assert_eq!(t.send("P2..5"), "P2=0\r\nP3=2\r\nP4=-21\r\nP5=3\r\n");
    assert_eq!(t.send("P6"), "P6=0\r\n", "another thread's count");
    // A host thread writes its own (and reads 0 until it does).
    assert_eq!(t.send("Ldata.CmdCount"), "Ldata.CmdCount=0\r\n");
    assert_eq!(
        t.send("Ldata.CmdCount=4 Ldata.CmdCount"),
        "Ldata.CmdCount=4\r\n"
    );
    assert!(t.send("Ldata.CmdCount=-1").contains("error #"));
}

/// Seed L40310-40316: `cmd"fmt",expr…` formats the text printf-style when it runs (here an
/// M-pointer to the bit P10 names); without arguments a `%` is the text's own.
#[test]
fn cmd_texts_take_printf_arguments() {
    let mut t = T::new();
    t.load(&[
        // A C.S. with a motor (one without reports % 0, seed L31846).
        "&1 #1->1000X",
        "P10=8",
        "open plc 5",
        "Ldata.CmdStatus = 1",
        "cmd\"M1->u.io:$A00000.%u.1\",P10",
        "cmd \"P%d=%.2f\", P10 + 3, 1/3",
        "cmd\"&1%50\"",
        "disable plc 5",
        "close",
        "enable plc 5",
    ]);
    t.run(20);
    assert_eq!(t.send("M1->"), "M1->u.io:$A00000.8.1\r\n");
    assert_eq!(t.send("P11"), "P11=0.33\r\n");
    assert_eq!(t.send("&1%"), "50\r\n");
    assert_eq!(
        t.send("list plc 5").lines().nth(1),
        Some("cmd\"M1->u.io:$A00000.%u.1\",P10")
    );
    for bad in ["cmd\"P1=%d\",1,2", "cmd\"P1=%s\",1", "cmd\"P1=%d\","] {
        assert_eq!(t.send("open plc 6"), "");
        assert!(t.send(bad).contains("error #20"), "{bad}");
    }
}
