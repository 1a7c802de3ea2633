# Shared pieces of the Python module's tests: the command-line executable (DSNAKE_EXE, set by
# ctest; else the release build's) and one run of the built-in default experiment per session.
import os
import pathlib

import pytest

import dsnake

SOURCE_DIR = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def dsnake_exe():
    exe = os.environ.get("DSNAKE_EXE", str(SOURCE_DIR / "build/release/experiments/dsnake"))
    if not os.path.exists(exe):
        pytest.skip("no dsnake executable at " + exe)
    return exe


@pytest.fixture(scope="session")
def default_result():
    return dsnake.run("builtin:default")
