//! The interactive terminal on the daisy chain (`mcc up` in the foreground, `mcc term`): type
//! PMAC command lines (with `@n`, `@@`, `@`), control characters as `^K` (or the real byte,
//! e.g. Ctrl-V Ctrl-K in the editor), read the replies. Meta commands start with a dot:
//! `.status` (or an empty line) prints a one-line cluster status, `.framing` toggles showing
//! `<ACK>`/`<CR>`/`<LF>`/`<BELL>`, `.help`, `.quit` (Ctrl-D too). With a terminal on stdin
//! it uses a line editor with history (rustyline); otherwise it reads lines from stdin.

use std::io::{BufRead, IsTerminal, Read, Write};

use std::time::Duration;

use anyhow::Result;

use crate::cluster::chain::link::ChainLink;
use crate::cluster::chain::text::{render, translate};
use crate::cluster::status::ClusterStatus;

/// Help text of the terminal.
pub const HELP: &str = "\
PMAC command lines go to the daisy chain; `@n` addresses card n, `@@` all cards, `@` reports.
^A..^Z (caret + letter) sends a control character, e.g. ^K kills every card's motors;
^^ is a literal caret. Meta commands: .status (or empty line), .framing, .help, .quit.";

/// What the terminal does after a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// Read the next line.
    Continue,
    /// Leave the terminal.
    Quit,
}

/// A terminal session on one chain connection.
pub struct Terminal<'a> {
    link: &'a ChainLink,
    /// Show framing characters.
    pub show_framing: bool,
    status: Box<dyn Fn() -> String + 'a>,
    /// Where asynchronous cluster events are printed (the editor's external printer while the
    /// editor runs, so the line being typed is kept).
    printer: Option<crate::cluster::events::Printer>,
}

impl std::fmt::Debug for Terminal<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Terminal")
            .field("link", &self.link)
            .field("show_framing", &self.show_framing)
            .finish_non_exhaustive()
    }
}

impl<'a> Terminal<'a> {
    /// A terminal on `link`; `status` produces the one-line cluster status.
    pub fn new(link: &'a ChainLink, show_framing: bool, status: impl Fn() -> String + 'a) -> Self {
        Terminal {
            link,
            show_framing,
            status: Box::new(status),
            printer: None,
        }
    }

    /// Print asynchronous events through `printer` (installs the editor's external printer).
    pub fn with_printer(mut self, printer: crate::cluster::events::Printer) -> Self {
        self.printer = Some(printer);
        self
    }

    /// Handle one typed line, writing what the user sees to `out` (notes to `err`).
    pub fn line(&mut self, line: &str, out: &mut dyn Write, err: &mut dyn Write) -> Flow {
        let t = line.trim();
        match t.to_ascii_lowercase().as_str() {
            ".quit" | ".exit" | ".q" => return Flow::Quit,
            "" | ".status" | ".s" => {
                let _ = writeln!(out, "{}", (self.status)());
                return Flow::Continue;
            }
            ".framing" | ".f" => {
                self.show_framing = !self.show_framing;
                let on = if self.show_framing { "shown" } else { "hidden" };
                let _ = writeln!(out, "(framing characters {on})");
                return Flow::Continue;
            }
            ".help" | ".h" | ".?" => {
                let _ = writeln!(out, "{HELP}");
                return Flow::Continue;
            }
            m if m.starts_with('.') => {
                let _ = writeln!(err, "unknown meta command {t:?} (.help lists them)");
                return Flow::Continue;
            }
            _ => {}
        }
        let bytes = translate(line.trim_end_matches(['\r', '\n']));
        let r = self.link.send(&bytes);
        let mut text = render(&r.bytes, self.show_framing);
        if !text.is_empty() && !text.ends_with('\n') {
            text.push('\n');
        }
        let _ = out.write_all(text.as_bytes());
        let _ = out.flush();
        if !r.silent.is_empty() {
            let _ = writeln!(err, "(card(s) {:?} did not answer in time)", r.silent);
        }
        Flow::Continue
    }

    /// Run until `.quit`, Ctrl-D or end of input.
    pub fn run(&mut self) -> Result<()> {
        if std::io::stdin().is_terminal() {
            self.run_editor()
        } else {
            self.run_lines(&mut std::io::stdin().lock())
        }
    }

