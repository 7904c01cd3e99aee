//! The controller's Linux shell as far as host tools need it (pure): a prompt, `gpascii [-2]`
//! entering the command interpreter with its banner, `exit`/`logout`, and a clear error for
//! any other command. With a pseudo-terminal (`pty-req`) the shell also plays the terminal's
//! line discipline, as the host tools rely on it: input is echoed, `CR` becomes `LF` (ICRNL),
//! output `LF` becomes `CR LF` (ONLCR), `<BS>`/`<DEL>` erase, `<CTRL-U>` kills the line,
//! `<CTRL-C>` interrupts (it ends `gpascii`, as Power PMAC hosts use it to), `<CTRL-D>` on an
//! empty line is end of input. The echo of everything received comes before what it causes,
//! as on a real terminal (clients strip the echoed command by its length).
//!
//! The SSH server ([`super::server`]) turns [`ShellOut`] into channel data and card requests.

use crate::host::gpascii::{BANNER, MAX_LINE};

/// The terminal modes the shell honours (the `pty-req` modes; Linux defaults when absent).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct TtyModes {
    /// ECHO: input is echoed.
    pub echo: bool,
    /// ICRNL: a received `CR` is an `LF`.
    pub icrnl: bool,
    /// ONLCR: an output `LF` is sent as `CR LF`.
    pub onlcr: bool,
}

impl Default for TtyModes {
    fn default() -> Self {
        TtyModes {
            echo: true,
            icrnl: true,
            onlcr: true,
        }
    }
}

/// What the shell asks of its server, in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum ShellOut {
    /// Send these bytes on the channel (already terminal-processed).
    Bytes(Vec<u8>),
    /// Send these bytes on the channel's stderr (sessions without a terminal).
    Stderr(Vec<u8>),
    /// `gpascii` started: open a command thread on the card.
    Begin,
    /// Run this command line on the command thread (an over-long line cut to `MAX_LINE + 1`
    /// bytes: the dialect refuses it); send [`Shell::reply`] of the card's reply.
    Line(Vec<u8>),
    /// `gpascii` ended: release its command thread.
    End,
    /// The session ends with this exit status.
    Exit(u32),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Shell,
    Gpascii,
    Done,
}

/// One SSH session's shell.
#[derive(Debug, Clone)]
pub(crate) struct Shell {
    tty: Option<TtyModes>,
    mode: Mode,
    /// An `exec` session: it ends when its command does; no prompt.
    exec: bool,
    /// The line being typed (at most `MAX_LINE + 1` bytes: longer is too long).
    line: Vec<u8>,
    prompt: Vec<u8>,
}

/// Exit status of a command the shell does not have (as `sh`).
pub(crate) const NOT_FOUND: u32 = 127;
/// Exit status after `<CTRL-C>` (128 + SIGINT).
const INTERRUPTED: u32 = 130;

impl Shell {
    /// An interactive login shell of `user` (`tty`: the session has a terminal); its output
    /// at start (the prompt).
    pub(crate) fn interactive(user: &str, tty: Option<TtyModes>) -> (Shell, Vec<ShellOut>) {
        let prompt = if user == "root" {
            format!("{user}@powerpmac:/opt/ppmac# ")
        } else {
            format!("{user}@powerpmac:/opt/ppmac$ ")
        };
        let sh = Shell {
            tty,
            mode: Mode::Shell,
            exec: false,
            line: Vec::new(),
            prompt: prompt.into_bytes(),
        };
        let out = vec![ShellOut::Bytes(sh.prompt.clone())];
        (sh, out)
    }

    /// An `exec` session running `command`; its output at start.
    pub(crate) fn exec(command: &[u8], tty: Option<TtyModes>) -> (Shell, Vec<ShellOut>) {
        let mut sh = Shell {
            tty,
            mode: Mode::Shell,
            exec: true,
            line: Vec::new(),
            prompt: Vec::new(),
        };
        let mut out = Vec::new();
        let command = command.strip_suffix(b"\n").unwrap_or(command);
        if command.len() > MAX_LINE {
            sh.error(b"-sh: command line too long\n", &mut out);
            sh.finish(NOT_FOUND, &mut out);
        } else {
            sh.run_command(command, &mut out);
        }
        (sh, out)
    }

