"""What ``pip install pytest-mcc`` put in the venv: the package at the workspace's version,
``mcc`` on the venv's PATH answering ``--version`` with the same, and nothing of a Rust
workspace around (``python/test-wheel.sh`` sets ``MCC_EXPECT_VERSION`` and the clean PATH)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest_mcc
from pytest_mcc._cli import bundled_mcc, find_mcc

VERSION = os.environ["MCC_EXPECT_VERSION"]
BIN = Path(sys.prefix) / "bin"


def test_pip_show_lists_the_package_with_its_version():
    out = subprocess.run([sys.executable, "-m", "pip", "show", "pytest-mcc"],
                         capture_output=True, text=True, check=True).stdout
    fields = dict(line.split(": ", 1) for line in out.splitlines() if ": " in line)
    assert fields["Name"] == "pytest-mcc"
    assert fields["Version"] == VERSION
    assert pytest_mcc.__version__ == VERSION


def test_mcc_on_the_venv_path_is_the_workspace_version():
    mcc = shutil.which("mcc")
    assert mcc is not None and Path(mcc).parent == BIN, mcc
    out = subprocess.run([mcc, "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == f"mcc {VERSION}"


def test_the_plugin_finds_the_bundled_binary_first():
    assert bundled_mcc() == str((BIN / "mcc").resolve())
    assert find_mcc() == bundled_mcc()


def test_nothing_of_the_workspace_is_around():
    for var in ("MCC_BIN", "MCC_BIN_DIR"):
        assert var not in os.environ
    for tool in ("cargo", "rustc", "mcc-card", "mcc-station"):
        assert shutil.which(tool) is None, tool
    for d in os.environ["PATH"].split(os.pathsep):
        assert "target" not in Path(d).parts and ".cargo" not in Path(d).parts, d
