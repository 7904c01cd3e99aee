//! Power's setup elements in Power's own units (issue 25 item 1), and the motion core's
//! I-variables (Turbo numbering, Turbo units) they become.
//!
//! The seed's conversion table, "Turbo PMAC 'I' variables and the equivalent Power PMAC
//! elements" (seed 000 L52300-52990) with its "servo gain equations" (L52945-52975), is the
//! rule. An element it converts ("FatalFeLimit = Ixx11/16", "InvAmax = 1/Ixx17", the gains …)
//! is *held* by the dialect: its value is the Power one a host reads and writes (seed default,
//! float where the seed says so, saved by `save`), and after every write the motor's (or
//! C.S.'s) model I-variables are computed again from the held values ([`motor_model`],
//! [`coord_model`]). An element of "the same value" (동일한 값으로 호환 운용) stays an alias of
//! its model I-variable; its Power default is written there at power-on and `$$$***`.
//!
//! [DECISION] Motor units are feedback counts: `Motor[x].PosSf`/`Pos2Sf` (default 1.0, the
//! seed's recommendation for a Turbo conversion, L52976) are held and enter the gain equations
//! as the seed writes them, but positions, speeds and limits are reported and taken in counts
//! whatever they hold.
//!
//! Pure: the functions take the element values and return model values.

use super::catalog::St;

/// `Motor[x]` elements the dialect holds in Power units (the seed converts them).
pub(crate) const MOTOR_HELD: &[&str] = &[
    "PosSf",
    "Pos2Sf",
    "MasterPosSf",
    "FatalFeLimit",
    "WarnFeLimit",
    "AbortTa",
    "InvAmax",
    "InvJmax",
    "JogTa",
    "JogTs",
    "HomeOffset",
    "InPosBand",
    "Servo.Kp",
    "Servo.Kvfb",
    "Servo.Kvff",
    "Servo.Ki",
    "Servo.Kaff",
    "Servo.MaxInt",
    "Servo.Kbreak",
    "Servo.BreakPosErr",
    "Servo.MaxPosErr",
    "BlSize",
    "BlHysteresis",
    "IiGain",
    "IpfGain",
    "AdvGain",
    "I2tTrip",
    "AdcMask",
    "CaptureMode",
    "PhasePosSf",
    "PhaseOffset",
];

/// `Coord[x]` elements the dialect holds in Power units.
pub(crate) const COORD_HELD: &[&str] = &["TimeBaseSlew", "FeedHoldSlew", "MinArcLen"];

/// Whether element `name` of structure `st` is held in Power units by the dialect.
pub(crate) fn held(st: St, name: &str) -> bool {
    match st {
        St::Motor => MOTOR_HELD.contains(&name),
        St::Coord => COORD_HELD.contains(&name),
        _ => false,
    }
}

/// Whether a write of element `name` of `st` changes the model I-variables computed from the
/// held elements: a held element, or an alias they are computed from (`JogSpeed`, `MaxSpeed`).
pub(crate) fn affects_model(st: St, name: &str) -> bool {
    held(st, name) || (st == St::Motor && matches!(name, "JogSpeed" | "MaxSpeed"))
}

/// 2^19, 2^23, 2^26 of the gain equations.
const P19: f64 = 524_288.0;
const P23: f64 = 8_388_608.0;
const P26: f64 = 67_108_864.0;

/// What a motor's model I-variables are computed from besides the held elements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MotorCtx {
    /// Model Ixx08 (position scale of the model's filter, 96).
    pub i08: f64,
    /// Model Ixx09 (velocity scale, 96).
    pub i09: f64,
    /// `Motor[x].JogSpeed` (an alias of Ixx22), motor units/ms.
    pub jog_speed: f64,
    /// `Motor[x].MaxSpeed` (an alias of Ixx16), motor units/ms.
    pub max_speed: f64,
    /// `Sys.ServoPeriod`, ms.
    pub servo_ms: f64,
}

/// `a / b`, 0 when `b` is 0 (a gain that cannot be expressed is off, not infinite).
fn ratio(a: f64, b: f64) -> f64 {
    if b == 0.0 || !b.is_finite() {
        0.0
    } else {
        a / b
    }
}

