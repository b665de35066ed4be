"""Shared fixtures of the Python module's tests: the `stend` program to compare with, the source
tree, simulated runs made once per session in a temporary folder (nothing is written elsewhere)."""
import json
import os
import subprocess
from pathlib import Path

import pytest

SOURCE = Path(os.environ.get("STEND_SOURCE_DIR", Path(__file__).resolve().parents[2]))
PROGRAM = os.environ.get("STEND_PROGRAM", str(SOURCE / "build" / "bin" / "stend"))
SHARED = Path(os.environ.get("STEND_SHARED_DATA_DIR", SOURCE.parent / "shared" / "data"))


class Cli:
    """The `stend` program run as a user runs it: its exit code, stdout (JSON under --json) and stderr."""

    def __call__(self, *args, check=True):
        p = subprocess.run([PROGRAM, *map(str, args)], capture_output=True, text=True, cwd=self.cwd)
        if check and p.returncode != 0:
            raise AssertionError(f"stend {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr}")
        return p

    def json(self, *args, check=True):
        p = self(*args, "--json", check=check)
        return p.returncode, json.loads(p.stdout) if p.stdout.strip() else None, p.stderr


@pytest.fixture(scope="session")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("stend-py")


@pytest.fixture(scope="session")
def cli(scratch):
    c = Cli()
    c.cwd = scratch  # nothing lands in the work tree
    return c


@pytest.fixture(scope="session")
def source():
    return SOURCE


@pytest.fixture(scope="session")
def shared():
    if not SHARED.is_dir():
        pytest.skip(f"{SHARED} is absent (the real recordings live in ../shared/data beside the repository)")
    return SHARED


@pytest.fixture(scope="session")
def paper_run(cli, scratch):
    """The paper's experiment on the simulated bench, run by the program (its model fitted)."""
    code, doc, _ = cli.json("run", SOURCE / "configs/paper_mpu6050_z.yaml", "--quiet", "--output", scratch / "runs",
                            "--name", "paper-cli")
    assert code == 0 and doc["status"] == "complete"
    return Path(doc["run_dir"])


@pytest.fixture(scope="session")
def six_run(cli, scratch):
    """The six-position test on the simulated bench (three-axis accelerometer and gyro)."""
    code, doc, _ = cli.json("run", SOURCE / "configs/six_position.yaml", "--quiet", "--output", scratch / "runs",
                            "--name", "six")
    assert code == 0
    return Path(doc["run_dir"])
