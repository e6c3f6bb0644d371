"""Shared fixtures: the repository, the dexcut binary the Python results are
compared with, and a helper running it."""
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT / "crates/nc/tests/data/real"


def cli_path() -> Path:
    if os.environ.get("DEXCUT_CLI"):
        return Path(os.environ["DEXCUT_CLI"])
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "dexcut"


@pytest.fixture(scope="session")
def cli() -> Path:
    path = cli_path()
    if not path.exists():
        message = f"{path} is missing: build it with `cargo build --release -p dexcut-cli` (or set DEXCUT_CLI)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return path


def run_cli(cli: Path, *args, check=True) -> subprocess.CompletedProcess:
    env = dict(os.environ, CI="1")
    p = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True, env=env)
    if check and p.returncode != 0:
        raise AssertionError(f"dexcut {' '.join(map(str, args))} failed: {p.stderr}")
    return p
