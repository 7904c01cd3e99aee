//! Issue 26 item 3: zenoh's authentication protects no card port, chain or EMCL bus; opening
//! them to other hosts is an explicit opt-in, and a Power card's SSH reachable from other
//! hosts refuses the factory password.

use super::*;
use crate::config::ZenohAuth;

/// One card, zenoh links authenticated and access-controlled (what other hosts' reach
/// already needs).
fn secured() -> ClusterConfig {
    let mut c = ClusterConfig::default_cluster(1, 0);
    c.zenoh.auth = Some(ZenohAuth {
        user: "mcc".into(),
        password_file: "/etc/mcc/zenoh.pass".into(),
        dictionary_file: None,
    });
    let mut acl = toml::Table::new();
    acl.insert("enabled".into(), toml::Value::Boolean(true));
    c.zenoh.access_control = Some(acl);
    c
}

fn verdict(c: &ClusterConfig) -> Result<(), (String, String)> {
    match c.validate() {
        Ok(()) => Ok(()),
        Err(ConfigError::Invalid { key, problem }) => Err((key, problem)),
        Err(other) => panic!("{other}"),
    }
}

/// A config edit that opens a port, the key named and what the message says is open.
type Opening = (&'static str, &'static str, fn(&mut ClusterConfig));

#[test]
fn unauthenticated_ports_off_loopback_need_the_named_opt_in() {
    let base = secured();
    assert_eq!(verdict(&base), Ok(()));
    let open: [Opening; 4] = [
        (
            "cards[0].bind",
            "card0's ASCII and PMAC Ethernet ports on 0.0.0.0",
            |c| c.cards[0].bind = Some("0.0.0.0".into()),
        ),
        ("chain.bind", "the daisy chain on 10.1.2.3", |c| {
            c.chain.bind = Some("10.1.2.3".into())
        }),
        ("emcl.bind", "the EMCL bus on ::", |c| {
            c.emcl.bind = Some("::".into())
        }),
        ("cards[0].bind", "card0's gpascii port on 0.0.0.0", |c| {
            c.cards[0].profile = "power".into();
            c.cards[0].ssh_password = "s3cret".into();
            c.cards[0].bind = Some("0.0.0.0".into());
        }),
    ];
    for (key, what, f) in open {
        let mut c = base.clone();
        f(&mut c);
        let (k, problem) = verdict(&c).unwrap_err();
        assert_eq!(k, key, "{problem}");
        assert!(problem.contains(what), "{problem}");
        assert!(
            problem.contains("[security] expose_unauthenticated = true"),
            "{problem}"
        );
        c.security.expose_unauthenticated = true;
        assert_eq!(verdict(&c), Ok(()), "{key} with the opt-in");
    }
    // Loopback needs nothing.
    let mut c = base.clone();
    c.cards[0].bind = Some("127.0.0.2".into());
    c.chain.bind = Some("::1".into());
    assert_eq!(verdict(&c), Ok(()));
}

#[test]
fn a_power_cards_ssh_off_loopback_refuses_the_factory_password() {
    let mut c = secured();
    c.cards[0].profile = "power".into();
    assert_eq!(c.cards[0].ssh_password, FACTORY_SSH_PASSWORD);
    // On loopback the factory login is what host tools expect.
    assert_eq!(verdict(&c), Ok(()));
    c.cards[0].bind = Some("192.168.1.9".into());
    // With or without the opt-in for the unauthenticated ports.
    for opt_in in [false, true] {
        c.security.expose_unauthenticated = opt_in;
        let (k, problem) = verdict(&c).unwrap_err();
        assert_eq!(k, "cards[0].ssh_password", "{problem}");
        assert!(problem.contains("cards[0].bind"), "{problem}");
        assert!(problem.contains("\"deltatau\""), "{problem}");
    }
    c.cards[0].ssh_password = "n0t-the-factory-one".into();
    assert_eq!(verdict(&c), Ok(()));
}

#[test]
fn the_opt_in_is_a_key_of_its_own_table() {
    let text = ClusterConfig::default_cluster(1, 0)
        .to_toml_string()
        .unwrap();
    assert!(
        !text.contains("[security]"),
        "the default writes no [security]"
    );
    let c = ClusterConfig::from_toml_str(&format!(
        "{text}\n[security]\nexpose_unauthenticated = true\n"
    ))
    .unwrap();
    assert!(c.security.expose_unauthenticated);
    let back = ClusterConfig::from_toml_str(&c.to_toml_string().unwrap()).unwrap();
    assert_eq!(back.security, c.security);
    let e = ClusterConfig::from_toml_str(&format!("{text}\n[security]\nexpose = true\n"));
    assert!(matches!(e, Err(ConfigError::Parse(_))), "{e:?}");
}
