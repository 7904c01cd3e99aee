"""The package's own tests: `pytester` runs inner pytest sessions for the teardown tests."""

pytest_plugins = ["pytester"]

import pytest

from pytest_mcc._cli import find_mcc


@pytest.fixture(scope="session")
def mcc(pytestconfig):
    """Path of the mcc binary under test."""
    return find_mcc(pytestconfig.getoption("--mcc-bin"))
