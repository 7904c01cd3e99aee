//! The daisy-chain wire format between the orchestrator's chain server and each card's
//! queryable `mcc/<cluster>/card/<n>/chain` (pmac-commands §8.3).
//!
//! Request: `op` (1 byte: [`OP_DATA`], [`OP_CLOSE`], [`OP_QUERY_START`], [`OP_TAKE_START`]),
//! the connection id (u64 little-endian), then for `D` at most [`MAX_CHUNK`] bytes of chain
//! input. `?` is answered with one flags byte ([`FLAG_STARTS`], [`FLAG_TALKS`]); `T` with the
//! flags byte then the line to run, or nothing. Every other reply is a list of segments
//! `position u32 LE, length u32 LE, bytes`, `position` being the index in the request's data
//! of the byte that produced the output, so the orchestrator can merge the segments of all
//! cards in input order.
//!
//! Refusals: a card that answers a line it refused (the addressed card; card 0 under `@@`)
//! says so in the zenoh reply **attachment** of a `D` request, beside the segments and never
//! in them (the reply bytes are what the card's framing made of the line: `ERRnnn`, a bare
//! `<BELL>` or nothing, per I6). The attachment is a list of `position u32 LE, length u8,
//! text` ([`encode_refusals`]), `position` being that of the `<CR>` that ran the line (the
//! position of its reply segment) and `text` the refusal's text form
//! ([`CardRefusal`]: `ERR003`, `error #20`). No attachment, or
//! an empty one, means no line was refused; a reader that ignores attachments sees the
//! same segments as before.

use super::refusal::{CardRefusal, RefusalParseError};

/// Request op: chain bytes follow.
pub const OP_DATA: u8 = b'D';
/// Request op: the host connection is gone (buffers it left open are closed).
pub const OP_CLOSE: u8 = b'X';
/// Request op: does the collected line start a program on this card? (one flags byte)
pub const OP_QUERY_START: u8 = b'?';
/// Request op: hand the collected line over for a synchronized start (flags byte + line).
pub const OP_TAKE_START: u8 = b'T';
/// Flags: the line this connection collected starts a program (`R`/`S`).
pub const FLAG_STARTS: u8 = 1;
/// Flags: this card answers the line (the addressed card; card 0 under `@@`).
pub const FLAG_TALKS: u8 = 2;
/// Largest data part of one request (the cards refuse more).
pub const MAX_CHUNK: usize = 4096;
/// Largest reply accepted from one card for one request, bytes.
pub const MAX_REPLY: usize = 4 << 20;

/// Largest refusal attachment accepted from one card for one request, bytes.
pub const MAX_REFUSALS: usize = 64 << 10;

/// `mcc/<cluster>/card/<n>/chain`.
pub fn chain_key(cluster: &str, n: u32) -> String {
    format!("mcc/{cluster}/card/{n}/chain")
}

/// One decoded request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Request<'a> {
    /// One of the `OP_*` codes.
    pub op: u8,
    /// Chain connection id.
    pub conn: u64,
    /// Chain input (empty but for [`OP_DATA`]).
    pub data: &'a [u8],
}

/// Encode a request.
pub fn encode_request(op: u8, conn: u64, data: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(9 + data.len());
    v.push(op);
    v.extend_from_slice(&conn.to_le_bytes());
    v.extend_from_slice(data);
    v
}

/// Why a chain request or reply payload was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ChainCodecError {
    /// No bytes at all.
    #[error("empty chain request")]
    Empty,
    /// An op byte this protocol does not have.
    #[error("unknown chain request op 0x{0:02X}")]
    UnknownOp(u8),
    /// Fewer than the 8 bytes of the connection id.
    #[error("chain request shorter than its connection id")]
    NoConnectionId,
    /// A request's data beyond [`MAX_CHUNK`].
    #[error("chain request of {0} bytes exceeds {MAX_CHUNK}")]
    ChunkTooLong(usize),
    /// A reply beyond [`MAX_REPLY`].
    #[error("reply of {0} bytes is too large")]
    ReplyTooLarge(usize),
    /// A reply segment shorter than its length says.
    #[error("truncated segment")]
    TruncatedSegment,
    /// Bytes left that do not make a segment header.
    #[error("truncated segment header")]
    TruncatedHeader,
    /// A refusal attachment beyond [`MAX_REFUSALS`].
    #[error("refusal attachment of {0} bytes is too large")]
    RefusalsTooLarge(usize),
    /// A refusal entry shorter than its header or its length says.
    #[error("truncated refusal entry")]
    TruncatedRefusal,
    /// A refusal entry whose text is not a refusal.
    #[error("bad refusal entry: {0}")]
    BadRefusal(#[from] RefusalParseError),
}

