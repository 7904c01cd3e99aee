//! The printf-style formats of Power PMAC's `send n,"fmt",expr,…` (seed L43796-43912).
//!
//! Power PMAC builds the text with the C library's formatter, so the C rules are followed for
//! the subset offered here: flags `- + space 0 #`, a width and a precision (each at most
//! [`MAX_FIELD`]), length modifiers `h l ll L` (accepted, no effect) and the conversions
//! `d i` (signed), `u o x X` (unsigned 32-bit), `f F e E g G` (double) and `%%`. Values are
//! doubles: an integer conversion truncates toward zero (`%d` saturates to the 32-bit range,
//! the unsigned ones wrap as a C `int` converted to `unsigned` does, so -1 prints `ffffffff`).
//! `%s` (strings in user shared memory) and `%c` (the seed's repeat-count form differs from C)
//! are not offered: a format using them is refused at entry, as is a `*` width.

/// Largest width or precision a conversion may give.
pub(crate) const MAX_FIELD: usize = 64;

/// Most conversions (and so expressions) of one `send`.
pub(crate) const MAX_ARGS: usize = 32;

/// One conversion specification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Spec {
    left: bool,
    plus: bool,
    space: bool,
    zero: bool,
    alt: bool,
    width: usize,
    prec: Option<usize>,
    conv: u8,
}

/// A piece of a parsed format.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Piece {
    /// Literal bytes (`%%` already turned into `%`).
    Lit(Vec<u8>),
    /// A conversion taking the next value.
    Conv(Spec),
}

/// Parse `fmt`; `Err(k)`: the conversion starting at byte `k` is malformed or not offered.
pub(crate) fn parse(fmt: &[u8]) -> Result<Vec<Piece>, usize> {
    let mut out = Vec::new();
    let mut lit = Vec::new();
    let mut i = 0;
    while i < fmt.len() {
        let b = fmt[i];
        if b != b'%' {
            lit.push(b);
            i += 1;
            continue;
        }
        let at = i;
        i += 1;
        if fmt.get(i) == Some(&b'%') {
            lit.push(b'%');
            i += 1;
            continue;
        }
        let mut sp = Spec::default();
        while let Some(&f) = fmt.get(i) {
            match f {
                b'-' => sp.left = true,
                b'+' => sp.plus = true,
                b' ' => sp.space = true,
                b'0' => sp.zero = true,
                b'#' => sp.alt = true,
                _ => break,
            }
            i += 1;
        }
        sp.width = field(fmt, &mut i).ok_or(at)?.unwrap_or(0);
        if fmt.get(i) == Some(&b'.') {
            i += 1;
            sp.prec = Some(field(fmt, &mut i).ok_or(at)?.unwrap_or(0));
        }
        while matches!(fmt.get(i), Some(b'h' | b'l' | b'L')) {
            i += 1;
        }
        match fmt.get(i) {
            Some(&c @ (b'd' | b'i' | b'u' | b'o' | b'x' | b'X' | b'f' | b'F' | b'e' | b'E'))
            | Some(&c @ (b'g' | b'G')) => sp.conv = c,
            _ => return Err(at),
        }
        i += 1;
        if !lit.is_empty() {
            out.push(Piece::Lit(std::mem::take(&mut lit)));
        }
        out.push(Piece::Conv(sp));
    }
    if !lit.is_empty() {
        out.push(Piece::Lit(lit));
    }
    Ok(out)
}

/// Decimal digits of a width or precision: `Some(None)` when there are none, `None` when the
/// value exceeds [`MAX_FIELD`].
fn field(fmt: &[u8], i: &mut usize) -> Option<Option<usize>> {
    let start = *i;
    let mut v: usize = 0;
    while let Some(d) = fmt.get(*i).filter(|d| d.is_ascii_digit()) {
        v = v.saturating_mul(10).saturating_add(usize::from(d - b'0'));
        *i += 1;
    }
    if *i == start {
        return Some(None);
    }
    (v <= MAX_FIELD).then_some(Some(v))
}

