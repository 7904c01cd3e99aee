//! Issue 25 item 1: Power's setup elements in Power's own units and with the seed's defaults
//! (the catalogue generated from seed 000), converted into the motion core's variables by the
//! seed's table (L52300-52990), saved by `save`, back at `$$$`, factory at `$$$***`.

use super::catalog::{Class, St, Ty, DEFS};
use super::tests_programs::T;
use super::tests_status::value;

/// A card that loaded `t`'s saved image.
pub(super) fn reloaded(t: &mut T) -> T {
    let image = t.card.save_image();
    let mut u = T::new();
    let loaded = u
        .card
        .apply_loaded(crate::lang::EffectResult::Loaded(Ok(Some(image))));
    assert_eq!(loaded, Ok(()));
    u
}

/// Elements whose power-on value is not the seed's default on this card, each for a reason
/// the card itself gives (docs/power-pmac.md, "Setup elements in Power's units").
const NOT_THE_SEED_DEFAULT: &[(St, &str, &str)] = &[
    // The seed's "automatically configured by the hardware" values: the model's own.
    (St::Sys, "ServoPeriod", "the cluster's servo period (I10)"),
    (St::Sys, "MaxMotors", "the card's motor count"),
];

/// Every `Motor[x]`, `Coord[x]` and `Sys` setup element the seed gives a default for reads
/// that default on a fresh card (a generated test: the list is the catalogue `generate.py`
/// builds from the seed, each entry with its seed line).
#[test]
fn a_fresh_card_reads_the_seed_default_of_every_motor_coord_and_sys_setup_element() {
    let mut t = T::new();
    let mut checked = 0;
    let mut wrong = Vec::new();
    for d in DEFS.iter() {
        let prefix = match d.st {
            St::Motor => "Motor[5].",
            St::Coord => "Coord[3].",
            St::Sys => "Sys.",
            _ => continue,
        };
        let skip = d.class == Class::Status
            || matches!(d.ty, Ty::Struct | Ty::Addr)
            || NOT_THE_SEED_DEFAULT
                .iter()
                .any(|(st, n, _)| *st == d.st && *n == d.name);
        if skip {
            continue;
        }
        // An element with indices of its own is read at index 0 of each.
        let name = format!("{prefix}{}{}", d.name, "[0]".repeat(d.dims.len()));
        let r = t.send(&name);
        if r.contains("error") {
            wrong.push(format!("{name} (L{}): {r:?}", d.line));
            continue;
        }
        let v = value(&mut t, &name);
        let tol = 1e-9 * d.default.abs().max(1.0);
        if (v - d.default).abs() > tol {
            wrong.push(format!(
                "{name} (L{}) = {v}, seed default {}",
                d.line, d.default
            ));
        }
        checked += 1;
    }
    assert!(
        wrong.is_empty(),
        "{} of {checked}:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
    assert!(checked > 200, "only {checked} elements checked");
}

/// The values the issue found in PMAC2 units now read as the seed gives them, and a written
/// float reads back as written (`Servo.Kp=2.5` was 3: an integer underneath).
#[test]
fn setup_elements_read_and_write_in_power_units() {
    let mut t = T::new();
    for (name, seed) in [
        ("Motor[1].FatalFeLimit", 2000.0),
        ("Motor[1].Servo.Kp", 4.0),
        ("Motor[1].Servo.Kvfb", 40.0),
        ("Motor[1].Servo.Kvff", 40.0),
        ("Motor[1].Servo.Ki", 0.001),
        ("Motor[1].PosSf", 1.0),
        ("Motor[1].InvAmax", 10.0),
        ("Motor[1].AbortTa", -2.0),
        ("Motor[1].InPosBand", 0.0),
        ("Motor[1].MaxDac", 28000.0),
        ("Motor[1].JogTa", 10.0),
        ("Motor[1].JogTs", -50.0),
        ("Motor[1].HomeVel", 10.0),
        ("Coord[1].Tm", -1.0),
        ("Coord[1].Ta", 100.0),
        ("Coord[1].Td", 100.0),
        ("Coord[1].TimeBaseSlew", 0.00001),
        ("Coord[1].FeedHoldSlew", 0.00001),
    ] {
        assert_eq!(value(&mut t, name), seed, "{name}");
    }
    t.load(&["Motor[1].Servo.Kp=2.5", "Motor[1].FatalFeLimit=123.25"]);
    assert_eq!(value(&mut t, "Motor[1].Servo.Kp"), 2.5);
    // The legacy number is the same element, in the same units (I130 = Motor[1].Servo.Kp).
    assert_eq!(value(&mut t, "I130"), 2.5);
    assert_eq!(value(&mut t, "I111"), 123.25);
    assert_eq!(value(&mut t, "Motor[1].FatalFeLimit"), 123.25);
    // The motion core's variables (model motor 2 is Power Motor[1]) hold the conversions.
    let m = |t: &T, n: u32| t.card.model.state.peek_ivar(n).unwrap();
    // (The model keeps 48-bit floats, as the PMAC does: equal to 1e-9 relative.)
    assert!((m(&t, 230) / (2.5 * 524_288.0 / 96.0) - 1.0).abs() < 1e-9);
    assert_eq!(m(&t, 211), 123.25 * 16.0);
    // Kvfb follows Kp: Ixx31 = Kvfb·2^26/(Ixx09·Ixx30).
    assert!((m(&t, 231) / (40.0 * 67_108_864.0 / (96.0 * m(&t, 230))) - 1.0).abs() < 1e-9);
    // The jog S-curve time follows `JogSpeed` (an alias the conversion reads): 16 units/ms over
    // JogTa 10 ms at jerk 1/50 is 80 ms (Ixx21 of model motor 2).
    t.load(&["Motor[1].JogSpeed=16"]);
    assert_eq!(m(&t, 221), 80.0);
    // A value out of the seed's range is refused and changes nothing.
    assert!(t.send("Motor[1].FatalFeLimit=-1").contains("error #22"));
    assert_eq!(value(&mut t, "Motor[1].FatalFeLimit"), 123.25);
}

/// `Motor[x].FatalFeLimit` is in motor units (counts), not Turbo's 1/16 count: a motor that
/// cannot follow (Kp 0) trips when its following error passes 50 counts, not 3.
#[test]
fn the_fatal_following_error_limit_trips_at_its_value_in_motor_units() {
    let mut t = T::new();
    t.ready_cs1();
    t.load(&[
        "Motor[1].FatalFeLimit=50",
        "Motor[1].Servo.Kp=0",
        "Motor[1].JogSpeed=1",
        "Motor[1].JogTa=-1",
        "Motor[1].JogTs=0",
        "#1j+",
    ]);
    let mut fe_at_trip = None;
    for _ in 0..400 {
        t.run(1);
        if value(&mut t, "Motor[1].FeFatal") == 1.0 {
            fe_at_trip = Some(value(&mut t, "Motor[1].DesPos") - value(&mut t, "Motor[1].ActPos"));
            break;
        }
    }
    let fe = fe_at_trip.expect("no fatal following error within 400 cycles");
    assert!((50.0..52.0).contains(&fe.abs()), "tripped at FE {fe}");
}

/// Servo gains at the seed's defaults hold a motor: a jog to a position ends inside a count,
/// and `InPosBand` (seed default 0: a following error of exactly 0) is in counts too.
#[test]
fn the_seed_default_gains_close_the_loop_on_the_plant() {
    let mut t = T::new();
    t.ready_cs1();
    assert_eq!(t.send("#1j=2000"), "");
    t.run(3000);
    let p = value(&mut t, "Motor[1].ActPos");
    let fe = value(&mut t, "Motor[1].DesPos") - p;
    assert!((p - 2000.0).abs() < 1.0, "ActPos {p}");
    assert!(fe.abs() < 1.0, "FE {fe}");
    t.load(&["Motor[1].InPosBand=1"]);
    t.run(5);
    assert_eq!(value(&mut t, "Motor[1].InPos"), 1.0);
    t.load(&[&format!("Motor[1].InPosBand={}", fe.abs() / 2.0)]);
    t.run(5);
    assert_eq!(value(&mut t, "Motor[1].InPos"), 0.0, "FE {fe}");
}

/// `save` keeps the Power values (a float gain, a held slew, a Gate3 bank B register); `$$$`
/// restores them, and the model with them; `$$$***` brings the seed's defaults back.
#[test]
fn save_keeps_power_values_and_factory_reset_restores_the_seed_defaults() {
    let mut t = T::new();
    t.load(&[
        "Motor[1].Servo.Kp=2.5",
        "Motor[1].HomeVel=7.5",
        "Coord[1].TimeBaseSlew=0.002",
        "Gate3[0].MacroEnableB=$1234",
    ]);
    let mut u = reloaded(&mut t);
    assert_eq!(value(&mut u, "Motor[1].Servo.Kp"), 2.5);
    assert_eq!(value(&mut u, "Motor[1].HomeVel"), 7.5);
    assert_eq!(value(&mut u, "Coord[1].TimeBaseSlew"), 0.002);
    assert_eq!(value(&mut u, "Gate3[0].MacroEnableB"), f64::from(0x1234));
    let m = |t: &T, n: u32| t.card.model.state.peek_ivar(n).unwrap();
    assert!((m(&u, 230) / (2.5 * 524_288.0 / 96.0) - 1.0).abs() < 1e-9);
    assert!((m(&u, 5294) / (0.002 * 8_388_608.0) - 1.0).abs() < 1e-9);
    // No image (`$$$` without a saved file): the seed's defaults, converted.
    let _ = u
        .card
        .apply_loaded(crate::lang::EffectResult::Loaded(Ok(None)));
    assert_eq!(value(&mut u, "Motor[1].Servo.Kp"), 4.0);
    assert_eq!(value(&mut u, "Motor[1].HomeVel"), 10.0);
    assert!((m(&u, 230) / (4.0 * 524_288.0 / 96.0) - 1.0).abs() < 1e-9);
    // `$$$***` on the first card: factory values.
    let _ = t.raw(b"$$$***");
    assert_eq!(value(&mut t, "Motor[1].Servo.Kp"), 4.0);
    assert_eq!(value(&mut t, "Coord[1].TimeBaseSlew"), 0.00001);
}

/// Issue 25 item 5: `Gate3[i].Chan[j]` elements (seed L10780-12303 saved setup, L22869-23153
/// non-saved, L27775-29299 status), the channel index inside the name, with the seed's
/// defaults (per channel where the seed gives one per channel), ranges, board aliases,
/// `save`.
#[test]
fn gate3_channel_elements_have_the_seed_defaults_ranges_and_names() {
    let mut t = T::new();
    assert_eq!(
        t.send("Gate3[0].Chan[1].EncCtrl"),
        "Gate3[0].Chan[1].EncCtrl=7\r\n"
    );
    assert_eq!(
        t.send("Acc24E3[2].Chan[3].OutCtrl"),
        "Acc24E3[2].Chan[3].OutCtrl=$F800001\r\n"
    );
    assert_eq!(value(&mut t, "Gate3[0].Chan[2].CaptFlagChan"), 2.0);
    assert_eq!(value(&mut t, "Gate3[0].Chan[3].EquOutMask"), 8.0);
    assert_eq!(value(&mut t, "Gate3[0].Chan[0].CaptCtrl"), 1.0);
    t.load(&[
        "Gate3[1].Chan[2].EncCtrl=3",
        "Gate3[1].Chan[0].Dac[1]=-1000",
    ]);
    assert_eq!(value(&mut t, "Gate3[1].Chan[2].EncCtrl"), 3.0);
    assert_eq!(value(&mut t, "Gate3[1].Chan[3].EncCtrl"), 7.0);
    assert_eq!(value(&mut t, "Gate3[1].Chan[0].Dac[1]"), -1000.0);
    // Out of the channel range, out of the value range, a status element.
    assert!(t.send("Gate3[0].Chan[4].EncCtrl").contains("error #21"));
    assert!(t.send("Gate3[0].Chan[0].EncCtrl=16").contains("error #22"));
    assert!(t.send("Gate3[0].Chan[0].Status=1").contains("error #23"));
    assert_eq!(value(&mut t, "Gate3[0].Chan[0].EncCtrl"), 7.0);
    // A channel element in a program expression.
    t.load(&[
        "open plc 5",
        "P70 = Gate3[1].Chan[2].EncCtrl * 10",
        "close",
        "enable plc 5",
    ]);
    t.run(3);
    assert_eq!(value(&mut t, "P70"), 30.0);
    // Saved setup: back after a load.
    let mut u = reloaded(&mut t);
    assert_eq!(value(&mut u, "Gate3[1].Chan[2].EncCtrl"), 3.0);
}

/// `Gate1[i]`, the PMAC2-style DSPGATE1 (seed L7788-9000 saved setup, L21970-22210 non-saved,
/// L26895-27490 status): multi-channel and `Chan[j]` elements with the seed's defaults, the
/// board aliases, indices 0-19, `backup`, `save`.
#[test]
fn gate1_elements_have_the_seed_defaults_aliases_and_save() {
    let mut t = T::new();
    assert_eq!(t.send("Gate1[4].PwmPeriod"), "Gate1[4].PwmPeriod=6527\r\n");
    assert_eq!(
        t.send("Acc24E2A[6].ServoClockDiv"),
        "Acc24E2A[6].ServoClockDiv=3\r\n"
    );
    assert_eq!(value(&mut t, "Gate1[4].Chan[0].EncCtrl"), 7.0);
    assert_eq!(value(&mut t, "Gate1[5].PwmDeadTime"), 15.0);
    t.load(&["Gate1[4].Chan[2].EncCtrl=3", "Acc51E[12].PwmPeriod=1000"]);
    assert_eq!(value(&mut t, "Gate1[4].Chan[2].EncCtrl"), 3.0);
    assert_eq!(value(&mut t, "Gate1[12].PwmPeriod"), 1000.0);
    assert!(t.send("Gate1[20].PwmPeriod").contains("error #21"));
    assert!(t.send("Gate1[4].Chan[4].EncCtrl").contains("error #21"));
    assert!(t.send("Gate1[4].PartNum=1").contains("error #23"));
    let b = t.send("backup Gate1[4].");
    assert!(b.contains("Gate1[4].Chan[2].EncCtrl=3\r\n"), "{b}");
    assert!(t
        .send("backup Gates")
        .contains("Gate1[12].PwmPeriod=1000\r\n"));
    let mut u = reloaded(&mut t);
    assert_eq!(value(&mut u, "Gate1[4].Chan[2].EncCtrl"), 3.0);
    assert_eq!(value(&mut u, "Gate1[12].PwmPeriod"), 1000.0);
}
