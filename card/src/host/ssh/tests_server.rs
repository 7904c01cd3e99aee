//! The SSH server over a real socket with russh's client: logins, the shell as host tools
//! drive it, exec sessions. Every wait is bounded.

use std::sync::Arc;
use std::time::Duration;

use russh::client::{self, AuthResult};
use russh::keys::PublicKeyOrCertificate;
use russh::{ChannelMsg, Disconnect, MethodKind};

use super::{Credentials, MAX_AUTH_TRIES};
use crate::host::gpascii::BANNER;
use crate::host::power_ports::tests::start;
use crate::host::power_ports::{BoundPowerPorts, PowerPortsConfig};
use crate::host::ssh::penalty::Delays;

const WAIT: Duration = Duration::from_secs(20);
/// Failed logins' waits short enough for tests that fail several.
const QUICK: Delays = Delays {
    first: Duration::from_millis(20),
    cap: Duration::from_millis(100),
};

struct Client;

impl client::Handler for Client {
    type Error = russh::Error;

    async fn check_server_key(
        &mut self,
        _key: &PublicKeyOrCertificate,
    ) -> Result<bool, Self::Error> {
        Ok(true)
    }
}

async fn login(
    ports: &BoundPowerPorts,
    user: &str,
    password: &str,
) -> (client::Handle<Client>, bool) {
    let config = Arc::new(client::Config::default());
    let mut h = tokio::time::timeout(WAIT, client::connect(config, ports.ssh, Client))
        .await
        .expect("connect in time")
        .expect("ssh handshake");
    let ok = tokio::time::timeout(WAIT, h.authenticate_password(user, password))
        .await
        .expect("auth in time")
        .expect("auth exchange");
    (h, matches!(ok, AuthResult::Success))
}

/// Read channel data until it ends with `tail` (or the channel closes); everything read.
async fn read_until(ch: &mut russh::Channel<client::Msg>, tail: &[u8]) -> Vec<u8> {
    let mut got = Vec::new();
    tokio::time::timeout(WAIT, async {
        while !got.ends_with(tail) {
            match ch.wait().await {
                Some(ChannelMsg::Data { data }) => got.extend_from_slice(&data),
                Some(_) => {}
                None => break,
            }
        }
    })
    .await
    .unwrap_or_else(|_| {
        panic!(
            "no {tail:?} in time; got {:?}",
            String::from_utf8_lossy(&got)
        )
    });
    got
}

