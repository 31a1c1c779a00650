"""The joint-space log for dynamic identification: reading and writing.

CSV with a header ``t,q1..qn,tau1..taun`` optionally followed by
``qd1..qdn`` and/or ``qdd1..qddn`` (any column order), or NPZ with arrays of
the same names (or those of other tools: ``times``, ``positions``,
``torques``, ``velocities``, ``accelerations``).

Motor currents. A drive that logs motor currents instead of joint torques
writes ``i1..in`` (A) in place of ``tau1..taun`` (NPZ: ``i`` or ``currents``).
The joint effort is then tau_j = g_j i_j with g_j the drive gain of joint j
(N m/A, or N/A for a prismatic joint, gear ratio included: the robot YAML's
``drive: {gain: [...]}``, :attr:`rmdrake.model.robot.RobotModel.drive_gain`, or a
command's ``--gains``). A currents log read without gains is refused, and so
is a log with both torque and current columns (which one would be meant is
not knowable from the file: keep one).
"""

from __future__ import annotations

import dataclasses
import io
import os
from pathlib import Path

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.io.atomic import atomic_write_bytes, atomic_write_text
from rmdrake.io.csv import CSV_ENCODING
from rmdrake.io.npz import read_npz_arrays

__all__ = [
    "JointLog",
    "read_joint_log",
    "torques_from_currents",
    "write_joint_log",
]