/// How many values the format takes.
pub(crate) fn conversions(pieces: &[Piece]) -> usize {
    pieces
        .iter()
        .filter(|p| matches!(p, Piece::Conv(_)))
        .count()
}

/// The text of `pieces` with `vals` (a missing value counts as 0, extra ones are ignored).
pub(crate) fn format(pieces: &[Piece], vals: &[f64]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut k = 0;
    for p in pieces {
        match p {
            Piece::Lit(b) => out.extend_from_slice(b),
            Piece::Conv(sp) => {
                let v = vals.get(k).copied().unwrap_or(0.0);
                k += 1;
                conv(&mut out, sp, v);
            }
        }
    }
    out
}

fn conv(out: &mut Vec<u8>, sp: &Spec, v: f64) {
    let upper = sp.conv.is_ascii_uppercase();
    let (neg, body, numeric) = match sp.conv {
        b'd' | b'i' => {
            let n = i64::from(v as i32);
            (
                n < 0,
                int_digits(n.unsigned_abs(), 10, sp.prec, false),
                true,
            )
        }
        b'u' | b'o' | b'x' | b'X' => {
            let n = u64::from(v as i64 as u32);
            let radix = match sp.conv {
                b'u' => 10,
                b'o' => 8,
                _ => 16,
            };
            let mut d = int_digits(n, radix, sp.prec, upper);
            if sp.alt && n != 0 {
                match radix {
                    8 if !d.starts_with('0') => d.insert(0, '0'),
                    16 => d.insert_str(0, if upper { "0X" } else { "0x" }),
                    _ => {}
                }
            }
            (false, d, true)
        }
        _ if !v.is_finite() => {
            let t = if v.is_nan() { "nan" } else { "inf" };
            let t = if upper {
                t.to_ascii_uppercase()
            } else {
                t.into()
            };
            (v.is_sign_negative() && !v.is_nan(), t, false)
        }
        c => {
            let prec = sp.prec.unwrap_or(6);
            let a = v.abs();
            let s = match c.to_ascii_lowercase() {
                b'f' => fixed(a, prec, sp.alt),
                b'e' => exp(a, prec, sp.alt),
                _ => general(a, prec, sp.alt),
            };
            let s = if upper { s.to_ascii_uppercase() } else { s };
            (v.is_sign_negative(), s, true)
        }
    };
    let sign = if neg {
        "-"
    } else if sp.plus && !matches!(sp.conv, b'u' | b'o' | b'x' | b'X') {
        "+"
    } else if sp.space && !matches!(sp.conv, b'u' | b'o' | b'x' | b'X') {
        " "
    } else {
        ""
    };
    let len = sign.len() + body.len();
    let pad = sp.width.saturating_sub(len);
    // `0` pads after the sign; ignored when left-justified or (integers) with a precision.
    let int = matches!(sp.conv, b'd' | b'i' | b'u' | b'o' | b'x' | b'X');
    let zero = sp.zero && !sp.left && numeric && !(int && sp.prec.is_some());
    if sp.left {
        out.extend_from_slice(sign.as_bytes());
        out.extend_from_slice(body.as_bytes());
        out.extend(std::iter::repeat_n(b' ', pad));
    } else if zero {
        out.extend_from_slice(sign.as_bytes());
        // After a `0x` prefix, as C does.
        let (pre, rest) = match body.get(..2) {
            Some("0x" | "0X") => body.split_at(2),
            _ => ("", body.as_str()),
        };
        out.extend_from_slice(pre.as_bytes());
        out.extend(std::iter::repeat_n(b'0', pad));
        out.extend_from_slice(rest.as_bytes());
    } else {
        out.extend(std::iter::repeat_n(b' ', pad));
        out.extend_from_slice(sign.as_bytes());
        out.extend_from_slice(body.as_bytes());
    }
}

