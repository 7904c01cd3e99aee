//! A fixed port another program holds (issue 26 item 7): `mcc up` fails naming the config key
//! and the address, before any member starts, and leaves no process behind.

use std::net::TcpListener;
use std::time::Duration;

use mcc_tests::process::{mcc_command, run_base, run_bounded, text, unique};

const BASE: &str = r#"
clock = "lockstep"
[[cards]]
name = "card0"
number = 0
master = 0
@CARD0@
[[cards]]
name = "card1"
number = 1
master = 1
profile = "power"
@CARD1@
[[stations]]
name = "station0"
master = 0
[[drives]]
name = "drive0"
address = 1
station = "station0"
[emcl]
@EMCL@
"#;

/// Processes whose command line names `needle` (members get their run dir's config path).
fn processes_naming(needle: &str) -> Vec<String> {
    let mut found = Vec::new();
    for e in std::fs::read_dir("/proc").into_iter().flatten().flatten() {
        let Ok(cmd) = std::fs::read(e.path().join("cmdline")) else {
            continue;
        };
        let cmd = text(&cmd).replace('\0', " ");
        if cmd.contains(needle) {
            found.push(format!("{}: {cmd}", e.file_name().to_string_lossy()));
        }
    }
    found
}

#[test]
fn a_busy_fixed_port_fails_up_naming_its_key_and_address() {
    let busy = TcpListener::bind("127.0.0.1:0").expect("a free port");
    let port = busy.local_addr().unwrap().port();
    let set = format!("{port}");
    let cases = [
        (
            "cards[0].ascii_port",
            "@CARD0@",
            format!("ascii_port = {set}"),
            None,
        ),
        (
            "cards[0].pmac_eth_port",
            "@CARD0@",
            format!("pmac_eth_port = {set}"),
            None,
        ),
        (
            "cards[1].gpascii_port",
            "@CARD1@",
            format!("gpascii_port = {set}"),
            None,
        ),
        (
            "cards[1].ssh_port",
            "@CARD1@",
            format!("ssh_port = {set}"),
            None,
        ),
        ("emcl.port", "@EMCL@", format!("port = {set}"), None),
        ("--chain-port", "@EMCL@", String::new(), Some(set.clone())),
    ];
    let dir = run_base();
    std::fs::create_dir_all(&dir).unwrap();
    for (key, slot, line, chain) in cases {
        let body = BASE.replace(slot, &line);
        let body = ["@CARD0@", "@CARD1@", "@EMCL@"]
            .iter()
            .fold(body, |b, s| b.replace(s, ""));
        let name = unique("busyport");
        let file = dir.join(format!("{name}.toml"));
        std::fs::write(&file, body).unwrap();
        let mut args = vec![
            "up".to_string(),
            "--detach".into(),
            "--timeout".into(),
            "60".into(),
            "--cluster".into(),
            name.clone(),
            "--config".into(),
            file.display().to_string(),
        ];
        if let Some(p) = &chain {
            args.extend(["--chain-port".into(), p.clone()]);
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = run_bounded(mcc_command(&args), None, Duration::from_secs(120))
            .unwrap_or_else(|e| panic!("{e}"));
        let err = text(&out.stderr);
        assert!(
            !out.status.success(),
            "{key}: mcc up succeeded on a busy port"
        );
        assert!(
            err.contains(key) && err.contains(&format!("127.0.0.1:{port} is already in use")),
            "{key}: {err}"
        );
        // Nothing of this cluster runs (members name their run dir's config).
        let left = processes_naming(&format!("/{name}/"));
        assert!(left.is_empty(), "{key}: left running: {left:?}");
        assert!(!dir.join(&name).join("supervisor.json").exists(), "{key}");
        let _ = std::fs::remove_file(&file);
    }
    drop(busy);
}
