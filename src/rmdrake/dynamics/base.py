"""Base (identifiable) parameters of a serial chain, found numerically.

Many standard parameters never change the joint torques (XX1 of a first link
turning about z) or only act in fixed combinations (Ia1 + ZZ1 + YY2 + ...). The
base parameters are a maximal set of independent combinations:

    Y(q, qd, qdd) @ chi == Y_base(q, qd, qdd) @ (K @ chi)  for every state,

with Y_base = Y[:, :, columns] a subset of the standard columns and K the
regrouping matrix (Gautier 1990; Khalil and Dombre, ch. 12).

Method. W = the regressor of ``n_samples`` random states stacked to (N n, p)
(seeded: q uniform in [-pi, pi] rad for a revolute joint and in [-1, 1] m for a
prismatic one, qd and qdd standard normal), each column scaled to unit norm (zero
columns, i.e. parameters that never act, are dropped). The rank is a generic
property of the states (Y is analytic in q), so any range of positive width gives
the same count; the prismatic range only keeps the slides' offsets and the
columns' scales of the order of a real arm's (rad and m columns alike of order 1).

* Rank: pivoted QR (``scipy.linalg.qr(..., pivoting=True)``); the number of base
  parameters is the count of |R_ii| > ``rtol`` * |R_00| (default 1e-8; on the
  RV-3SB the kept |R_ii| are above 1e-4 and the rest below 1e-13, so the count
  does not depend on rtol anywhere in between; :attr:`BaseParameters.r_diagonal`
  keeps them for inspection).
* Which columns: a greedy pass in Khalil's order of preference (link by link from
  the base; in a link XX XY XZ YZ ZZ MX MY MZ M YY, then Ia fv fc) keeps a column
  when its residual after orthogonal projection onto the kept ones exceeds
  ``rtol`` (twice-orthogonalised Gram-Schmidt). So Ia1 and YY2 merge into ZZ1,
  giving the readable "ZZ1R = ZZ1 + Ia1 + YY2 + ..." of the literature. The
  same order follows Khalil's rules for prismatic joints (Khalil and Bennis
  1995; Khalil and Dombre, ch. 12): across a prismatic joint j the angular
  velocity does not change, so link j's six inertia entries merge into link
  j-1's, which come first; a slide before the first revolute joint carries only
  its mass. The greedy count must equal the QR rank, else ValueError.
* Terms: with ``terms`` (:class:`~rmdrake.model.robot.DynamicTerms`) the parameters
  considered are those of :func:`~rmdrake.model.dynamic_parameters.term_columns`
  (indices into the (15n,) extended vector: Ia, fv, fc where on, fcn and tau0
  where on; these come last in a link's preference, ``... Ia fv fc fcn tau0``).
  With both asymmetric Coulomb and offsets, columns max(s, 0), min(s, 0) and 1
  are dependent wherever qd != 0 (max(s, 0) - min(s, 0) = 1), so the offset
  is regrouped into the two Coulomb levels (fcR = fc + tau0, fcnR = fcn - tau0)
  and only one term per joint is added to the symmetric model's count.
  A chain with coupled motors (its robot's transmission) adds each coupled
  motor m's ``Iam, fvm, fcm`` where Ia, fv, fc are on (indices 15n + 3i + ..,
  :mod:`rmdrake.model.dynamic_parameters`), last in link m's preference; on a
  coupled wrist (motor 6 at 0.8 qd5 + qd6) all three are base parameters.
* Regrouping: the dependent columns are W_d = W_b beta (least squares, exact up
  to round-off), so K = [I beta] in column order; entries below 1e-10 relative
  are set to zero.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rmdrake.arrays import as_finite_array
from rmdrake.dynamics.chain import SerialChain, as_serial_chain
from rmdrake.dynamics.regressor import regressor, regressor_columns
from rmdrake.model.dynamic_parameters import (
    N_EXTENDED,
    N_PER_LINK,
    extended_names,
    extended_width,
    term_columns,
)
from rmdrake.model.robot import (
    DYNAMIC_KEYS,
    EXTRA_DYNAMIC_KEYS,
    MOTOR_KEYS,
    DynamicTerms,
    RobotModel,
)

__all__ = ["BaseParameters", "base_parameters"]

# Khalil's preference inside a link: the parameters that absorb others first.
_PREFERENCE = ("XX", "XY", "XZ", "YZ", "ZZ", "MX", "MY", "MZ", "M", "YY")
_PREFERENCE += ("Ia", "fv", "fc", *EXTRA_DYNAMIC_KEYS, *MOTOR_KEYS)


@dataclasses.dataclass(frozen=True, eq=False)
class BaseParameters:
    """Base parameters of a chain (see module docstring).

    Attributes:
      per_link: standard parameters per link considered (10, 11 or 13; 13
        when ``terms`` chose them).
      standard_columns: (p,) indices into the 13n standard vector of the
        parameters considered (all 13n when per_link is 13), or into the
        (15n,) extended vector when ``terms`` has fcn or tau0.
      columns: (nb,) indices into the same vector of the base columns,
        ascending; ``Y_base = Y[:, :, columns]``.
      K: (nb, p) regrouping matrix, chi_base = K @ chi[standard_columns]
        (:attr:`K_full` is the same map on the whole (13n,) vector).
      names: (nb,) base parameter names: the standard name of the kept column,
        with a trailing ``R`` when other parameters are regrouped into it.
      unidentifiable: names of the standard parameters that never act.
      r_diagonal: |R_ii| / |R_00| of the pivoted QR (rank diagnostics).
      rtol: the relative tolerance used.
      terms: the terms the parameters were chosen by, or None (``per_link``).
      links: the number of links n (0: from ``standard_columns``, old records).
      motors: 0-based indices of the chain's coupled motors (their Iam, fvm,
        fcm are entries 15n + 3i + (0, 1, 2) of the extended vector).

    Example:

    >>> from rmdrake import base_parameters, load_robot, standard_parameters
    >>> robot = load_robot("rv3sb")
    >>> base = base_parameters(robot)
    >>> base.regroup(standard_parameters(robot)).shape  # the 52 base values
    (52,)
    >>> len(base.unidentifiable) > 0
    True
    """

    per_link: int
    standard_columns: np.ndarray
    columns: np.ndarray
    K: np.ndarray
    names: tuple[str, ...]
    unidentifiable: tuple[str, ...]
    r_diagonal: np.ndarray
    rtol: float
    terms: DynamicTerms | None = None
    links: int = 0
    motors: tuple[int, ...] = ()

    @property
    def count(self) -> int:
        """Number of base parameters nb."""
        return int(self.columns.size)

    @property
    def n_links(self) -> int:
        """Number of links n of the chain."""
        if self.links:
            return self.links
        return int(self.standard_columns.max()) // N_PER_LINK + 1

    @property
    def width(self) -> int:
        """Length of the parameter vector K_full acts on: 13n, or the extended
        vector's (15n, or 15n + 3k with k coupled motors) when fcn, tau0 or
        a coupled motor's terms are considered."""
        n = self.n_links
        extended = int(self.standard_columns.max()) >= N_PER_LINK * n
        return extended_width(n, len(self.motors)) if extended else N_PER_LINK * n

    @property
    def standard_names(self) -> list[str]:
        """Names of the p standard parameters K acts on."""
        names = extended_names(self.n_links, self.motors)
        return [names[i] for i in self.standard_columns]

    @property
    def K_full(self) -> np.ndarray:
        """(nb, :attr:`width`) regrouping matrix on the whole standard (or
        extended) vector: chi_base = K_full @ chi (K in the columns
        ``standard_columns``, zero elsewhere; a new array on every access)."""
        K = np.zeros((self.count, self.width))
        K[:, self.standard_columns] = self.K
        return K

    def regroup(self, chi: object) -> np.ndarray:
        """chi_base = K @ chi[standard_columns] for a (:attr:`width`,) vector."""
        chi = as_finite_array(chi, "chi", (self.width,))
        return self.K @ chi[self.standard_columns]

    def regressor(
        self,
        chain: SerialChain | RobotModel,
        q: object,
        qd: object,
        qdd: object,
        *,
        out: np.ndarray | None = None,
        coulomb_width: float = 0.0,
    ) -> np.ndarray:
        """Base regressor Y_base (N, n, nb) (or (n, nb) for one sample), N m or
        N per base-parameter unit, without building the full (N, n, 13n) array; ``out``
        and ``coulomb_width`` as in :func:`rmdrake.dynamics.regressor`."""
        return regressor(
            chain,
            q,
            qd,
            qdd,
            columns=self.columns,
            out=out,
            coulomb_width=coulomb_width,
            asymmetric=self.asymmetric,
        )

    @property
    def asymmetric(self) -> bool:
        """True when the Coulomb friction is asymmetric (fc columns
        max(s, 0), see :mod:`rmdrake.dynamics.regressor`)."""
        return self.terms is not None and self.terms.coulomb_asymmetric

    def expressions(self, digits: int = 6) -> list[str]:
        """Readable regrouping, one line per base parameter, e.g.
        ``ZZ1R = ZZ1 + Ia1 + YY2 + 0.0729 M3 + ...`` (coefficients in SI
        units: 1, m or m^2)."""
        std = self.standard_names
        lines = []
        for name, row in zip(self.names, self.K, strict=True):
            terms = []
            for c in np.flatnonzero(row):
                v = row[c]
                mag = "" if abs(abs(v) - 1.0) < 1e-12 else f"{abs(v):.{digits}g} "
                sign = "-" if v < 0 else "+"
                terms.append(f"{sign} {mag}{std[c]}")
            text = " ".join(terms)
            text = text[2:] if text.startswith("+ ") else "-" + text[1:]
            lines.append(f"{name} = {text}")
        return lines

    def __str__(self) -> str:
        head = f"{self.count} base parameters ({self.per_link} per link considered)"
        lines = [head, *self.expressions()]
        if self.unidentifiable:
            lines.append("never act: " + ", ".join(self.unidentifiable))
        return "\n".join(lines)


