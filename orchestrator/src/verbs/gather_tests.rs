//! Unit tests of `mcc gather`'s set-up, decoding, CSV and plot.

use super::*;

fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&b[12..16], b"IHDR");
    let w = u32::from_be_bytes([b[16], b[17], b[18], b[19]]);
    let h = u32::from_be_bytes([b[20], b[21], b[22], b[23]]);
    (w, h)
}

#[test]
fn motors_parse_and_bad_ones_are_named() {
    assert_eq!(parse_motors("1, 3").unwrap(), vec![1, 3]);
    assert!(parse_motors("9").unwrap_err().contains("1-8"));
    assert!(parse_motors("0").unwrap_err().contains("1-8"));
    assert!(parse_motors("x").unwrap_err().contains("\"x\""));
    assert!(parse_motors("2,2").unwrap_err().contains("twice"));
    assert!(parse_motors(" ,").is_err());
}

#[test]
fn sources_are_the_position_registers_of_the_motors() {
    // Motor 1: D:$0028 / D:$002B; motor 2 one calculation block ($3C) further.
    assert_eq!(
        setup_line(&[1, 2], 3),
        "I19=3 I20=$F I21=$800028 I22=$80002B I23=$800064 I24=$800067"
    );
    assert_eq!(setup_line(&[8], 1), "I19=1 I20=$3 I21=$8001CC I22=$8001CF");
}

#[test]
fn words_decode_to_counts() {
    let reply = b"\n000000000C00 FFFFFFFFF400 000000003000\r\n00000000F000 000000006000\r\x06";
    let w = parse_words(reply).unwrap();
    assert_eq!(w, [0xC00, 0xFFFF_FFFF_F400, 0x3000, 0xF000, 0x6000]);
    // Ix08 = 96: 3072 / 3072 = 1 count; negative words are two's complement.
    let s = decode(&w, &[96.0]);
    // The fifth word is a partial sample: dropped.
    assert_eq!(s, vec![vec![(1.0, -1.0)], vec![(4.0, 20.0)]]);
    assert!(parse_words(b"12AB\r").unwrap_err().contains("12AB"));
    assert!(parse_words(b"00000000000G\r").is_err());
    assert_eq!(decode(&[1, 2, 3], &[]), Vec::<Vec<(f64, f64)>>::new());
}

fn ramp() -> Recording {
    Recording {
        motors: vec![1, 2],
        period: 2,
        cycle_ms: 0.5,
        samples: (0..50)
            .map(|k| {
                vec![
                    (k as f64 * 10.0, k as f64 * 9.5),
                    (-(k as f64), -(k as f64) + 0.5),
                ]
            })
            .collect(),
    }
}

#[test]
fn csv_has_cycle_time_and_a_column_pair_per_motor() {
    let csv = ramp().csv();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 51);
    assert_eq!(
        lines[0],
        "cycle,time_ms,m1_commanded,m1_actual,m2_commanded,m2_actual"
    );
    assert_eq!(lines[1], "0,0.0000,0.0000,0.0000,-0.0000,0.5000");
    assert_eq!(lines[3], "4,2.0000,20.0000,19.0000,-2.0000,-1.5000");
}

#[test]
fn plots_are_pngs_with_and_without_text() {
    let dir = std::env::temp_dir().join(format!("mcc-gather-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bare = dir.join("bare.png");
    plot::draw_with(&ramp(), &bare, "test", false).unwrap();
    assert_eq!(png_size(&bare), (1000, 600));
    let full = dir.join("full.png");
    let labelled = plot::draw(&ramp(), &full, "test").unwrap();
    assert_eq!(png_size(&full), (1000, 600));
    eprintln!("labelled: {labelled}");
    // A flat or empty recording still draws.
    let mut flat = ramp();
    flat.samples.truncate(1);
    plot::draw_with(&flat, &dir.join("flat.png"), "flat", false).unwrap();
    if std::env::var_os("MCC_KEEP_PLOT").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}
