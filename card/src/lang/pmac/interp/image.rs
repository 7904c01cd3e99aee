//! What the interpreter contributes to `SAVE` (programs, PLCs, DEFINE'd buffers, axis
//! definitions), the reset paths `$$$` / `$$$***` / start-up, and the effects that need the
//! operating system: SAVE hands the encoded image out as [`Effect::Save`], `$$$` asks for the
//! saved image with [`Effect::Load`]. The interpreter never touches a file: whoever runs the
//! line performs the effect (off the servo thread) and hands back an [`EffectResult`].

use crate::domain::{CsNum, MotorNum};
use serde::{Deserialize, Serialize};

use super::Pmac;
use crate::domain::ast::AxisDef;
use crate::model::{persist, user_memory_words, Buffers, PartLoad, ProgLine, RunState, PLCS};

/// PMAC2 register holding the end of unreserved memory (X:$0F3F).
const UNRESERVED_END_REG: u32 = 0x0F3F;
/// One past the top of user memory (the DEFINE'd buffers stack down from $9FFF).
const MEMORY_END: u64 = 0xA000;

/// `???` word 1 bit 10: saved data bad, factory defaults used.
pub(super) const EAROM_ERROR: u32 = 1 << 10;

/// An operating-system request a command waits for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Effect {
    /// Write this encoded image as the saved state (atomically).
    Save(Vec<u8>),
    /// Read the saved state (`$$$`).
    Load,
}

/// What an [`Effect`] came to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum EffectResult {
    /// The image was written (`true`) or the write failed (`false`).
    Saved(bool),
    /// The saved image's bytes (`None`: there is none), or why it could not be read.
    Loaded(Result<Option<Vec<u8>>, String>),
}

/// Where a card's saved state lives (a file for a card process; memory in tests).
pub trait Storage: std::fmt::Debug {
    /// Write `bytes` as the saved state (atomically: old or new, never a mix).
    fn save(&mut self, bytes: &[u8]) -> Result<(), String>;
    /// The saved state's bytes, `None` when nothing was saved yet.
    fn load(&mut self) -> Result<Option<Vec<u8>>, String>;
}

/// INTERP's part of the saved image, format 1 (bincode of the parsed form; read only).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct InterpImage {
    /// Programs, PLCs, rotary and DEFINE'd buffers.
    pub bufs: Buffers<ProgLine>,
    /// Axis definitions per motor.
    pub axes: Vec<Option<(u16, AxisDef)>>,
}

/// A stored program or PLC as its canonical listing (one text per stored line).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct ProgText {
    /// PROG or PLC number.
    pub n: u16,
    /// `LIST` text of each stored line (short keywords).
    pub lines: Vec<String>,
    /// Structurally complete at the last CLOSE.
    pub valid: bool,
}

/// A rotary buffer: its size and the lines not yet run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct RotaryText {
    /// C.S. number.
    pub cs: u8,
    /// `DEFINE ROT` size in words.
    pub size: u32,
    /// Lines not yet run, as listing text.
    pub lines: Vec<String>,
}

/// One compensation table as saved (the schema's own form of `model::CompTable`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct TableText {
    /// The definition as `LIST COMP DEF` lists it (`100,#2,#2,100000`).
    pub def: String,
    /// Entries expected.
    pub entries: u32,
    /// Entries received (1/16 count units).
    pub data: Vec<i64>,
}

/// The DEFINE'd buffers as saved (the schema's own form of `model::Defines`; the field names
/// are the saved format's, whatever the model calls them).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(super) struct DefinesText {
    /// `DEFINE UBUFFER n` (0: none).
    pub ubuffer: u32,
    /// Leadscrew tables by motor.
    pub comp: std::collections::BTreeMap<u8, TableText>,
    /// Torque tables by motor.
    pub tcomp: std::collections::BTreeMap<u8, TableText>,
    /// Backlash tables by motor.
    pub blcomp: std::collections::BTreeMap<u8, TableText>,
    /// Transformation matrices (`DEFINE TBUF n`).
    pub tbuf: u32,
    /// Gather buffer words (`DEFINE GATHER n`).
    pub gather: Option<u32>,
}

