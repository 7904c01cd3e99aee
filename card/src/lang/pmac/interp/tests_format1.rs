//! The save file of format 1 (bincode of the internal types, read only): the reader stays
//! as a converter into today's in-memory image, held by its own golden file
//! (`tests/golden/card-pmac2-format1.sav`). That file was written on 2026-12-07 by the
//! writer below (the format-1 layout over the internal types of that day), the only writer
//! of format 1 left; regenerate with `MCC_WRITE_GOLDEN=1` only if the file is lost.

use super::image::InterpImage;
use super::{Card, Session};
use crate::domain::Profile;
use crate::model::persist::{fnv1a64, MAGIC};

const SETUP: &[&str] = &[
    "I130=1500 P1=5 Q3=7 M3->Y:$1FF0,4,8,S",
    "OPEN PROG 3 CLEAR LINEAR INC TA200 TS50 F5000 X10 Y-2.5 CLOSE",
    "OPEN PLC 17 CLEAR P2=P2+1 IF (M3=1) P3=SIN(30) ENDIF CLOSE",
    "&1 #1->1000X #2->8660X-5000Y+10",
    "DEFINE GATHER 100",
];

const CHECKS: &[&str] = &[
    "I130 P1 Q3 M3->",
    "LIST PROG 3",
    "LIST PLC 17",
    "&1 #1-> #2->",
    "???",
];

/// The format-1 file of `card`: bincode of the image, the interpreter's part bincode of
/// its buffers and axis definitions.
fn format1(card: &Card) -> Vec<u8> {
    let cfg = bincode::config::standard();
    let interp = InterpImage {
        bufs: card.model.bufs.clone(),
        axes: card.model.run.axes.clone(),
    };
    let blob = bincode::serde::encode_to_vec(&interp, cfg).unwrap();
    let image = card.model.state.to_image(blob);
    let payload = bincode::serde::encode_to_vec(&image, cfg).unwrap();
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&1u32.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    out.extend_from_slice(&fnv1a64(&payload).to_le_bytes());
    out
}

fn ask(c: &mut Card, s: &mut Session, line: &str) -> String {
    String::from_utf8_lossy(&c.command_line(s, line.as_bytes())).into_owned()
}

#[test]
#[allow(clippy::disallowed_methods)] // a test reading (and regenerating) its golden file
fn golden_save_file_of_format_1_converts_and_loads() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/golden/card-pmac2-format1.sav");
    let mut fresh = Card::new(Profile::Pmac2);
    let mut fs = Session::default();
    for l in SETUP {
        let r = ask(&mut fresh, &mut fs, l);
        assert!(!r.contains('\x07'), "{l}: {r:?}");
    }
    if std::env::var_os("MCC_WRITE_GOLDEN").is_some() {
        std::fs::write(&path, format1(&fresh)).unwrap();
    }
    let bytes = std::fs::read(&path).expect("the golden file is committed");
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 1);
    let mut c = Card::new(Profile::Pmac2);
    let r = c.apply_loaded(super::EffectResult::Loaded(Ok(Some(bytes))));
    assert_eq!(r, Ok(()));
    let mut s = Session::default();
    for l in CHECKS {
        let want = ask(&mut fresh, &mut fs, l);
        assert!(want.len() > 3, "{l}: {want:?}");
        assert_eq!(ask(&mut c, &mut s, l), want, "{l}");
    }
    // Saved again, it is written in today's format and loads as such.
    let again = c.save_image();
    assert_eq!(
        u32::from_le_bytes(again[8..12].try_into().unwrap()),
        crate::model::persist::VERSION
    );
    let mut d = Card::new(Profile::Pmac2);
    assert_eq!(
        d.apply_loaded(super::EffectResult::Loaded(Ok(Some(again)))),
        Ok(())
    );
    let mut ds = Session::default();
    assert_eq!(
        ask(&mut d, &mut ds, "LIST PLC 17"),
        ask(&mut fresh, &mut fs, "LIST PLC 17")
    );
}
