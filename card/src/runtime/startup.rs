//! The card's start-up layer on a ring: the ring settings the cluster config derives, the
//! motors on their MACRO nodes, the MACRO IC base addresses. It speaks the card's own
//! numbering (PMAC2: I995/I996, I1000/I1002, Ix00; Turbo: I6840/I6841, I70/I71, Ixx00, I20;
//! Power: the `Motor[x]` pointer elements, `Motor[x]` x = 1..8 on the servo nodes)
//! and checks every reply: a refused line stops the start-up with an error naming the line
//! and the card's `ERRnnn`, so a card never runs half set up.

use crate::domain::Profile;
use crate::lang::{Card, Session};
use crate::model::Space;

/// A start-up line the card refused.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StartupError {
    /// The line sent.
    pub line: String,
    /// The card's reply (framing characters removed), e.g. `ERR003`.
    pub reply: String,
}

impl std::fmt::Display for StartupError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the card refused start-up line '{}': {}",
            self.line, self.reply
        )
    }
}

impl std::error::Error for StartupError {}

/// What to say of refusal `e` with its reply: the reply's own text when it names the refusal
/// (`ERR003`, `stdin:1:1: error #21: …`), else the refusal (I6 = 1 or 2 printed no code).
pub(crate) fn refusal_text(reply: &[u8], e: crate::domain::Refusal) -> String {
    let text = String::from_utf8_lossy(reply);
    let text = text.trim_matches(|c: char| c.is_control() || c.is_whitespace());
    if text.contains(&e.to_string()) {
        text.to_string()
    } else {
        e.to_string()
    }
}

/// Send `line`; a refusal (whatever I6 prints of it) is a [`StartupError`].
pub(crate) fn send(card: &mut Card, line: &str) -> Result<(), StartupError> {
    let mut s = Session::default();
    let (reply, refused) = card.command_line_refused(&mut s, line.as_bytes());
    match refused {
        Some(e) => Err(StartupError {
            line: line.to_string(),
            reply: refusal_text(&reply, e.into()),
        }),
        None => Ok(()),
    }
}

/// The ring settings (I995/I996 on PMAC2, I6840/I6841 on Turbo) the config derives.
pub(crate) fn apply_ring_settings(
    card: &mut Card,
    cfg: u32,
    nodes: u32,
) -> Result<(), StartupError> {
    let rv = card.state.ring_ivars();
    send(
        card,
        &format!("I{}=${cfg:X} I{}=${nodes:X}", rv.cfg, rv.nodes),
    )
}

/// Activate the motors whose Ix02 (Turbo Ixx02) register is register 0 of one of `nodes`
/// (servo nodes only) and enable the Type 1 auxiliary flag copy of those nodes (PMAC2 I1000,
/// I1002; Turbo I70, I71). On Turbo, I20 reports MACRO IC 0 at $078400 when the card serves
/// ring nodes (`$0` otherwise), as a Turbo PMAC2 Ultralite does. Returns the motors activated.
pub fn wire_macro_motors(card: &mut Card, nodes: &[u8]) -> Result<Vec<u16>, StartupError> {
    let map = *card.state.map();
    let rv = card.state.ring_ivars();
    let mut aux = 0u32;
    let mut motors = Vec::new();
    let mut max = card.state.limits().motors.min(map.mapped_motors);
    if card.profile() == Profile::Power {
        power_motor_pointers(card)?;
        max = (max + 1).min(card.state.limits().motors);
    }
    for x in 1..=max {
        let ix02 = card.state.peek_ivar(100 * u32::from(x) + 2).unwrap_or(0.0) as u32;
        if ix02 & (1 << 19) != 0 && card.profile() == Profile::Pmac2 {
            continue;
        }
        let Some((node, 0)) = map.node_of(Space::Y, ix02 & map.max_addr) else {
            continue;
        };
        if !nodes.contains(&(node as u8)) {
            continue;
        }
        aux |= 1 << node;
        motors.push(x);
    }
    report_macro_ics(card, nodes);
    let mut line = format!("I{}=${aux:X} I{}=${aux:X}", rv.aux_enable, rv.protocol);
    // A PMAC2 or Turbo card on a ring of 16-axis MACRO Stations talks to them over Type 1
    // auxiliary communications: I1003 (Turbo I78) = 32, the suggested timeout, unless the card
    // has its own value (host tools such as dls-pmacanalyse read the stations with `MS`).
    let classic = matches!(card.profile(), Profile::Pmac2 | Profile::Turbo);
    if classic && card.state.peek_ivar(rv.aux_timeout).unwrap_or(0.0) == 0.0 {
        line.push_str(&format!(" I{}=32", rv.aux_timeout));
    }
    for x in &motors {
        line.push_str(&format!(" I{x}00=1"));
    }
    send(card, &line)?;
    Ok(motors)
}

