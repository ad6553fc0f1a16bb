"""The benchmark problems, their references, and the error and energy measures.

Three published test problems, each a liebody scene with its initial state:

* ``hlw``: the free body ``I = (2, 1, 2/3)``, ``L0 = (cos 1.1, 0, sin 1.1)`` of Hairer,
  Lubich & Wanner, *Geometric Numerical Integration*, 2nd ed., Springer (2006); it
  breaks the triangle inequality, so MuJoCo refuses it;
* ``asym``: the physical asymmetric free body ``I = (0.6, 0.8, 1.0)`` of Hairer &
  Vilmart, J. Phys. A 39 (2006) 13225;
* ``top``: the fast heavy top of Simo & Wong, Int. J. Numer. Meth. Eng. 31 (1991) 19–52:
  ``J = diag(5, 5, 1)`` about the fixed point, ``Mgl = 20``, spin 50 rad/s, tilted by
  0.05 rad.

Only liebody's public API is used (``integrate``, ``methods``, the scenes,
``quaternion``), so that the benchmarks keep running while the core changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache

import numpy as np

import liebody
from bench.core import quiet_runtime_warnings


@dataclass(frozen=True)
class Problem:
    """One benchmark problem: a scene, its initial state and where it comes from.

    ``q0`` is scalar-first (body -> space) and ``L0`` body-frame, as everywhere in
    liebody. ``h_max`` is the largest step tried; step ladders halve it.
    """

    key: str
    title: str
    scene: object
    q0: np.ndarray
    L0: np.ndarray
    h_max: float
    source: str
    physical: bool  # MuJoCo accepts the inertia (triangle inequality)
    extra: dict = field(default_factory=dict)

    @property
    def moments(self) -> np.ndarray:
        return self.scene.body.moments

    @property
    def free(self) -> bool:
        return type(self.scene) is liebody.FreeBody

    @property
    def omega_max(self) -> float:
        """|omega| at the start (for a free body, the largest |omega| on the orbit is
        close to it; the benchmarks quote steps as h |omega_0|)."""
        return float(np.linalg.norm(self.L0 / self.moments))

    @property
    def E0(self) -> float:
        return float(energy(self, self.q0[None], self.L0[None])[0])

    def methods(self) -> list[str]:
        """Every registered time-stepping method that can integrate this scene (on a free
        body, not those that are the exact flow there: ``Method.exact_when_free``)."""
        free = not self.scene.capabilities.torque
        return [m.name for m in liebody.methods()
                if m.family != "exact" and m.supports(self.scene)
                and not (free and m.exact_when_free)]

    def integrate(self, method: str, dt: float, steps: int, save_every: int = 1):
        """``liebody.integrate`` from this problem's initial state; the baselines'
        blow-up warnings are silenced (``Trajectory.failed_at`` records them)."""
        with quiet_runtime_warnings():
            return liebody.integrate(self.scene, q0=self.q0, L0=self.L0, dt=dt, steps=steps,
                                     method=method, save_every=save_every)


def method_names() -> list[str]:
    """liebody's registered methods, in registry order."""
    return [m.name for m in liebody.methods()]


#: the keys of :func:`problems`
PROBLEM_KEYS = ("hlw", "asym", "top")


@cache
def problems() -> dict[str, Problem]:
    """The benchmark problems by key (:data:`PROBLEM_KEYS`): ``hlw``, ``asym``, ``top``."""
    from liebody import quaternion

    hlw = Problem(
        key="hlw", title="HLW free body, I = (2, 1, 2/3)",
        scene=liebody.FreeBody(liebody.RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False)),
        q0=np.array([1.0, 0.0, 0.0, 0.0]), L0=np.array([np.cos(1.1), 0.0, np.sin(1.1)]),
        h_max=0.4, physical=False,
        source="Hairer, Lubich & Wanner, Geometric Numerical Integration, 2nd ed. (2006)")
    asym = Problem(
        key="asym", title="asymmetric free body, I = (0.6, 0.8, 1.0)",
        scene=liebody.FreeBody(liebody.RigidBody([0.6, 0.8, 1.0])),
        q0=np.array([1.0, 0.0, 0.0, 0.0]), L0=np.array([1.8, 0.4, -0.9]),
        h_max=0.2, physical=True,
        source="Hairer & Vilmart, J. Phys. A 39 (2006) 13225")
    top = Problem(
        key="top", title="Simo-Wong fast heavy top, J = (5, 5, 1), Mgl = 20, spin 50",
        scene=liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass=20.0, cm=[0.0, 0.0, 1.0],
                               g=1.0),
        q0=quaternion.exp([0.05, 0.0, 0.0]), L0=np.array([0.0, 0.0, 50.0]),
        h_max=0.04, physical=True,
        source="Simo & Wong, Int. J. Numer. Meth. Eng. 31 (1991) 19-52",
        extra={"omega_nutation": 10.0})
    return {p.key: p for p in (hlw, asym, top)}


