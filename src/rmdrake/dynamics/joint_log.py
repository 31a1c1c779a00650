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

Motor side. An industrial arm's drives log the motor side: ``qm1..qmn``
(motor angles, rad at the motor shafts) with ``taum1..taumn`` (motor torques,
N m at the motor shafts) or ``i1..in`` (motor currents, A), optionally
``qdm1..`` and ``qddm1..`` (rad/s, rad/s^2); NPZ arrays ``qm, taum, i, qdm,
qddm``. Such a log is mapped to the joint side by the robot's transmission
(:class:`~rmdrake.model.transmission.Transmission`, T = diag(ratio) C):
q = T^-1 q_m (and qd, qdd alike), tau = T^T tau_m, and for currents
tau_m = k_m i with k_m the transmission's ``torque_constant`` (N m/A at the
motor shaft; the robot's ``drive: {gain}`` is for joint-side logs only).
E.g. a coupled wrist with T[5] = 50 (q5 + q6): q6 = qm6 / 50 - q5, and
motor 6's torque adds 50 taum6 to joint 5 and to joint 6. A motor-side log
read without a transmission is refused, and so is a log mixing joint-side and
motor-side columns. :attr:`JointLog.motor_side` records which side was read;
:func:`write_joint_log` writes the motor side back given the transmission.
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
from rmdrake.model.transmission import Transmission

__all__ = [
    "ABSURD_FACTOR",
    "ABSURD_RANGES",
    "MAX_LOG_JOINTS",
    "JointLog",
    "check_magnitudes",
    "read_joint_log",
    "motor_side_arrays",
    "torques_from_currents",
    "write_joint_log",
]


MAX_LOG_JOINTS = 64
"""The most joints a log may have: a CSV header with more joint columns is
refused before its rows are read (a 100 000-column header would otherwise be
read, and its columns matched, for minutes)."""
ABSURD_FACTOR = 1000.0
"""A logged effort, velocity or acceleration over this many times the joint's
limit is no measurement of it (a broken row, another unit): refused at the
door, naming its row and column. The real logs stay under 1x."""
ABSURD_RANGES = 100.0
"""A logged position beyond the joint's limits by more than this many times
its range (rad or m) is refused at the door (q1 = 1e308; a prismatic joint
logged in mm). Degrees of a revolute joint stay under it and are left to the
identification's share-of-samples rule
(:func:`~rmdrake.dynamics.sanity.check_positions`)."""
ABSURD_VALUE = 1e9
"""The bound (SI) on a logged value where the robot gives no finite limit."""


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
      motor_side: True when read from a motor-side log (``qm``, ``taum``;
        every array here is already mapped to the joint side).

    Example:

    >>> import numpy as np
    >>> from rmdrake import JointLog
    >>> log = JointLog(t=np.arange(3) * 0.01, q=np.zeros((3, 2)), tau=np.ones((3, 2)))
    >>> log.columns()
    ['t', 'q1', 'q2', 'tau1', 'tau2']
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None
    current: np.ndarray | None = None
    motor_side: bool = False

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
        object.__setattr__(self, "motor_side", bool(self.motor_side))

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


