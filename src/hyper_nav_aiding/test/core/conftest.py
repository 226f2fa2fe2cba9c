"""Shared seed 004 flights (scenario seed004_virtual: lock lost from 30 s) for the virtual GNSS tests."""
import pytest

from hyper_nav_aiding.seed004_cases import prepare

DURATION_S = 40.0


@pytest.fixture(scope="session")
def flight_perfect():
    return prepare(1, "perfect", DURATION_S)


@pytest.fixture(scope="session")
def flight_realistic():
    return prepare(1, "realistic", DURATION_S)