/// The Motor pointer elements a Power card's start-up sets, in the dialect's names, with the
/// Turbo I-variable (within the motor's block) the model keeps each in.
const POWER_POINTERS: [(&str, u32); 5] = [
    ("pDac", 2),
    ("pEnc", 3),
    ("pEnc2", 4),
    ("pEncStatus", 25),
    ("pPhaseEnc", 83),
];

/// A Power card numbers its servo motors from 1 (`Motor[0]` is no servo motor): `Motor[x]`
/// (x = 1..8) gets the registers of the x-th servo node (0, 1, 4, 5, 8, 9, 12, 13) —
/// `Motor[x].pDac` its command register, `pEnc`/`pEnc2` its feedback (encoder conversion
/// entry), `pEncStatus` its flag register, `pPhaseEnc` its phase position — and `Motor[0]`
/// none. Sent in Power syntax through the dialect, every reply checked.
fn power_motor_pointers(card: &mut Card) -> Result<(), StartupError> {
    let mut dialect = crate::lang::Dialect::for_card(card);
    let mut s = Session::default();
    // The model's factory addresses of motor k (Turbo numbering: motor k on the k-th servo
    // node), read before any is moved.
    let factory = |card: &Card, k: u16, n: u32| -> u32 {
        if k == 0 || k > SERVO_NODES {
            return 0;
        }
        card.state.peek_ivar(100 * u32::from(k) + n).unwrap_or(0.0) as u32
    };
    let mut lines = Vec::new();
    for x in 0..=SERVO_NODES {
        let mut line = String::new();
        for (name, n) in POWER_POINTERS {
            line.push_str(&format!("Motor[{x}].{name}=${:X} ", factory(card, x, n)));
        }
        lines.push(line);
    }
    lines.push("Motor[0].ServoCtrl=0".into());
    // [DECISION] The simulated drives are built for the PMAC factory gains; the seed's Power
    // defaults (Kp 4, Kvfb/Kvff 40: eleven times stiffer) make them run away. As a project's
    // setup tunes its motors, the start-up gives each wired motor still at the seed's
    // default gains the PMAC factory gains in Power units (Ixx30 = 2000, Ixx31/Ixx32 = 1280,
    // Ixx33 = 0 through the seed's gain equations); gains a host has set are left alone.
    for x in 1..=SERVO_NODES {
        let at_defaults = SEED_GAINS.iter().all(|(name, seed)| {
            let q = format!("Motor[{x}].{name}");
            let (reply, _) = dialect.detached_line(card, &mut s, 0, q.as_bytes());
            let text = String::from_utf8_lossy(&reply);
            let v = text
                .split(['=', '\r'])
                .nth(1)
                .and_then(|v| v.parse::<f64>().ok());
            v == Some(*seed)
        });
        if at_defaults {
            let mut line = String::new();
            for (name, v) in DRIVE_GAINS {
                line.push_str(&format!("Motor[{x}].{name}={v} "));
            }
            lines.push(line);
        }
    }
    for line in lines {
        let line = line.trim_end().to_string();
        let (reply, refused) = dialect.detached_line(card, &mut s, 0, line.as_bytes());
        let text = String::from_utf8_lossy(&reply);
        if refused.is_some() {
            return Err(StartupError {
                reply: text
                    .trim_matches(|c: char| c.is_control() || c.is_whitespace())
                    .to_string(),
                line,
            });
        }
    }
    Ok(())
}