@dataclasses.dataclass(frozen=True)
class JointLog:
    """A joint-space log for dynamic identification.

    Attributes:
      t: (M,) sample times in s, strictly increasing.
      q: (M, n) joint positions in rad (m for a prismatic joint).
      tau: (M, n) joint efforts in N m or N (what a joint-torque sensor reads:
        the actuator torque; for a currents log, drive gain x current).
      qd: (M, n) joint velocities in rad/s or m/s, or None when not measured.
      qdd: (M, n) joint accelerations in rad/s^2 or m/s^2, or None.
      current: (M, n) motor currents in A when the log holds currents (then
        ``tau`` is derived from them), else None.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None
    current: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = as_finite_array(self.t, "t", (None,))
        q = as_finite_array(self.q, "q", (t.shape[0], None))
        n = q.shape[1]
        fields = {"t": t, "q": q, "tau": as_finite_array(self.tau, "tau", q.shape)}
        for key in ("qd", "qdd", "current"):
            value = getattr(self, key)
            fields[key] = (
                None if value is None else as_finite_array(value, key, q.shape)
            )
        if n < 1:
            raise ValueError("q: expected at least one joint column, found none")
        if t.size > 1 and not np.all(np.diff(t) > 0):
            k = int(np.flatnonzero(np.diff(t) <= 0)[0])
            raise ValueError(
                f"t: expected strictly increasing times, found t[{k + 1}] = "
                f"{t[k + 1]} after t[{k}] = {t[k]}"
            )
        for key, value in fields.items():
            if value is not None:
                value.flags.writeable = False
            object.__setattr__(self, key, value)

    @property
    def n_joints(self) -> int:
        """Number of joints n."""
        return int(self.q.shape[1])

    @property
    def n_samples(self) -> int:
        """Number of samples M."""
        return int(self.t.shape[0])

    def _effort(self) -> tuple[str, np.ndarray]:
        """The effort as written: currents (``i``) if any, else torques."""
        return ("tau", self.tau) if self.current is None else ("i", self.current)

    def columns(self) -> list[str]:
        """Column names in file order: t, q1..qn, tau1..taun (i1..in for a
        currents log)[, qd.., qdd..]."""
        n = self.n_joints
        names = ["t"] + [f"q{j}" for j in range(1, n + 1)]
        names += [f"{self._effort()[0]}{j}" for j in range(1, n + 1)]
        for key in ("qd", "qdd"):
            if getattr(self, key) is not None:
                names += [f"{key}{j}" for j in range(1, n + 1)]
        return names

    def table(self) -> np.ndarray:
        """(M, 1 + 2n [+ 2n]) array in :meth:`columns` order."""
        parts = [self.t[:, None], self.q, self._effort()[1]]
        parts += [p for p in (self.qd, self.qdd) if p is not None]
        return np.hstack(parts)


def torques_from_currents(current: object, gains: object) -> np.ndarray:
    """Joint efforts tau = gains * current, (M, n) in N m or N.

    Args:
      current: (M, n) motor currents, A.
      gains: (n,) drive gains, N m/A (N/A for a prismatic joint), positive.

    Raises:
      ValueError: one line: gains of the wrong count, not finite or not
        positive.
    """
    current = as_finite_array(current, "current", (None, None))
    n = current.shape[1]
    g = np.asarray(gains, dtype=np.float64).ravel()
    if g.shape != (n,):
        raise ValueError(
            f"gains: expected {n} drive gains (one per joint), found {g.size}"
        )
    if not np.all(np.isfinite(g)) or np.any(g <= 0):
        raise ValueError(f"gains: expected positive finite N m/A, found {g.tolist()}")
    return current * g


def write_joint_log(path: str | os.PathLike, log: JointLog) -> Path:
    """Writes ``log`` atomically as CSV (header :meth:`JointLog.columns`, full
    float precision) or, for a ``.npz`` path, as NPZ with arrays of the same
    names (``t, q, tau`` or ``i``, ``qd, qdd``). Returns the path."""
    path = Path(path)
    if path.suffix.lower() == ".npz":
        buf = io.BytesIO()
        arrays = {"t": log.t, "q": log.q, log._effort()[0]: log._effort()[1]}
        arrays.update(
            {k: getattr(log, k) for k in ("qd", "qdd") if getattr(log, k) is not None}
        )
        np.savez(buf, **arrays)
        return atomic_write_bytes(path, buf.getvalue())
    buf = io.StringIO()
    np.savetxt(
        buf,
        log.table(),
        fmt="%.17g",
        delimiter=",",
        header=",".join(log.columns()),
        comments="",
    )
    return atomic_write_text(path, buf.getvalue())


def read_joint_log(
    path: str | os.PathLike,
    n_joints: int | None = None,
    gains: object = None,
) -> JointLog:
    """Reads a joint-space log (CSV with a header, or NPZ with the same names
    or the names other tools use: see the module docstring).

    The CSV header must be ``t,q1..qn,tau1..taun`` (or ``i1..in``, motor
    currents in A) optionally followed by ``qd1..qdn`` and/or ``qdd1..qddn``;
    columns may come in any order.

    Args:
      n_joints: expected joint count (for example the robot's), or None.
      gains: (n,) drive gains (N m/A or N/A) turning a currents log's ``i``
        into ``tau`` = gains x i; ignored for a torque log.

    Raises:
      ValueError: one line naming the file and the problem (unreadable file,
        missing or unknown columns, joint count, NaN, non-increasing time, a
        currents log without gains or with gains of the wrong count, both
        torque and current columns).
    """
    path = Path(path)
    try:
        if path.suffix.lower() == ".npz":
            arrays = _read_npz(path)
        else:
            arrays = _read_csv(path)
        if "tau" in arrays and "i" in arrays:
            raise ValueError(
                "both torques (tau) and motor currents (i) given; keep one "
                "(refused rather than guessing which is meant)"
            )
        if "i" in arrays:
            if gains is None:
                raise ValueError(
                    "the log holds motor currents (i) but no drive gains are given "
                    "(robot YAML 'drive: {gain: [...]}' or --gains)"
                )
            current = arrays.pop("i")
            arrays["tau"] = torques_from_currents(current, gains)
            arrays["current"] = current
        log = JointLog(**arrays)
        if n_joints is not None and log.n_joints != n_joints:
            raise ValueError(
                f"log has {log.n_joints} joints, expected {n_joints} (the robot's)"
            )
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None
    return log


_NPZ_NDIM = {"t": 1, "q": 2, "tau": 2, "i": 2, "qd": 2, "qdd": 2}
_NPZ_ALIASES = {
    "times": "t",
    "positions": "q",
    "torques": "tau",
    "currents": "i",
    "velocities": "qd",
    "accelerations": "qdd",
}
"""Array names other tools write, and rmdrake's name for each."""


def _read_npz(path: Path) -> dict[str, np.ndarray]:
    ndim = _NPZ_NDIM | {k: _NPZ_NDIM[v] for k, v in _NPZ_ALIASES.items()}
    arrays: dict[str, np.ndarray] = {}
    for key, value in read_npz_arrays(path, ndim).items():
        name = _NPZ_ALIASES.get(key, key)
        if name in arrays:
            raise ValueError(f"arrays '{name}' and '{key}' both given; keep one")
        arrays[name] = value
    for key in ("t", "q", "tau"):
        if key not in arrays and not (key == "tau" and "i" in arrays):
            alias = next(k for k, v in _NPZ_ALIASES.items() if v == key)
            more = " or motor currents 'i' (or 'currents')" if key == "tau" else ""
            raise ValueError(f"missing array '{key}' (or '{alias}'){more}")
    return arrays


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    try:
        with path.open(encoding=CSV_ENCODING) as f:
            header = f.readline().strip()
            data = np.loadtxt(f, delimiter=",", ndmin=2)
    except OSError as e:
        raise ValueError(f"cannot read log: {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    except ValueError as e:
        raise ValueError(f"not a numeric CSV below the header ({e})") from None
    names = [c.strip() for c in header.split(",")]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate columns in header '{header}'")
    if "t" not in names:
        raise ValueError(f"missing column 't' in header '{header}'")
    n = sum(1 for c in names if c.startswith("q") and c[1:].isdigit())
    if n < 1:
        raise ValueError(f"no joint columns q1..qn in header '{header}'")
    effort = "i" if "i1" in names and "tau1" not in names else "tau"
    groups = {}
    for key in ("q", "tau", "i", "qd", "qdd"):
        want = [f"{key}{j}" for j in range(1, n + 1)]
        have = [c for c in want if c in names]
        if key in ("q", effort) or have:
            missing = [c for c in want if c not in names]
            if missing:
                raise ValueError(
                    f"missing column(s) {', '.join(missing)} for {n} joints"
                )
            groups[key] = [names.index(c) for c in want]
    known = {"t"} | {
        f"{k}{j}" for k in ("q", "tau", "i", "qd", "qdd") for j in range(1, n + 1)
    }
    unknown = [c for c in names if c not in known]
    if unknown:
        raise ValueError(
            f"unknown column(s) {', '.join(unknown)} (expected t,q1..q{n},"
            f"tau1..tau{n} or i1..i{n}[,qd..,qdd..])"
        )
    if data.size == 0:
        raise ValueError("no data rows")
    if data.shape[1] != len(names):
        raise ValueError(f"rows have {data.shape[1]} values, header has {len(names)}")
    arrays = {k: data[:, idx] for k, idx in groups.items()}
    return {"t": data[:, names.index("t")], **arrays}
