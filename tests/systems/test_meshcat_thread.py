"""A Meshcat is destroyed on the thread that made it.

Drake aborts the process (``meshcat.cc ... IsThread(main_thread_id_)``) when a
Meshcat is destroyed on another thread. The diagrams drawing into one hold it in
reference cycles, and Python's collector runs on whichever thread allocates: a
``run`` of four at once aborted with exit 134 that way. Each case runs in a
child process (an abort is then a failed test, not a dead pytest) beside a
thread that calls ``gc.collect()`` without pause: the adversary that made the
old code abort on the first Meshcat page (checked by hand: exit 134).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

HAMMER = """
import gc, threading, time
def _hammer():
    while True:
        gc.collect()
        time.sleep(0.0005)
threading.Thread(target=_hammer, daemon=True).start()
"""


def _run_child(body: str) -> subprocess.CompletedProcess:
    code = HAMMER + textwrap.dedent(body)
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600
    )


def test_run_twenty_times_with_its_meshcat_page_never_aborts(tmp_path):
    done = _run_child(
        f"""
        from pathlib import Path
        from rmdrake.studies.runner import run_scenario
        from rmdrake.studies.scenarios import Scenario

        scenario = Scenario(robot="rv3sb", show=True, calibration=None,
                            identification=None)
        for i in range(20):
            out = run_scenario(scenario, Path({str(tmp_path)!r}) / str(i))
            assert (out / "rv3sb.html").stat().st_size > 100_000
        print("twenty runs")
        """
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "twenty runs" in done.stdout
    assert len(list(tmp_path.glob("*/rv3sb.html"))) == 20


def test_meshcat_of_a_failed_drawing_is_destroyed_on_its_thread():
    """The drawing raises while its diagram (a reference cycle) holds the
    Meshcat: the exception's traceback must not keep it for another thread."""
    done = _run_child(
        """
        from rmdrake.model.loading import load_robot
        from rmdrake.systems.visualization import RobotScene, with_own_meshcat

        class Cycle:
            pass

        def draw(model, *, meshcat):
            held = Cycle()
            held.scene, held.me = RobotScene(model=model, meshcat=meshcat), held
            raise ValueError("drawing failed")

        model = load_robot("rv3sb")
        for _ in range(5):
            try:
                with_own_meshcat(draw, model)
            except ValueError as e:
                error = e  # kept alive on purpose, traceback and all
        print("survived", error.__traceback__ is not None)
        """
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "survived True" in done.stdout
