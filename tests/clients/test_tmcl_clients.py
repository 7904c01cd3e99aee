"""Real TMCL host libraries against a running cluster's EMCL bus (issue 12): pytrinamic over TCP
(`SocketTmclInterface`) and pyTMCL over the pseudo-terminal (pyserial). Version string, axis and
global parameters set/get/store/restore, positioning and read-back, rotate and stop, reference
search, digital and analog I/O, user variables (bank 2), program download (132/133) and its
execution. Every client call runs with a socket or serial timeout (shared/spec/tmcl-clients.md §4.4)."""

import socket

import pytest
import serial
import pyTMCL
from pyTMCL.commands import Command
from pytrinamic.connections import SerialTmclInterface, SocketTmclInterface
from pytrinamic.tmcl import TMCLReplyStatusError

from emcl_cluster import EmclCluster, wait_for

TIMEOUT = 20  # seconds per reply: the bus answers in ms, the machine may be busy


@pytest.fixture(scope="module")
def cluster():
    c = EmclCluster()
    yield c
    c.stop()


@pytest.fixture
def trinamic(cluster):
    iface = SocketTmclInterface(cluster.tcp, timeout_s=TIMEOUT)
    iface._socket.settimeout(TIMEOUT)  # required: pytrinamic sets none (blocks on silence)
    yield iface
    iface.close()


@pytest.fixture
def tmcl(cluster):
    port = serial.Serial(cluster.pty, 9600, timeout=TIMEOUT)
    port.reset_input_buffer()
    yield pyTMCL.connect(port)
    port.close()


# ---------------------------------------------------------------- pytrinamic over TCP


def test_pytrinamic_version_string_and_binary(trinamic):
    assert trinamic.get_version_string() == "1360V131"
    assert trinamic.send(136, 1, 0, 0).value == 0x05500131


def test_pytrinamic_axis_parameters_set_get_store_restore(trinamic):
    trinamic.set_axis_parameter(6, 0, 176)
    assert trinamic.get_axis_parameter(6, 0) == 176
    trinamic.store_axis_parameter(6, 0)
    trinamic.set_axis_parameter(6, 0, 100)
    assert trinamic.get_axis_parameter(6, 0) == 100
    trinamic.restore_axis_parameter(6, 0)
    assert trinamic.get_axis_parameter(6, 0) == 176
    # A parameter the EDB does not have (TMCL's microstep resolution): status 3.
    with pytest.raises(TMCLReplyStatusError) as e:
        trinamic.get_axis_parameter(140, 0)
    assert e.value.reply.status == 3
    # Out of range: status 4; nothing changed.
    with pytest.raises(TMCLReplyStatusError) as e:
        trinamic.set_axis_parameter(6, 0, 300)
    assert e.value.reply.status == 4
    assert trinamic.get_axis_parameter(6, 0) == 176


def test_pytrinamic_global_parameters_and_user_variables(trinamic):
    assert trinamic.get_global_parameter(66, 0) == 1
    trinamic.set_global_parameter(75, 0, 0)  # telegram pause (EEPROM at once)
    assert trinamic.get_global_parameter(75, 0) == 0
    trinamic.set_global_parameter(7, 2, -123456)
    assert trinamic.get_global_parameter(7, 2, signed=True) == -123456
    trinamic.store_global_parameter(7, 2)
    trinamic.set_global_parameter(7, 2, 0)
    trinamic.restore_global_parameter(7, 2)
    assert trinamic.get_global_parameter(7, 2, signed=True) == -123456
    # Variables 56..255 are RAM only: STGP refuses them (status 3).
    trinamic.set_global_parameter(200, 2, 9)
    assert trinamic.get_global_parameter(200, 2) == 9
    with pytest.raises(TMCLReplyStatusError) as e:
        trinamic.store_global_parameter(200, 2)
    assert e.value.reply.status == 3


def test_pytrinamic_move_to_position_and_read_it_back(trinamic):
    trinamic.set_axis_parameter(4, 0, 200000)
    trinamic.set_axis_parameter(5, 0, 400000)
    trinamic.move_to(0, 12345)
    wait_for("the target", lambda: trinamic.get_axis_parameter(8, 0) == 1
             and trinamic.get_axis_parameter(1, 0, signed=True) == 12345)
    trinamic.move_by(0, -22345)
    wait_for("the relative target", lambda: trinamic.get_axis_parameter(8, 0) == 1)
    assert trinamic.get_axis_parameter(1, 0, signed=True) == -10000
    assert trinamic.get_axis_parameter(0, 0, signed=True) == -10000


def test_pytrinamic_rotate_and_stop(trinamic):
    trinamic.set_axis_parameter(5, 0, 400000)
    trinamic.rotate(0, -20000)  # pytrinamic sends ROR with a signed velocity
    assert trinamic.get_axis_parameter(2, 0, signed=True) == -20000
    wait_for("full speed", lambda: trinamic.get_axis_parameter(3, 0, signed=True) == -20000)
    trinamic.stop(0)
    wait_for("standstill", lambda: trinamic.get_axis_parameter(3, 0, signed=True) == 0)
    p = trinamic.get_axis_parameter(1, 0, signed=True)
    wait_for("no drift", lambda: trinamic.get_axis_parameter(1, 0, signed=True) == p)