/// The model I-variables (number within the motor's block, value) of a motor whose held
/// elements read `get(name)`.
pub(crate) fn motor_model(get: impl Fn(&str) -> f64, c: &MotorCtx) -> Vec<(u32, f64)> {
    let pos_sf = get("PosSf");
    let pos2_sf = get("Pos2Sf");
    // Servo gain equations (L52945-52975), solved for the Turbo variables.
    let kp = get("Servo.Kp") * P19 * pos_sf / c.i08;
    let per_kp = |v: f64, sf: f64, i0x: f64| ratio(v * P26 * sf, i0x * kp);
    let mut out = vec![
        (7, get("MasterPosSf") * c.i08),
        (11, 16.0 * get("FatalFeLimit")),
        (12, 16.0 * get("WarnFeLimit")),
        (15, abort_rate(get("AbortTa"), c)),
        (17, ratio(1.0, get("InvAmax"))),
        (26, 16.0 * get("HomeOffset")),
        (28, 16.0 * get("InPosBand")),
        (30, kp),
        (31, per_kp(get("Servo.Kvfb"), pos2_sf, c.i09)),
        (32, per_kp(get("Servo.Kvff"), pos_sf, c.i08)),
        (33, get("Servo.Ki") * P23),
        (35, per_kp(get("Servo.Kaff"), pos_sf, c.i08)),
        (56, ratio(get("AdvGain"), c.i09 * 32.0)),
        (58, ratio(get("I2tTrip") * 1000.0, 230.0 * c.servo_ms)),
        (61, get("IiGain") / 8.0),
        (62, get("IpfGain") / 4.0),
        (63, ratio(get("Servo.MaxInt") * P23, c.i08 * kp)),
        (64, 16.0 * get("Servo.Kbreak") - 16.0),
        (65, 16.0 * get("Servo.BreakPosErr")),
        (67, 16.0 * get("Servo.MaxPosErr")),
        (84, (get("AdcMask") / 256.0).trunc()),
        (86, 16.0 * get("BlSize")),
        (87, 16.0 * get("BlHysteresis")),
        // CaptureMode 0 hardware capture, 1 software capture, 2 following-error trigger, 3
        // timer-assisted software capture (L13922-13947); Turbo Ixx97 bit 0 software capture,
        // bit 1 FE trigger (L52890: Ixx97 = 3 is CaptureMode 2).
        (
            97,
            [0.0, 1.0, 3.0, 1.0][(get("CaptureMode").clamp(0.0, 3.0)) as usize],
        ),
        // `PhasePosSf = 256/(Ixx71/Ixx70)` (L52822): Ixx70 = 1 pole pair per Ixx71 counts;
        // `PhaseOffset` the same angle in Turbo's 0..2047 (Power's is signed, -1024..1023).
        (70, 1.0),
        (71, ratio(256.0, get("PhasePosSf")).round()),
        (72, get("PhaseOffset").rem_euclid(2048.0)),
    ];
    out.extend(jog_ramp(get("JogTa"), get("JogTs"), c.jog_speed));
    out
}

/// Model Ixx15 (abort deceleration, counts/ms²) for `Motor[x].AbortTa`: negative, the inverse
/// of the rate (L52445: `AbortTa = -1/Ixx15`); positive, a time [DECISION] over which the
/// motor's `MaxSpeed` (its `JogSpeed` when 0) would stop; 0, the fastest the model allows.
fn abort_rate(ta: f64, c: &MotorCtx) -> f64 {
    if ta < 0.0 {
        -1.0 / ta
    } else if ta > 0.0 {
        let v = if c.max_speed > 0.0 {
            c.max_speed
        } else {
            c.jog_speed
        };
        v.abs() / ta
    } else {
        f64::INFINITY
    }
}

/// Model Ixx19 (jog acceleration limit, 0 = none), Ixx20 (acceleration time) and Ixx21
/// (S-curve time) for `JogTa`/`JogTs` (seed L15262-15330). Power's rules: a positive `JogTa`
/// is a time, a negative one the inverse of the acceleration; a positive `JogTs` an S-curve
/// time, a negative one the inverse of the jerk; with `JogTa` ≥ `JogTs` the acceleration takes
/// `JogTa + JogTs` (Turbo: `max(Ixx20, 2·Ixx21)`), otherwise `2·JogTs`. [DECISION] A jerk
/// limit becomes the S-curve time that reaches the ramp's acceleration at that jerk (the
/// acceleration of a full-speed start when `JogTa` is a time; `√(JogSpeed·|JogTs|)` for a
/// pure S-curve).
fn jog_ramp(ta: f64, ts: f64, jog_speed: f64) -> [(u32, f64); 3] {
    let (amax, t_acc, accel) = if ta < 0.0 {
        (-1.0 / ta, 0.0, -1.0 / ta)
    } else {
        (0.0, ta, ratio(jog_speed.abs(), ta))
    };
    let s = if ts >= 0.0 {
        ts
    } else if accel > 0.0 {
        accel * -ts
    } else {
        (jog_speed.abs() * -ts).sqrt()
    };
    let t20 = if t_acc > s { t_acc + s } else { t_acc };
    [(19, amax), (20, t20), (21, s)]
}

