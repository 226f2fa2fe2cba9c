"""Shared seed 004 flights for the virtual GNSS tests: scenario seed004_virtual,
20 s, lock lost from 10 s (the scenario's 30 s would cost 30 s more of flight)."""
import pytest

from hyper_nav_aiding.virtual_gnss.offline import prepare

DURATION_S = 20.0
T_LOSS_S = 10.0
OVER = {"gnss.raw.lock.outages": [[T_LOSS_S, 500.0]]}


@pytest.fixture(scope="session")
def flight_perfect():
    return prepare(1, "perfect", DURATION_S, overrides=OVER)


@pytest.fixture(scope="session")
def flight_realistic():
    return prepare(1, "realistic", DURATION_S, overrides=OVER)