/// Decode a request payload; the error names the problem when malformed.
pub fn decode_request(p: &[u8]) -> Result<Request<'_>, ChainCodecError> {
    let (&op, rest) = p.split_first().ok_or(ChainCodecError::Empty)?;
    if ![OP_DATA, OP_CLOSE, OP_QUERY_START, OP_TAKE_START].contains(&op) {
        return Err(ChainCodecError::UnknownOp(op));
    }
    let id: [u8; 8] = rest
        .get(..8)
        .and_then(|b| b.try_into().ok())
        .ok_or(ChainCodecError::NoConnectionId)?;
    let data = rest.get(8..).unwrap_or_default();
    if data.len() > MAX_CHUNK {
        return Err(ChainCodecError::ChunkTooLong(data.len()));
    }
    Ok(Request {
        op,
        conn: u64::from_le_bytes(id),
        data,
    })
}

/// Encode reply segments `(position, bytes)`.
pub fn encode_reply(segments: &[(u32, Vec<u8>)]) -> Vec<u8> {
    let mut v = Vec::new();
    for (pos, bytes) in segments {
        v.extend_from_slice(&pos.to_le_bytes());
        v.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
        v.extend_from_slice(bytes);
    }
    v
}

/// Decode one card's reply segments; the error names the problem when malformed.
pub fn decode_reply(mut p: &[u8]) -> Result<Vec<(u32, Vec<u8>)>, ChainCodecError> {
    if p.len() > MAX_REPLY {
        return Err(ChainCodecError::ReplyTooLarge(p.len()));
    }
    let mut out = Vec::new();
    while let Some((head, rest)) = p.split_first_chunk::<8>() {
        let pos = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
        let len = u32::from_le_bytes([head[4], head[5], head[6], head[7]]) as usize;
        let bytes = rest.get(..len).ok_or(ChainCodecError::TruncatedSegment)?;
        out.push((pos, bytes.to_vec()));
        p = rest.get(len..).unwrap_or_default();
    }
    if !p.is_empty() {
        return Err(ChainCodecError::TruncatedHeader);
    }
    Ok(out)
}

/// Encode the refusals attachment: `(position, refusal)` in order, each as `position u32
/// LE, length u8, text` (see the module docs).
pub fn encode_refusals(refusals: &[(u32, CardRefusal)]) -> Vec<u8> {
    let mut v = Vec::new();
    for (pos, r) in refusals {
        let text = r.to_string();
        v.extend_from_slice(&pos.to_le_bytes());
        // A refusal's text form is a few bytes (MAX_REFUSAL_TEXT).
        v.push(text.len().min(usize::from(u8::MAX)) as u8);
        v.extend_from_slice(text.as_bytes());
    }
    v
}

