use super::*;

fn parse(text: &str) -> Result<ClusterConfig, ConfigError> {
    ClusterConfig::from_toml_str(text)
}

fn err(text: &str) -> (String, String) {
    match parse(text).unwrap_err() {
        ConfigError::Invalid { key, problem } => (key, problem),
        other => panic!("{other}"),
    }
}

const TWO_HOSTS: &str = r#"
cluster = "lab"
[zenoh]
routers = ["tcp/127.0.0.1:7447"]
[[cards]]
name = "card0"
number = 0
master = 0
host = "a"
[[cards]]
name = "card1"
number = 1
master = 1
host = "b"
[[stations]]
name = "station0"
master = 0
host = "a"
[[stations]]
name = "station1"
master = 1
host = "b"
[[drives]]
name = "drive0"
address = 1
station = "station1"
[[drives]]
name = "loose"
address = 2
host = "a"
"#;

#[test]
fn members_belong_to_hosts_and_drives_follow_their_station() {
    let c = parse(TWO_HOSTS).unwrap();
    assert!(c.is_multi_host());
    assert_eq!(
        c.topology(),
        Topology::Routers(vec!["tcp/127.0.0.1:7447".into()])
    );
    assert_eq!(c.host_names(), vec!["a", "b"]);
    assert_eq!(c.host_processes("a"), vec!["card0", "station0", "loose"]);
    assert_eq!(c.host_processes("b"), vec!["card1", "station1"]);
    assert_eq!(c.member_host("drive0"), Some("b"));
    assert_eq!(c.member_host("nobody"), None);
    // The resolved config survives the run directory; its digest is stable and sensitive.
    let again = parse(&c.to_toml_string().unwrap()).unwrap();
    assert_eq!(again, c);
    assert_eq!(again.digest(), c.digest());
    assert_eq!(c.digest().len(), 64);
    let mut other = c.clone();
    other.rate_hz = 1000.0;
    assert_ne!(other.digest(), c.digest());
    // A cluster without hosts is one host, "local".
    let single = ClusterConfig::default_cluster(2, 2);
    assert_eq!(single.topology(), Topology::Single);
    assert_eq!(single.host_names(), vec![LOCAL_HOST]);
    assert_eq!(single.host_processes(LOCAL_HOST).len(), 4);
}

#[test]
fn host_rules_name_the_key() {
    let missing = TWO_HOSTS.replacen("host = \"b\"\n[[stations]]", "[[stations]]", 1);
    let (key, problem) = err(&missing);
    assert_eq!(key, "cards[1].host");
    assert!(problem.contains("\"card1\" names no host"), "{problem}");
    assert!(problem.contains("\"card0\" is on host \"a\""), "{problem}");
    let (key, problem) = err(&TWO_HOSTS.replace(
        "station = \"station1\"",
        "station = \"station1\"\nhost = \"a\"",
    ));
    assert_eq!(key, "drives[0].host");
    assert!(problem.contains("runs on station"), "{problem}");
    let (key, _) =
        err(&TWO_HOSTS.replace("host = \"a\"\n[[cards]]", "host = \"local\"\n[[cards]]"));
    assert_eq!(key, "cards[0].host");
    let (key, problem) = err(&format!("{TWO_HOSTS}\n[hosts.c]\n"));
    assert_eq!(key, "hosts.c");
    assert!(problem.contains("no member is on host \"c\""), "{problem}");
    // Several hosts need a router or every host's address.
    let p2p = TWO_HOSTS.replace("routers = [\"tcp/127.0.0.1:7447\"]", "");
    let (key, problem) = err(&p2p);
    assert_eq!(key, "hosts.a.address");
    assert!(problem.contains("zenoh.routers"), "{problem}");
    let (key, _) = err(&format!("{p2p}\n[hosts.a]\naddress = \"127.0.0.1\"\n"));
    assert_eq!(key, "hosts.b.address");
    let ok = parse(&format!(
        "{p2p}\n[hosts.a]\naddress = \"127.0.0.1\"\nport = 7001\n[hosts.b]\naddress = \"127.0.0.1\"\nport = 7002\n"
    ))
    .unwrap();
    assert_eq!(ok.topology(), Topology::PeerToPeer);
    assert_eq!(ok.host_endpoint("b").as_deref(), Some("tcp/127.0.0.1:7002"));
    assert_eq!(ok.host_listen("a").as_deref(), Some("tcp/127.0.0.1:0"));
    let (key, problem) = err(&format!(
        "{p2p}\n[hosts.a]\naddress = \"127.0.0.1\"\n[hosts.b]\naddress = \"127.0.0.1\"\n"
    ));
    assert_eq!(key, "hosts.b.port");
    assert!(problem.contains("already host \"a\""), "{problem}");
    let (key, _) = err(&format!(
        "{p2p}\n[hosts.a]\naddress = \"rack1\"\n[hosts.b]\naddress = \"::1\"\n"
    ));
    assert_eq!(key, "hosts.a.address");
    let (key, _) = err(&format!(
        "{TWO_HOSTS}\n[hosts.a]\naddress = \"127.0.0.1\"\n"
    ));
    assert_eq!(key, "hosts.a.address");
    let (key, _) = err(&format!(
        "{p2p}\n[hosts.a]\naddress = \"127.0.0.1\"\nport = 0\n[hosts.b]\naddress = \"127.0.0.2\"\n"
    ));
    assert_eq!(key, "hosts.a.port");
}