    /// The session has ended (no more input is read).
    #[cfg(test)]
    pub(crate) fn done(&self) -> bool {
        self.mode == Mode::Done
    }

    /// `gpascii` is running.
    #[cfg(test)]
    pub(crate) fn in_gpascii(&self) -> bool {
        self.mode == Mode::Gpascii
    }

    /// The bytes to send for the card's reply to a [`ShellOut::Line`]. The dialect answers
    /// as a host sees `gpascii` (lines and the ACK ended by `CR LF`); the program itself
    /// writes `LF`, so the terminal's modes decide: `CR LF` under ONLCR, `LF` without.
    pub(crate) fn reply(&self, card_reply: &[u8]) -> Vec<u8> {
        let mut program = Vec::with_capacity(card_reply.len());
        let mut it = card_reply.iter().peekable();
        while let Some(&b) = it.next() {
            if b == b'\r' && it.peek() == Some(&&b'\n') {
                continue;
            }
            program.push(b);
        }
        self.term(&program)
    }

    /// The client sent end of file: the running program and the session end.
    pub(crate) fn eof(&mut self) -> Vec<ShellOut> {
        let mut out = Vec::new();
        if self.mode != Mode::Done {
            self.finish(0, &mut out);
        }
        out
    }

    /// Feed bytes the client sent; what to do, in order (nothing once [`Shell::done`]).
    pub(crate) fn feed(&mut self, bytes: &[u8]) -> Vec<ShellOut> {
        let mut echo = Vec::new();
        let mut out = Vec::new();
        for &b in bytes {
            if self.mode == Mode::Done {
                break;
            }
            self.byte(b, &mut echo, &mut out);
        }
        if !echo.is_empty() {
            out.insert(0, ShellOut::Bytes(echo));
        }
        out
    }

    fn byte(&mut self, b: u8, echo: &mut Vec<u8>, out: &mut Vec<ShellOut>) {
        let Some(tty) = self.tty else {
            // No terminal: lines end at LF; a CR (of a CR LF) is dropped.
            match b {
                b'\n' => self.end_line(out),
                b'\r' => {}
                _ => self.push(b),
            }
            return;
        };
        let b = if tty.icrnl && b == b'\r' { b'\n' } else { b };
        let mut echoed = |bytes: &[u8]| {
            if tty.echo {
                echo.extend_from_slice(&term(Some(tty), bytes));
            }
        };
        match b {
            b'\n' => {
                echoed(b"\n");
                self.end_line(out);
            }
            0x7F | 0x08 => {
                if self.line.len() <= MAX_LINE && self.line.pop().is_some() {
                    echoed(b"\x08 \x08");
                }
            }
            0x15 => {
                for _ in 0..self.line.len() {
                    echoed(b"\x08 \x08");
                }
                self.discard_line();
            }
            0x03 => {
                echoed(b"^C");
                self.discard_line();
                self.interrupt(out);
            }
            0x04 if self.line.is_empty() => {
                let mut rest = self.eof();
                out.append(&mut rest);
            }
            0x00..=0x1F => {}
            _ => {
                echoed(&[b]);
                self.push(b);
            }
        }
    }

    fn push(&mut self, b: u8) {
        if self.line.len() <= MAX_LINE {
            self.line.push(b);
        }
    }

    fn discard_line(&mut self) {
        self.line.clear();
    }

    /// `<CTRL-C>`: ends `gpascii` (back to the prompt), or abandons the shell's line.
    fn interrupt(&mut self, out: &mut Vec<ShellOut>) {
        if self.mode == Mode::Gpascii {
            if self.exec {
                self.finish(INTERRUPTED, out);
                return;
            }
            out.push(ShellOut::End);
            self.mode = Mode::Shell;
        }
        let mut bytes = self.term(b"\n");
        bytes.extend_from_slice(&self.prompt);
        out.push(ShellOut::Bytes(bytes));
    }

