//! The card's chain queryable `mcc/<cluster>/card/<n>/chain`: each query goes to the card's
//! servo thread as a [`handle::Request::Chain`], where the card core's chain receivers
//! (`core::chain`, pure) run it; the reply payload is the encoded segments and the reply
//! attachment the refusals of the lines the card answered.

use mcc_contracts::control::chain::chain_key;
use zenoh::Wait;

use super::handle::{self, CardHandle, Response, REPLY_TIMEOUT};

/// Declare the chain queryable of card `n` of `cluster`. Keep the returned value alive.
pub(crate) async fn declare_chain_queryable(
    zsession: &zenoh::Session,
    cluster: &str,
    n: u32,
    card: CardHandle,
) -> zenoh::Result<zenoh::query::Queryable<()>> {
    let worker = handle::query_worker("chain", move |query| {
        let payload = query
            .payload()
            .map(|p| p.to_bytes().into_owned())
            .unwrap_or_default();
        let res = match card.call(handle::Request::Chain(payload), REPLY_TIMEOUT) {
            Some(Response::Chain(r)) => r,
            _ => Err("the card did not answer".to_string()),
        };
        let sent = match res {
            Ok(r) if r.refusals.is_empty() => {
                query.reply(query.key_expr().clone(), r.payload).wait()
            }
            Ok(r) => query
                .reply(query.key_expr().clone(), r.payload)
                .attachment(r.refusals)
                .wait(),
            Err(e) => query.reply_err(e).wait(),
        };
        if let Err(e) = sent {
            tracing::warn!("card chain reply failed: {e}");
        }
    });
    zsession
        .declare_queryable(chain_key(cluster, n))
        .callback(worker)
        .await
}