impl DefinesText {
    fn of(d: &crate::model::Defines) -> Self {
        let tables = |m: &std::collections::BTreeMap<u8, crate::model::CompTable>| {
            m.iter()
                .map(|(k, t)| {
                    let t = TableText {
                        def: t.def.clone(),
                        entries: t.entries,
                        data: t.data.clone(),
                    };
                    (*k, t)
                })
                .collect()
        };
        DefinesText {
            ubuffer: d.ubuffer,
            comp: tables(&d.comp),
            tcomp: tables(&d.tcomp),
            blcomp: tables(&d.blcomp),
            tbuf: d.tbuf,
            gather: d.gather,
        }
    }

    fn into_defines(self) -> crate::model::Defines {
        let tables = |m: std::collections::BTreeMap<u8, TableText>| {
            m.into_iter()
                .map(|(k, t)| {
                    let t = crate::model::CompTable {
                        def: t.def,
                        entries: t.entries,
                        data: t.data,
                    };
                    (k, t)
                })
                .collect()
        };
        crate::model::Defines {
            ubuffer: self.ubuffer,
            comp: tables(self.comp),
            tcomp: tables(self.tcomp),
            blcomp: tables(self.blcomp),
            tbuf: self.tbuf,
            gather: self.gather,
        }
    }
}

/// INTERP's part of the saved image, format 2: programs as text, so an old file still reads
/// when the statement forms grow (JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct InterpImageV2 {
    /// Motion programs.
    pub progs: Vec<ProgText>,
    /// PLC programs.
    pub plcs: Vec<ProgText>,
    /// Rotary buffers.
    pub rotary: Vec<RotaryText>,
    /// DEFINE'd buffers (gather size, TBUF, compensation tables, UBUFFER).
    pub defines: DefinesText,
    /// Axis definitions: (motor, C.S., definition text such as `1000X+500`).
    pub axes: Vec<(u16, u16, String)>,
    /// The installed language's own fields (a Power card's `sources`, `mvars`, `elems`;
    /// none on PMAC2/Turbo and in older files), written after these and read back whole
    /// (`model::ImagePart`). They replace the buffers `progs`/`plcs` rebuild.
    #[serde(flatten)]
    pub dialect: crate::model::ImagePart,
}

fn prog_text(n: u16, p: &crate::model::Program<ProgLine>) -> ProgText {
    ProgText {
        n,
        lines: p
            .lines
            .iter()
            .map(|l| crate::lang::pmac::listing::line(&l.stmts, false))
            .collect(),
        valid: p.valid,
    }
}

/// Parse listing lines back into stored lines (a line that no longer parses is dropped and
/// the program marked invalid: it cannot run until fixed).
fn parse_lines(
    lines: &[String],
    kind: crate::lang::pmac::ast::BufferKind,
) -> (Vec<ProgLine>, bool) {
    let mut ok = true;
    let mut out = Vec::with_capacity(lines.len());
    for l in lines {
        // The RETURN that CLOSE appends is stored in every buffer kind, even where it cannot
        // be typed (PLCs).
        if l == "RET" || l == "RETURN" {
            out.push(<ProgLine as crate::model::StoredLine>::return_line());
            continue;
        }
        match crate::lang::pmac::parse_program_line(l.as_bytes(), kind) {
            Ok(stmts) if !stmts.is_empty() => out.push(ProgLine::new(stmts)),
            _ => ok = false,
        }
    }
    (out, ok)
}

