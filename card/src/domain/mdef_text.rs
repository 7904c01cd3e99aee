//! The text of an M-variable definition, both ways: `Display` prints the `Mn->` reply body
//! (`X:$C001,24,S`, `Y:$FFC2,8`, `Y:$C003,8,16,S`, `D:$002C`, `*`; `{:#}` with six address
//! digits as a Turbo card prints them), and `FromStr` reads exactly that canonical text back
//! (the saved image keeps M-definitions as this text, not as the internal form).

use std::fmt;
use std::str::FromStr;

use super::ast::{MDef, MFormat, XySpace};

/// The letter of a format (`U`, `S`, `D`, `C`).
fn fmt_letter(f: MFormat) -> char {
    match f {
        MFormat::U => 'U',
        MFormat::S => 'S',
        MFormat::D => 'D',
        MFormat::C => 'C',
    }
}

fn letter_fmt(s: &str) -> Option<MFormat> {
    match s {
        "U" => Some(MFormat::U),
        "S" => Some(MFormat::S),
        "D" => Some(MFormat::D),
        "C" => Some(MFormat::C),
        _ => None,
    }
}

impl fmt::Display for MDef {
    /// `X:$C001,24,S`; the alternate form (`{:#}`) prints six address digits as a Turbo card
    /// does (`D:$00008B`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = if f.alternate() { 6 } else { 4 };
        match *self {
            MDef::SelfRef => write!(f, "*"),
            MDef::Bits {
                space,
                addr,
                offset,
                width,
                format,
            } => {
                let sp = if space == XySpace::X { 'X' } else { 'Y' };
                match width {
                    1 => write!(f, "{sp}:${addr:0w$X},{offset}"),
                    24 => write!(f, "{sp}:${addr:0w$X},24,{}", fmt_letter(format)),
                    _ => write!(
                        f,
                        "{sp}:${addr:0w$X},{offset},{width},{}",
                        fmt_letter(format)
                    ),
                }
            }
            MDef::D(a) => write!(f, "D:${a:0w$X}"),
            MDef::L(a) => write!(f, "L:${a:0w$X}"),
            MDef::F(a) => write!(f, "F:${a:0w$X}"),
            MDef::Dp(a) => write!(f, "DP:${a:0w$X}"),
            MDef::Twb {
                mux,
                offset,
                size,
                format,
            } => write!(f, "TWB:{mux},{offset},{size},{}", fmt_letter(format)),
            MDef::Twd {
                mux,
                offset,
                digits,
                decimals,
                format,
            } => {
                write!(
                    f,
                    "TWD:{mux},{offset},{digits}.{decimals},{}",
                    fmt_letter(format)
                )
            }
            MDef::Twr { mux, offset } => write!(f, "TWR:{mux},{offset}"),
            MDef::Tws { mux } => write!(f, "TWS:{mux}"),
        }
    }
}

/// Text that is not a definition as [`MDef`]'s `Display` prints one.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("not an M-variable definition: {0:?}")]
pub struct BadMDef(pub String);

impl FromStr for MDef {
    type Err = BadMDef;

    fn from_str(text: &str) -> Result<MDef, BadMDef> {
        parse(text).ok_or_else(|| BadMDef(text.chars().take(64).collect()))
    }
}

fn parse(text: &str) -> Option<MDef> {
    if text == "*" {
        return Some(MDef::SelfRef);
    }
    let (kind, rest) = text.split_once(':')?;
    let parts: Vec<&str> = rest.split(',').collect();
    let hex = |s: &str| u32::from_str_radix(s.strip_prefix('$')?, 16).ok();
    let num = |s: &str| s.parse::<u8>().ok();
    Some(match (kind, parts.as_slice()) {
        ("X" | "Y", [a, rest @ ..]) => {
            let space = if kind == "X" { XySpace::X } else { XySpace::Y };
            let addr = hex(a)?;
            let (offset, width, format) = match rest {
                [o] => (num(o)?, 1, MFormat::U),
                [w, f] if *w == "24" => (0, 24, letter_fmt(f)?),
                [o, w, f] => (num(o)?, num(w)?, letter_fmt(f)?),
                _ => return None,
            };
            MDef::Bits {
                space,
                addr,
                offset,
                width,
                format,
            }
        }
        ("D", [a]) => MDef::D(hex(a)?),
        ("L", [a]) => MDef::L(hex(a)?),
        ("F", [a]) => MDef::F(hex(a)?),
        ("DP", [a]) => MDef::Dp(hex(a)?),
        ("TWB", [m, o, s, f]) => MDef::Twb {
            mux: num(m)?,
            offset: num(o)?,
            size: num(s)?,
            format: letter_fmt(f)?,
        },
        ("TWD", [m, o, d, f]) => {
            let (digits, decimals) = d.split_once('.')?;
            MDef::Twd {
                mux: num(m)?,
                offset: num(o)?,
                digits: num(digits)?,
                decimals: num(decimals)?,
                format: letter_fmt(f)?,
            }
        }
        ("TWR", [m, o]) => MDef::Twr {
            mux: num(m)?,
            offset: num(o)?,
        },
        ("TWS", [m]) => MDef::Tws { mux: num(m)? },
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn every_form() -> Vec<MDef> {
        let mut v = vec![MDef::SelfRef];
        for space in [XySpace::X, XySpace::Y] {
            for (offset, width) in [(0, 1), (23, 1), (0, 24), (4, 8), (8, 16), (20, 4)] {
                for format in [MFormat::U, MFormat::S, MFormat::D, MFormat::C] {
                    let format = if width == 1 { MFormat::U } else { format };
                    for addr in [0, 0x1FF0, 0xFFFF, 0x7_FFFF] {
                        v.push(MDef::Bits {
                            space,
                            addr,
                            offset,
                            width,
                            format,
                        });
                    }
                }
            }
        }
        for a in [0, 0x8B, 0xC0A0, 0x7_FFFF] {
            v.extend([MDef::D(a), MDef::L(a), MDef::F(a), MDef::Dp(a)]);
        }
        for format in [MFormat::U, MFormat::S] {
            v.push(MDef::Twb {
                mux: 255,
                offset: 7,
                size: 32,
                format,
            });
            v.push(MDef::Twd {
                mux: 3,
                offset: 4,
                digits: 12,
                decimals: 8,
                format,
            });
        }
        v.push(MDef::Twr {
            mux: 254,
            offset: 7,
        });
        v.push(MDef::Tws { mux: 127 });
        v
    }

    #[test]
    fn every_form_reads_back_from_its_text_in_both_widths() {
        for d in every_form() {
            assert_eq!(d.to_string().parse::<MDef>(), Ok(d), "{d}");
            assert_eq!(format!("{d:#}").parse::<MDef>(), Ok(d), "{d:#}");
        }
        assert_eq!(
            "Y:$1FF0,4,8,S".parse::<MDef>(),
            Ok(MDef::Bits {
                space: XySpace::Y,
                addr: 0x1FF0,
                offset: 4,
                width: 8,
                format: MFormat::S
            })
        );
    }

    #[test]
    fn text_that_is_no_definition_is_refused() {
        for bad in [
            "",
            "Q:$10",
            "X:10,0",
            "X:$10",
            "D:$",
            "TWD:1,0,4,U",
            "Y:$10,4,8,Q",
            "*x",
        ] {
            assert!(bad.parse::<MDef>().is_err(), "{bad}");
        }
    }
}
