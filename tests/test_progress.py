"""Progress of long commands: on stderr at a terminal, with the steps and an estimate of what remains; never
in a pipe, a log or a library call."""

from __future__ import annotations

import scara_robust as sr
from scara_robust._progress import progress_on, shown, steps
from scara_robust.cli import main
from scara_robust.robustness.search import bisect


def test_a_search_shows_its_steps_only_when_asked(capsys):
    assert not progress_on()
    lo, hi = bisect(lambda x: x * x < 2.0, 1.0, 2.0, 1e-6, desc="square root")
    assert capsys.readouterr().err == ""  # a library call prints nothing
    with shown(True):
        again = bisect(lambda x: x * x < 2.0, 1.0, 2.0, 1e-6, desc="square root")
    err = capsys.readouterr().err
    assert again == (lo, hi)  # the same answer, shown or not
    assert "square root" in err and "/19 [" in err and "<" in err  # steps of the expected 19, the time remaining
    assert not progress_on()


def test_a_silent_bar_does_nothing(capsys):
    bar = steps("nothing", 3)
    bar.update(1)
    bar.set_postfix_str("x")
    bar.close()
    assert capsys.readouterr().err == ""


def test_the_command_line_shows_progress_at_a_terminal_only(capsys, monkeypatch):
    argv = ["margin", "--rho", "3", "--eta", "90", "--method", "theorem1", "--tol", "0.05"]
    assert main(argv) == 0
    quiet = capsys.readouterr()
    assert quiet.err == ""  # stderr is not a terminal here: nothing but the answer
    monkeypatch.setattr("sys.stderr.isatty", lambda: True, raising=False)
    assert main(argv) == 0
    loud = capsys.readouterr()
    # the same answer (the table's last column is the seconds it took)
    assert [line.rsplit(None, 1)[0] for line in loud.out.splitlines() if line.strip()] == \
        [line.rsplit(None, 1)[0] for line in quiet.out.splitlines() if line.strip()]
    assert "payload:" in loud.err and "test/s" in loud.err  # the payload search, step by step
    assert sr.__name__  # the package imports as before


def test_a_bisection_s_first_test_is_the_one_asked_where_it_lies_inside():
    from scara_robust.robustness.search import bisect

    tested = []

    def ok(x):
        tested.append(x)
        return x <= 9.97

    assert bisect(ok, 0.0, 10.0, 0.01, first=9.95) == (9.95, 10.0) and tested == [9.95]  # one test
    tested.clear()
    lo, hi = bisect(ok, 0.0, 10.0, 0.01, first=9.99)  # fails: the bisection goes on below it
    assert tested[0] == 9.99 and hi - lo <= 0.01 * hi and lo <= 9.97 < hi
    tested.clear()
    assert bisect(ok, 0.0, 10.0, 0.01, first=12.0) == bisect(ok, 0.0, 10.0, 0.01)  # outside: plain halving
