//! The zenoh session options of every mcc process of a cluster, from its config (issue 15):
//! where it listens, whom it connects to, client or peer, authentication and access control.
//!
//! - One machine (members name no host): peers on loopback; members connect to their
//!   supervisor's endpoint, the CLI too.
//! - Routers (`[zenoh] routers`): every process is a zenoh client of the routers; every ring
//!   hop goes through a router.
//! - Peer to peer (`[hosts.NAME] address`): a host's supervisor listens on `address:port`, its
//!   members and CLI verbs on `address`, any port; everybody connects to every supervisor and
//!   zenoh's gossip opens one direct link per pair. Nothing listens on loopback or unix sockets
//!   (their locators would be handed to other hosts).

use super::session::{SessionAuth, SessionOptions};
use super::TransportError;
use mcc_contracts::config::{ClusterConfig, Topology};

/// Who opens the session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role<'a> {
    /// The supervisor of `host`'s share.
    Supervisor {
        /// Its host.
        host: &'a str,
    },
    /// A member process (ring member or stand-alone drive) called `name`.
    Member {
        /// Its name.
        name: &'a str,
    },
    /// A CLI verb running on `host`.
    Client {
        /// The host it runs on.
        host: &'a str,
    },
}

/// Session options of `role` in a cluster on several hosts (`cfg.topology()` is not
/// [`Topology::Single`]); None for a cluster on one machine (the caller's loopback options
/// apply, see [`secure`]).
pub fn host_options(
    cfg: &ClusterConfig,
    role: Role<'_>,
) -> Result<Option<SessionOptions>, TransportError> {
    let mut opts = match cfg.topology() {
        Topology::Single => return Ok(None),
        Topology::Routers(routers) => SessionOptions {
            client: true,
            connect: routers.iter().chain(&cfg.zenoh.connect).cloned().collect(),
            ..Default::default()
        },
        Topology::PeerToPeer => {
            let host = match role {
                Role::Supervisor { host } | Role::Client { host } => host.to_string(),
                Role::Member { name } => cfg
                    .member_host(name)
                    .ok_or_else(|| TransportError::Io(format!("{name:?} is not in the config")))?
                    .to_string(),
            };
            let own = cfg.host_endpoint(&host);
            let listen = match role {
                Role::Supervisor { .. } => own.clone(),
                _ => cfg.host_listen(&host),
            }
            .ok_or_else(|| TransportError::Io(format!("host {host:?} has no address")))?;
            let mut connect: Vec<String> = cfg
                .host_names()
                .iter()
                .filter_map(|h| cfg.host_endpoint(h))
                .filter(|ep| !matches!(role, Role::Supervisor { .. }) || Some(ep) != own.as_ref())
                .collect();
            connect.extend(cfg.zenoh.connect.iter().cloned());
            let mut listen = vec![listen];
            listen.extend(cfg.zenoh.listen.iter().cloned());
            SessionOptions {
                listen,
                connect,
                ..Default::default()
            }
        }
    };
    secure(&mut opts, cfg)?;
    Ok(Some(opts))
}

