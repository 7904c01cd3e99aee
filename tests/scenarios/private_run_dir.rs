//! The run directory is the user's only (issue 26 item 5): after `mcc up --detach` it is 0700
//! and the resolved config (which holds a Power card's `ssh_password`), the supervisor record
//! and the logs are 0600.

use std::os::unix::fs::PermissionsExt;
use std::path::Path;

use mcc_testing::Cluster;
use mcc_tests::process::bin_dir;

const CONFIG: &str = r#"
clock = "lockstep"
[[cards]]
name = "card0"
number = 0
master = 0
profile = "power"
ssh_password = "not-for-other-users"
[[stations]]
name = "station0"
master = 0
"#;

fn mode(p: &Path) -> u32 {
    std::fs::metadata(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .permissions()
        .mode()
        & 0o777
}

#[test]
fn the_run_dir_and_the_config_with_a_password_are_private() {
    let mut c = Cluster::builder()
        .mcc(bin_dir().join("mcc"))
        .config_toml(CONFIG)
        .tag("private")
        .start()
        .unwrap_or_else(|e| panic!("cluster up: {e}"));
    let st = c.status().expect("status").0;
    let name = st["cluster"].as_str().expect("cluster name").to_string();
    let dir = c.run_base().join(&name);
    let config = dir.join("cluster.toml");
    let text = std::fs::read_to_string(&config).expect("cluster.toml");
    assert!(text.contains("not-for-other-users"), "{text}");
    assert_eq!(mode(&dir), 0o700, "{}", dir.display());
    assert_eq!(mode(&config), 0o600);
    assert_eq!(mode(&dir.join("supervisor.json")), 0o600);
    let logs: Vec<_> = std::fs::read_dir(dir.join("logs"))
        .expect("logs")
        .flatten()
        .map(|e| e.path())
        .collect();
    assert!(logs.len() >= 3, "{logs:?}");
    for l in logs {
        assert_eq!(mode(&l), 0o600, "{}", l.display());
    }
    assert_eq!(mode(&dir.join("logs")), 0o700);
}
