//! The card's zenoh command queryable `mcc/<cluster>/card/<n>/cmd` (used by the orchestrator's
//! `mcc send`): the query payload is terminal input (one command line; an implicit `<CR>` ends
//! it, control characters act at once), the reply payload is the card's framed reply bytes.
//! All queries share one session on the card, like one terminal: `#2` in one query addresses
//! motor 2 for the next.
//!
//! The first refusal of the payload's lines (`HostReply::error`, whether or not I6 printed
//! it) travels in the reply's **attachment** as its text form (`ERR003`, `error #20`:
//! `mcc_contracts::control::refusal`); no attachment when nothing was refused. The payload
//! bytes are unchanged by it.

use mcc_contracts::control::CardRefusal;
use zenoh::Wait;

use super::ascii::AsciiCodec;
use super::port::{run_events, CardPort, Interpreter};
use crate::domain::Refusal;
use crate::service::handle::CardHandle;

/// `mcc/<cluster>/card/<n>/cmd` (architecture §4).
pub(crate) fn cmd_key(cluster: &str, n: u32) -> String {
    mcc_ring::control::card_cmd_key(cluster, n)
}

/// Run one query payload against the card (blocks until the card answers): the reply bytes
/// and the first refusal among its lines.
pub(crate) fn execute_payload(
    port: &mut CardPort,
    codec: &mut AsciiCodec,
    payload: &[u8],
) -> (Vec<u8>, Option<Refusal>) {
    let mut events = codec.feed(payload);
    codec.finish_line(&mut events);
    let mut out = Vec::new();
    let _ = port.take_refusal();
    run_events(events, port, &mut out);
    (out, port.take_refusal())
}