/// Decode one card's refusals attachment; the error names the problem when malformed.
pub fn decode_refusals(mut p: &[u8]) -> Result<Vec<(u32, CardRefusal)>, ChainCodecError> {
    if p.len() > MAX_REFUSALS {
        return Err(ChainCodecError::RefusalsTooLarge(p.len()));
    }
    let mut out = Vec::new();
    while !p.is_empty() {
        let (head, rest) = p
            .split_first_chunk::<5>()
            .ok_or(ChainCodecError::TruncatedRefusal)?;
        let pos = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
        let len = usize::from(head[4]);
        let text = rest.get(..len).ok_or(ChainCodecError::TruncatedRefusal)?;
        out.push((pos, CardRefusal::from_bytes(text)?));
        p = rest.get(len..).unwrap_or_default();
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_encode_and_decode() {
        let r = vec![
            (4, CardRefusal::Pmac(3)),
            (9, CardRefusal::Power(20)),
            (12, CardRefusal::Bell),
        ];
        let wire = encode_refusals(&r);
        assert_eq!(&wire[..11], b"\x04\0\0\0\x06ERR003");
        assert_eq!(decode_refusals(&wire).unwrap(), r);
        assert_eq!(decode_refusals(b"").unwrap(), vec![]);
        assert!(encode_refusals(&[]).is_empty());
    }

    #[test]
    fn malformed_refusals_are_named() {
        assert_eq!(
            decode_refusals(b"\x04\0\0").unwrap_err(),
            ChainCodecError::TruncatedRefusal
        );
        assert_eq!(
            decode_refusals(b"\x04\0\0\0\x07ERR003").unwrap_err(),
            ChainCodecError::TruncatedRefusal
        );
        let e = decode_refusals(b"\x04\0\0\0\x03ERR").unwrap_err();
        assert!(matches!(e, ChainCodecError::BadRefusal(_)), "{e}");
        assert!(e.to_string().contains("ERR"), "{e}");
        assert_eq!(
            decode_refusals(&vec![0; MAX_REFUSALS + 1]).unwrap_err(),
            ChainCodecError::RefusalsTooLarge(MAX_REFUSALS + 1)
        );
    }

    #[test]
    fn requests_encode_and_decode() {
        let req = encode_request(OP_DATA, 0x0102, b"P1\r");
        assert_eq!(req, b"D\x02\x01\0\0\0\0\0\0P1\r");
        let d = decode_request(&req).unwrap();
        assert_eq!((d.op, d.conn, d.data), (OP_DATA, 0x0102, &b"P1\r"[..]));
        assert!(decode_request(b"").is_err());
        let e = decode_request(b"Q12345678").unwrap_err();
        assert_eq!(e, ChainCodecError::UnknownOp(b'Q'));
        assert!(e.to_string().contains("op 0x51"), "{e}");
        assert!(decode_request(b"D1234").is_err());
        assert!(decode_request(&encode_request(OP_DATA, 1, &[b'P'; MAX_CHUNK + 1])).is_err());
        assert!(decode_request(&encode_request(OP_TAKE_START, 3, &[])).is_ok());
        assert_eq!(chain_key("lab", 2), "mcc/lab/card/2/chain");
    }

    #[test]
    fn replies_encode_and_decode() {
        let segs = vec![(3, b"ab".to_vec()), (9, Vec::new())];
        let wire = encode_reply(&segs);
        assert_eq!(&wire[..10], b"\x03\0\0\0\x02\0\0\0ab");
        assert_eq!(decode_reply(&wire).unwrap(), segs);
        assert_eq!(decode_reply(b"").unwrap(), vec![]);
        assert_eq!(
            decode_reply(b"\x03\0\0\0\x05\0\0\0ab").unwrap_err(),
            ChainCodecError::TruncatedSegment
        );
        assert_eq!(
            decode_reply(b"\x03\0\0").unwrap_err(),
            ChainCodecError::TruncatedHeader
        );
    }

    mod fuzz {
        use super::super::*;
        use proptest::prelude::*;

        const OPS: &[u8] = &[OP_DATA, OP_CLOSE, OP_QUERY_START, OP_TAKE_START];

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(500))]

            #[test]
            fn any_request_bytes_decode_or_name_the_problem(
                p in proptest::collection::vec(any::<u8>(), 0..64)
            ) {
                if let Ok(r) = decode_request(&p) {
                    prop_assert_eq!(encode_request(r.op, r.conn, r.data), p);
                }
            }

            #[test]
            fn any_reply_bytes_decode_or_name_the_problem(
                p in proptest::collection::vec(any::<u8>(), 0..64)
            ) {
                if let Ok(segs) = decode_reply(&p) {
                    prop_assert_eq!(encode_reply(&segs), p);
                }
            }

            #[test]
            fn any_refusal_bytes_decode_or_name_the_problem(
                p in proptest::collection::vec(any::<u8>(), 0..64)
            ) {
                if let Ok(r) = decode_refusals(&p) {
                    prop_assert_eq!(encode_refusals(&r), p);
                }
            }

            #[test]
            fn refusals_round_trip(
                r in proptest::collection::vec((any::<u32>(), prop_oneof![
                    (1u16..=999).prop_map(CardRefusal::Pmac),
                    any::<u16>().prop_map(CardRefusal::Power),
                    Just(CardRefusal::Bell),
                ]), 0..8),
            ) {
                prop_assert_eq!(decode_refusals(&encode_refusals(&r)), Ok(r));
            }

            #[test]
            fn requests_and_replies_round_trip(
                op in proptest::sample::select(OPS),
                conn: u64,
                data in proptest::collection::vec(any::<u8>(), 0..MAX_CHUNK.min(300)),
                segs in proptest::collection::vec((any::<u32>(), proptest::collection::vec(any::<u8>(), 0..40)), 0..8),
            ) {
                let req = encode_request(op, conn, &data);
                prop_assert_eq!(decode_request(&req), Ok(Request { op, conn, data: &data }));
                prop_assert_eq!(decode_reply(&encode_reply(&segs)), Ok(segs));
            }
        }
    }
}
