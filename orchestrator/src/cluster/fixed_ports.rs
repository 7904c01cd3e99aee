//! Fixed TCP ports checked before `mcc up` starts anything (issue 26 item 7): a port another
//! program holds is named by its config key and address (`cards[0].ascii_port:
//! 127.0.0.1:5000 is already in use`), rather than by a member that exits with "Address
//! already in use". Each port is bound for a moment and released; a port taken in between
//! still fails the member that binds it (its log says so).

use std::net::TcpListener;

use anyhow::{bail, Result};
use mcc_contracts::config::{ClusterConfig, LOCAL_HOST};

/// One fixed port: the key that sets it, the address it binds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FixedPort {
    /// The config key (or option) that sets the port.
    pub key: String,
    /// Bind address.
    pub bind: String,
    /// Port (never 0).
    pub port: u16,
}

/// The fixed ports the processes of `host`'s share (`None`: the whole cluster on this
/// machine) will listen on: its cards' host ports, the daisy chain (`chain_port`, set by
/// `--chain-port`), the EMCL bus (`emcl_port`, `[emcl] port` or `--emcl-port`), the
/// supervisor's endpoint of a host share (`hosts.NAME.port`) and `zenoh.listen` TCP endpoints.
pub fn fixed_ports(
    cfg: &ClusterConfig,
    host: Option<&str>,
    chain_port: u16,
    emcl_port: u16,
) -> Vec<FixedPort> {
    let here = host.unwrap_or(LOCAL_HOST);
    let mut out = Vec::new();
    let mut add = |key: String, bind: &str, port: u16| {
        if port != 0 {
            out.push(FixedPort {
                key,
                bind: bind.to_string(),
                port,
            });
        }
    };
    for (i, c) in cfg.cards.iter().enumerate() {
        if cfg.member_host(&c.name) != Some(here) {
            continue;
        }
        let bind = c.bind.as_deref().unwrap_or("127.0.0.1");
        let fields: [(&str, u16); 2] = if c.profile == "power" {
            [("gpascii_port", c.gpascii_port), ("ssh_port", c.ssh_port)]
        } else {
            [
                ("ascii_port", c.ascii_port),
                ("pmac_eth_port", c.pmac_eth_port),
            ]
        };
        for (field, port) in fields {
            add(format!("cards[{i}].{field}"), bind, port);
        }
    }
    add(
        "--chain-port (MCC_CHAIN_PORT)".into(),
        cfg.chain.bind.as_deref().unwrap_or("127.0.0.1"),
        chain_port,
    );
    if !cfg.drives.is_empty() {
        let key = if emcl_port == cfg.emcl.port {
            "emcl.port"
        } else {
            "--emcl-port (MCC_EMCL_PORT)"
        };
        add(
            key.into(),
            cfg.emcl.bind.as_deref().unwrap_or("127.0.0.1"),
            emcl_port,
        );
    }
    if let Some(h) = host.and_then(|h| cfg.hosts.get(h).map(|c| (h, c))) {
        if let Some(addr) = h.1.address.as_deref() {
            add(format!("hosts.{}.port", h.0), addr, h.1.port);
        }
    }
    for (i, ep) in cfg.zenoh.listen.iter().enumerate() {
        if let Some((bind, port)) = tcp_addr(ep) {
            add(format!("zenoh.listen[{i}]"), bind, port);
        }
    }
    out
}

/// `tcp/ADDR:PORT` (ADDR may be `[v6]`): the address and port.
fn tcp_addr(endpoint: &str) -> Option<(&str, u16)> {
    let rest = endpoint.strip_prefix("tcp/")?;
    let rest = rest.split(['#', '?']).next()?;
    let (addr, port) = rest.rsplit_once(':')?;
    let addr = addr
        .strip_prefix('[')
        .and_then(|a| a.strip_suffix(']'))
        .unwrap_or(addr);
    Some((addr, port.parse().ok()?))
}

/// Every port of `ports` can be listened on now; else the first that cannot, by key and
/// address.
pub fn check_free(ports: &[FixedPort]) -> Result<()> {
    for p in ports {
        if let Err(e) = TcpListener::bind((p.bind.as_str(), p.port)) {
            let addr = if p.bind.contains(':') {
                format!("[{}]:{}", p.bind, p.port)
            } else {
                format!("{}:{}", p.bind, p.port)
            };
            if e.kind() == std::io::ErrorKind::AddrInUse {
                bail!(
                    "{}: {addr} is already in use (another program or cluster listens \
                     there; choose another port, or 0 for any free one)",
                    p.key
                );
            }
            bail!("{}: cannot listen on {addr}: {e}", p.key);
        }
    }
    Ok(())
}

/// `mcc up`: the fixed ports of this share are free (ports from the environment as the
/// supervisor will read them).
pub fn check_up(cfg: &ClusterConfig, host: Option<&str>) -> Result<()> {
    let chain = crate::cluster::chain::server::ChainOptions::from_env()?.port;
    let emcl = if cfg.drives.is_empty() {
        0
    } else {
        crate::cluster::emcl::server::BusOptions::resolve(cfg)?.port
    };
    check_free(&fixed_ports(cfg, host, chain, emcl))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_busy_port_is_named_by_key_and_address() {
        let busy = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = busy.local_addr().unwrap().port();
        let mut cfg = ClusterConfig::default_cluster(2, 1);
        cfg.cards[1].pmac_eth_port = port;
        let ports = fixed_ports(&cfg, None, 0, 0);
        assert_eq!(
            ports,
            vec![FixedPort {
                key: "cards[1].pmac_eth_port".into(),
                bind: "127.0.0.1".into(),
                port
            }]
        );
        let e = check_free(&ports).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "cards[1].pmac_eth_port: 127.0.0.1:{port} is already in use (another program \
                 or cluster listens there; choose another port, or 0 for any free one)"
            )
        );
        drop(busy);
        check_free(&ports).unwrap();
    }

    #[test]
    fn every_fixed_port_kind_is_listed() {
        let mut cfg = ClusterConfig::default_cluster(2, 1);
        cfg.cards[0].ascii_port = 5001;
        cfg.cards[1].profile = "power".into();
        cfg.cards[1].ssh_port = 5002;
        cfg.cards[1].pmac_eth_port = 5009; // not a port of a Power card
        cfg.zenoh.listen = vec!["tcp/127.0.0.1:5003".into(), "tcp/[::1]:0".into()];
        let keys: Vec<(String, u16)> = fixed_ports(&cfg, None, 5004, 5005)
            .into_iter()
            .map(|p| (p.key, p.port))
            .collect();
        assert_eq!(
            keys,
            vec![
                ("cards[0].ascii_port".into(), 5001),
                ("cards[1].ssh_port".into(), 5002),
                ("--chain-port (MCC_CHAIN_PORT)".into(), 5004),
                ("--emcl-port (MCC_EMCL_PORT)".into(), 5005),
                ("zenoh.listen[0]".into(), 5003),
            ]
        );
        // The bus port from the config is named by its key; no drives, no bus.
        cfg.emcl.port = 5005;
        let key = |cfg: &ClusterConfig| {
            fixed_ports(cfg, None, 0, 5005)
                .into_iter()
                .find(|p| p.port == 5005)
                .map(|p| p.key)
        };
        assert_eq!(key(&cfg).as_deref(), Some("emcl.port"));
        cfg.drives.clear();
        assert_eq!(key(&cfg), None);
        assert_eq!(tcp_addr("tcp/[::1]:7447"), Some(("::1", 7447)));
        assert_eq!(tcp_addr("unixsock-stream//tmp/x.sock"), None);
    }
}
