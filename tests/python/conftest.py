"""Shared fixtures: the runner binary (GRAINS_BIN, set by tests/run.sh) and the repository root."""
import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
if os.environ.get("GRAINS_BIN"):   # absolute, for the tests that run commands from other folders
    os.environ["GRAINS_BIN"] = str(pathlib.Path(os.environ["GRAINS_BIN"]).resolve())


@pytest.fixture(scope="session")
def grains_bin():
    path = os.environ.get("GRAINS_BIN")
    if not path:
        pytest.skip("GRAINS_BIN is not set (tests/run.sh sets it)")
    return path


@pytest.fixture(scope="session")
def root():
    return ROOT