def check_magnitudes(
    log: JointLog,
    lower: object,
    upper: object,
    *,
    velocity: object = None,
    acceleration: object = None,
    effort: object = None,
    sigma: object = None,
) -> None:
    """Refuses a log holding a value no measurement of this robot can be, as
    read (before resampling or filtering spread it): a position beyond the
    joint limits ``lower``, ``upper`` (n,) by over :data:`ABSURD_RANGES`
    times the range, an effort, velocity or acceleration over
    :data:`ABSURD_FACTOR` times the joint's ``effort``, ``velocity``,
    ``acceleration`` limit (n,) (None or a non-finite limit: over
    :data:`ABSURD_VALUE`). ``sigma`` (n,): 1 for a prismatic joint (m, N),
    for the units named.

    Raises:
      ValueError: one line naming the row (1-based, of the data below a
        CSV's header), the column, the value and the bound.
    """
    n = log.n_joints
    slide = np.zeros(n, bool) if sigma is None else np.asarray(sigma) == 1
    lo, hi = (np.broadcast_to(np.asarray(v, float), (n,)) for v in (lower, upper))
    span = np.where(np.isfinite(hi - lo) & (hi > lo), hi - lo, 0.0)
    reach = np.where(span > 0, ABSURD_RANGES * np.maximum(span, 1e-3), ABSURD_VALUE)
    past = np.maximum(log.q - np.where(np.isfinite(hi), hi, np.inf), 0.0)
    past = np.maximum(past, np.where(np.isfinite(lo), lo, -np.inf) - log.q)
    past = np.where(np.isfinite(lo) & np.isfinite(hi), past, np.abs(log.q))
    bad = past > reach
    if np.any(bad):
        k, j = (int(v) for v in np.argwhere(bad)[0])
        unit = "m" if slide[j] else "rad"
        raise ValueError(
            f"row {k + 1}, column q{j + 1}: {log.q[k, j]:.4g} {unit} is beyond "
            f"joint {j + 1}'s limits ({lo[j]:.4g} .. {hi[j]:.4g} {unit}) by over "
            f"{ABSURD_RANGES:g}x its range: no position of this robot (a broken "
            f"row? {'mm? convert to m' if slide[j] else 'degrees? convert to rad'})"
        )
    kinds = [("tau", log.tau, effort, ("N m", "N"), "effort")]
    kinds += [("qd", log.qd, velocity, ("rad/s", "m/s"), "velocity")]
    kinds += [("qdd", log.qdd, acceleration, ("rad/s^2", "m/s^2"), "acceleration")]
    for key, x, limit, units, what in kinds:
        if x is None:
            continue
        lim = np.full(n, np.nan) if limit is None else np.asarray(limit, float)
        lim = np.broadcast_to(lim, (n,))
        known = np.isfinite(lim) & (lim > 0)
        bound = np.where(known, ABSURD_FACTOR * np.where(known, lim, 1.0), ABSURD_VALUE)
        bad = np.abs(x) > bound
        if np.any(bad):
            k, j = (int(v) for v in np.argwhere(bad)[0])
            unit = units[int(slide[j])]
            name = "tau" if key == "tau" and log.current is None else key
            limit_text = (
                f"{ABSURD_FACTOR:g}x joint {j + 1}'s {what} limit {lim[j]:.4g} {unit}"
                if known[j]
                else f"{ABSURD_VALUE:g} {unit}"
            )
            raise ValueError(
                f"row {k + 1}, column {name}{j + 1}: {x[k, j]:.4g} {unit} is over "
                f"{limit_text}: no measurement of this robot (a broken row, "
                "another unit?)"
            )


def motor_side_arrays(log: JointLog, transmission: Transmission) -> dict:
    """The motor-side arrays of a joint-side ``log`` (module docstring), in
    file order: ``t, qm`` (rad), ``taum`` (N m; or ``i``, A, the log's
    currents as they are), then ``qdm, qddm`` where the log has qd, qdd."""
    tr = transmission
    if tr.n != log.n_joints:
        raise ValueError(
            f"transmission: {tr.n} motors, expected {log.n_joints} (the log's joints)"
        )
    out = {"t": log.t, "qm": tr.motor_positions(log.q)}
    if log.current is None:
        out["taum"] = tr.motor_efforts(log.tau)
    else:
        out["i"] = log.current
    for key in ("qd", "qdd"):
        if getattr(log, key) is not None:
            out[key + "m"] = tr.motor_positions(getattr(log, key))
    return out


