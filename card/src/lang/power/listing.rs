//! Reading programs back (seed §2.7, L33567-33602 and L36521-36754): `list prog|subprog|plc n`
//! with the seed's line-number forms, and `buffer` (each stored buffer's name, offset and
//! size). The dialect keeps each closed buffer's text as it was entered (comments and blank
//! lines dropped, surrounding white space trimmed): the lines `list` shows and numbers from 0.

use crate::domain::PowerErr;
use crate::model::DEFAULT_STACK_OFFSET;
use std::collections::BTreeMap;

use super::{exec, Thread};
use crate::domain::profile::POWER_SUBPROG_BASE;
use crate::lang::Card;
use crate::model::BufId;

/// Longest listing one command sends (lines), as for other list replies.
const MAX_LIST_LINES: usize = 8192;

/// The text of every closed buffer, in the order `buffer` reports them (motion programs,
/// subprograms, PLCs; each by number).
#[derive(Debug, Default)]
pub(crate) struct Sources(
    BTreeMap<(u8, u32), Vec<String>>,
    /// How many stored lines each text line became (a line with several block statements is
    /// stored as several: see `program::stored_lines`).
    BTreeMap<(u8, u32), Vec<usize>>,
    /// Stack offsets other than the default (`open prog n,{offset}`).
    BTreeMap<(u8, u32), u32>,
);

/// The listing order and number of buffer `id`.
fn key(id: BufId) -> (u8, u32) {
    match id {
        BufId::Prog(n) if n >= POWER_SUBPROG_BASE => (1, u32::from(n - POWER_SUBPROG_BASE)),
        BufId::Prog(n) => (0, u32::from(n)),
        BufId::Plc(n) => (2, u32::from(n)),
        BufId::Rot => (3, 0),
    }
}

fn id_of(kind: u8, n: u32) -> Option<BufId> {
    match kind {
        0 if (1..=32_767).contains(&n) => Some(BufId::Prog(n as u16)),
        1 if n <= 32_767 => Some(BufId::Prog(POWER_SUBPROG_BASE + n as u16)),
        2 if n <= 31 => Some(BufId::Plc(n as u8)),
        _ => None,
    }
}

impl Sources {
    /// Buffer `id` closed with `text`, its line `i` stored as `stored[i]` lines, its stack
    /// offset `stack`.
    pub(crate) fn insert(&mut self, id: BufId, text: Vec<String>, stored: Vec<usize>, stack: u32) {
        self.0.insert(key(id), text);
        self.1.insert(key(id), stored);
        if stack == DEFAULT_STACK_OFFSET {
            self.2.remove(&key(id));
        } else {
            self.2.insert(key(id), stack);
        }
    }

    pub(crate) fn remove(&mut self, id: &BufId) {
        self.0.remove(&key(*id));
        self.1.remove(&key(*id));
        self.2.remove(&key(*id));
    }

    /// The stack offset of buffer `id`.
    pub(crate) fn stack(&self, id: BufId) -> u32 {
        self.2
            .get(&key(id))
            .copied()
            .unwrap_or(DEFAULT_STACK_OFFSET)
    }

    /// The text line of buffer `id` that stored line `k` came from (`None`: past the text).
    fn text_line(&self, id: BufId, k: usize) -> Option<usize> {
        let counts = self.1.get(&key(id))?;
        let mut first = 0;
        for (i, c) in counts.iter().enumerate() {
            if k < first + c {
                return Some(i);
            }
            first += c;
        }
        None
    }

    /// Every buffer's text, in `buffer` order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (BufId, &Vec<String>)> {
        self.0
            .iter()
            .filter_map(|(&(kind, n), l)| id_of(kind, n).map(|id| (id, l)))
    }
}

/// Buffer kinds by name (saved images).
const KINDS: [(&str, u8); 3] = [("prog", 0), ("subprog", 1), ("plc", 2)];

/// The kind name and Power number of buffer `id`.
pub(crate) fn name_of(id: BufId) -> Option<(&'static str, u32)> {
    let (kind, n) = key(id);
    KINDS.iter().find(|k| k.1 == kind).map(|k| (k.0, n))
}

/// The buffer of kind `name` number `n`.
pub(crate) fn id_named(name: &str, n: u32) -> Option<BufId> {
    KINDS
        .iter()
        .find(|k| k.0 == name)
        .and_then(|k| id_of(k.1, n))
}

