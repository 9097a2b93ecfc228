"""Shared fixtures: the runner binary (GRAINS_BIN, set by tests/run.sh) and the repository root."""
import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def grains_bin():
    path = os.environ.get("GRAINS_BIN")
    if not path:
        pytest.skip("GRAINS_BIN is not set (tests/run.sh sets it)")
    return str(pathlib.Path(path).resolve())   # tests run commands from other folders


@pytest.fixture(scope="session")
def root():
    return ROOT
