//! Shell emulation: byte-exact terminal output for what host tools send.

use super::ShellOut::*;
use super::*;

const PROMPT: &[u8] = b"root@powerpmac:/opt/ppmac# ";

fn tty() -> Option<TtyModes> {
    Some(TtyModes::default())
}

fn bytes(s: &[u8]) -> ShellOut {
    Bytes(s.to_vec())
}

/// What the channel carries for `outs`, answering every card line with `answer(line)`.
fn transcript(sh: &Shell, outs: &[ShellOut], answer: impl Fn(&[u8]) -> Vec<u8>) -> Vec<u8> {
    let mut v = Vec::new();
    for o in outs {
        match o {
            Bytes(b) => v.extend_from_slice(b),
            Line(l) => v.extend_from_slice(&sh.reply(&answer(l))),
            _ => {}
        }
    }
    v
}

#[test]
fn login_prompt_has_the_user_and_an_at_sign() {
    let (_, out) = Shell::interactive("root", tty());
    assert_eq!(out, vec![bytes(PROMPT)]);
    let (_, out) = Shell::interactive("ops", None);
    assert_eq!(out, vec![bytes(b"ops@powerpmac:/opt/ppmac$ ")]);
}

/// dls_pmaclib's `PPmacSshInterface`: waits for "@", sends `gpascii -2\r\n`, waits for
/// "ASCII", then sends `cmd\r\n` and reads until `ACK CR LF ACK CR LF`, strips the echoed
/// command by its length and the `CR LF CR LF` after it.
#[test]
fn ppmac_ssh_interface_exchange_is_byte_exact() {
    let (mut sh, _) = Shell::interactive("root", tty());
    let out = sh.feed(b"gpascii -2\r\n");
    assert_eq!(
        out,
        vec![
            bytes(b"gpascii -2\r\n\r\n"),
            Begin,
            bytes(b"STDIN Open for ASCII Input\r\n"),
            // The LF after the CR is an empty line for gpascii, as through a real terminal.
            Line(Vec::new()),
        ]
    );
    assert!(sh.in_gpascii());
    let out = sh.feed(b"cid\r\n");
    assert_eq!(
        out,
        vec![
            bytes(b"cid\r\n\r\n"),
            Line(b"cid".to_vec()),
            Line(Vec::new())
        ]
    );
    // The dialect's replies (CR LF line ends, ACK CR LF) through the terminal.
    let seen = transcript(&sh, &out, |l| {
        if l.is_empty() {
            b"\x06\r\n".to_vec()
        } else {
            b"604020\r\n\x06\r\n".to_vec()
        }
    });
    assert_eq!(seen, b"cid\r\n\r\n604020\r\n\x06\r\n\x06\r\n");
    // The client's own post-processing yields the bare number.
    let text = String::from_utf8(seen).unwrap();
    let r = text[3..]
        .replace("\r\n\r\n", "")
        .replace("\r\n", "\r")
        .replace('\x06', "")
        .replace("\r\r\r", "\r");
    assert_eq!(r, "604020\r");
}

#[test]
fn ctrl_c_leaves_gpascii_for_the_prompt_and_exit_logs_out() {
    let (mut sh, _) = Shell::interactive("root", tty());
    sh.feed(b"gpascii -2\r");
    let out = sh.feed(b"P1\r\x03");
    assert_eq!(
        out,
        vec![
            bytes(b"P1\r\n^C"),
            Line(b"P1".to_vec()),
            End,
            Bytes([b"\r\n".as_slice(), PROMPT].concat()),
        ]
    );
    assert!(!sh.in_gpascii());
    let out = sh.feed(b"exit\r");
    assert_eq!(out, vec![bytes(b"exit\r\n"), bytes(b"logout\r\n"), Exit(0)]);
    assert!(sh.done());
    assert_eq!(sh.feed(b"gpascii\r"), vec![]);
}

#[test]
fn other_commands_get_a_clear_shell_error() {
    let (mut sh, _) = Shell::interactive("root", tty());
    let out = sh.feed(b"ls -l /var/ftp\r");
    assert_eq!(
        out,
        vec![
            bytes(b"ls -l /var/ftp\r\n"),
            bytes(
                b"-sh: ls: command not found (this controller's shell runs gpascii -2 and \
                  exit)\r\n"
            ),
            bytes(PROMPT),
        ]
    );
    let out = sh.feed(b"gpascii -f x\r");
    assert_eq!(
        out[1],
        bytes(b"gpascii: unsupported option '-f' (this controller takes -2)\r\n")
    );
    assert!(!sh.in_gpascii());
    let out = sh.feed(b"exit 3 4\r");
    assert_eq!(out[1], bytes(b"-sh: exit: numeric argument required\r\n"));
    assert!(!sh.done());
    assert_eq!(sh.feed(b"\r"), vec![bytes(b"\r\n"), bytes(PROMPT)]);
    assert_eq!(sh.feed(b"logout 300\r").last(), Some(&Exit(300 & 0xFF)));
}