impl Pmac<'_> {
    /// Serialize INTERP's saved part (format 2).
    pub(crate) fn interp_blob(&self) -> Vec<u8> {
        let b = &self.model.bufs;
        let img = InterpImageV2 {
            progs: b.progs.iter().map(|(n, p)| prog_text(*n, p)).collect(),
            plcs: b
                .plcs
                .iter()
                .map(|(n, p)| prog_text(u16::from(*n), p))
                .collect(),
            rotary: b
                .rotary
                .iter()
                .map(|(cs, r)| RotaryText {
                    cs: *cs,
                    size: r.size,
                    lines: r
                        .lines
                        .iter()
                        .map(|l| crate::lang::pmac::listing::line(&l.stmts, false))
                        .collect(),
                })
                .collect(),
            defines: DefinesText::of(&b.defines),
            axes: self
                .model
                .run
                .axes
                .iter()
                .enumerate()
                .filter_map(|(k, a)| {
                    a.as_ref()
                        .map(|(cs, d)| (k as u16 + 1, *cs, crate::model::axis_def_text(d)))
                })
                .collect(),
            dialect: self.model.export_image_part(),
        };
        serde_json::to_vec(&img).unwrap_or_default()
    }

    /// Restore INTERP's saved part of format 2; the installed language's part is returned.
    fn load_blob_v2(&mut self, blob: &[u8]) -> crate::model::ImagePart {
        use crate::lang::pmac::ast::{BufferKind, CmdKind};
        let Ok(img) = serde_json::from_slice::<InterpImageV2>(blob) else {
            return crate::model::ImagePart::default();
        };
        let lim = self.model.state.limits();
        let b = &mut self.model.bufs;
        for p in img.progs {
            let (lines, ok) = parse_lines(&p.lines, BufferKind::Prog);
            b.progs.insert(
                p.n,
                crate::model::Program {
                    lines,
                    valid: p.valid && ok,
                },
            );
        }
        for p in img.plcs {
            let Ok(n) = u8::try_from(p.n) else { continue };
            let (lines, ok) = parse_lines(&p.lines, BufferKind::Plc(n));
            b.plcs.insert(
                n,
                crate::model::Program {
                    lines,
                    valid: p.valid && ok,
                },
            );
        }
        for r in img.rotary {
            let (lines, _) = parse_lines(&r.lines, BufferKind::Rotary);
            b.rotary.insert(
                r.cs,
                crate::model::Rotary {
                    size: r.size,
                    lines,
                },
            );
        }
        b.defines = img.defines.into_defines();
        for (m, cs, text) in img.axes {
            let line = format!("#{m}->{text}");
            let def = crate::lang::pmac::parse_line(line.as_bytes())
                .ok()
                .and_then(|cmds| cmds.into_iter().last())
                .and_then(|c| match c.kind {
                    CmdKind::AxisDefine(_, d) => Some(d),
                    _ => None,
                });
            let slot = usize::from(m)
                .checked_sub(1)
                .and_then(|k| self.model.run.axes.get_mut(k));
            if let (Some(d), Some(slot)) = (def, slot) {
                if cs >= 1 && cs <= lim.coords {
                    *slot = Some((cs, d));
                }
            }
        }
        img.dialect
    }

    /// Restore INTERP's saved part (an undecodable blob leaves empty buffers).
    fn load_blob(&mut self, blob: &[u8], format: u32) {
        let lim = self.model.state.limits();
        let profile = self.model.profile();
        self.model.run = RunState::new(lim.motors, lim.coords, PLCS);
        self.model.bufs = Buffers::new(user_memory_words(profile));
        // The buffers are gone: so is the language's part (the image brings its own).
        if blob.is_empty() {
            self.model.load_image_part(PartLoad::Factory);
            return;
        }
        if format >= 2 {
            let part = self.load_blob_v2(blob);
            self.model.load_image_part(PartLoad::Image(part));
            return;
        }
        let cfg = bincode::config::standard().with_limit::<{ 64 << 20 }>();
        if let Ok((img, _)) = bincode::serde::decode_from_slice::<InterpImage, _>(blob, cfg) {
            let mut img: InterpImage = img;
            img.bufs.capacity = user_memory_words(profile);
            self.model.bufs = img.bufs;
            for (k, a) in img
                .axes
                .into_iter()
                .enumerate()
                .take(self.model.run.axes.len())
            {
                self.model.run.axes[k] = a.filter(|(c, _)| *c >= 1 && *c <= lim.coords);
            }
        }
        self.model
            .load_image_part(PartLoad::Image(crate::model::ImagePart::default()));
    }

    /// The encoded image `SAVE` writes.
    pub(crate) fn save_image(&self) -> Vec<u8> {
        persist::encode(&self.model.state.to_image(self.interp_blob()))
    }

    /// `$$$` / start-up with the result of [`Effect::Load`]: reload the saved image (factory
    /// defaults without one, or when it is bad: then `???` word 1 bit 10 is set and the reason
    /// is returned).
    pub(crate) fn apply_loaded(&mut self, loaded: EffectResult) -> Result<(), String> {
        let image = match loaded {
            EffectResult::Loaded(Ok(Some(bytes))) => {
                persist::decode(&bytes).map(Some).map_err(|e| e.to_string())
            }
            EffectResult::Loaded(Ok(None)) => Ok(None),
            EffectResult::Loaded(Err(e)) => Err(e),
            EffectResult::Saved(_) => Err("not an image".into()),
        };
        let (image, mut result) = match image {
            Ok(img) => (img, Ok(())),
            Err(e) => (None, Err(e)),
        };
        let format = image.as_ref().map_or(0, |i| i.format);
        let blob = match self.model.state.reset(image.as_ref()) {
            Ok(b) => b,
            Err(e) => {
                let _ = self.model.state.reset(None);
                result = Err(e.to_string());
                Vec::new()
            }
        };
        self.load_blob(&blob, format);
        self.after_reset();
        if result.is_err() {
            // Saved data bad: factory defaults in use (`???` word 1 bit 10, EAROM error).
            self.model.state.global.word1_other |= EAROM_ERROR;
        }
        result
    }

    /// Common tail of every reset: no open buffer, status coords (the resetting session's
    /// chain addressing goes back to card 0 in `exec_info`).
    fn after_reset(&mut self) {
        self.mem.open = None;
        self.mem.pending_table = None;
        self.model.clear_actions();
        self.model.note_reset();
        self.model.sync_motor_coords();
        self.sync_global_flags();
    }

    /// `$$$***`: factory I-variables, programs and DEFINE'd buffers erased, password cleared;
    /// P/Q, M-definitions and axis definitions kept.
    pub(crate) fn reinit(&mut self) {
        let profile = self.model.profile();
        self.model.state.factory();
        self.model.bufs = Buffers::new(user_memory_words(profile));
        self.model.load_image_part(PartLoad::Reinit);
        self.mem.open = None;
        self.mem.pending_table = None;
        let lim = self.model.state.limits();
        let axes = std::mem::take(&mut self.model.run.axes);
        self.model.run = RunState::new(lim.motors, lim.coords, PLCS);
        self.model.run.axes = axes;
        self.model.push_action(crate::model::Action {
            motor: MotorNum::of(1),
            coord: CsNum::of(1),
            kind: crate::model::ActionKind::KillAll,
        });
        self.model.note_reset();
        self.model.sync_motor_coords();
        self.sync_global_flags();
    }

    /// Buffer-open bits of the global status word.
    pub(crate) fn sync_global_flags(&mut self) {
        use crate::model::BufId;
        let i18 = self.model.state.peek_ivar(18).unwrap_or(10.0);
        let nearly_full = (self.model.bufs.free() as f64) < i18;
        let id = self.mem.open.map(|o| o.id);
        let binary = self.mem.open.is_some_and(|o| o.binary);
        let g = &mut self.model.state.global;
        g.motion_buffer_open = matches!(id, Some(BufId::Prog(_)) | Some(BufId::Rot));
        g.rotary_open = matches!(id, Some(BufId::Rot));
        g.plc_open = matches!(id, Some(BufId::Plc(_)));
        g.binary_rotary = binary;
        g.buffer_nearly_full = nearly_full;
        self.note_memory_end();
    }

    /// PMAC2 X:$0F3F: the end of unreserved memory (seed 7768-7778). The DEFINE'd buffers
    /// (UBUFFER first, then tables, TBUF, rotary buffers, GATHER) stack down from $9FFF, so
    /// it holds $A000 with none and the start of the lowest one otherwise.
    fn note_memory_end(&mut self) {
        if self.model.profile() != crate::domain::profile::Profile::Pmac2 {
            return;
        }
        let b = &self.model.bufs;
        let rot: u64 = b.rotary.values().map(|r| u64::from(r.size)).sum();
        let end = MEMORY_END.saturating_sub(b.defines.words() + rot);
        self.model
            .state
            .memory
            .write(crate::model::Space::X, UNRESERVED_END_REG, end as u32);
    }
}
