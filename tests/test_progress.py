"""``bench run``'s progress bar shows no time left until its first sample, whose time holds the
one-time setup, is done (issue 61: ours' first sample took 25 s and the bar said 19:45 left)."""

from __future__ import annotations

import time

from catpose.bench.run.runner import _Progress


def test_no_estimate_from_the_first_sample_then_one_from_the_rest(capsys):
    bar = _Progress(total=40, done=2, desc="ours on synthetic", enabled=True)
    assert bar.bar_format == _Progress.NO_ETA and "remaining" not in _Progress.NO_ETA
    time.sleep(1.0)  # the slow first sample: from it, 32 more would take 32 s
    bar.update(1)
    assert bar.bar_format is None  # tqdm's own format, time left included, timed from here
    for _ in range(5):
        bar.update(1)
    bar.close()
    err = capsys.readouterr().err
    assert "no estimate yet" in err and "8/40" in err
    last = err.replace("\r", "\n").strip().splitlines()[-1]
    assert "<" in last and "8/40" in last, last  # elapsed<remaining, from the fast samples only
    assert last.split("<")[1].startswith("00:00"), last  # from the fast samples, not 00:32 from the first


def test_a_disabled_bar_stays_silent(capsys):
    bar = _Progress(total=3, done=0, desc="x", enabled=False)
    for _ in range(3):
        bar.update(1)
    bar.close()
    assert capsys.readouterr().err == ""