/// The listed form of one line entered into a buffer: without its `//` comment and outer
/// white space; `None` for a line with nothing left.
pub(crate) fn text_of(line: &[u8]) -> Option<String> {
    let s = String::from_utf8_lossy(line);
    let s = s.split("//").next().unwrap_or_default().trim();
    (!s.is_empty()).then(|| s.to_string())
}

/// What a `list` names: which lines, numbered or not.
#[derive(Debug, PartialEq)]
struct Range {
    first: usize,
    count: Option<usize>,
    numbered: bool,
}

/// `list {prog|subprog|plc} n[,[a[,b]]]`: the buffer kind, number and range; `Err(())` for
/// a malformed one.
fn parse_list(rest: &str) -> Result<(u8, u32, Range), ()> {
    let rest = rest.trim_start();
    let (kind, after) = [("subprog", 1u8), ("prog", 0), ("plc", 2)]
        .iter()
        .find_map(|(w, k)| rest.strip_prefix(w).map(|a| (*k, a)))
        .ok_or(())?;
    let mut parts = after.split(',');
    let n: u32 = parts
        .next()
        .unwrap_or_default()
        .trim()
        .parse()
        .map_err(|_| ())?;
    let nums: Vec<&str> = parts.map(str::trim).collect();
    let num = |t: &str| t.parse::<usize>().map_err(|_| ());
    let range = match nums.as_slice() {
        [] => Range {
            first: 0,
            count: None,
            numbered: false,
        },
        [""] => Range {
            first: 0,
            count: None,
            numbered: true,
        },
        [c] => Range {
            first: 0,
            count: Some(num(c)?),
            numbered: true,
        },
        [a, c] => Range {
            first: num(a)?,
            count: Some(num(c)?),
            numbered: true,
        },
        _ => return Err(()),
    };
    Ok((kind, n, range))
}

fn name(kind: u8, n: u32) -> String {
    match kind {
        0 => format!("Prog{n}"),
        1 => format!("SubProg{n}"),
        _ => format!("Plc{n}"),
    }
}

/// `list …` and `buffer` alone on a line: the thread's framed output (`None`: not one of
/// them).
pub(crate) fn command(
    card: &mut Card,
    sources: &Sources,
    kin: &super::kinematics::Routines,
    th: &mut Thread,
    line: &[u8],
) -> Option<Vec<u8>> {
    let text = String::from_utf8_lossy(line).trim().to_ascii_lowercase();
    let mut out = Vec::new();
    let mut say = |s: &str| {
        out.extend_from_slice(s.as_bytes());
        out.extend_from_slice(b"\r\n");
    };
    if text == "buffer" {
        th.lines += 1;
        // Offsets count the program memory's bytes in the order listed; a buffer's size is
        // the bytes of its text (each line with its terminator).
        let mut offset = 0usize;
        for (&(kind, n), lines) in &sources.0 {
            let exists = id_of(kind, n).is_some_and(|id| card.model.bufs.program(id).is_some());
            if !exists {
                continue;
            }
            let size: usize = lines.iter().map(|l| l.len() + 1).sum();
            say(&format!("{} offset {offset}, size {size}", name(kind, n)));
            offset += size;
        }
        out.extend_from_slice(&exec::frame(th, line, None));
        return Some(out);
    }
    let rest = text.strip_prefix("list")?;
    if !rest.starts_with(|c: char| c.is_ascii_whitespace()) {
        return None;
    }
    th.lines += 1;
    let bad = |code| {
        Some(exec::frame(
            th,
            line,
            Some(super::parse::SyntaxError { at: 0, code }),
        ))
    };
    if let Some(r) = list_pc(card, sources, th, rest) {
        return match r {
            Ok(lines) => {
                for l in lines {
                    say(&l);
                }
                out.extend_from_slice(&exec::frame(th, line, None));
                Some(out)
            }
            Err(code) => bad(code),
        };
    }
    if let Some(r) = super::kinematics::list(kin, th, rest.trim()) {
        return match r {
            Ok(lines) => {
                lines.iter().for_each(|l| say(l));
                out.extend_from_slice(&exec::frame(th, line, None));
                Some(out)
            }
            Err(code) => bad(code),
        };
    }
    let Ok((kind, n, range)) = parse_list(rest) else {
        let other = ["forward", "inverse", "rotary"];
        let w = rest
            .trim_start()
            .split([' ', ','])
            .next()
            .unwrap_or_default();
        return bad(if other.contains(&w) {
            PowerErr::NotSupported
        } else {
            PowerErr::IllegalCmd
        });
    };
    let Some(id) = id_of(kind, n) else {
        return bad(PowerErr::IllegalParameter);
    };
    if card.model.bufs.program(id).is_none() {
        return bad(PowerErr::IllegalParameter);
    }
    let empty = Vec::new();
    let lines = sources.0.get(&(kind, n)).unwrap_or(&empty);
    let count = range.count.unwrap_or(usize::MAX).min(MAX_LIST_LINES);
    for (i, l) in lines.iter().enumerate().skip(range.first).take(count) {
        if range.numbered {
            say(&format!("{i}:{l}"));
        } else {
            say(l);
        }
    }
    out.extend_from_slice(&exec::frame(th, line, None));
    Some(out)
}