#[test]
fn line_editing_erases_and_kills() {
    let (mut sh, _) = Shell::interactive("root", tty());
    sh.feed(b"gpascii\r");
    let out = sh.feed(b"P12\x7f3\r");
    assert_eq!(out[0], bytes(b"P12\x08 \x083\r\n"));
    assert_eq!(out[1], Line(b"P13".to_vec()));
    // Erasing an empty line echoes nothing; CTRL-U kills what was typed.
    let out = sh.feed(b"\x08ab\x15cd\r");
    assert_eq!(out[0], bytes(b"ab\x08 \x08\x08 \x08cd\r\n"));
    assert_eq!(out[1], Line(b"cd".to_vec()));
    // Other control characters are not part of a line.
    assert_eq!(sh.feed(b"\x01\tx\r")[1], Line(b"x".to_vec()));
}

#[test]
fn ctrl_d_on_an_empty_line_is_end_of_input() {
    let (mut sh, _) = Shell::interactive("root", tty());
    sh.feed(b"gpascii -2\r");
    // Not on a partial line.
    assert_eq!(sh.feed(b"P\x04"), vec![bytes(b"P")]);
    sh.feed(b"\x15");
    assert_eq!(sh.feed(b"\x04"), vec![End, bytes(b"logout\r\n"), Exit(0)]);
    let (mut sh, _) = Shell::interactive("root", tty());
    assert_eq!(sh.feed(b"\x04"), vec![bytes(b"logout\r\n"), Exit(0)]);
}

#[test]
fn terminal_modes_are_honoured() {
    let modes = TtyModes {
        echo: false,
        icrnl: true,
        onlcr: false,
    };
    let (mut sh, _) = Shell::interactive("root", Some(modes));
    let out = sh.feed(b"gpascii -2\r");
    assert_eq!(out, vec![Begin, bytes(b"STDIN Open for ASCII Input\n")]);
    let out = sh.feed(b"vers\r");
    assert_eq!(out, vec![Line(b"vers".to_vec())]);
    assert_eq!(sh.reply(b"2.6.0.0\r\n\x06\r\n"), b"2.6.0.0\n\x06\n");
    // A CR that does not end a line is the program's own.
    assert_eq!(sh.reply(b"a\rb\r\n"), b"a\rb\n");
}

#[test]
fn overlong_lines_are_refused_without_running() {
    let (mut sh, _) = Shell::interactive(
        "root",
        Some(TtyModes {
            echo: false,
            ..TtyModes::default()
        }),
    );
    sh.feed(b"gpascii -2\r");
    let mut long = vec![b'P'; MAX_LINE + 20];
    long.push(b'\r');
    // The dialect gets the line cut to one byte over its limit and refuses it.
    assert_eq!(sh.feed(&long), vec![Line(vec![b'P'; MAX_LINE + 1])]);
    // Exactly the limit is a line; the shell refuses an over-long command too.
    let mut ok = vec![b'P'; MAX_LINE];
    ok.push(b'\r');
    assert_eq!(sh.feed(&ok), vec![Line(vec![b'P'; MAX_LINE])]);
    sh.feed(b"\x03");
    let out = sh.feed(&long);
    assert_eq!(out[0], bytes(b"-sh: command line too long\r\n"));
    assert!(!sh.in_gpascii());
}

#[test]
fn exec_sessions_run_one_command() {
    // `exec gpascii -2` without a terminal: lines end at LF, the session ends at EOF.
    let (mut sh, out) = Shell::exec(b"gpascii -2", None);
    assert_eq!(out, vec![Begin, bytes(b"STDIN Open for ASCII Input\n")]);
    assert_eq!(
        sh.feed(b"cid\r\n\n"),
        vec![Line(b"cid".to_vec()), Line(Vec::new())]
    );
    assert_eq!(sh.eof(), vec![End, Exit(0)]);
    assert!(sh.done());
    // Anything else: the error on stderr and status 127.
    let (sh, out) = Shell::exec(b"cat /var/ftp/usrflash/Database/pp_swtbl1.sym\n", None);
    assert_eq!(
        out,
        vec![
            Stderr(
                b"-sh: cat: command not found (this controller's shell runs gpascii -2 and \
                  exit)\n"
                    .to_vec()
            ),
            Exit(NOT_FOUND),
        ]
    );
    assert!(sh.done());
    let (_, out) = Shell::exec(b"", None);
    assert_eq!(out, vec![Exit(0)]);
    // With a terminal, CTRL-C interrupts the exec'd gpascii.
    let (mut sh, _) = Shell::exec(b"gpascii -2", tty());
    assert_eq!(sh.feed(b"\x03"), vec![bytes(b"^C"), End, Exit(130)]);
}

#[test]
fn arbitrary_bytes_never_panic() {
    let (mut sh, _) = Shell::interactive("root", tty());
    let mut x: u32 = 12345;
    for _ in 0..2000 {
        let mut chunk = Vec::new();
        for _ in 0..(x % 64) {
            x = x.wrapping_mul(1103515245).wrapping_add(12345);
            chunk.push((x >> 16) as u8);
        }
        let _ = sh.feed(&chunk);
        if sh.done() {
            let (s, _) = Shell::interactive("root", tty());
            sh = s;
            let _ = sh.feed(b"gpascii -2\r");
        }
    }
}
