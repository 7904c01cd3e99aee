"""dls_pmaclib's PPmacSshInterface, unmodified, against Power cards: SSH login (root/deltatau),
the shell's `gpascii -2`, `cid`, element reads and writes, wrong credentials refused (a standalone
`mcc-card --profile power`), and a program download and run on a Power card in a lockstep
cluster (`mcc up --config` with `profile = "power"`, its SSH port from `mcc status --json`).
Every wait is bounded (SIGALRM: the client itself waits forever for a reply end)."""

import os
import tempfile
from pathlib import Path

import pytest
from dls_pmaclib.dls_pmacremote import PPmacSshInterface
from conftest import CardProcess
from mcc_cluster import SCRUB, UP_TIMEOUT, Cluster, wait_for


@pytest.fixture(autouse=True)
def bounded(deadline):
    """Every test here is bounded (conftest's `deadline`)."""


def ssh_client(port, **login):
    p = PPmacSshInterface(timeout=5.0)
    p.setConnectionParams("127.0.0.1", port)
    err = p.connect(**login)
    return p, err


def ask(p, cmd):
    reply, ok = p.sendCommand(cmd)
    assert ok, (cmd, reply)
    return reply


def test_standalone_power_card_prints_its_gpascii_and_ssh_ports(power_card):
    assert set(power_card.ports) == {"gpascii", "ssh"}
    assert power_card.ssh != power_card.gpascii


def test_connect_cid_and_model(power_card):
    p, err = ssh_client(power_card.ssh)
    assert err is None, err
    try:
        assert p.isConnectionOpen
        # getPmacModel asks `cid` (the client returns the code only on its first call).
        assert p.getPmacModel() == "Power PMAC UMAC"
        assert ask(p, "cid") == "604020\r"
    finally:
        p.disconnect()


def test_element_and_variable_reads_and_writes(power_card):
    p, err = ssh_client(power_card.ssh)
    assert err is None, err
    try:
        # `connect` set echo 7: value-only replies.
        p.setVar("P100", 42.5)
        assert ask(p, "P100") == "42.5\r"
        p.setVar("Motor[1].JogSpeed", 12.25)
        assert ask(p, "Motor[1].JogSpeed") == "12.25\r"
        # Several values in one line: one per line.
        assert ask(p, "P100 Motor[1].JogSpeed") == "42.5\r12.25\r"
    finally:
        p.disconnect()


def test_each_connection_is_its_own_command_thread(power_card):
    a, err = ssh_client(power_card.ssh)
    assert err is None, err
    b, err = ssh_client(power_card.ssh)
    assert err is None, err
    try:
        ask(a, "#3")
        ask(b, "#5")
        assert ask(a, "#") == "#3\r"
        assert ask(b, "#") == "#5\r"
    finally:
        a.disconnect()
        b.disconnect()


def test_wrong_credentials_are_refused(power_card):
    for login in ({"password": "DeltaTau"}, {"username": "admin"}, {"password": ""}):
        p, err = ssh_client(power_card.ssh, **login)
        assert err == "Invalid username or password", (login, err)
        assert not p.isConnectionOpen


class PowerCluster(Cluster):
    """`mcc up --detach --config` of a lockstep cluster whose card0 (the sync master) is a Power
    card, with one station, in a private run directory; `mcc down` at the end."""

    def __init__(self, tmp):
        self.run_dir = tempfile.mkdtemp(prefix="mcc-power-")
        self.name = f"power{os.getpid()}"
        self.env = {k: v for k, v in os.environ.items() if k not in SCRUB}
        self.env["MCC_RUN_DIR"] = self.run_dir
        text = self.mcc("up", "--cards", "1", "--stations", "1", "--print-config")
        assert 'profile = "pmac2"' in text, text
        text = text.replace('profile = "pmac2"', 'profile = "power"', 1)
        text = text.replace('clock = "paced"', 'clock = "lockstep"', 1)
        self.config = Path(tmp) / "power.toml"
        self.config.write_text(text)
        self.mcc("up", "--detach", "--config", str(self.config), "--timeout", "150",
                 timeout=UP_TIMEOUT)


@pytest.fixture(scope="module")
def power_cluster(tmp_path_factory):
    cluster = PowerCluster(tmp_path_factory.mktemp("power"))
    yield cluster
    cluster.stop()


