//! Typed text ↔ chain bytes, for the terminal and `mcc send`.
//!
//! Input: `^` followed by a letter is that control character (`^K` = 0x0B, `^k` too), `^^`
//! is a literal `^` (PMAC's `J^` jog needs it only before a digit, sign or `(`, where `^`
//! stays literal anyway). Real control bytes pass through. A line holding only control
//! characters is sent as they are (they act at once, as on a PMAC terminal); any other line
//! gets a `<CR>`.
//!
//! Output: by default `<CR>` becomes a new line and `<ACK>`/`<LF>` are dropped, `<BELL>` shows
//! as `<BELL>` (an error follows it); with framing shown, every control byte is written as
//! `<ACK>`, `<CR>`, `<LF>`, `<BELL>` or `<0xNN>`.

/// A typed line as chain bytes.
pub fn translate(line: &str) -> Vec<u8> {
    let b = line.as_bytes();
    let mut out = Vec::with_capacity(b.len() + 1);
    let mut i = 0;
    while let Some(&c) = b.get(i) {
        match (c, b.get(i + 1)) {
            (b'^', Some(&b'^')) => {
                out.push(b'^');
                i += 2;
            }
            (b'^', Some(&n)) if n.is_ascii_alphabetic() => {
                out.push(n.to_ascii_uppercase() - b'@');
                i += 2;
            }
            _ => {
                out.push(c);
                i += 1;
            }
        }
    }
    let only_controls = !out.is_empty() && out.iter().all(|&c| c < 0x20);
    if !only_controls {
        out.push(b'\r');
    }
    out
}

fn name(c: u8) -> Option<&'static str> {
    Some(match c {
        0x06 => "<ACK>",
        0x07 => "<BELL>",
        0x0A => "<LF>",
        0x0D => "<CR>",
        _ => return None,
    })
}

/// Reply bytes as text for a terminal.
pub fn render(reply: &[u8], show_framing: bool) -> String {
    let mut s = String::new();
    let mut after_bell = false;
    for &c in reply {
        // Plain: the <CR>/<LF> right after <BELL> only frames the ERRnnn that follows.
        if std::mem::take(&mut after_bell) && !show_framing && (c == 0x0D || c == 0x0A) {
            after_bell = true;
            continue;
        }
        if show_framing && c < 0x20 {
            match name(c) {
                Some(n) => s.push_str(n),
                None => s.push_str(&format!("<0x{c:02X}>")),
            }
            if c == 0x0D {
                s.push('\n');
            }
            continue;
        }
        match c {
            0x0D => s.push('\n'),
            0x06 | 0x0A => {}
            0x07 => {
                s.push_str("<BELL>");
                after_bell = true;
            }
            0x20..=0x7E => s.push(char::from(c)),
            _ => s.push_str(&format!("<0x{c:02X}>")),
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn carets_become_control_characters() {
        assert_eq!(translate("^K"), b"\x0b");
        assert_eq!(translate("^k^a"), b"\x0b\x01");
        assert_eq!(translate("#1J^1000"), b"#1J^1000\r");
        assert_eq!(translate("P1^^"), b"P1^\r");
        assert_eq!(translate("P1^B"), b"P1\x02\r");
        assert_eq!(translate("\x0b"), b"\x0b");
        assert_eq!(translate(""), b"\r");
        assert_eq!(translate("^"), b"^\r");
        assert_eq!(translate("@1P1"), b"@1P1\r");
    }

    #[test]
    fn replies_render_plain_or_with_framing() {
        assert_eq!(render(b"5\r\x06", false), "5\n");
        assert_eq!(render(b"\n5\r\n", false), "5\n");
        assert_eq!(render(b"\x07ERR003\r", false), "<BELL>ERR003\n");
        assert_eq!(render(b"\x07\r\nERR003\r", false), "<BELL>ERR003\n");
        assert_eq!(render(b"\n5\r\n", true), "<LF>5<CR>\n<LF>");
        assert_eq!(render(b"5\r\x06", true), "5<CR>\n<ACK>");
        assert_eq!(render(b"\x07\x01\xff", true), "<BELL><0x01><0xFF>");
    }
}