def base_parameters(
    chain: SerialChain | RobotModel,
    per_link: int = N_PER_LINK,
    *,
    terms: DynamicTerms | None = None,
    n_samples: int = 200,
    seed: int = 0,
    rtol: float = 1e-8,
) -> BaseParameters:
    """Numerical base parameters of ``chain`` (see module docstring).

    Args:
      chain: SerialChain or RobotModel.
      per_link: 10 (inertial), 11 (+ Ia) or 13 (+ fv, fc) per link.
      terms: the terms to consider instead of ``per_link`` (module docstring).
      n_samples: random states stacked (each gives n rows).
      seed: seed of the random states.
      rtol: relative tolerance on |R_ii| and on greedy residuals.

    Raises:
      ValueError: bad per_link, too few samples, or an inconsistent rank.

    Example:

    >>> from rmdrake import base_parameters, load_robot
    >>> base = base_parameters(load_robot("rv3sb"))
    >>> base.count, base.names[:2]
    (52, ('ZZ1R', 'fv1'))
    """
    import scipy.linalg

    chain = as_serial_chain(chain)
    if per_link not in (10, 11, 13):
        raise ValueError(f"per_link: expected 10, 11 or 13, found {per_link}")
    n = chain.n_joints
    motors = chain.coupled_motors if terms is not None else ()
    if terms is not None:
        per_link = N_PER_LINK
        std = term_columns(n, terms, len(motors))
    else:
        std = np.array([13 * j + c for j in range(n) for c in range(per_link)])
    if n_samples * n < std.size:
        raise ValueError(
            f"n_samples: expected at least {-(-std.size // n)} samples for "
            f"{std.size} parameters, found {n_samples}"
        )
    rng = np.random.default_rng(seed)
    half = np.where(chain.prismatic, 1.0, np.pi)[:, None]  # m or rad
    qT = rng.uniform(-1.0, 1.0, (n, n_samples)) * half
    qdT, qddT = rng.standard_normal((2, n, n_samples))
    asym = terms is not None and terms.coulomb_asymmetric
    qdT = np.ascontiguousarray(qdT)
    Yc = regressor_columns(chain, qT, qdT, qddT, columns=std, asymmetric=asym)
    W = Yc.reshape(std.size, -1).T  # (N n, p)
    norms = np.linalg.norm(W, axis=0)
    acting = np.flatnonzero(norms > rtol * norms.max())
    # Compress once: W[:, acting] / norms = Q R0 with orthonormal Q, so the
    # columns of the small R0 have the ranks, dependencies and regrouping
    # coefficients of the tall W (and the rest costs no large BLAS calls).
    R0 = scipy.linalg.qr(W[:, acting] / norms[acting], mode="r")[0][: acting.size]
    R = scipy.linalg.qr(R0, mode="r", pivoting=True)[0]
    diag = np.abs(np.diag(R)) / abs(R[0, 0])
    rank = int(np.sum(diag > rtol))

    # Greedy choice in Khalil's preference order (positions within ``acting``).
    pos = {k: i for i, k in enumerate(_PREFERENCE)}
    n13 = N_PER_LINK * n

    def key_of(i: int) -> tuple[int, int]:
        if i < n13:
            return i // 13, pos[DYNAMIC_KEYS[i % 13]]
        if i >= N_EXTENDED * n:  # a coupled motor's: last in its own link
            i_m, c = divmod(i - N_EXTENDED * n, len(MOTOR_KEYS))
            return motors[i_m], pos[MOTOR_KEYS[c]]
        return (i - n13) % n, pos[EXTRA_DYNAMIC_KEYS[(i - n13) // n]]

    key = [key_of(std[i]) for i in acting]
    Q = np.empty((acting.size, 0))
    kept = []
    for a in sorted(range(acting.size), key=key.__getitem__):
        v = R0[:, a].copy()
        for _ in range(2):  # twice: classical Gram-Schmidt loses orthogonality
            v -= Q @ (Q.T @ v)
        r = np.linalg.norm(v)
        if r > rtol:
            kept.append(a)
            Q = np.column_stack([Q, v / r])
    if len(kept) != rank:
        raise ValueError(
            f"base parameters: pivoted QR rank {rank} but greedy selection kept "
            f"{len(kept)} columns at rtol {rtol}; use more samples or another rtol"
        )
    kept = np.array(sorted(kept))
    beta_n = np.linalg.lstsq(R0[:, kept], R0, rcond=None)[0]  # scaled columns
    beta = np.zeros((kept.size, std.size))  # W = W[:, kept] @ beta
    beta[:, acting] = beta_n * norms[acting] / norms[acting[kept]][:, None]
    beta[np.abs(beta) < 1e-10 * max(1.0, np.abs(beta).max())] = 0.0
    beta[np.arange(kept.size), acting[kept]] = 1.0
    kept = acting[kept]
    names_std = extended_names(n, motors)
    names = tuple(
        names_std[std[i]] + ("R" if np.count_nonzero(beta[b]) > 1 else "")
        for b, i in enumerate(kept)
    )
    return BaseParameters(
        per_link=per_link,
        standard_columns=std,
        columns=std[kept],
        K=beta,
        names=names,
        unidentifiable=tuple(
            names_std[std[i]] for i in np.setdiff1d(np.arange(std.size), acting)
        ),
        r_diagonal=diag,
        rtol=rtol,
        terms=terms,
        links=n,
        motors=motors,
    )
