//! A card's refusal of a host line as it travels between processes ([`CardRefusal`]), beside
//! the reply bytes and never inside them: the card's command queryable
//! `mcc/<cluster>/card/<n>/cmd` puts it in the zenoh reply **attachment** (its text form,
//! its `Display`; no attachment: the line was not refused), the daisy chain in
//! its reply attachment ([`super::chain::encode_refusals`]) and a synchronized start in
//! [`super::AtReply::refusal`]. The reply bytes stay what the card's framing made of the
//! line (I6 may print `ERRnnn`, a bare `<BELL>` or nothing), so callers match on the refusal,
//! not on the bytes.
//!
//! Text form (the same strings `mcc send --json` prints in its `"error"` field):
//! `ERRnnn` (a PMAC2/Turbo code, three digits), `error #n` (a Power PMAC error) and `BELL`
//! (a bell without a code: a refusal the sender could not name).

use std::fmt;
use std::str::FromStr;

/// Why a card refused a line, in its dialect's terms (the card's own type is
/// `mcc_card::domain::Refusal`; this one only carries the number across processes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CardRefusal {
    /// A PMAC2/Turbo `ERRnnn` (1..=999).
    Pmac(u16),
    /// A Power PMAC `error #n`.
    Power(u16),
    /// A bell without a code: the card refused without naming why.
    Bell,
}

/// Longest text form accepted ([`CardRefusal::from_str`]).
pub const MAX_REFUSAL_TEXT: usize = 16;

/// Why a refusal's text form was not read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RefusalParseError {
    /// Not `ERRnnn`, `error #n` or `BELL`.
    #[error("not a card refusal: {0:?}")]
    Unknown(String),
    /// Longer than [`MAX_REFUSAL_TEXT`] bytes.
    #[error("card refusal text of {0} bytes is too long")]
    TooLong(usize),
}

impl fmt::Display for CardRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CardRefusal::Pmac(n) => write!(f, "ERR{n:03}"),
            CardRefusal::Power(n) => write!(f, "error #{n}"),
            CardRefusal::Bell => f.write_str("BELL"),
        }
    }
}

impl FromStr for CardRefusal {
    type Err = RefusalParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.len() > MAX_REFUSAL_TEXT {
            return Err(RefusalParseError::TooLong(s.len()));
        }
        let number = |d: &str, len: std::ops::RangeInclusive<usize>| {
            (len.contains(&d.len()) && d.bytes().all(|b| b.is_ascii_digit()))
                .then(|| d.parse::<u16>().ok())
                .flatten()
        };
        let parsed = if s == "BELL" {
            Some(CardRefusal::Bell)
        } else if let Some(d) = s.strip_prefix("ERR") {
            number(d, 3..=3).filter(|&n| n > 0).map(CardRefusal::Pmac)
        } else if let Some(d) = s.strip_prefix("error #") {
            // One spelling per number (no leading zero), so the text round-trips.
            number(d, 1..=5)
                .filter(|_| d == "0" || !d.starts_with('0'))
                .map(CardRefusal::Power)
        } else {
            None
        };
        parsed.ok_or_else(|| RefusalParseError::Unknown(s.to_string()))
    }
}

/// JSON (a synchronized start's [`super::AtReply::refusal`]): the text form.
impl serde::Serialize for CardRefusal {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> serde::Deserialize<'de> for CardRefusal {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = <std::borrow::Cow<'de, str>>::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

impl CardRefusal {
    /// Read the text form from bytes (a zenoh attachment).
    pub fn from_bytes(b: &[u8]) -> Result<Self, RefusalParseError> {
        if b.len() > MAX_REFUSAL_TEXT {
            return Err(RefusalParseError::TooLong(b.len()));
        }
        std::str::from_utf8(b)
            .map_err(|_| RefusalParseError::Unknown(String::from_utf8_lossy(b).into_owned()))?
            .parse()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_forms_round_trip() {
        for (r, text) in [
            (CardRefusal::Pmac(3), "ERR003"),
            (CardRefusal::Pmac(15), "ERR015"),
            (CardRefusal::Power(20), "error #20"),
            (CardRefusal::Bell, "BELL"),
        ] {
            assert_eq!(r.to_string(), text);
            assert_eq!(text.parse::<CardRefusal>(), Ok(r));
            assert_eq!(CardRefusal::from_bytes(text.as_bytes()), Ok(r));
        }
    }

    #[test]
    fn json_is_the_text_form() {
        let j = serde_json::to_string(&CardRefusal::Power(21)).unwrap();
        assert_eq!(j, r#""error #21""#);
        assert_eq!(
            serde_json::from_str::<CardRefusal>(&j).unwrap(),
            CardRefusal::Power(21)
        );
        assert!(serde_json::from_str::<CardRefusal>(r#""ERR3""#).is_err());
    }

    #[test]
    fn malformed_text_is_named() {
        for bad in [
            "",
            "ERR",
            "ERR3",
            "ERR0003",
            "ERR000",
            "ERRabc",
            "error #",
            "error #x",
            "error #020",
            "bell",
            "ERR003\r",
        ] {
            assert_eq!(
                bad.parse::<CardRefusal>(),
                Err(RefusalParseError::Unknown(bad.to_string())),
                "{bad:?}"
            );
        }
        assert_eq!(
            "error #123456789012".parse::<CardRefusal>(),
            Err(RefusalParseError::TooLong(19))
        );
        assert!(CardRefusal::from_bytes(b"\xffERR").is_err());
        assert!(CardRefusal::from_bytes(&[b'E'; 100]).is_err());
    }
}
