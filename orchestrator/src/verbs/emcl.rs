//! `mcc emcl send|input`: put frames on a running cluster's bus from the command line (the
//! reply decoded), and set a drive's input lines (the test bench's hands).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use anyhow::{anyhow, bail, Context, Result};
use mcc_contracts::control::emcl::{io_key, IoRequest};
use mcc_ring::control::CtlReply;
use mcc_station::emcl::codec::{Instr, Reply, Request, FRAME_LEN};

use crate::cli::{EmclArgs, EmclCommand};
use crate::cluster::attach::attach;

/// Parse `ADDR OP TYPE MOTOR VALUE` (decimal or 0x hex) or nine hex bytes.
pub fn parse_frame(words: &[String]) -> Result<[u8; FRAME_LEN]> {
    let num = |w: &str| -> Result<i64> {
        let w = w.trim();
        let (neg, w) = w.strip_prefix('-').map_or((false, w), |r| (true, r));
        let v = match w.strip_prefix("0x").or_else(|| w.strip_prefix("0X")) {
            Some(h) => i64::from_str_radix(h, 16),
            None => w.parse(),
        }
        .map_err(|_| anyhow!("{w:?} is not a number"))?;
        Ok(if neg { -v } else { v })
    };
    match words.len() {
        5 => {
            let b = |k: usize, what: &str| -> Result<u8> {
                let v = num(&words[k])?;
                u8::try_from(v).map_err(|_| anyhow!("{what} {v} is out of range 0-255"))
            };
            let value = num(&words[4])?;
            let value = i32::try_from(value)
                .or_else(|_| u32::try_from(value).map(|u| u as i32))
                .map_err(|_| anyhow!("value {value} does not fit 32 bits"))?;
            Ok(Request {
                addr: b(0, "address")?,
                instr: Instr::new(
                    b(1, "instruction")?,
                    b(2, "type")?,
                    b(3, "motor/bank")?,
                    value,
                ),
            }
            .to_bytes())
        }
        9 => {
            let mut f = [0u8; FRAME_LEN];
            for (k, w) in words.iter().enumerate() {
                f[k] = u8::from_str_radix(w.trim_start_matches("0x"), 16)
                    .map_err(|_| anyhow!("{w:?} is not a hex byte"))?;
            }
            Ok(f)
        }
        n => bail!("expected ADDR OP TYPE MOTOR VALUE or 9 hex bytes, got {n} words"),
    }
}

fn hex(b: &[u8]) -> String {
    b.iter()
        .map(|x| format!("{x:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `mcc emcl ...`.
pub fn cmd_emcl(cluster: &str, args: &EmclArgs) -> Result<()> {
    match &args.command {
        EmclCommand::Send { timeout_ms, words } => {
            let frame = parse_frame(words)?;
            let rd = crate::cluster::rundir::RunDir::find(cluster)?;
            let info = rd
                .running()
                .ok_or_else(|| anyhow!("cluster {cluster:?} is not running"))?;
            let addr = info
                .emcl_bus
                .ok_or_else(|| anyhow!("cluster {cluster:?} has no EMCL bus"))?;
            let mut s = TcpStream::connect(&addr).with_context(|| format!("EMCL bus {addr}"))?;
            s.set_read_timeout(Some(Duration::from_millis((*timeout_ms).max(1))))?;
            s.write_all(&frame)?;
            let mut r = [0u8; FRAME_LEN];
            println!("-> {}", hex(&frame));
            match s.read_exact(&mut r) {
                Ok(()) => {
                    let text = match Reply::parse(&r) {
                        Some(p) => format!(
                            "host {} module {} status {} instruction {} value {}",
                            p.host, p.module, p.status, p.op, p.value
                        ),
                        None => format!(
                            "no checksum: {:?}",
                            String::from_utf8_lossy(r.get(1..).unwrap_or_default())
                        ),
                    };
                    println!("<- {}  ({text})", hex(&r));
                }
                Err(_) => println!("<- (no reply within {timeout_ms} ms)"),
            }
            Ok(())
        }
        EmclCommand::Input { drive, settings } => {
            let a = attach(cluster)?;
            let d = a
                .cfg
                .drive(drive)
                .ok_or_else(|| anyhow!("unknown drive {drive:?}"))?;
            for s in settings {
                let (k, v) = s
                    .split_once('=')
                    .ok_or_else(|| anyhow!("{s:?}: expected NAME=VALUE"))?;
                let value: i64 = v.trim().parse().map_err(|_| anyhow!("{s:?}: bad value"))?;
                let req = IoRequest {
                    drive: drive.clone(),
                    input: k.trim().to_string(),
                    value,
                };
                let r: CtlReply = crate::cluster::ctl::query_ctl(
                    &a.session,
                    &io_key(&a.cfg.cluster, d.host()),
                    Some(serde_json::to_string(&req)?),
                    Duration::from_secs(3),
                )?;
                if !r.ok {
                    bail!("{}", r.message);
                }
                println!("{}", r.message);
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(s: &str) -> Vec<String> {
        s.split_whitespace().map(str::to_string).collect()
    }

    #[test]
    fn frames_from_words() {
        assert_eq!(
            parse_frame(&w("1 1 0 0 10000")).unwrap(),
            [1, 1, 0, 0, 0, 0, 0x27, 0x10, 0x39]
        );
        assert_eq!(
            parse_frame(&w("1 4 1 0 -10000")).unwrap(),
            [1, 4, 1, 0, 0xFF, 0xFF, 0xD8, 0xF0, 0xCC]
        );
        assert_eq!(
            parse_frame(&w("01 01 00 00 00 00 27 10 38")).unwrap()[8],
            0x38,
            "raw bytes are sent as they are (even a bad checksum)"
        );
        assert!(parse_frame(&w("1 2 3")).is_err());
        assert!(parse_frame(&w("256 1 0 0 0")).is_err());
        assert_eq!(
            parse_frame(&w("1 9 0x49 0 0xFFFFFFFF")).unwrap()[4..8],
            [0xFF; 4]
        );
    }
}