/// The model I-variables (number within the C.S. block, value) of a C.S. whose held elements
/// read `get(name)`: `TimeBaseSlew = Isx94/2^23`, `FeedHoldSlew = Isx95/2^23`, `MinArcLen =
/// π·Isx97` (L52985-52990).
pub(crate) fn coord_model(get: impl Fn(&str) -> f64) -> Vec<(u32, f64)> {
    vec![
        (94, get("TimeBaseSlew") * P23),
        (95, get("FeedHoldSlew") * P23),
        (97, get("MinArcLen") / std::f64::consts::PI),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lang::power::catalog::{find, DEFS};

    fn default_of(st: St, name: &str) -> f64 {
        DEFS[find(st, name).unwrap_or_else(|| panic!("{name}"))].default
    }

    const CTX: MotorCtx = MotorCtx {
        i08: 96.0,
        i09: 96.0,
        jog_speed: 32.0,
        max_speed: 32.0,
        servo_ms: 0.442_742_11,
    };

    fn model_of(over: &[(&str, f64)]) -> std::collections::HashMap<u32, f64> {
        let get = |n: &str| {
            over.iter()
                .find(|(k, _)| *k == n)
                .map_or_else(|| default_of(St::Motor, n), |(_, v)| *v)
        };
        motor_model(get, &CTX).into_iter().collect()
    }

    #[test]
    fn every_held_element_is_in_the_catalogue_with_a_legacy_number_or_none() {
        for n in MOTOR_HELD {
            assert!(find(St::Motor, n).is_some(), "{n}");
        }
        for n in COORD_HELD {
            assert!(find(St::Coord, n).is_some(), "{n}");
        }
    }

    /// The seed's own conversions, checked on its defaults (L52340-52975).
    #[test]
    fn seed_defaults_give_the_turbo_equivalents_of_the_table() {
        let m = model_of(&[]);
        // FatalFeLimit 2000 = Ixx11/16; WarnFeLimit 1000 = Ixx12/16.
        assert_eq!((m[&11], m[&12]), (32_000.0, 16_000.0));
        // AbortTa -2 = -1/Ixx15; InvAmax 10 = 1/Ixx17.
        assert_eq!((m[&15], m[&17]), (0.5, 0.1));
        // Kp 4 = Ixx30·Ixx08/2^19 → Ixx30 = 21845.33; Kvfb 40 = Ixx31·Ixx09·Ixx30/2^26.
        assert!((m[&30] - 21_845.333).abs() < 0.001, "{}", m[&30]);
        assert!((m[&31] - 1280.0).abs() < 1e-9, "{}", m[&31]);
        assert!((m[&32] - 1280.0).abs() < 1e-9, "{}", m[&32]);
        // Ki 0.001 = Ixx33/2^23; Kbreak 0 = (Ixx64+16)/16; MaxPosErr 10000 = Ixx67/16.
        assert!((m[&33] - 8388.608).abs() < 1e-9);
        assert_eq!((m[&64], m[&67]), (-16.0, 160_000.0));
        // MaxInt 28000 = Ixx63·Ixx08·Ixx30/2^23.
        assert!((m[&63] * 96.0 * m[&30] / P23 - 28_000.0).abs() < 1e-6);
        // JogTa 10 ms, JogTs -50 ms³/unit: a 32 units/ms jog accelerates at 3.2 units/ms²,
        // reached at jerk 1/50 after 160 ms: S time 160 (> Ta: the ramp takes 2·160 ms).
        assert_eq!((m[&19], m[&20], m[&21]), (0.0, 10.0, 160.0));
        // CaptureMode 0 → Ixx97 0; MasterPosSf 1.0 → Ixx07 = Ixx08.
        assert_eq!((m[&97], m[&7]), (0.0, 96.0));
    }

    #[test]
    fn written_values_convert_by_the_seed_equations() {
        let m = model_of(&[("Servo.Kp", 2.5), ("Servo.Kvfb", 10.0), ("PosSf", 0.5)]);
        // Ixx30 = Kp·2^19·PosSf/Ixx08.
        assert!((m[&30] - 2.5 * P19 * 0.5 / 96.0).abs() < 1e-9);
        // Kvfb uses Pos2Sf (1.0 here) and the converted Ixx30.
        assert!((m[&31] - 10.0 * P26 / (96.0 * m[&30])).abs() < 1e-9);
        let m = model_of(&[("JogTa", -4.0), ("JogTs", 5.0), ("AbortTa", 100.0)]);
        // A rate (1/4 unit/ms², no time) with a 5 ms S-curve; AbortTa 100 ms from MaxSpeed 32.
        assert_eq!((m[&19], m[&20], m[&21], m[&15]), (0.25, 0.0, 5.0, 0.32));
        let m = model_of(&[("JogTa", 30.0), ("JogTs", 10.0), ("Servo.Kp", 0.0)]);
        // Ta > Ts: Ta + Ts in Turbo's max(Ixx20, 2·Ixx21) rule; no Kp, no velocity gains.
        assert_eq!((m[&20], m[&21], m[&31]), (40.0, 10.0, 0.0));
        let m = model_of(&[("CaptureMode", 2.0), ("InvAmax", 0.0)]);
        assert_eq!((m[&97], m[&17]), (3.0, 0.0));
    }

    #[test]
    fn coord_slews_are_scaled_by_2_to_the_23() {
        let m: std::collections::HashMap<u32, f64> = coord_model(|n| default_of(St::Coord, n))
            .into_iter()
            .collect();
        assert!((m[&94] - 83.886_08).abs() < 1e-9, "{}", m[&94]);
        assert!((m[&95] - 83.886_08).abs() < 1e-9);
        assert_eq!(m[&97], 0.0);
    }
}
