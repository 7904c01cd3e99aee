//! The save files of format 3, one per profile (`tests/golden/card-<profile>-format3.sav`):
//! every later mcc must load them. Each is written by a card that ran its profile's setup;
//! the test loads it into a fresh card and asks what the setup stored, against a card that
//! ran the same setup and never saved, and a loaded file saves back to the same bytes (the
//! schema keeps everything it holds). Regenerate with `MCC_WRITE_GOLDEN=1 cargo test -p
//! mcc-card golden` only when a new format is introduced (old files stay; a new one is added).

use super::storage::write_atomic;
use crate::domain::Profile;
use crate::lang::{Card, Dialect, EffectResult, Session};

struct Golden {
    profile: Profile,
    file: &'static str,
    setup: &'static [&'static str],
    /// Lines asked after the load, each answered as by the card that ran the setup.
    checks: &'static [&'static str],
}

const GOLDENS: &[Golden] = &[
    Golden {
        profile: Profile::Pmac2,
        file: "card-pmac2-format3.sav",
        setup: &[
            "I3=2 I6=1 I130=1500 I1001=16 P1=5 P1023=0.25 Q3=7 M3->Y:$1FF0,4,8,S M4->*",
            "M5->X:$C003,8 M6->D:$0720 M7->TWD:3,4,6.2,S",
            "OPEN PROG 3 CLEAR LINEAR INC TA200 TS50 F5000 X10 Y-2.5 CLOSE",
            "OPEN PLC 17 CLEAR P2=P2+1 IF (M3=1) P3=SIN(30) ENDIF CLOSE",
            "&1 #1->1000X #2->8660X-5000Y+10",
            "DEFINE GATHER 100",
        ],
        checks: &[
            "I130 I1001 P1 P1023 Q3",
            "M3-> M4-> M5-> M6-> M7->",
            "LIST PROG 3",
            "LIST PLC 17",
            "&1 #1-> #2->",
            "???",
        ],
    },
    Golden {
        profile: Profile::Turbo,
        file: "card-turbo-format3.sav",
        setup: &[
            "I3=2 I6=1 I130=1500 I6841=$FF P1=5 P8191=-3 Q3=7",
            "M3->Y:$0000C0,8,16,S M4->L:$000100 M5->*",
            "OPEN PROG 12 CLEAR ABS RAPID X1 DWELL 10 CLOSE",
            "OPEN PLC 31 CLEAR P2=P2+1 CLOSE",
            "&2 #3->500Y",
        ],
        checks: &[
            "I130 I6841 P1 P8191 &1 Q3",
            "M3-> M4-> M5->",
            "LIST PROG 12",
            "LIST PLC 31",
            "&2 #3->",
            "???",
        ],
    },
    Golden {
        profile: Profile::Power,
        file: "card-power-format3.sav",
        setup: &[
            "P1=5 Q3=7 Motor[1].Servo.Kp=1.5 Motor[2].JogSpeed=3",
            "open prog 12",
            "  L2 = 5   // a local",
            "Sys.P[60] = L2 * 2",
            "close",
            "open plc 4",
            "P62 = P62 + 1",
            "close",
        ],
        checks: &[
            "P1 Q3",
            "Motor[1].Servo.Kp Motor[2].JogSpeed",
            "list prog 12",
            "list plc 4",
            "buffer",
        ],
    },
];

fn path(file: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/golden")
        .join(file)
}

/// A card of `profile` with its language attached, and a way to ask it a line.
struct Asker {
    card: Card,
    dialect: Dialect,
    session: Session,
}

impl Asker {
    fn new(profile: Profile) -> Self {
        let mut card = Card::new(profile);
        let dialect = Dialect::for_card(&mut card);
        Asker {
            card,
            dialect,
            session: Session::default(),
        }
    }

    fn ask(&mut self, line: &str) -> String {
        let (r, e) = match self.dialect.script_line(&mut self.card, 1, line.as_bytes()) {
            Some(r) => (r, None),
            None => self
                .card
                .command_line_refused(&mut self.session, line.as_bytes()),
        };
        let text = String::from_utf8_lossy(&r).into_owned();
        assert!(e.is_none() && !text.contains("error #"), "{line}: {text:?}");
        text
    }
}

#[test]
fn golden_save_files_of_format_3_load_on_every_profile() {
    for g in GOLDENS {
        let mut fresh = Asker::new(g.profile);
        for l in g.setup {
            fresh.ask(l);
        }
        let file = path(g.file);
        if std::env::var_os("MCC_WRITE_GOLDEN").is_some() {
            write_atomic(&file, &fresh.card.save_image()).unwrap();
        }
        let bytes = std::fs::read(&file).expect("the golden file is committed");
        assert_eq!(&bytes[..8], b"MCCSAVE\0", "{}", g.file);
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 3);
        let mut loaded = Asker::new(g.profile);
        let r = loaded
            .card
            .apply_loaded(EffectResult::Loaded(Ok(Some(bytes.clone()))));
        assert_eq!(r, Ok(()), "{} loads", g.file);
        for l in g.checks {
            let want = fresh.ask(l);
            assert!(
                want.len() > 3,
                "{}: {l} answers something: {want:?}",
                g.file
            );
            assert_eq!(loaded.ask(l), want, "{}: {l}", g.file);
        }
        assert_eq!(
            loaded.card.save_image(),
            bytes,
            "{}: a loaded file saves back to the same bytes",
            g.file
        );
    }
}

#[test]
fn the_format_3_payload_is_the_schema_not_the_internal_types() {
    let bytes = std::fs::read(path("card-pmac2-format3.sav")).expect("committed");
    let n = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    let v: serde_json::Value = serde_json::from_slice(&bytes[20..20 + n]).unwrap();
    assert_eq!(v["mdefs"][3], "Y:$1FF0,4,8,S");
    assert_eq!(v["mdefs"][4], "*");
    assert_eq!(v["regions"][0]["space"], "Y");
    let prog = &v["programs"]["progs"][0];
    assert_eq!(prog["n"], 3);
    assert_eq!(prog["lines"][0], "LIN INC TA200 TS50 F5000 X10 Y-2.5");
    assert_eq!(v["programs"]["defines"]["gather"], 100);
}
