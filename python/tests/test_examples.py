"""python/examples/ runs as a script."""

import subprocess
import sys


def test_look_dev_runs(repo):
    out = subprocess.run(
        [sys.executable, str(repo / "python" / "examples" / "look_dev.py"), "32"],
        check=True, capture_output=True, text=True,
    ).stdout
    assert "materials: ['marble']" in out
    assert "metal alpha  0.5" in out and "cornell: (24, 32, 3)" in out
    assert "@" in out or "%" in out