/// Declare the queryable for card `n` of `cluster`. Keep the returned value alive: dropping it
/// undeclares the queryable.
pub(crate) async fn declare_cmd_queryable(
    zsession: &zenoh::Session,
    cluster: &str,
    n: u32,
    card: CardHandle,
) -> zenoh::Result<zenoh::query::Queryable<()>> {
    let key = cmd_key(cluster, n);
    let mut state = (CardPort::new(card), AsciiCodec::new());
    let worker = crate::service::handle::query_worker("cmd", move |query| {
        let payload = query
            .payload()
            .map(|p| p.to_bytes().into_owned())
            .unwrap_or_default();
        let (port, codec) = &mut state;
        let (reply, refusal) = execute_payload(port, codec, &payload);
        let mut answer = query.reply(query.key_expr().clone(), reply);
        if let Some(r) = refusal {
            answer = answer.attachment(CardRefusal::from(r).to_string());
        }
        if let Err(e) = answer.wait() {
            tracing::warn!("card cmd reply failed: {e}");
        }
    });
    zsession.declare_queryable(key).callback(worker).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::CardCore;
    use crate::domain::{ErrCode, Profile};
    use crate::lang::{Card, Session};
    use crate::service::handle::channel;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    fn card_thread() -> (CardHandle, Arc<AtomicBool>, std::thread::JoinHandle<()>) {
        let (mut runner, h) = channel(CardCore::new(Card::new(Profile::Pmac2)), None);
        let stop = Arc::new(AtomicBool::new(false));
        let st = Arc::clone(&stop);
        (h, stop, std::thread::spawn(move || runner.run_until(&st)))
    }

    #[test]
    fn key_format() {
        assert_eq!(cmd_key("lab", 3), "mcc/lab/card/3/cmd");
    }

    #[test]
    fn payload_runs_as_one_line_with_implicit_cr() {
        let (h, stop, t) = card_thread();
        let mut p = CardPort::new(h);
        let mut c = AsciiCodec::new();
        let want = Card::new(Profile::Pmac2).command_line(&mut Session::default(), b"UUU");
        // `UUU` is no command (ERR003): its refusal comes with the bytes.
        let refused = Some(Refusal::Pmac(ErrCode::Data));
        assert_eq!(
            execute_payload(&mut p, &mut c, b"UUU"),
            (want.clone(), refused)
        );
        // An explicit CR (or CR LF) does not add a second, empty command.
        assert_eq!(execute_payload(&mut p, &mut c, b"UUU\r\n"), (want, refused));
        assert!(c.partial().is_empty());
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap();
    }

    #[test]
    fn a_refusal_is_reported_whatever_i6_prints() {
        let (h, stop, t) = card_thread();
        let mut p = CardPort::new(h);
        let mut c = AsciiCodec::new();
        // I6 = 2: a refused line answers a bare <BELL>, no code in the bytes.
        assert_eq!(execute_payload(&mut p, &mut c, b"I6=2").1, None);
        let (bytes, refusal) = execute_payload(&mut p, &mut c, b"UUU");
        assert!(!bytes.windows(3).any(|w| w == b"ERR"), "{bytes:?}");
        assert_eq!(refusal, Some(Refusal::Pmac(ErrCode::Data)));
        // The first refusal of the payload; a later good line does not clear it.
        let (_, refusal) = execute_payload(&mut p, &mut c, b"UUU\rP1");
        assert_eq!(refusal, Some(Refusal::Pmac(ErrCode::Data)));
        assert_eq!(execute_payload(&mut p, &mut c, b"P1").1, None);
        // CTRL-I re-executes the last line (`UUU`): its refusal too.
        execute_payload(&mut p, &mut c, b"UUU");
        assert_eq!(
            execute_payload(&mut p, &mut c, b"\x09").1,
            Some(Refusal::Pmac(ErrCode::Data))
        );
        // An over-long line is the card's ERR003.
        let long = vec![b'P'; 4000];
        assert_eq!(
            execute_payload(&mut p, &mut c, &long).1,
            Some(Refusal::Pmac(ErrCode::Data))
        );
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap();
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn queryable_answers_with_framed_reply() {
        let mut cfg = zenoh::Config::default();
        for (k, v) in [
            ("mode", "\"peer\""),
            ("scouting/multicast/enabled", "false"),
            ("listen/endpoints", "[]"),
            ("connect/endpoints", "[]"),
        ] {
            cfg.insert_json5(k, v).unwrap();
        }
        let z = zenoh::open(cfg).await.unwrap();
        let (h, stop, t) = card_thread();
        let _q = declare_cmd_queryable(&z, "hosttest", 7, h).await.unwrap();
        let want = Card::new(Profile::Pmac2).command_line(&mut Session::default(), b"UUU");
        let replies = z.get(cmd_key("hosttest", 7)).payload("UUU").await.unwrap();
        let r = tokio::time::timeout(std::time::Duration::from_secs(10), replies.recv_async())
            .await
            .expect("reply in time")
            .unwrap();
        let got = r
            .result()
            .expect("ok reply")
            .payload()
            .to_bytes()
            .into_owned();
        assert_eq!(got, want);
        let a = r
            .result()
            .unwrap()
            .attachment()
            .map(|a| a.to_bytes().into_owned());
        assert_eq!(a.as_deref(), Some(&b"ERR003"[..]), "UUU is refused");
        // I6 = 2 prints a bare <BELL>: the refusal is in the attachment only.
        for (line, attach) in [("I6=2", None), ("UUU", Some("ERR003")), ("P1", None)] {
            let replies = z.get(cmd_key("hosttest", 7)).payload(line).await.unwrap();
            let r = tokio::time::timeout(std::time::Duration::from_secs(10), replies.recv_async())
                .await
                .expect("reply in time")
                .unwrap();
            let s = r.result().expect("ok reply");
            let a = s.attachment().map(|a| a.to_bytes().into_owned());
            assert_eq!(a.as_deref(), attach.map(str::as_bytes), "{line}");
            if line == "UUU" {
                assert_eq!(s.payload().to_bytes().as_ref(), b"\x07");
                let parsed = CardRefusal::from_bytes(a.as_deref().unwrap_or_default());
                assert_eq!(parsed, Ok(CardRefusal::Pmac(ErrCode::Data.code())));
            }
        }
        z.close().await.unwrap();
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap();
    }
}
