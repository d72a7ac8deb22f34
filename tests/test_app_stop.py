"""``python -m scara_robust app`` stops cleanly on SIGTERM and on SIGINT (Ctrl-C).

The command runs in a subprocess of its own process group on a free port; once the port
listens, the signal goes to the whole group, as Ctrl-C in a terminal sends SIGINT to the
page and its worker processes alike. The page must say it stopped in one line, exit with
0, leave no traceback (not even from a worker still starting) and no process behind.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from page_driver import free_port

pytestmark = pytest.mark.app

ROOT = Path(__file__).resolve().parents[1]
MOTOR = str(ROOT / "examples" / "plant-dc-motor.toml")
#: Importing the numeric stack and computing the map takes seconds on a loaded machine.
START_TIMEOUT = 90.0


def _listens(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.5):
            return True
    except OSError:
        return False


def _group_gone(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return True
    return False


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_the_page_stops_on_a_signal_in_one_line(tmp_path, sig):
    port = free_port()
    server = subprocess.Popen([sys.executable, "-m", "scara_robust", "app", "--model", MOTOR, "--rho", "0.5:5:3",
                               "--eta", "1:5:3", "--port", str(port)], cwd=tmp_path, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + START_TIMEOUT
        while not _listens(port):
            assert server.poll() is None, server.communicate()[1]
            assert time.monotonic() < deadline, f"the page did not listen on port {port} in {START_TIMEOUT:g} s"
            time.sleep(0.1)
        os.killpg(server.pid, sig)  # the page and its worker processes, as Ctrl-C in a terminal
        out, err = server.communicate(timeout=60)
    finally:
        if server.poll() is None:
            os.killpg(server.pid, signal.SIGKILL)
            server.wait()
    assert server.returncode == 0, err
    assert "Traceback" not in err and "Error" not in err, err
    assert out == ""
    lines = err.splitlines()
    assert lines[-1] == f"scara_robust: the design page stopped ({sig.name})", err
    assert lines[:-1] in ([], [f"serving the design page at http://127.0.0.1:{port}/ (Ctrl-C stops it)"]), err
    deadline = time.monotonic() + 30
    while not _group_gone(server.pid):  # the worker processes went with the page
        assert time.monotonic() < deadline, "a worker process of the page is still running"
        time.sleep(0.1)