    fn end_line(&mut self, out: &mut Vec<ShellOut>) {
        let line = std::mem::take(&mut self.line);
        match self.mode {
            // Every line (an empty one too: it counts, and is acknowledged) is the dialect's.
            Mode::Gpascii => out.push(ShellOut::Line(line)),
            Mode::Shell if line.len() > MAX_LINE => {
                self.error(b"-sh: command line too long\n", out);
                self.prompt_again(out);
            }
            Mode::Shell => {
                self.run_command(&line, out);
                if self.mode == Mode::Shell {
                    self.prompt_again(out);
                }
            }
            Mode::Done => {}
        }
    }

    fn prompt_again(&mut self, out: &mut Vec<ShellOut>) {
        if self.exec {
            return;
        }
        out.push(ShellOut::Bytes(self.prompt.clone()));
    }

    /// Run one shell command line.
    fn run_command(&mut self, line: &[u8], out: &mut Vec<ShellOut>) {
        let text = String::from_utf8_lossy(line);
        let words: Vec<&str> = text.split_whitespace().collect();
        match words.as_slice() {
            [] => {
                if self.exec {
                    self.finish(0, out);
                }
            }
            ["exit" | "logout", rest @ ..] => {
                let code = match rest {
                    [] => Some(0),
                    [n] => n.parse::<u32>().ok().map(|n| n & 0xFF),
                    _ => None,
                };
                match code {
                    Some(c) => self.finish(c, out),
                    None => {
                        self.error(b"-sh: exit: numeric argument required\n", out);
                        if self.exec {
                            self.finish(2, out);
                        }
                    }
                }
            }
            ["gpascii", opts @ ..] => {
                if let Some(bad) = opts.iter().find(|o| **o != "-2") {
                    let msg =
                        format!("gpascii: unsupported option '{bad}' (this controller takes -2)\n");
                    self.error(msg.as_bytes(), out);
                    if self.exec {
                        self.finish(1, out);
                    }
                    return;
                }
                self.mode = Mode::Gpascii;
                out.push(ShellOut::Begin);
                out.push(ShellOut::Bytes(self.term(BANNER)));
            }
            [name, ..] => {
                let msg = format!(
                    "-sh: {name}: command not found (this controller's shell runs \
                     gpascii -2 and exit)\n"
                );
                self.error(msg.as_bytes(), out);
                if self.exec {
                    self.finish(NOT_FOUND, out);
                }
            }
        }
    }

    /// An error message: on the terminal, or on stderr without one.
    fn error(&self, msg: &[u8], out: &mut Vec<ShellOut>) {
        if self.tty.is_some() {
            out.push(ShellOut::Bytes(self.term(msg)));
        } else {
            out.push(ShellOut::Stderr(msg.to_vec()));
        }
    }

    fn finish(&mut self, code: u32, out: &mut Vec<ShellOut>) {
        if self.mode == Mode::Gpascii {
            out.push(ShellOut::End);
        }
        if !self.exec && self.tty.is_some() {
            out.push(ShellOut::Bytes(self.term(b"logout\n")));
        }
        self.mode = Mode::Done;
        out.push(ShellOut::Exit(code));
    }

    /// Output through the terminal.
    fn term(&self, bytes: &[u8]) -> Vec<u8> {
        term(self.tty, bytes)
    }
}

/// Output through a terminal with modes `tty`: `LF` → `CR LF` under ONLCR.
fn term(tty: Option<TtyModes>, bytes: &[u8]) -> Vec<u8> {
    match tty {
        Some(t) if t.onlcr => {
            let mut v = Vec::with_capacity(bytes.len() + 8);
            for &b in bytes {
                if b == b'\n' {
                    v.push(b'\r');
                }
                v.push(b);
            }
            v
        }
        _ => bytes.to_vec(),
    }
}

#[cfg(test)]
#[path = "tests_shell.rs"]
mod tests;