#[test]
fn endpoints_on_loopback_stay_local() {
    assert!(!endpoint_is_exposed("tcp/127.0.0.1:7447"));
    assert!(!endpoint_is_exposed("tcp/127.5.0.1:7447?x=1#y=2"));
    assert!(!endpoint_is_exposed("tcp/[::1]:7447"));
    assert!(!endpoint_is_exposed("tcp/localhost:7447"));
    assert!(!endpoint_is_exposed("unixsock-stream//run/mcc/x.sock"));
    assert!(endpoint_is_exposed("tcp/0.0.0.0:7447"));
    assert!(endpoint_is_exposed("tcp/[::]:7447"));
    assert!(endpoint_is_exposed("tcp/10.0.0.5:7447#iface=eth0"));
    assert!(endpoint_is_exposed("tls/rack1.lab:7447"));
    assert_eq!(tcp_endpoint("::1", 5), "tcp/[::1]:5");
}

const SECURED: &str = r#"
[zenoh.auth]
user = "mcc"
password_file = "/etc/mcc/zenoh.pass"
[zenoh.access_control]
enabled = true
default_permission = "deny"
"#;

fn verdict(c: &ClusterConfig) -> Result<(), (String, String)> {
    match c.validate() {
        Ok(()) => Ok(()),
        Err(ConfigError::Invalid { key, problem }) => Err((key, problem)),
        Err(other) => panic!("{other}"),
    }
}

fn secure(c: &mut ClusterConfig) {
    let extra = parse(&format!(
        "{}\n{SECURED}",
        ClusterConfig::default_cluster(1, 0)
            .to_toml_string()
            .unwrap()
    ))
    .unwrap();
    c.zenoh.auth = extra.zenoh.auth;
    c.zenoh.access_control = extra.zenoh.access_control;
}

/// A config edit that opens something to other hosts, and the key it names.
type Opening = (&'static str, fn(&mut ClusterConfig));

#[test]
fn opening_anything_to_other_hosts_needs_auth_and_access_control() {
    let base = ClusterConfig::default_cluster(2, 2);
    // Everything on loopback: nothing to secure.
    assert!(verdict(&base).is_ok());
    let open: [Opening; 6] = [
        ("zenoh.listen[0]", |c| {
            c.zenoh.listen.push("tcp/0.0.0.0:7447".into())
        }),
        ("zenoh.connect[0]", |c| {
            c.zenoh.connect.push("tcp/10.0.0.5:7447".into())
        }),
        ("chain.bind", |c| c.chain.bind = Some("0.0.0.0".into())),
        ("emcl.bind", |c| c.emcl.bind = Some("::".into())),
        ("cards[0].bind", |c| {
            c.cards[0].bind = Some("10.1.2.3".into())
        }),
        ("cards[1].bind", |c| {
            c.cards[1].bind = Some("192.168.1.9".into())
        }),
    ];
    for (key, f) in open {
        let mut c = base.clone();
        f(&mut c);
        let (k, problem) = verdict(&c).unwrap_err();
        assert_eq!(k, "zenoh.auth", "{key}");
        assert!(problem.contains(key), "{key}: {problem}");
        assert!(problem.contains("zenoh.access_control"), "{problem}");
        // Auth alone is not enough: access control too.
        let mut half = c.clone();
        let listens = key == "zenoh.listen[0]";
        secure(&mut half);
        half.zenoh.access_control = None;
        if listens {
            half.zenoh.auth.as_mut().unwrap().dictionary_file = Some("/etc/mcc/users".into());
        }
        assert_eq!(
            verdict(&half).unwrap_err().0,
            "zenoh.access_control",
            "{key}"
        );
        secure(&mut c);
        if listens {
            // A listener open to other hosts must know whom it accepts.
            assert_eq!(verdict(&c).unwrap_err().0, "zenoh.auth.dictionary_file");
            c.zenoh.auth.as_mut().unwrap().dictionary_file = Some("/etc/mcc/users".into());
        }
        if key.ends_with(".bind") {
            // Ports with no authentication of their own: the explicit opt-in too.
            assert_eq!(verdict(&c).unwrap_err().0, key);
            c.security.expose_unauthenticated = true;
        }
        assert_eq!(verdict(&c), Ok(()), "{key}");
    }
    let mut c = base.clone();
    c.cards[0].bind = Some("10.1.2.3".into());
    assert!(verdict(&c)
        .unwrap_err()
        .1
        .contains("card0's host ports on 10.1.2.3"));
    // Loopback binds are no exposure; a bind that is no address is an error.
    c.cards[0].bind = Some("127.0.0.1".into());
    assert_eq!(verdict(&c), Ok(()));
    c.cards[0].bind = Some("anywhere".into());
    assert_eq!(verdict(&c).unwrap_err().0, "cards[0].bind");
    // Access control must be enabled.
    let mut c = base.clone();
    secure(&mut c);
    c.zenoh
        .access_control
        .as_mut()
        .unwrap()
        .insert("enabled".into(), toml::Value::Boolean(false));
    assert_eq!(verdict(&c).unwrap_err().0, "zenoh.access_control.enabled");
    // TLS on every exposed endpoint instead of user/password.
    let mut tls = base.clone();
    tls.zenoh.listen.push("tls/0.0.0.0:7447".into());
    tls.zenoh.tls = Some(toml::Table::new());
    secure(&mut tls);
    tls.zenoh.auth = None;
    assert_eq!(verdict(&tls), Ok(()));
    tls.zenoh.listen.push("tcp/0.0.0.0:7448".into());
    assert_eq!(verdict(&tls).unwrap_err().0, "zenoh.auth");
    // A router on another host is a link to other hosts too.
    let routed = parse(&TWO_HOSTS.replace("127.0.0.1:7447", "10.0.0.5:7447"));
    let routed = routed.unwrap_err();
    assert!(routed.to_string().contains("zenoh.auth"), "{routed}");
    assert!(parse(&format!(
        "{}\n{SECURED}",
        TWO_HOSTS.replace("127.0.0.1:7447", "10.0.0.5:7447")
    ))
    .is_ok());
}
