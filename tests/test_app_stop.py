"""``python -m scara_robust app`` stops cleanly on SIGTERM and on SIGINT (Ctrl-C).

The command runs in a subprocess of its own process group on a free port; once the page
says it serves, the signal goes to the whole group, as Ctrl-C in a terminal sends SIGINT to the
page and its worker processes alike. The page must say it stopped in one line, exit with
0, leave no traceback (not even from a worker still starting) and no process behind.
"""

from __future__ import annotations

import os
import select
import signal
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


def _serving(server: subprocess.Popen[str], port: int) -> bool:
    """Wait until this page, not another process on a reused port, says it serves; False if the port was taken."""
    assert server.stderr is not None
    deadline = time.monotonic() + START_TIMEOUT
    while True:
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"the page did not serve on port {port} in {START_TIMEOUT:g} s"
        ready, _, _ = select.select([server.stderr], [], [], remaining)
        if not ready:
            continue
        line = server.stderr.readline()
        if line.startswith(f"serving the design page at http://127.0.0.1:{port}/"):
            return True
        if f"`--port` {port}: is in use" in line:
            return False
        assert line, f"the page ended before serving: exit {server.wait()}"
        raise AssertionError(f"unexpected line before the page served: {line!r}")


def _group_gone(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return True
    return False


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_the_page_stops_on_a_signal_in_one_line(tmp_path, sig):
    for _ in range(3):  # another test's server may take the free port first: then try another
        port = free_port()
        server = subprocess.Popen([sys.executable, "-m", "scara_robust", "app", "--model", MOTOR, "--rho",
                                   "0.5:5:3", "--eta", "1:5:3", "--port", str(port)], cwd=tmp_path,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
        try:
            if not _serving(server, port):
                server.communicate(timeout=60)
                continue
            os.killpg(server.pid, sig)  # the page and its worker processes, as Ctrl-C in a terminal
            out, err = server.communicate(timeout=60)
            break
        finally:
            if server.poll() is None:
                os.killpg(server.pid, signal.SIGKILL)
                server.wait()
    else:
        raise AssertionError("three free ports were taken before the page could serve")
    assert server.returncode == 0, err
    assert "Traceback" not in err and "Error" not in err, err
    assert out == ""
    assert err.splitlines() == [f"scara_robust: the design page stopped ({sig.name})"], err  # after "serving ..."
    deadline = time.monotonic() + 30
    while not _group_gone(server.pid):  # the worker processes went with the page
        assert time.monotonic() < deadline, "a worker process of the page is still running"
        time.sleep(0.1)
