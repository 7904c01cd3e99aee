use super::*;
use crate::model::Memory;

fn bits(space: XySpace, addr: u32, offset: u8, width: u8, format: MFormat) -> MDef {
    MDef::Bits {
        space,
        addr,
        offset,
        width,
        format,
    }
}

#[test]
fn canonical_forms() {
    assert_eq!(
        format_def(&bits(XySpace::X, 0xC001, 0, 24, MFormat::S), 4),
        "X:$C001,24,S"
    );
    assert_eq!(
        format_def(&bits(XySpace::Y, 0xFFC2, 8, 1, MFormat::U), 4),
        "Y:$FFC2,8"
    );
    assert_eq!(
        format_def(&bits(XySpace::Y, 0xC003, 8, 16, MFormat::S), 4),
        "Y:$C003,8,16,S"
    );
    assert_eq!(
        format_def(&bits(XySpace::Y, 0xC0A0, 8, 16, MFormat::S), 4),
        "Y:$C0A0,8,16,S"
    );
    assert_eq!(
        format_def(&bits(XySpace::X, 0x003D, 21, 1, MFormat::U), 4),
        "X:$003D,21"
    );
    assert_eq!(
        format_def(&bits(XySpace::X, 0x0818, 0, 4, MFormat::U), 4),
        "X:$0818,0,4,U"
    );
    assert_eq!(format_def(&MDef::D(0x2B), 4), "D:$002B");
    assert_eq!(format_def(&MDef::L(0x082B), 4), "L:$082B");
    assert_eq!(format_def(&MDef::Dp(0xD000), 4), "DP:$D000");
    assert_eq!(format_def(&MDef::F(0xD001), 4), "F:$D001");
    assert_eq!(format_def(&MDef::SelfRef, 4), "*");
    let twd = MDef::Twd {
        mux: 0,
        offset: 4,
        digits: 6,
        decimals: 2,
        format: MFormat::S,
    };
    assert_eq!(format_def(&twd, 4), "TWD:0,4,6.2,S");
    assert_eq!(format_def(&MDef::Tws { mux: 8 }, 4), "TWS:8");
    // Turbo prints six address digits.
    assert_eq!(format_def(&MDef::D(0x8B), 6), "D:$00008B");
    assert_eq!(
        format_def(&bits(XySpace::Y, 0x07_8420, 8, 16, MFormat::S), 6),
        "Y:$078420,8,16,S"
    );
}

#[test]
fn validation() {
    assert!(validate(&bits(XySpace::X, 0, 23, 1, MFormat::U)).is_ok());
    assert!(validate(&bits(XySpace::X, 0, 8, 16, MFormat::U)).is_ok());
    assert!(validate(&bits(XySpace::X, 0, 12, 16, MFormat::U)).is_err());
    assert!(validate(&bits(XySpace::X, 0, 2, 4, MFormat::U)).is_err());
    assert!(validate(&bits(XySpace::X, 0, 0, 7, MFormat::U)).is_err());
    assert!(validate(&bits(XySpace::X, 0, 4, 24, MFormat::U)).is_err());
    assert!(validate(&MDef::Twr { mux: 3, offset: 0 }).is_err());
    assert!(validate(&MDef::Tws { mux: 124 }).is_ok());
}

#[test]
fn bit_fields_read_write() {
    let mut m = Memory::default();
    let s16 = bits(XySpace::Y, 0x0100, 8, 16, MFormat::S);
    write(&s16, &mut m, -2.0);
    assert_eq!(m.read(Space::Y, 0x0100), 0xFFFE00);
    assert_eq!(read(&s16, &mut m), -2.0);
    let u16f = bits(XySpace::Y, 0x0100, 8, 16, MFormat::U);
    assert_eq!(read(&u16f, &mut m), 65534.0);
    let b3 = bits(XySpace::Y, 0x0100, 3, 1, MFormat::U);
    write(&b3, &mut m, 1.0);
    assert_eq!(m.read(Space::Y, 0x0100), 0xFFFE08);
    assert_eq!(read(&b3, &mut m), 1.0);
    write(&b3, &mut m, 2.0); // wraps into the field: bit cleared
    assert_eq!(read(&b3, &mut m), 0.0);
    let w24 = bits(XySpace::X, 0x0200, 0, 24, MFormat::S);
    write(&w24, &mut m, 10.0 * 2.0 / 3.0);
    assert_eq!(read(&w24, &mut m), 7.0);
    write(&w24, &mut m, -8_388_609.0);
    assert_eq!(read(&w24, &mut m), 8_388_607.0);
}

#[test]
fn bcd_fields() {
    let mut m = Memory::default();
    let d = bits(XySpace::X, 0x10, 0, 12, MFormat::D);
    write(&d, &mut m, 123.0);
    assert_eq!(m.read(Space::X, 0x10), 0x123);
    assert_eq!(read(&d, &mut m), 123.0);
    let c = bits(XySpace::X, 0x11, 4, 8, MFormat::C);
    write(&c, &mut m, 42.0);
    assert_eq!(m.read(Space::X, 0x11), 0xBD0);
    assert_eq!(read(&c, &mut m), 42.0);
}

#[test]
fn long_forms() {
    let mut m = Memory::default();
    write(&MDef::D(0x2B), &mut m, -3_072_000.0);
    assert_eq!(read(&MDef::D(0x2B), &mut m), -3_072_000.0);
    assert_eq!(m.read(Space::X, 0x2B), 0xFFFFFF);
    write(&MDef::L(0x82B), &mut m, 1.0);
    assert_eq!(m.read(Space::X, 0x82B), 0x400000);
    assert_eq!(m.read(Space::Y, 0x82B), 0x000801);
    assert_eq!(read(&MDef::L(0x82B), &mut m), 1.0);
    m.write(Space::X, 0xD000, 0xAB0000);
    write(&MDef::Dp(0xD000), &mut m, -2.0);
    assert_eq!(m.read(Space::X, 0xD000), 0xABFFFF);
    assert_eq!(m.read(Space::Y, 0xD000), 0x00FFFE);
    assert_eq!(read(&MDef::Dp(0xD000), &mut m), -2.0);
    write(&MDef::F(0xD002), &mut m, 1.5);
    assert_eq!(read(&MDef::F(0xD002), &mut m), 1.5);
    assert_eq!(read(&MDef::Tws { mux: 0 }, &mut m), 0.0);
}

#[test]
fn macro_node_through_mvar() {
    let mut m = Memory::default();
    let def = bits(XySpace::Y, 0xC0A0, 0, 24, MFormat::S);
    write(&def, &mut m, 1000.0);
    assert_eq!(m.node_command(0)[0], 1000);
    assert_eq!(read(&def, &mut m), 0.0);
    m.set_node_feedback(0, [0xFFFFFF, 0, 0, 0]);
    assert_eq!(read(&def, &mut m), -1.0);
}

#[test]
fn self_ref_wrap() {
    assert_eq!(wrap_self(5.4), 5);
    assert_eq!(wrap_self(-1.0), -1);
    assert_eq!(wrap_self(1_048_576.0), -1_048_576);
    assert_eq!(wrap_self(f64::NAN), 0);
}
