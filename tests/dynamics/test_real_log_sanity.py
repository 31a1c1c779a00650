"""The identification's sanity rule on every real torque log of ../shared/data
(the Panda of Gaz et al. 2019, the KUKA LWR4+ runs 1-3 of FloBaRoID): each log
passes, and each wrong variant made from it (two loaded joints' torques
swapped, the largest negated, torques in N mm, the torque 0.3 s late, the
other arm's model) is refused for its own reason. And the LWR4 end to end:
every method identifies runs 1 and 2 and writes a model, which predicts run 3
within 1.2x per joint of a plain least-squares fit of the same runs."""

from __future__ import annotations

import dataclasses
import functools
import re

import numpy as np
import pytest
from conftest import SHARED_DATA

from rmdrake.dynamics.data import prepare_samples, stack_samples
from rmdrake.dynamics.identification import identify
from rmdrake.dynamics.joint_log import JointLog, read_joint_log, write_joint_log
from rmdrake.dynamics.log_samples import prepare_logs
from rmdrake.dynamics.sanity import check_identification, check_log
from rmdrake.model.loading import load_robot
from rmdrake.pipelines.identify import identify_file
from rmdrake.pipelines.validate import validate_file

LWR4 = SHARED_DATA / "lwr4_flobaroid"
PANDA = SHARED_DATA / "panda_gaz2019"
pytestmark = pytest.mark.skipif(
    not (LWR4.is_dir() and PANDA.is_dir()),
    reason=f"the real logs are not here ({SHARED_DATA})",
)
LOGS = ["lwr4 run 1", "lwr4 run 2", "lwr4 run 3", "panda"]
PANDA_PREPARATION = {"rate": 200.0, "cutoff": 10.0}  # as examples/real_panda.py
LATE = 0.3  # s


@functools.cache
def _robot(name: str):
    if name == "lwr4":
        return load_robot(str(LWR4 / "kuka_lwr4_nogeom.urdf"))
    return load_robot(str(PANDA / "panda.yaml"))


def _lwr4_log(run: int) -> JointLog:
    """FloBaRoID's npz (Unix time stamps, target_* arrays unused) as a log."""
    d = np.load(LWR4 / f"measurements_{run}.npz")
    t = d["times"] - d["times"][0]
    return JointLog(t=t, q=d["positions"], tau=d["torques"], qd=d["velocities"])


@functools.cache
def _log(name: str) -> tuple[str, JointLog, dict]:
    """(the arm, its log, the preparation)."""
    if name == "panda":
        return "panda", read_joint_log(PANDA / "trajectory1.csv", 7), PANDA_PREPARATION
    return "lwr4", _lwr4_log(int(name[-1])), {}


def _variant(log: JointLog, kind: str) -> tuple[JointLog, tuple[int, int]]:
    """The wrong variant ``kind`` of ``log``, and its two loaded joints (the
    largest torque RMS first; 0-based)."""
    rms = np.sqrt(np.mean(log.tau**2, axis=0))
    a, b = (int(j) for j in np.argsort(-rms)[:2])
    tau = log.tau.copy()
    if kind == "swap":
        tau[:, [a, b]] = tau[:, [b, a]]
    elif kind == "negated":
        tau[:, a] *= -1
    elif kind == "N mm":
        tau *= 1e3
    elif kind == "late":  # the torque of t - LATE logged at t
        tau = np.stack([np.interp(log.t - LATE, log.t, c) for c in tau.T], axis=1)
        keep = log.t >= log.t[0] + LATE
        return JointLog(t=log.t[keep], q=log.q[keep], tau=tau[keep], qd=log.qd[keep]), (
            a,
            b,
        )
    return dataclasses.replace(log, tau=tau), (a, b)


def _reasons(arm: str, log: JointLog, preparation: dict) -> list[str]:
    """Every refusal of ``identify``'s rule (before and after an OLS fit)."""
    model = _robot(arm)
    s = prepare_samples(log.t, log.q, log.tau, log.qd, **preparation)
    before = check_log(s, model, model.limits.effort, prior=model)
    if before:
        return before
    result = identify(model, s, method="ols")
    return list(check_identification(result, model=model, samples=s).reasons)


@pytest.mark.parametrize("name", LOGS)
def test_real_logs_pass(name):
    arm, log, preparation = _log(name)
    assert _reasons(arm, log, preparation) == []


WRONG = {
    "swap": r"joint order: joints {a} and {b} exchanged leave 0\.[0-3]\d*x",
    "negated": r"sign: joint {a}'s torque negated leaves 0\.\d+x",
    "N mm": r"unit: the 99th-percentile \|torque\| of .* is up to \d{{3}}x",
    "late": r"time base: the torque 0\.3\d* s late leaves 0\.\d+x",
    "other robot": r"positions: \d\d(\.\d)? % of the samples leave the joint limits of "
    r"robot '[\w-]+'",
}


@pytest.mark.parametrize("name", LOGS)
@pytest.mark.parametrize("kind", list(WRONG))
def test_wrong_variants_of_real_logs_are_refused(name, kind):
    arm, log, preparation = _log(name)
    if kind == "other robot":
        arm = "lwr4" if arm == "panda" else "panda"
        joints = (0, 0)
    else:
        log, joints = _variant(log, kind)
    reasons = _reasons(arm, log, preparation)
    a, b = sorted(joints) if kind == "swap" else joints
    pattern = WRONG[kind].format(a=a + 1, b=b + 1)
    assert any(re.match(pattern, r) for r in reasons), reasons
    assert all(len(r) < 160 for r in reasons), reasons  # short lines


@pytest.fixture(scope="module")
def lwr4_csv(tmp_path_factory):
    """The three LWR4 runs as rmdrake CSV logs (t, q, tau, qd)."""
    folder = tmp_path_factory.mktemp("lwr4")
    return [write_joint_log(folder / f"run{r}.csv", _lwr4_log(r)) for r in (1, 2, 3)]


@pytest.mark.parametrize("method", ["ols", "wls", "de", "physical"])
def test_every_method_identifies_the_lwr4_and_predicts_run_3(
    tmp_path, lwr4_csv, method
):
    model = _robot("lwr4")
    run1, run2, run3 = lwr4_csv
    lines: list[str] = []
    out = identify_file(
        model, [run1, run2], tmp_path / "lwr4.yaml", method=method, echo=lines.append
    )
    assert out.is_file()
    text = "\n".join(lines)
    assert "joints that carry little torque unexplained" in text  # joint 1
    assert re.search(r"\n  joint 1: \d\d(\.\d)? % of its torque scale", text)
    errors = validate_file([out], run3, echo=lines.append)
    _, (s3,) = prepare_logs([run3], 7)
    predicted = errors.predicted[0]
    rms = np.sqrt(np.mean((predicted - s3.tau) ** 2, axis=0))
    # the reference: plain least squares on the same runs and preparation
    _, parts = prepare_logs([run1, run2], 7)
    ols = identify(model, stack_samples(parts), method="ols")
    Y = ols.base.regressor(model, s3.q, s3.qd, s3.qdd)
    reference = np.sqrt(np.mean((Y @ ols.params - s3.tau) ** 2, axis=0))
    assert np.all(rms <= 1.2 * reference), rms / reference
