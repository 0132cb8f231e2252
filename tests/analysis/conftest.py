"""Fixtures of the analysis tests: hand-written protocol modules (see fixtures/README.md)."""

from __future__ import annotations

import pytest
from _analysis_helpers import load_fixture


@pytest.fixture(scope="session")
def two_mass():
    return load_fixture("two_mass")


@pytest.fixture(scope="session")
def spring_pendulum():
    return load_fixture("spring_pendulum")


@pytest.fixture(scope="session")
def cartesian_pendulum():
    return load_fixture("cartesian_pendulum")


@pytest.fixture(scope="session")
def cart_pendulum():
    return load_fixture("cart_pendulum")


@pytest.fixture(scope="session")
def slider_crank():
    return load_fixture("slider_crank")