    /// Lines from a reader (a pipe or file), no editor.
    pub fn run_lines(&mut self, input: &mut dyn BufRead) -> Result<()> {
        let mut buf = Vec::new();
        loop {
            buf.clear();
            // Bounded: a line longer than this is cut (the cards reject over-long lines).
            let n = (&mut *input).take(64 * 1024).read_until(b'\n', &mut buf)?;
            if n == 0 {
                return Ok(());
            }
            let line = String::from_utf8_lossy(&buf).into_owned();
            let line = line.trim_end_matches(['\r', '\n']);
            let (mut o, mut e) = (std::io::stdout(), std::io::stderr());
            if self.line(line, &mut o, &mut e) == Flow::Quit {
                return Ok(());
            }
        }
    }

    fn run_editor(&mut self) -> Result<()> {
        let mut ed = rustyline::DefaultEditor::new()?;
        if let Some(p) = &self.printer {
            // Events appear above the prompt; the line being typed is redrawn.
            if let Ok(mut ext) = ed.create_external_printer() {
                use rustyline::ExternalPrinter as _;
                p.install(Box::new(move |line| {
                    let _ = ext.print(line);
                }));
            }
        }
        let r = self.editor_loop(&mut ed);
        if let Some(p) = &self.printer {
            p.uninstall();
        }
        r
    }

    fn editor_loop(&mut self, ed: &mut rustyline::DefaultEditor) -> Result<()> {
        use rustyline::error::ReadlineError;
        loop {
            match ed.readline("mcc> ") {
                Ok(line) => {
                    if !line.trim().is_empty() {
                        let _ = ed.add_history_entry(line.as_str());
                    }
                    let (mut o, mut e) = (std::io::stdout(), std::io::stderr());
                    if self.line(&line, &mut o, &mut e) == Flow::Quit {
                        return Ok(());
                    }
                }
                Err(ReadlineError::Interrupted) => {
                    eprintln!("(type ^C and Enter to send <CTRL-C>; Ctrl-D or .quit to leave)");
                }
                Err(ReadlineError::Eof) => return Ok(()),
                Err(e) => return Err(e.into()),
            }
        }
    }
}

/// One line of cluster status for the terminal.
pub fn one_line(doc: &ClusterStatus) -> String {
    let r = &doc.ring;
    let state = match (r.locked, r.faulted) {
        (_, true) => "FAULTED",
        (true, false) => "locked",
        (false, false) => "NOT LOCKED",
    };
    let alive = doc.members.iter().filter(|m| m.alive).count();
    let mut s = format!(
        "cluster {}: ring {} {state} at cycle {}, {alive}/{} members alive, {} cards, {}",
        doc.cluster,
        r.name,
        r.cycle,
        doc.members.len(),
        doc.cards.len(),
        doc.clock
    );
    if let Some(t) = &doc.timing {
        s.push_str(&format!(
            " rtf {:.2} of {}, {} late cycles, worst lag {:.1} ms",
            t.rtf,
            doc.rtf_requested,
            t.late_cycles,
            t.max_lag_us as f64 / 1000.0
        ));
    }
    if let Some(l) = &r.broken_link {
        s.push_str(&format!(", broken link {l}"));
    }
    let faulted: Vec<&str> = doc
        .members
        .iter()
        .filter(|m| m.ring_fault)
        .map(|m| m.name.as_str())
        .collect();
    if !faulted.is_empty() {
        s.push_str(&format!(", ring fault at {}", faulted.join(",")));
    }
    s
}

/// A closure producing the one-line status of an attached cluster.
pub fn status_line(
    session: zenoh::Session,
    cfg: mcc_contracts::config::ClusterConfig,
    info: crate::cluster::rundir::SupervisorInfo,
    run_dir: String,
) -> impl Fn() -> String {
    move || {
        let (st, slow) = crate::cluster::ctl::query_round(
            &session,
            &cfg,
            Duration::from_millis(500),
            Duration::from_millis(1000),
        );
        one_line(&crate::cluster::status::build(
            &cfg, &info, &run_dir, &st, &slow,
        ))
    }
}

/// `mcc up` in the foreground: the terminal on its own thread over a new chain connection;
/// the receiver gets a message when the user leaves it (the cluster then goes down).
pub fn spawn_foreground(
    session: zenoh::Session,
    cfg: mcc_contracts::config::ClusterConfig,
    info: crate::cluster::rundir::SupervisorInfo,
    run_dir: String,
    show_framing: bool,
    printer: crate::cluster::events::Printer,
) -> std::sync::mpsc::Receiver<()> {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let link = ChainLink::new(
            session.clone(),
            &cfg,
            crate::cluster::chain::link::DEFAULT_TIMEOUT,
        );
        let status = status_line(session, cfg, info, run_dir);
        let term = Terminal::new(&link, show_framing, status).with_printer(printer);
        if let Err(e) = { term }.run() {
            eprintln!("mcc: terminal: {e:#}");
        }
        link.close();
        let _ = tx.send(());
    });
    rx
}