def test_pytrinamic_reference_search(trinamic):
    trinamic.set_axis_parameter(195, 0, 51200)  # search speed
    trinamic.reference_search(0, 0)  # START
    wait_for("the search to finish", lambda: trinamic.reference_search(2, 0) == 0)
    assert trinamic.get_axis_parameter(1, 0, signed=True) == 0
    assert trinamic.get_axis_parameter(209, 0, signed=True) == 0
    assert trinamic.get_axis_parameter(8, 0) == 1


def test_pytrinamic_digital_and_analog_io(trinamic, cluster):
    trinamic.set_global_parameter(72, 0, 0)  # OUT_0..2 as general outputs
    try:
        trinamic.set_digital_output(1)
        assert trinamic.get_digital_output(1) == 1
        trinamic.clear_digital_output(1)
        assert trinamic.get_digital_output(1) == 0
        cluster.input("in2=1", "analog=3000")
        assert trinamic.get_digital_input(2) == 1
        assert trinamic.get_digital_input(0) == 0
        assert trinamic.get_analog_input(0) == 3000
        cluster.input("in2=0")
        assert trinamic.get_digital_input(2) == 0
    finally:
        trinamic.set_global_parameter(72, 0, 7)


def test_pytrinamic_refusals_and_silence(trinamic):
    with pytest.raises(TMCLReplyStatusError) as e:
        trinamic.send(22, 0, 0, 5)  # JA in direct mode
    assert e.value.reply.status == 6
    with pytest.raises(TMCLReplyStatusError) as e:
        trinamic.send(99, 0, 0, 0)
    assert e.value.reply.status == 2
    # Nobody at address 5: RS485 silence (the socket times out).
    trinamic._socket.settimeout(1.5)
    with pytest.raises((socket.timeout, TimeoutError)):
        trinamic.send(6, 1, 0, 0, module_id=5)


def test_pytrinamic_refused_by_a_full_bus_raises_rather_than_reading_text(cluster):
    # Issue 26 item 4: the bus serves 16 hosts; the 17th is refused by closing, never with a
    # text line (which pytrinamic read as the version string "cc: EMCL").
    frame = bytes([1, 6, 1, 0, 0, 0, 0, 0, 8])  # GAP 1 of drive 1
    host, port = cluster.tcp.rsplit(":", 1)
    hosts = []
    try:
        for _ in range(16):
            s = socket.create_connection((host, int(port)), timeout=TIMEOUT)
            s.sendall(frame)
            got = b""
            while len(got) < 9:
                chunk = s.recv(9 - len(got))
                assert chunk, "a host below the limit was closed"
                got += chunk
            assert got[2] == 100, got
            hosts.append(s)
        iface = SocketTmclInterface(cluster.tcp, timeout_s=3)
        iface._socket.settimeout(3)
        try:
            with pytest.raises((ConnectionError, TimeoutError, socket.timeout)):
                iface.get_version_string()
        finally:
            iface.close()
    finally:
        for s in hosts:
            s.close()


def test_pytrinamic_download_and_run_a_program(trinamic):
    # pytrinamic's own recipe (examples/.../tmcl_script_load.py): 132, frames, 133, 131, 129 type 0.
    program = [
        (5, 4, 0, 100000),   # SAP 4
        (1, 0, 0, 30000),    # ROR 30000
        (27, 0, 0, 20),      # WAIT TICKS 20 (200 ms)
        (3, 0, 0, 0),        # MST
        (27, 0, 0, 30),      # WAIT TICKS 30 (the MST ramp)
        (9, 20, 2, 4242),    # SGP 20, 2, 4242: tell the host
        (28, 0, 0, 0),       # STOP
    ]
    assert trinamic.send(132, 0, 0, 0).status == 100
    for op, typ, motor, value in program:
        assert trinamic.send(op, typ, motor, value).status == 101
    assert trinamic.send(133, 0, 0, 0).status == 100
    trinamic.set_global_parameter(20, 2, 0)
    start = trinamic.get_axis_parameter(1, 0, signed=True)
    trinamic.send(131, 0, 0, 0)
    assert trinamic.send(135, 0, 0, 0).value == 3
    trinamic.send(129, 0, 0, 0)
    wait_for("the program's mailbox", lambda: trinamic.get_global_parameter(20, 2) == 4242)
    wait_for("the program to stop", lambda: trinamic.send(135, 0, 0, 0).value == 0)
    assert trinamic.get_global_parameter(130, 0) == 6, "PC stays on STOP"
    moved = trinamic.get_axis_parameter(1, 0, signed=True) - start
    # ~200 ms at 30000 pps plus the ramps: about 6000 µsteps.
    assert 5000 < moved < 9000, moved
    assert trinamic.get_axis_parameter(3, 0, signed=True) == 0


# ---------------------------------------------------------------- pyTMCL over the pty