/// Add the config's authentication, access control and TLS settings to `opts` (every session
/// of every process of the cluster). The password is read from its file here.
pub fn secure(opts: &mut SessionOptions, cfg: &ClusterConfig) -> Result<(), TransportError> {
    if let Some(a) = &cfg.zenoh.auth {
        let text = std::fs::read_to_string(&a.password_file).map_err(|e| {
            TransportError::Io(format!(
                "zenoh.auth.password_file: cannot read {}: {e}",
                a.password_file.display()
            ))
        })?;
        let password = text.lines().next().unwrap_or("").trim().to_string();
        if password.is_empty() {
            return Err(TransportError::Io(format!(
                "zenoh.auth.password_file: {} holds no password",
                a.password_file.display()
            )));
        }
        opts.auth = Some(SessionAuth {
            user: a.user.clone(),
            password,
            dictionary_file: a.dictionary_file.as_ref().map(|p| p.display().to_string()),
        });
    }
    let json =
        |t: &toml::Table| serde_json::to_value(t).map_err(|e| TransportError::Io(e.to_string()));
    if let Some(acl) = &cfg.zenoh.access_control {
        opts.access_control = Some(json(acl)?);
    }
    if let Some(tls) = &cfg.zenoh.tls {
        opts.tls = Some(json(tls)?);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::session::zenoh_config;

    fn cfg(extra: &str, hosts: &str) -> ClusterConfig {
        let mut text = String::from(extra);
        for (i, (name, host)) in [("card0", "a"), ("card1", "b")].iter().enumerate() {
            text.push_str(&format!(
                "[[cards]]\nname = \"{name}\"\nnumber = {i}\nmaster = {i}\nhost = \"{host}\"\n"
            ));
        }
        text.push_str(hosts);
        ClusterConfig::from_toml_str(&text).unwrap()
    }

    #[test]
    fn routers_make_every_process_a_client() {
        let c = cfg("[zenoh]\nrouters = [\"tcp/127.0.0.1:7447\"]\n", "");
        for role in [
            Role::Supervisor { host: "a" },
            Role::Member { name: "card1" },
            Role::Client { host: "b" },
        ] {
            let o = host_options(&c, role).unwrap().unwrap();
            assert!(o.client && o.listen.is_empty(), "{role:?}");
            assert_eq!(o.connect, vec!["tcp/127.0.0.1:7447"]);
            let z = format!("{}", zenoh_config(&o).unwrap());
            assert!(z.contains("\"mode\":\"client\""), "{z}");
        }
        assert!(host_options(
            &ClusterConfig::default_cluster(1, 1),
            Role::Client { host: "local" }
        )
        .unwrap()
        .is_none());
    }

    #[test]
    fn peers_listen_on_their_host_and_connect_to_every_supervisor() {
        let c = cfg(
            "",
            "[hosts.a]\naddress = \"127.0.0.1\"\nport = 7001\n[hosts.b]\naddress = \"127.0.0.2\"\nport = 7002\n",
        );
        let sup = host_options(&c, Role::Supervisor { host: "a" })
            .unwrap()
            .unwrap();
        assert!(!sup.client);
        assert_eq!(sup.listen, vec!["tcp/127.0.0.1:7001"]);
        assert_eq!(sup.connect, vec!["tcp/127.0.0.2:7002"]);
        let m = host_options(&c, Role::Member { name: "card1" })
            .unwrap()
            .unwrap();
        assert_eq!(m.listen, vec!["tcp/127.0.0.2:0"]);
        assert_eq!(m.connect, vec!["tcp/127.0.0.1:7001", "tcp/127.0.0.2:7002"]);
        assert!(host_options(&c, Role::Member { name: "ghost" }).is_err());
    }

    #[test]
    fn auth_and_access_control_reach_zenoh() {
        let dir = std::env::temp_dir().join(format!("mcc-auth-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let pass = dir.join("pass");
        std::fs::write(&pass, "s3cret\n").unwrap();
        let text = format!(
            "[zenoh]\nrouters = [\"tcp/127.0.0.1:7447\"]\n[zenoh.auth]\nuser = \"mcc\"\npassword_file = {:?}\n[zenoh.access_control]\nenabled = true\ndefault_permission = \"deny\"\n",
            pass.display().to_string()
        );
        let c = cfg(&text, "");
        let o = host_options(&c, Role::Client { host: "a" })
            .unwrap()
            .unwrap();
        let a = o.auth.clone().unwrap();
        assert_eq!((a.user.as_str(), a.password.as_str()), ("mcc", "s3cret"));
        assert!(!format!("{a:?}").contains("s3cret"));
        let z = zenoh_config(&o).unwrap();
        let acl = z.get_json("access_control").unwrap();
        assert!(acl.contains("\"default_permission\":\"deny\""), "{acl}");
        assert!(z
            .get_json("transport/auth/usrpwd/user")
            .unwrap()
            .contains("mcc"));
        std::fs::write(&pass, "\n").unwrap();
        let e = host_options(&c, Role::Client { host: "a" })
            .unwrap_err()
            .to_string();
        assert!(e.contains("holds no password"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
        let e = host_options(&c, Role::Client { host: "a" })
            .unwrap_err()
            .to_string();
        assert!(e.contains("zenoh.auth.password_file: cannot read"), "{e}");
    }
}