/// Everything until the channel closes: (stdout, stderr, exit status).
async fn drain(ch: &mut russh::Channel<client::Msg>) -> (Vec<u8>, Vec<u8>, Option<u32>) {
    let (mut out, mut err, mut status) = (Vec::new(), Vec::new(), None);
    tokio::time::timeout(WAIT, async {
        while let Some(m) = ch.wait().await {
            match m {
                ChannelMsg::Data { data } => out.extend_from_slice(&data),
                ChannelMsg::ExtendedData { data, ext: 1 } => err.extend_from_slice(&data),
                ChannelMsg::ExitStatus { exit_status } => status = Some(exit_status),
                _ => {}
            }
        }
    })
    .await
    .expect("channel closes in time");
    (out, err, status)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn wrong_credentials_are_refused_and_configured_ones_accepted() {
    let cfg = PowerPortsConfig {
        creds: Credentials {
            user: "ops".into(),
            password: "s3cret".into(),
        },
        ssh_delays: QUICK,
        ..PowerPortsConfig::default()
    };
    let ports = start(cfg).await;
    for (u, p) in [
        ("root", "deltatau"),
        ("ops", "s3cre"),
        ("ops", "s3cret "),
        ("", ""),
    ] {
        let (h, ok) = login(&ports, u, p).await;
        assert!(!ok, "{u}/{p} must be refused");
        let _ = h.disconnect(Disconnect::ByApplication, "", "").await;
    }
    let (h, ok) = login(&ports, "ops", "s3cret").await;
    assert!(ok);
    let mut ch = h.channel_open_session().await.unwrap();
    ch.request_pty(true, "vt100", 80, 24, 0, 0, &[])
        .await
        .unwrap();
    ch.request_shell(true).await.unwrap();
    assert_eq!(
        read_until(&mut ch, b"$ ").await,
        b"ops@powerpmac:/opt/ppmac$ "
    );
    ports.shutdown().await;
}

/// What dls_pmaclib's PPmacSshInterface does: shell on a vt100 pty, wait for "@",
/// `gpascii -2\r\n`, wait for "ASCII", then commands ended by `\r\n`, each read until
/// `ACK CR LF ACK CR LF`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shell_gpascii_session_as_ppmac_ssh_interface_drives_it() {
    let ports = start(PowerPortsConfig::default()).await;
    let (h, ok) = login(&ports, "root", "deltatau").await;
    assert!(ok);
    let mut ch = h.channel_open_session().await.unwrap();
    ch.request_pty(true, "vt100", 80, 24, 0, 0, &[])
        .await
        .unwrap();
    ch.request_shell(true).await.unwrap();
    assert_eq!(
        read_until(&mut ch, b"# ").await,
        b"root@powerpmac:/opt/ppmac# "
    );
    ch.data_bytes(&b"gpascii -2\r\n"[..]).await.unwrap();
    let got = read_until(&mut ch, b"\x06\r\n").await;
    assert_eq!(
        got,
        b"gpascii -2\r\n\r\nSTDIN Open for ASCII Input\r\n\x06\r\n".as_slice()
    );
    ch.data_bytes(&b"cid\r\n"[..]).await.unwrap();
    let got = read_until(&mut ch, b"\x06\r\n\x06\r\n").await;
    assert_eq!(got, b"cid\r\n\r\n604020\r\n\x06\r\n\x06\r\n".as_slice());
    ch.data_bytes(&b"P7=12.5\r\n"[..]).await.unwrap();
    read_until(&mut ch, b"\x06\r\n\x06\r\n").await;
    ch.data_bytes(&b"P7\r\n"[..]).await.unwrap();
    let got = read_until(&mut ch, b"\x06\r\n\x06\r\n").await;
    assert_eq!(got, b"P7\r\n\r\nP7=12.5\r\n\x06\r\n\x06\r\n".as_slice());
    // An error of the dialect names the thread's line (every line counts: two per command, and
    // the empty line after `gpascii -2\r`).
    ch.data_bytes(&b"Motor[99].JogSpeed\r\n"[..]).await.unwrap();
    let got = read_until(&mut ch, b"\x06\r\n\x06\r\n").await;
    assert_eq!(
        String::from_utf8_lossy(&got),
        "Motor[99].JogSpeed\r\n\r\n\
         stdin:8:1: error #21: ILLEGAL PARAMETER: Motor[99].JogSpeed\r\n\x06\r\n\x06\r\n"
    );
    // CTRL-C leaves gpascii for the prompt; other commands are a clear shell error; exit.
    ch.data_bytes(&b"\x03"[..]).await.unwrap();
    let got = read_until(&mut ch, b"# ").await;
    assert_eq!(got, b"^C\r\nroot@powerpmac:/opt/ppmac# ".as_slice());
    ch.data_bytes(&b"ls\r"[..]).await.unwrap();
    let got = read_until(&mut ch, b"# ").await;
    assert!(
        got.starts_with(b"ls\r\n-sh: ls: command not found"),
        "{:?}",
        String::from_utf8_lossy(&got)
    );
    ch.data_bytes(&b"exit\r"[..]).await.unwrap();
    let (out, _, status) = drain(&mut ch).await;
    assert_eq!(out, b"exit\r\nlogout\r\n");
    assert_eq!(status, Some(0));
    ports.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn exec_sessions_run_gpascii_or_refuse_the_command() {
    let ports = start(PowerPortsConfig::default()).await;
    let (h, ok) = login(&ports, "root", "deltatau").await;
    assert!(ok);
    let mut ch = h.channel_open_session().await.unwrap();
    ch.exec(true, "ls /var/ftp").await.unwrap();
    let (out, err, status) = drain(&mut ch).await;
    assert_eq!(out, b"");
    assert_eq!(
        String::from_utf8_lossy(&err),
        "-sh: ls: command not found (this controller's shell runs gpascii -2 and exit)\n"
    );
    assert_eq!(status, Some(127));
    // `gpascii -2` without a terminal: no echo, LF line ends, the end of input ends it.
    let mut ch = h.channel_open_session().await.unwrap();
    ch.exec(true, "gpascii -2").await.unwrap();
    ch.data_bytes(&b"cid\n#2\n#\n"[..]).await.unwrap();
    ch.eof().await.unwrap();
    let (out, _, status) = drain(&mut ch).await;
    let want = [BANNER, b"604020\n\x06\n\x06\n#2\n\x06\n".as_slice()].concat();
    assert_eq!(
        String::from_utf8_lossy(&out),
        String::from_utf8_lossy(&want)
    );
    assert_eq!(status, Some(0));
    // Subsystems (sftp) are refused, the connection stays usable.
    let ch = h.channel_open_session().await.unwrap();
    assert!(ch.request_subsystem(true, "sftp").await.is_ok());
    ports.shutdown().await;
}

/// Issue 26 item 6: after a wrong password the client is told it may try a password again and
/// its next attempt is answered (before: no method left, and the second attempt waited for
/// the client's own timeout); the attempt after `MAX_AUTH_TRIES` refusals is disconnected, as
/// sshd's MaxAuthTries; the host's failures delay it (growing: `penalty`'s tests) without
/// locking out the right password.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn each_wrong_password_is_answered_until_the_attempts_run_out() {
    let cfg = PowerPortsConfig {
        ssh_delays: QUICK,
        ..PowerPortsConfig::default()
    };
    let ports = start(cfg).await;
    let config = Arc::new(client::Config::default());
    let mut h = tokio::time::timeout(WAIT, client::connect(config, ports.ssh, Client))
        .await
        .expect("connect in time")
        .expect("ssh handshake");
    for k in 1..=MAX_AUTH_TRIES {
        let r = tokio::time::timeout(WAIT, h.authenticate_password("root", "guess"))
            .await
            .unwrap_or_else(|_| panic!("attempt {k} answered in time"))
            .unwrap_or_else(|e| panic!("attempt {k}: {e}"));
        match r {
            AuthResult::Failure {
                remaining_methods,
                partial_success: false,
            } => assert_eq!(&remaining_methods[..], &[MethodKind::Password], "{k}"),
            other => panic!("attempt {k}: {other:?}"),
        }
    }
    // One more, even the right one, on this connection: disconnected.
    let r = tokio::time::timeout(WAIT, h.authenticate_password("root", "deltatau"))
        .await
        .expect("the last attempt ends in time");
    assert!(!matches!(r, Ok(AuthResult::Success)), "{r:?}");
    tokio::time::timeout(WAIT, async {
        while !h.is_closed() {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    })
    .await
    .expect("the server closes the connection");
    // A new connection with the right password gets in (after the host's wait).
    let (h, ok) = login(&ports, "root", "deltatau").await;
    assert!(ok);
    let _ = h.disconnect(Disconnect::ByApplication, "", "").await;
    ports.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn gpascii_replies_over_ssh_go_through_the_link_fault() {
    use mcc_ring::linkfault::{LinkFaultKind, LinkFaultSlot, LinkFaultSpec};
    let link = LinkFaultSlot::default();
    let ports = start(PowerPortsConfig {
        link: link.clone(),
        ..PowerPortsConfig::default()
    })
    .await;
    let (h, ok) = login(&ports, "root", "deltatau").await;
    assert!(ok);
    let mut ch = h.channel_open_session().await.unwrap();
    ch.request_pty(true, "vt100", 80, 24, 0, 0, &[])
        .await
        .unwrap();
    ch.request_shell(true).await.unwrap();
    read_until(&mut ch, b"# ").await;
    ch.data_bytes(&b"gpascii -2\r\n"[..]).await.unwrap();
    read_until(&mut ch, b"\x06\r\n").await;
    let one = |kind| LinkFaultSpec {
        kind,
        probability: 1.0,
        seed: 0,
        replies: Some(1),
        delay_ms: 0,
    };
    // `cid\r\n` is two lines over SSH (`cid` and the empty one, each answered): the first
    // reply (cid's) is dropped, the empty line's ACK and the second command's come.
    link.set(one(LinkFaultKind::NoReply));
    ch.data_bytes(&b"cid\r\n"[..]).await.unwrap();
    ch.data_bytes(&b"cid\r\n"[..]).await.unwrap();
    let got = read_until(&mut ch, b"\x06\r\n\x06\r\n").await;
    assert_eq!(
        String::from_utf8_lossy(&got),
        "cid\r\n\r\n\x06\r\ncid\r\n\r\n604020\r\n\x06\r\n\x06\r\n"
    );
    // A reset drops the session: no reply, no exit status, the channel ends.
    link.set(one(LinkFaultKind::Reset));
    ch.data_bytes(&b"cid\r\n"[..]).await.unwrap();
    let (out, _, status) = drain(&mut ch).await;
    assert!(!out.windows(6).any(|w| w == b"604020"), "{out:?}");
    assert_eq!(status, None);
    ports.shutdown().await;
}
