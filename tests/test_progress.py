"""Progress in batch use: whole lines at the start, every interval, and the
end, so a log file shows a long run advancing."""

from __future__ import annotations

import io

from rmdrake.progress import (
    LineProgress,
    progress_bar,
    progress_iter,
    simulated_time_progress,
)


def test_line_progress_writes_whole_lines():
    out = io.StringIO()
    bar = LineProgress(total=4, desc="generations", interval=0.0, file=out)
    bar.update(1)
    bar.set_postfix(best="12.5")
    bar.update(3)
    bar.close()
    bar.close()  # once
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("generations: 0/4 (0 %), ")
    assert lines[1].startswith("generations: 1/4 (25 %), ")
    assert lines[-1].startswith("generations: 4/4 (100 %), ")
    assert lines[-1].endswith("best=12.5")
    assert len(lines) == 3  # start, two updates; close adds no repeat of 4/4
    assert "\r" not in out.getvalue()


def test_line_progress_waits_for_the_interval():
    out = io.StringIO()
    bar = LineProgress(total=None, desc="simulated s", interval=3600.0, file=out)
    for _ in range(100):
        bar.update(0.5)
    bar.close()
    assert out.getvalue().splitlines()[-1].startswith("simulated s: 50, ")
    assert len(out.getvalue().splitlines()) == 2  # start and end only


def test_batch_use_gets_lines_and_disabled_shows_nothing(capsys):
    # Under pytest stderr is captured: not a terminal, as in a batch job.
    assert isinstance(progress_bar(total=3, desc="x"), LineProgress)
    assert list(progress_iter(range(3), desc="seeds")) == [0, 1, 2]
    err = capsys.readouterr().err
    assert "seeds: 3/3 (100 %)" in err
    list(progress_iter(range(3), desc="quiet", disable=True))
    assert capsys.readouterr().err == ""


def test_line_progress_estimates_the_time_left_from_the_rate(monkeypatch):
    """A quarter done after 10 s: about 30 s left (the elapsed time scaled by
    the work left); none on the final line."""
    now = [0.0]
    monkeypatch.setattr("rmdrake.progress.time.perf_counter", lambda: now[0])
    out = io.StringIO()
    bar = LineProgress(total=100, desc="simulated s", interval=0.0, file=out)
    now[0] = 10.0
    bar.update(25)
    now[0] = 40.0
    bar.update(75)
    bar.close()
    lines = out.getvalue().splitlines()
    assert lines[1] == "simulated s: 25/100 (25 %), 10 s, about 30 s left"
    assert "left" not in lines[-1]


def test_simulated_time_progress_opens_at_the_first_step(capsys):
    with simulated_time_progress(2.0) as progress:
        pass
    assert capsys.readouterr().err == ""  # refused before a step: no bar
    with simulated_time_progress(2.0) as progress:
        progress(0.5, 2.0)
        progress(2.0, 2.0)
    assert "simulated s: 2/2 (100 %)" in capsys.readouterr().err