# ------------------------------------------------------------------------- measures


def energy(problem: Problem, q: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Total energy (kinetic plus the scene's potential) of states ``(n, 4)``, ``(n, 3)``.

    A peer's quaternion that has drifted off the unit sphere enters the potential as that
    peer's own equations see it: ``R(q)`` unnormalised, i.e. ``|q|^2`` times the potential
    of the rotation ``q`` stands for. Non-finite states (a blow-up) give NaN.
    """
    q, L = np.asarray(q, dtype=float), np.asarray(L, dtype=float)
    T = 0.5 * np.sum(L * L / problem.moments, axis=-1)
    if problem.scene.capabilities.free:
        return T
    with np.errstate(over="ignore"):
        n2 = np.sum(q * q, axis=-1)
    V = np.full(n2.shape, np.nan)
    ok = np.all(np.isfinite(q), axis=-1) & (n2 > 0.0)
    V[ok] = problem.scene.potential(q[ok]) * n2[ok]
    return T + V


def state_error(problem: Problem, q, L, q_ref, L_ref) -> np.ndarray:
    """Global error: the larger of ``|L - L_ref| / |L0|`` and ``min(|q - q_ref|, |q + q_ref|)``
    (max-norms; q and -q are the same rotation)."""
    q, L, q_ref, L_ref = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q, L, q_ref, L_ref))
    eL = np.abs(L - L_ref).max(axis=-1) / np.linalg.norm(problem.L0)
    eq = np.minimum(np.abs(q - q_ref).max(axis=-1), np.abs(q + q_ref).max(axis=-1))
    return np.maximum(eL, eq)


# ------------------------------------------------------------------------ references


def reference(problem: Problem, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """Reference states at ``times`` (each a whole multiple of the smallest).

    Free bodies: the exact flow (Jacobi elliptic functions), itself checked in the tests
    against 34-digit mpmath and against DOP853 at rtol 1e-13. The heavy top has no closed
    form in (q, L): the reference is ``splitting8`` at ``h = 1e-3`` (Kahan–Li order 8 on
    the exact symmetric-top flow), checked here against a second method, ``splitting6`` at
    ``h = 5e-4``, at every time, and against scipy's DOP853 at rtol = atol = 1e-13 at the
    first time. The largest of the two differences is returned as ``info["uncertainty"]``;
    errors below it are not resolved.
    """
    times = np.asarray(times, dtype=float)
    base = times[0]
    idx = np.rint(times / base).astype(np.int64)
    if not np.allclose(idx * base, times, rtol=1e-12, atol=0):
        raise ValueError("reference times must be whole multiples of the first")
    if problem.free:
        tr = problem.integrate("exact", base, int(idx[-1]))
        return tr.q[idx], tr.L[idx], {"reference": "exact flow", "uncertainty": 1e-14}

    def fine(method, h):
        n_per = round(base / h)
        tr = problem.integrate(method, base / n_per, int(idx[-1]) * n_per, save_every=n_per)
        return tr.q[idx], tr.L[idx]

    q, L = fine("splitting8", 1e-3)
    q2, L2 = fine("splitting6", 5e-4)
    spread = float(state_error(problem, q, L, q2, L2).max())
    from bench.peers import scipy_solve

    res = scipy_solve(problem, float(times[0]), "DOP853", 1e-13)
    vs_dop = float(state_error(problem, q[0], L[0], res["q"][-1], res["L"][-1])[0])
    info = {"reference": "splitting8 h=1e-3 (checked: splitting6 h=5e-4, DOP853 rtol 1e-13)",
            "spread_vs_splitting6": spread, "vs_dop853_at_first_time": vs_dop,
            "uncertainty": max(spread, vs_dop, 1e-14)}
    return q, L, info