/// Servo nodes of a MACRO IC (0, 1, 4, 5, 8, 9, 12, 13).
const SERVO_NODES: u16 = 8;

/// The seed's default servo gains of a Power motor (seed 000: `Servo.Kp` 4, `Kvfb`/`Kvff` 40,
/// `Ki` 0.001).
const SEED_GAINS: [(&str, f64); 4] = [
    ("Servo.Kp", 4.0),
    ("Servo.Kvfb", 40.0),
    ("Servo.Kvff", 40.0),
    ("Servo.Ki", 0.001),
];

/// The PMAC factory gains in Power units: `Kp = Ixx30·Ixx08/2^19` = 2000·96/2^19,
/// `Kvfb = Ixx31·Ixx09·Ixx30/2^26` = 1280·96·2000/2^26, the same for `Kvff`, `Ki` 0.
const DRIVE_GAINS: [(&str, f64); 4] = [
    ("Servo.Kp", 0.366_210_937_5),
    ("Servo.Kvfb", 3.662_109_375),
    ("Servo.Kvff", 3.662_109_375),
    ("Servo.Ki", 0.0),
];

/// Turbo I20-I23 (read-only to hosts): MACRO IC 0 at $078400 when the card serves ring nodes,
/// `$0` (absent) otherwise and for ICs 1-3, as a Turbo PMAC2 Ultralite with one MACRO IC.
pub(crate) fn report_macro_ics(card: &mut Card, nodes: &[u8]) {
    if card.profile() != Profile::Turbo {
        return;
    }
    let base = if nodes.is_empty() {
        0.0
    } else {
        f64::from(crate::model::MACRO_IC0_BASE)
    };
    card.state.vars.force_i(20, base);
}