def test_program_download_and_run_on_a_power_card_in_a_cluster(power_cluster):
    card = power_cluster.status()["cards"][0]
    assert card["profile"] == "power"
    assert card["gpascii"] and card["ssh"], card
    assert card["ascii"] is None and card["pmac_eth"] is None, card
    p, err = ssh_client(card["ssh"])
    assert err is None, err
    try:
        assert p.getPmacModelCode() == 604020
        program = [
            "P200=0 P201=0",
            "open plc 1",
            "P200=7",
            "P201=P201+1",
            "if (P201 >= 5) {",
            "disable plc 1",
            "}",
            "close",
            "enable plc 1",
        ]
        # A line without output: the client's post-processing leaves the two ACK line ends.
        for line in program:
            assert ask(p, line) == "\r\r", line
        wait_for("PLC 1 to finish", lambda: ask(p, "P201") == "5\r", timeout=120)
        assert ask(p, "P200") == "7\r"
    finally:
        p.disconnect()


def test_unsupported_shell_commands_get_a_clear_shell_error(power_card):
    p, err = ssh_client(power_card.ssh)
    assert err is None, err
    try:
        # dls-powerpmacanalyse's executeRemoteShellCommand: exec, then the exit status.
        stdin, stdout, stderr = p.client.exec_command("ls /var/ftp/usrflash", timeout=10)
        assert stdout.channel.recv_exit_status() == 127
        assert stderr.read().decode() == (
            "-sh: ls: command not found (this controller's shell runs gpascii -2 and exit)\n"
        )
        assert stdout.read() == b""
        # The SFTP subsystem (scp, getFile) is refused; the session's gpascii still answers.
        with pytest.raises(Exception):
            p.client.open_sftp()
        assert ask(p, "cid") == "604020\r"
    finally:
        p.disconnect()




def test_a_wrong_password_leaves_password_to_try_again():
    """Issue 26 item 6, as paramiko (PPmacSshInterface's SSH library) sees it: a refusal is a
    plain authentication failure that still offers `password` (before: no method was left,
    `BadAuthenticationType`), and paramiko's next attempts on the same connection are
    answered: a second wrong password is refused again (paramiko asks for the `ssh-userauth`
    service before every attempt; russh 0.65 ignored the repeat and left paramiko waiting for
    its own 20 s timeout, fixed in card/vendor/russh), then the right one logs in. A card of
    its own: only this test's failures to wait for (0.6 s, then 1.2 s)."""
    import socket
    import time

    import paramiko

    card = CardProcess("power")
    sock = socket.create_connection(("127.0.0.1", card.ssh), timeout=20)
    t = paramiko.Transport(sock)
    t.auth_timeout = 20
    try:
        t.start_client(timeout=20)
        with pytest.raises(paramiko.AuthenticationException) as e:
            t.auth_password("root", "guess")
        assert not isinstance(e.value, paramiko.BadAuthenticationType), e.value
        started = time.monotonic()
        with pytest.raises(paramiko.AuthenticationException) as e:
            t.auth_password("root", "guess again")
        assert not isinstance(e.value, paramiko.BadAuthenticationType), e.value
        assert time.monotonic() - started < 15, "the second attempt was not answered"
        assert t.auth_password("root", "deltatau") == []
        assert t.is_authenticated()
    finally:
        t.close()
        card.stop()


def test_paramiko_attempts_on_one_connection_end_at_max_auth_tries():
    """sshd's MaxAuthTries (6) as paramiko meets it: six refused attempts on one connection,
    each answered, then the connection is closed by the server ("Too many authentication
    attempts"); paramiko raises instead of waiting for its timeout."""
    import socket

    import paramiko

    card = CardProcess("power")
    sock = socket.create_connection(("127.0.0.1", card.ssh), timeout=60)
    t = paramiko.Transport(sock)
    t.auth_timeout = 30
    try:
        t.start_client(timeout=20)
        for i in range(6):
            with pytest.raises(paramiko.AuthenticationException):
                t.auth_password("root", f"guess {i}")
        with pytest.raises((paramiko.SSHException, EOFError)):
            t.auth_password("root", "deltatau")
        assert not t.is_authenticated()
    finally:
        t.close()
        card.stop()