def test_version_string_over_the_pty(cluster):
    # pyTMCL cannot decode the checksum-less 136 string reply (KeyError, tmcl-clients.md §2.2):
    # read it with pytrinamic's serial interface on the same pty, and raw with pyserial.
    with SerialTmclInterface(cluster.pty, datarate=9600, timeout_s=TIMEOUT) as iface:
        assert iface.get_version_string() == "1360V131"
    with serial.Serial(cluster.pty, 115200, timeout=TIMEOUT) as port:
        port.reset_input_buffer()
        port.write(bytes.fromhex("01 88 00 00 00 00 00 00 89"))
        assert port.read(9) == b"\x021360V131"


def test_pytmcl_axis_parameters_and_eeprom(tmcl):
    motor = tmcl.get_motor(1)
    motor.axis.max_current = 150
    assert motor.axis.max_current == 150
    assert motor.send(Command.STAP, 6, 0, 0).status == 100
    motor.axis.max_current = 20
    assert motor.send(Command.RSAP, 6, 0, 0).status == 100
    assert motor.axis.max_current == 150
    assert tmcl.send(1, Command.GET_FIRMWARE_VERSION, 1, 0, 0).value == 0x05500131
    with pytest.raises(pyTMCL.reply.TrinamicException):
        motor.axis.get(153)  # TMCL ramp divisor: not an EDB parameter


def test_pytmcl_move_and_read_back(tmcl):
    motor = tmcl.get_motor(1)
    motor.axis.max_positioning_speed = 200000
    motor.axis.max_accelleration = 400000
    motor.move_absolute(-7777)
    wait_for("the target", lambda: motor.axis.target_position_reached == 1)
    assert motor.axis.actual_position == -7777
    motor.move_relative(10000)
    wait_for("the relative target", lambda: motor.axis.target_position_reached == 1)
    assert motor.axis.actual_position == 2223


def test_pytmcl_rotate_left_and_stop(tmcl):
    motor = tmcl.get_motor(1)
    motor.rotate_left(15000)  # pyTMCL sends ROL: the EDB turns negative
    assert motor.axis.target_speed == -15000
    wait_for("full speed", lambda: motor.axis.actual_speed == -15000)
    motor.stop()
    wait_for("standstill", lambda: motor.axis.actual_speed == 0)


def test_pytmcl_reference_search(tmcl):
    motor = tmcl.get_motor(1)
    motor.move_absolute(30000)
    wait_for("the start point", lambda: motor.axis.target_position_reached == 1)
    assert motor.reference_search(0) == 100  # RFS START (pyTMCL sends value 99)
    wait_for("the search", lambda: motor.send(Command.RFS, 2, 0, 0).value == 0)
    assert motor.axis.actual_position == 0


def test_pytmcl_user_variables_and_io(tmcl, cluster):
    motor = tmcl.get_motor(1)
    motor.set_user_var(3, -99)
    assert motor.get_user_var(3) == -99
    tmcl.send(1, Command.SGP, 72, 0, 0)
    try:
        assert tmcl.send(1, Command.SIO, 0, 2, 1).status == 100
        assert tmcl.send(1, Command.GIO, 0, 2, 0).value == 1
        cluster.input("in1=1")
        assert tmcl.send(1, Command.GIO, 1, 0, 0).value == 1
        cluster.input("in1=0")
        tmcl.send(1, Command.SIO, 0, 2, 0)
    finally:
        tmcl.send(1, Command.SGP, 72, 0, 7)


def test_pytmcl_download_and_run_command(tmcl):
    # A jump table at 0/1 (the seed's host-called routines, §12) loaded with 132/133.
    prog = [
        (22, 0, 0, 2),            # 0: JA 2
        (22, 0, 0, 5),            # 1: JA 5
        (19, 9, 0, 11),           # 2: CALC LOAD 11
        (35, 30, 2, 0),           # 3: AGP 30, 2
        (28, 0, 0, 0),            # 4: STOP
        (19, 9, 0, 22),           # 5: CALC LOAD 22
        (35, 30, 2, 0),           # 6: AGP 30, 2
        (28, 0, 0, 0),            # 7: STOP
    ]
    assert tmcl.send(1, Command.START_DOWNLOAD_MODE, 0, 0, 0).status == 100
    for op, typ, bank, value in prog:
        assert tmcl.send(1, op, typ, bank, value).status == 101
    assert tmcl.send(1, Command.QUIT_DOWNLOAD_MODE, 0, 0, 0).status == 100
    motor = tmcl.get_motor(1)
    assert motor.run_command(1) == 100  # 129 type 1 at 1: Func2
    wait_for("routine 2", lambda: motor.get_user_var(30) == 22)
    wait_for("its STOP", lambda: tmcl.send(1, Command.GET_APPLICATION_STATUS, 0, 0, 0).value == 0)
    assert tmcl.send(1, Command.GGP, 130, 0, 0).value == 7
    assert motor.run_command(0) == 100
    wait_for("routine 1", lambda: motor.get_user_var(30) == 11)
