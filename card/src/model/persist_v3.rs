//! Save format 3: the payload is this module's own JSON schema ([`ImageV3`]), not the
//! internal types. M-variable definitions are their `Mn->` text (`Y:$1FF0,4,8,S`, `*`),
//! memory regions name their space (`"X"`/`"Y"`), and the interpreter's part (programs and
//! PLCs as listing text, DEFINE'd buffers, axis definitions, a dialect's own fields) is
//! embedded as JSON, so every listing line is a JSON string a person can read. Formats 2
//! (the internal types as JSON, programs as a byte array) and 1 (bincode) are read by
//! converters into the same in-memory image (`persist::decode`).

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::memory::Space;
use super::persist::{PersistError, PersistImage};
use crate::domain::ast::MDef;

/// The format-3 payload.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct ImageV3 {
    /// Profile name (`pmac2`, `turbo`, `power`).
    profile: String,
    /// I-variable values, I0 first.
    ivars: Vec<f64>,
    /// P-variable values, P0 first.
    pvars: Vec<f64>,
    /// Q-variable values per coordinate system.
    qvars: Vec<Vec<f64>>,
    /// M-variable definitions as their `Mn->` text, M0 first (`*`: self-referenced).
    mdefs: Vec<String>,
    /// Self-referenced M-variable values, M0 first.
    mself: Vec<i32>,
    /// Saved memory regions.
    regions: Vec<Region>,
    /// Words reserved by DEFINE UBUFFER.
    ubuffer_words: u32,
    /// Password (empty: none).
    password: String,
    /// The interpreter's part (a JSON object; `null` when it saved nothing).
    programs: Value,
}

/// One saved memory region.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Region {
    /// `X` or `Y`.
    space: String,
    /// First address.
    start: u16,
    /// Its words (24 bits each).
    words: Vec<u32>,
}

fn space_name(s: Space) -> &'static str {
    match s {
        Space::X => "X",
        Space::Y => "Y",
    }
}

fn bad(what: String) -> PersistError {
    PersistError::Decode(what)
}

impl ImageV3 {
    /// The schema's form of `img`.
    pub(super) fn from_image(img: &PersistImage) -> ImageV3 {
        // The interpreter writes a JSON object; other bytes ride as a string.
        let programs = if img.programs.is_empty() {
            Value::Null
        } else {
            serde_json::from_slice(&img.programs).unwrap_or_else(|_| {
                Value::String(String::from_utf8_lossy(&img.programs).into_owned())
            })
        };
        ImageV3 {
            profile: img.profile.clone(),
            ivars: img.ivars.clone(),
            pvars: img.pvars.clone(),
            qvars: img.qvars.clone(),
            mdefs: img.mdefs.iter().map(MDef::to_string).collect(),
            mself: img.mself.clone(),
            regions: img
                .regions
                .iter()
                .map(|(s, start, words)| Region {
                    space: space_name(*s).to_string(),
                    start: *start,
                    words: words.clone(),
                })
                .collect(),
            ubuffer_words: img.ubuffer_words,
            password: img.password.clone(),
            programs,
        }
    }

    /// The in-memory image; a definition or region the schema does not allow is refused.
    pub(super) fn into_image(self) -> Result<PersistImage, PersistError> {
        let mdefs = self
            .mdefs
            .iter()
            .enumerate()
            .map(|(m, t)| t.parse::<MDef>().map_err(|e| bad(format!("M{m}: {e}"))))
            .collect::<Result<Vec<_>, _>>()?;
        let regions = self
            .regions
            .into_iter()
            .map(|r| {
                let s = match r.space.as_str() {
                    "X" => Space::X,
                    "Y" => Space::Y,
                    other => return Err(bad(format!("region space {other:?} (X or Y)"))),
                };
                Ok((s, r.start, r.words))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let programs = match self.programs {
            Value::Null => Vec::new(),
            Value::String(s) => s.into_bytes(),
            v => serde_json::to_vec(&v).map_err(|e| bad(e.to_string()))?,
        };
        Ok(PersistImage {
            profile: self.profile,
            ivars: self.ivars,
            pvars: self.pvars,
            qvars: self.qvars,
            mdefs,
            mself: self.mself,
            regions,
            ubuffer_words: self.ubuffer_words,
            password: self.password,
            programs,
            format: 3,
        })
    }
}
