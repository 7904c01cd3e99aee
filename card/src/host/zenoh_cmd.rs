//! The card's zenoh command queryable `mcc/<cluster>/card/<n>/cmd` (used by the orchestrator's
//! `mcc send`): the query payload is terminal input (one command line; an implicit `<CR>` ends
//! it, control characters act at once), the reply payload is the card's framed reply bytes.
//! All queries share one session on the card, like one terminal: `#2` in one query addresses
//! motor 2 for the next.

use zenoh::Wait;

use super::ascii::AsciiCodec;
use super::port::{run_events, CardPort};
use crate::service::handle::CardHandle;

/// `mcc/<cluster>/card/<n>/cmd` (architecture §4).
pub(crate) fn cmd_key(cluster: &str, n: u32) -> String {
    mcc_ring::control::card_cmd_key(cluster, n)
}

/// Run one query payload against the card (blocks until the card answers).
pub(crate) fn execute_payload(
    port: &mut CardPort,
    codec: &mut AsciiCodec,
    payload: &[u8],
) -> Vec<u8> {
    let mut events = codec.feed(payload);
    codec.finish_line(&mut events);
    let mut out = Vec::new();
    run_events(events, port, &mut out);
    out
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
        let reply = execute_payload(port, codec, &payload);
        if let Err(e) = query.reply(query.key_expr().clone(), reply).wait() {
            tracing::warn!("card cmd reply failed: {e}");
        }
    });
    zsession.declare_queryable(key).callback(worker).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::CardCore;
    use crate::domain::Profile;
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
        assert_eq!(execute_payload(&mut p, &mut c, b"UUU"), want);
        // An explicit CR (or CR LF) does not add a second, empty command.
        assert_eq!(execute_payload(&mut p, &mut c, b"UUU\r\n"), want);
        assert!(c.partial().is_empty());
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
        z.close().await.unwrap();
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap();
    }
}
