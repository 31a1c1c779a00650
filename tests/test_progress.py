"""Progress in batch use: whole lines at the start, every interval, and the
end, so a log file shows a long run advancing."""

from __future__ import annotations

import io

from rmdrake.progress import LineProgress, progress_bar, progress_iter


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
    assert len(lines) == 3 + 1  # start, two updates, close
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