/// `list pc[,[n]]` / `list apc[,[n]]` (seed L36521-36570, L36669-36720): the addressed
/// C.S.'s program from its program counter (`apc`: where it was when last aborted); with a
/// comma numbered and headed by the program's name, the end of the program as `end`. `None`:
/// not one of them.
fn list_pc(
    card: &Card,
    sources: &Sources,
    th: &Thread,
    rest: &str,
) -> Option<Result<Vec<String>, PowerErr>> {
    let rest = rest.trim();
    let (abort, after) = if let Some(a) = rest.strip_prefix("apc") {
        (true, a)
    } else {
        (false, rest.strip_prefix("pc")?)
    };
    let after = after.trim_start();
    if !(after.is_empty() || after.starts_with(',')) {
        return None;
    }
    let (numbered, count) = match after.strip_prefix(',').map(str::trim) {
        None => (false, None),
        Some("") => (true, None),
        Some(c) => match c.parse::<usize>() {
            Ok(c) => (true, Some(c)),
            Err(_) => return Some(Err(PowerErr::IllegalCmd)),
        },
    };
    let run = card.model.run.cs.get(usize::from(th.coord))?;
    let at = if abort {
        run.apc_at
    } else {
        run.pc_at.or(run.pointer.map(|(p, _)| (p, 0)))
    };
    let Some((prog, offset)) = at else {
        return Some(Ok(Vec::new()));
    };
    let id = match u16::try_from(prog) {
        Ok(0) | Err(_) => return Some(Err(PowerErr::NotSupported)),
        Ok(n) => BufId::Prog(n),
    };
    let Some(p) = card.model.bufs.program(id) else {
        return Some(Err(PowerErr::IllegalParameter));
    };
    // The stored line holding the word offset, and the text line it came from (past the
    // text: the `return` close appended, listed as `end`).
    let mut words = 0u64;
    let mut stored = p.lines.len();
    for (i, l) in p.lines.iter().enumerate() {
        words += u64::from(crate::model::StoredLine::words(l));
        if words > u64::from(offset) {
            stored = i;
            break;
        }
    }
    let empty = Vec::new();
    let text = sources.0.get(&key(id)).unwrap_or(&empty);
    let first = sources.text_line(id, stored).unwrap_or(text.len());
    let mut lines: Vec<(usize, &str)> = text.iter().map(String::as_str).enumerate().collect();
    if numbered {
        lines.push((text.len(), "end"));
    }
    let mut out = Vec::new();
    if numbered {
        let (kind, n) = name_of(id)?;
        out.push(format!("{kind} {n}"));
    }
    let take = count.unwrap_or(usize::MAX).min(MAX_LIST_LINES);
    for (i, l) in lines.into_iter().skip(first).take(take) {
        out.push(if numbered {
            format!("{i}:{l}")
        } else {
            l.to_string()
        });
    }
    Some(Ok(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn list_forms_of_the_seed() {
        let r = |first, count, numbered| Range {
            first,
            count,
            numbered,
        };
        assert_eq!(parse_list(" prog 2000"), Ok((0, 2000, r(0, None, false))));
        assert_eq!(parse_list(" prog 2000,"), Ok((0, 2000, r(0, None, true))));
        assert_eq!(parse_list(" plc 10, 5"), Ok((2, 10, r(0, Some(5), true))));
        assert_eq!(
            parse_list(" subprog 1000, 8, 20"),
            Ok((1, 1000, r(8, Some(20), true)))
        );
        assert_eq!(parse_list(" prog3"), Ok((0, 3, r(0, None, false))));
        assert_eq!(parse_list(" prog x"), Err(()));
        assert_eq!(parse_list(" prog 1,2,3,4"), Err(()));
        assert_eq!(parse_list(" rotary"), Err(()));
    }
}