/// Digits of `n` in `radix`, at least `prec` of them (C: precision 0 and value 0 give none).
fn int_digits(n: u64, radix: u32, prec: Option<usize>, upper: bool) -> String {
    let mut s = match radix {
        8 => format!("{n:o}"),
        16 if upper => format!("{n:X}"),
        16 => format!("{n:x}"),
        _ => n.to_string(),
    };
    match prec {
        Some(0) if n == 0 => s.clear(),
        Some(p) if s.len() < p => s.insert_str(0, &"0".repeat(p - s.len())),
        _ => {}
    }
    s
}

/// `%f` of a non-negative finite value.
fn fixed(a: f64, prec: usize, alt: bool) -> String {
    let mut s = format!("{a:.prec$}");
    if alt && prec == 0 {
        s.push('.');
    }
    s
}

/// `%e` of a non-negative finite value: `d.ddde±XX`.
fn exp(a: f64, prec: usize, alt: bool) -> String {
    let s = format!("{a:.prec$e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    let mut m = m.to_string();
    if alt && prec == 0 {
        m.push('.');
    }
    format!(
        "{m}e{}{:02}",
        if e < 0 { '-' } else { '+' },
        e.unsigned_abs()
    )
}

/// `%g` of a non-negative finite value (C99 7.19.6.1).
fn general(a: f64, prec: usize, alt: bool) -> String {
    let p = if prec == 0 { 1 } else { prec };
    let e = format!("{a:.*e}", p - 1);
    let x: i64 = e
        .split_once('e')
        .and_then(|(_, x)| x.parse().ok())
        .unwrap_or(0);
    let mut s = if (x as i128) < p as i128 && x >= -4 {
        fixed(a, (p as i64 - 1 - x) as usize, alt)
    } else {
        exp(a, p - 1, alt)
    };
    if !alt {
        let (m, tail) = match s.find('e') {
            Some(k) => (s[..k].to_string(), s[k..].to_string()),
            None => (s.clone(), String::new()),
        };
        let m = if m.contains('.') {
            m.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            m
        };
        s = m + &tail;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(fmt: &str, vals: &[f64]) -> String {
        let p = parse(fmt.as_bytes()).unwrap();
        String::from_utf8(format(&p, vals)).unwrap()
    }

    #[test]
    fn c_conversions() {
        assert_eq!(
            f("n=%d|%5d|%-5d|%05d|%+d", &[42.9, -7.0, 3.0, -42.0, 5.0]),
            "n=42|   -7|3    |-0042|+5"
        );
        assert_eq!(f("%i %.3d %u", &[-3.7, 5.0, -1.0]), "-3 005 4294967295");
        assert_eq!(
            f("%x %X %08x %#x %o", &[255.0, 255.0, 48879.0, 255.0, 8.0]),
            "ff FF 0000beef 0xff 10"
        );
        assert_eq!(
            f(
                "%f %.2f %9.3f %-8.1f| %.0f",
                &[2.5, 1.23456, -1.5, 2.26, 2.6]
            ),
            "2.500000 1.23    -1.500 2.3     | 3"
        );
        assert_eq!(
            f(
                "%e %.2E %g %g %g %G",
                &[1234.5, 0.000123, 100000.0, 1e6, 0.0001, 1e-5]
            ),
            "1.234500e+03 1.23E-04 100000 1e+06 0.0001 1E-05"
        );
        assert_eq!(f("%g %.3g %#g", &[2.5, 1.23456, 1.0]), "2.5 1.23 1.00000");
        assert_eq!(
            f("100%% %f %F", &[f64::NAN, f64::NEG_INFINITY]),
            "100% nan -INF"
        );
        assert_eq!(f("%ld %lf", &[1.0, 1.0]), "1 1.000000");
    }

    #[test]
    fn refused_formats() {
        for bad in ["%s", "%c", "%*d", "%", "%5", "%.99f", "%100d", "%q"] {
            assert!(parse(bad.as_bytes()).is_err(), "{bad}");
        }
        assert_eq!(conversions(&parse(b"a%db%%c%5.1f").unwrap()), 2);
    }
}