/// The whole ring start-up: ring settings (when the card is on a configured ring), then the
/// motor wiring (when `wire`).
pub fn ring_startup(
    card: &mut Card,
    ring: Option<(u32, u32)>,
    nodes: &[u8],
    wire: bool,
) -> Result<Vec<u16>, StartupError> {
    if let Some((cfg, n)) = ring {
        apply_ring_settings(card, cfg, n)?;
    }
    if wire {
        wire_macro_motors(card, nodes)
    } else {
        report_macro_ics(card, nodes);
        Ok(Vec::new())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(card: &mut Card, line: &str) -> String {
        let mut s = Session::default();
        card.command_line(&mut s, b"I3=2");
        String::from_utf8_lossy(&card.command_line(&mut s, line.as_bytes()))
            .trim_matches(|c: char| c.is_control() || c.is_whitespace())
            .to_string()
    }

    #[test]
    fn a_refusal_is_said_with_the_reply_that_names_it_or_by_itself() {
        use crate::domain::{ErrCode, PowerErr, Refusal};
        let pmac = Refusal::Pmac(ErrCode::Data);
        assert_eq!(refusal_text(b"\x07\rERR003\r", pmac), "ERR003");
        assert_eq!(refusal_text(b"\x07", pmac), "ERR003", "I6 = 2: a bare BELL");
        let power = Refusal::Power(PowerErr::IllegalParameter);
        let line = b"stdin:1:1: error #21: ILLEGAL PARAMETER: I9999=1\r\n\x06\r\n";
        assert_eq!(
            refusal_text(line, power),
            "stdin:1:1: error #21: ILLEGAL PARAMETER: I9999=1"
        );
    }

    #[test]
    fn pmac2_wiring_speaks_pmac2_numbers() {
        let mut card = Card::new(Profile::Pmac2);
        ring_startup(&mut card, Some((0x8090, 0x8F_3333)), &[0, 1, 4, 5], true).unwrap();
        assert_eq!(q(&mut card, "I995 I996"), "$8090\r$8F3333");
        assert_eq!(q(&mut card, "I1000 I1002"), "$33\r$33");
        assert_eq!(q(&mut card, "I100 I200 I300 I400 I500"), "1\r1\r1\r1\r0");
    }

    /// Issue 14 item 1: a Turbo card on a ring is set up in Turbo numbers (I6840/I6841,
    /// I70/I71, Ixx00) and I20 reports MACRO IC 0 (item 3).
    #[test]
    fn turbo_wiring_speaks_turbo_numbers() {
        let mut card = Card::new(Profile::Turbo);
        let motors = ring_startup(
            &mut card,
            Some((0x8090, 0x8F_3333)),
            &[0, 1, 4, 5, 8, 9, 12, 13],
            true,
        )
        .unwrap();
        assert_eq!(motors, [1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(q(&mut card, "I6840 I6841"), "$8090\r$8F3333");
        assert_eq!(q(&mut card, "I70 I71"), "$3333\r$3333");
        assert_eq!(q(&mut card, "I800 I900 I1000 I1002"), "1\r0\r0\r$0");
        assert_eq!(q(&mut card, "I20 I21"), "$78400\r$0");
        assert_eq!(q(&mut card, "I995"), "0");
    }

    /// Issue 13 item 6: a Power card's start-up points `Motor[1]`..`Motor[8]` at the servo
    /// nodes (0, 1, 4, 5, 8, 9, 12, 13) through the Motor pointer elements, activates them,
    /// and leaves `Motor[0]` without a servo node.
    #[test]
    fn power_wiring_speaks_power_elements() {
        let mut card = Card::new(Profile::Power);
        let motors = ring_startup(
            &mut card,
            Some((0x8090, 0x8F_3333)),
            &[0, 1, 4, 5, 8, 9, 12, 13],
            true,
        )
        .unwrap();
        // Model motors (Power x + 1).
        assert_eq!(motors, [2, 3, 4, 5, 6, 7, 8, 9]);
        let mut p = crate::lang::Dialect::for_card(&mut card);
        let mut ask = |line: &str| {
            let r = p
                .script_line(&mut card, 1, format!("echo7 {line}").as_bytes())
                .unwrap_or_default();
            String::from_utf8(r).unwrap().replace("\x06\r\n", "")
        };
        assert_eq!(
            ask("Motor[0].pDac Motor[1].pDac Motor[2].pDac Motor[8].pDac Motor[9].pDac"),
            "$0\r\nGate3[0].MacroOutA[0][0].a\r\nGate3[0].MacroOutA[1][0].a\r\n\
             Gate3[0].MacroOutA[13][0].a\r\n$0\r\n"
        );
        assert_eq!(
            ask("Motor[1].pEnc Motor[1].pEncStatus"),
            "$3502\r\n$3440\r\n"
        );
        assert_eq!(
            ask("Motor[0].ServoCtrl Motor[1].ServoCtrl Motor[8].ServoCtrl Motor[9].ServoCtrl"),
            "$0\r\n$1\r\n$1\r\n$0\r\n"
        );
        assert_eq!(ask("Gate3[0].MacroEnableA"), "$8F333300\r\n");
        // The wired motors get the drive's gains; the others keep the seed's defaults.
        assert_eq!(
            ask("Motor[1].Servo.Kp Motor[8].Servo.Kvfb Motor[8].Servo.Ki Motor[9].Servo.Kp"),
            "0.3662109375\r\n3.662109375\r\n0\r\n4\r\n"
        );
        // Gains a host set are not replaced when the wiring is applied again (after `$$$`).
        assert_eq!(ask("Motor[2].Servo.Kp=1.5"), "");
        wire_macro_motors(&mut card, &[0, 1, 4, 5, 8, 9, 12, 13]).unwrap();
        let mut p = crate::lang::Dialect::for_card(&mut card);
        let r = p
            .script_line(&mut card, 1, b"echo7 Motor[2].Servo.Kp Motor[3].Servo.Kp")
            .unwrap_or_default();
        assert_eq!(
            String::from_utf8(r).unwrap().replace("\x06\r\n", ""),
            "1.5\r\n0.3662109375\r\n"
        );
    }

    #[test]
    fn a_refused_line_stops_the_start_up() {
        let mut card = Card::new(Profile::Turbo);
        // I70 takes 16 bits: a value past it is refused with ERR003 (out of range).
        let e = send(&mut card, "I70=$10000").unwrap_err();
        assert_eq!(e.line, "I70=$10000");
        assert!(e.reply.contains("ERR"), "{e}");
        assert!(e.to_string().contains("I70=$10000"));
    }
}