def write_joint_log(
    path: str | os.PathLike,
    log: JointLog,
    transmission: Transmission | None = None,
) -> Path:
    """Writes ``log`` atomically as CSV (header :meth:`JointLog.columns`, full
    float precision) or, for a ``.npz`` path, as NPZ with arrays of the same
    names (``t, q, tau`` or ``i``, ``qd, qdd``). Returns the path.

    With ``transmission`` the motor side is written instead
    (:func:`motor_side_arrays`: columns ``t, qm1.., taum1..`` or ``i1..``,
    ``qdm1.., qddm1..``), as an industrial arm's drives log it.

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake import JointLog, write_joint_log
    >>> log = JointLog(t=np.arange(3) * 0.01, q=np.zeros((3, 2)), tau=np.ones((3, 2)))
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_joint_log(Path(tmp, "log.csv"), log)
    ...     print(path.read_text().splitlines()[0])
    ...
    t,q1,q2,tau1,tau2
    """
    path = Path(path)
    if transmission is not None:
        arrays = motor_side_arrays(log, transmission)
        if path.suffix.lower() == ".npz":
            buf = io.BytesIO()
            np.savez(buf, **arrays)
            return atomic_write_bytes(path, buf.getvalue())
        n = log.n_joints
        names = ["t"] + [f"{k}{j}" for k in list(arrays)[1:] for j in range(1, n + 1)]
        table = np.hstack([a.reshape(log.n_samples, -1) for a in arrays.values()])
        buf = io.StringIO()
        np.savetxt(
            buf, table, fmt="%.17g", delimiter=",", header=",".join(names), comments=""
        )
        return atomic_write_text(path, buf.getvalue())
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
    transmission: Transmission | None = None,
) -> JointLog:
    """Reads a joint-space log (CSV with a header, or NPZ with the same names
    or the names other tools use: see the module docstring).

    The CSV header must be ``t,q1..qn,tau1..taun`` (or ``i1..in``, motor
    currents in A) optionally followed by ``qd1..qdn`` and/or ``qdd1..qddn``;
    columns may come in any order.

    Args:
      n_joints: expected joint count (for example the robot's), or None.
      gains: (n,) drive gains (N m/A or N/A) turning a currents log's ``i``
        into ``tau`` = gains x i; ignored for a torque log and a motor-side
        log.
      transmission: the robot's transmission, mapping a motor-side log
        (``qm1..``, module docstring) to the joint side; None refuses one.

    Raises:
      ValueError: one line naming the file and the problem (unreadable file,
        missing or unknown columns, joint count, NaN, non-increasing time, a
        currents log without gains or with gains of the wrong count, both
        torque and current columns).

    Example:

    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from rmdrake import JointLog, read_joint_log, write_joint_log
    >>> log = JointLog(t=np.arange(3) * 0.01, q=np.zeros((3, 2)), tau=np.ones((3, 2)))
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     again = read_joint_log(write_joint_log(Path(tmp, "log.npz"), log))
    ...
    >>> again.q.shape, again.qd is None, bool((again.tau == log.tau).all())
    ((3, 2), True, True)
    """
    path = Path(path)
    try:
        if path.suffix.lower() == ".npz":
            arrays = _read_npz(path)
        else:
            arrays = _read_csv(path)
        if ("tau" in arrays or "taum" in arrays) and "i" in arrays:
            raise ValueError(
                "both torques (tau) and motor currents (i) given; keep one "
                "(refused rather than guessing which is meant)"
            )
        if any(k in arrays for k in _MOTOR_SIDE):
            arrays = _joint_side(arrays, transmission)
        elif "i" in arrays:
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


_MOTOR_SIDE = {"qm": "q", "taum": "tau", "qdm": "qd", "qddm": "qdd"}
"""Motor-side array names and the joint-side names they map to."""


def _joint_side(
    arrays: dict[str, np.ndarray], transmission: Transmission | None
) -> dict[str, np.ndarray]:
    """The joint-side arrays of a motor-side log (module docstring)."""
    mixed = [k for k in _MOTOR_SIDE.values() if k in arrays]
    if mixed:
        raise ValueError(
            f"both motor-side (qm, taum, ...) and joint-side ({', '.join(mixed)}) "
            "columns given: a log is one side or the other"
        )
    if "qm" not in arrays:
        raise ValueError("motor-side columns without motor angles qm1..qmn")
    if "taum" not in arrays and "i" not in arrays:
        raise ValueError(
            "motor angles qm1..qmn without motor torques taum1..taumn or motor "
            "currents i1..in"
        )
    if transmission is None:
        raise ValueError(
            "a motor-side log (qm1..) but the robot has no transmission (robot "
            "YAML 'transmission: {ratio: [...], coupling: [...]}') to map it to "
            "the joints"
        )
    n = arrays["qm"].shape[-1] if arrays["qm"].ndim == 2 else -1
    if n != transmission.n:
        raise ValueError(
            f"log has {n} motors, the robot's transmission {transmission.n}"
        )
    out: dict = {"t": arrays["t"], "motor_side": True}
    for motor, joint in _MOTOR_SIDE.items():
        if motor == "taum" or motor not in arrays:
            continue
        x = as_finite_array(arrays[motor], motor, (None, n))
        out[joint] = transmission.joint_positions(x)
    if "i" in arrays:
        k = transmission.torque_constant
        if k is None:
            raise ValueError(
                "the motor-side log holds motor currents (i) but the robot's "
                "transmission has no torque_constant (N m/A at the motor shafts)"
            )
        current = as_finite_array(arrays["i"], "i", (None, n))
        out["current"] = current
        out["tau"] = transmission.joint_efforts(current * k)
    else:
        taum = as_finite_array(arrays["taum"], "taum", (None, n))
        out["tau"] = transmission.joint_efforts(taum)
    return out


