"""Which ``mcc`` the plugin runs: the one the wheel installed (``python/run-tests.sh``
installs the wheel), before ``--mcc-bin`` and ``$MCC_BIN``."""

import sys
import warnings
from pathlib import Path

import pytest

from pytest_mcc._cli import bundled_mcc, find_mcc


def test_the_wheel_installed_mcc_in_the_environment_scripts():
    assert bundled_mcc() == str((Path(sys.prefix) / "bin" / "mcc").resolve())


def test_another_binary_named_is_warned_about_and_the_bundled_one_runs(tmp_path, monkeypatch):
    bundled = bundled_mcc()
    other = tmp_path / "mcc"
    other.write_text("#!/bin/sh\nexit 1\n")
    other.chmod(0o755)
    with pytest.warns(UserWarning, match=r"runs the mcc binary it was installed with .* not"):
        assert find_mcc(str(other)) == bundled
    monkeypatch.setenv("MCC_BIN", str(other))
    with pytest.warns(UserWarning, match="--mcc-bin/\\$MCC_BIN are for an install without it"):
        assert find_mcc() == bundled
    # Naming the bundled binary itself is no news.
    monkeypatch.delenv("MCC_BIN")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert find_mcc(bundled) == bundled
