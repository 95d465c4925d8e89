"""Shared fixtures: the repository, and Rust binaries the tests compare with
(built with cargo on first use, in the workspace's target directory)."""

import json
import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def cargo_binary(args, name, kind):
    """Builds a binary with `cargo build ARGS` and returns its path."""
    subprocess.run(["cargo", "build", "--quiet", *args], cwd=REPO, check=True)
    meta = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"],
        cwd=REPO, check=True, capture_output=True, text=True,
    )
    target = pathlib.Path(json.loads(meta.stdout)["target_directory"])
    path = target / "debug" / (kind + name) if kind else target / "debug" / name
    assert path.exists(), path
    return path


@pytest.fixture(scope="session")
def repo():
    return REPO


@pytest.fixture(scope="session")
def reference():
    """python/tests/reference.rs: the Rust API's answers, point by point."""
    return cargo_binary(["-p", "tsl-python", "--example", "reference"], "reference", "examples/")


@pytest.fixture(scope="session")
def tslc():
    """The CLI (`TSLC` names a built one)."""
    if os.environ.get("TSLC"):
        return pathlib.Path(os.environ["TSLC"])
    return cargo_binary(["--bin", "tslc"], "tslc", "")