_NPZ_NDIM = {"t": 1, "q": 2, "tau": 2, "i": 2, "qd": 2, "qdd": 2}
_NPZ_NDIM |= {k: 2 for k in _MOTOR_SIDE}
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
    if "qm" in arrays:  # motor side: checked by _joint_side
        return arrays
    for key in ("t", "q", "tau"):
        if key not in arrays and not (key == "tau" and "i" in arrays):
            alias = next(k for k, v in _NPZ_ALIASES.items() if v == key)
            more = " or motor currents 'i' (or 'currents')" if key == "tau" else ""
            raise ValueError(f"missing array '{key}' (or '{alias}'){more}")
    return arrays


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    max_columns = 1 + 5 * MAX_LOG_JOINTS  # t, q, tau or i, qd, qdd
    try:
        with path.open(encoding=CSV_ENCODING) as f:
            line = f.readline(64 * max_columns)  # the rest, if any, is no log
            header = line.strip()
            names = [c.strip() for c in header.split(",")]
            wide = len(names) > max_columns  # its rows are not read
            data = None if wide else np.loadtxt(f, delimiter=",", ndmin=2)
    except OSError as e:
        raise ValueError(f"cannot read log: {e.strerror}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a UTF-8 text file") from None
    except ValueError as e:
        raise ValueError(f"not a numeric CSV below the header ({e})") from None
    if data is None:
        more = "" if line.endswith("\n") else " or more"
        raise ValueError(
            f"header has {len(names)}{more} columns, over the {max_columns} of a "
            f"log of at most {MAX_LOG_JOINTS} joints (t, q, tau, qd, qdd): not a "
            "joint log"
        )
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate columns in header '{header}'")
    if "t" not in names:
        raise ValueError(f"missing column 't' in header '{header}'")
    motor = "qm1" in names and "q1" not in names
    pos = "qm" if motor else "q"
    n = sum(1 for c in names if c.startswith(pos) and c[len(pos) :].isdigit())
    if n < 1:
        raise ValueError(f"no joint columns q1..qn in header '{header}'")
    effort = "i" if "i1" in names and "tau1" not in names else "tau"
    if motor:
        effort = "i" if "i1" in names and "taum1" not in names else "taum"
    groups = {}
    keys = ("q", "tau", "i", "qd", "qdd", *_MOTOR_SIDE)
    for key in keys:
        want = [f"{key}{j}" for j in range(1, n + 1)]
        have = [c for c in want if c in names]
        if key in (pos, effort) or have:
            missing = [c for c in want if c not in names]
            if missing:
                raise ValueError(
                    f"missing column(s) {', '.join(missing)} for {n} joints"
                )
            groups[key] = [names.index(c) for c in want]
    known = {"t"} | {f"{k}{j}" for k in keys for j in range(1, n + 1)}
    unknown = [c for c in names if c not in known]
    if unknown:
        raise ValueError(
            f"unknown column(s) {', '.join(unknown)} (expected t,q1..q{n},"
            f"tau1..tau{n} or i1..i{n}[,qd..,qdd..], or the motor side t,"
            f"qm1..qm{n},taum1..taum{n} or i1..i{n}[,qdm..,qddm..])"
        )
    if data.size == 0:
        raise ValueError("no data rows")
    if data.shape[1] != len(names):
        raise ValueError(f"rows have {data.shape[1]} values, header has {len(names)}")
    arrays = {k: data[:, idx] for k, idx in groups.items()}
    return {"t": data[:, names.index("t")], **arrays}
