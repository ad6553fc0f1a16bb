"""Conservation regression tests for anyone's rigid-body integrator.

In the spirit of ``numpy.testing``: reference problems with trusted solutions, the
observed order of a method (liebody's, a user composition, or a plain Python step
function), a classifier of the energy error (bounded, linear drift or random walk)
and assertions on the invariants with messages that say which, by how much and when.

* :func:`problems` / :func:`problem` — named reference problems (:class:`Problem`):
  free bodies with the exact flow, a symmetric body in closed form, Simo & Wong's fast
  top with a certified reference, a Lagrange top released from rest by quadrature.
* :func:`observed_order` / :func:`assert_order` — the order, from a ladder of halved
  steps whose asymptotic range is found automatically (:class:`Order`).
* :func:`run_step` — a user step function ``step(q, L, h) -> (q, L)`` run as a
  :class:`~liebody.Trajectory`, so that every diagnostic applies to it.
* :func:`energy_drift` — bounded, drift or random walk, or undetermined for a run too
  short to tell (:class:`EnergyDrift`).
* :func:`assert_invariants` — ``|q|``, ``|L|``, the spatial angular momentum and the
  energy.

A check of one's own integrator in a test module::

    import numpy as np
    from liebody import testing

    def my_step(q, L, h):          # the integrator under test: (4,), (3,) -> (4,), (3,)
        ...

    def test_my_integrator():
        hlw = testing.problem("hlw")
        assert testing.observed_order(my_step, hlw).rounded == 2
        traj = testing.run_step(my_step, hlw, dt=0.05, steps=20_000, save_every=10)
        assert testing.energy_drift(traj).kind == "bounded"
        testing.assert_invariants(traj, qnorm=1e-12, casimir=1e-12)

Conventions as everywhere in liebody: quaternions scalar-first ``(w, x, y, z)``,
rotating body to space; ``L`` in the body's principal frame.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

__all__ = ["MIN_CYCLES", "EnergyDrift", "Order", "Problem", "assert_invariants", "assert_order",
           "energy_drift", "observed_order", "problem", "problems", "run_step",
           "state_error"]


# ----------------------------------------------------------------------------------------
# reference problems
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Problem:
    """A reference problem: a scene, an initial state, a horizon and a trusted solution.

    Attributes
    ----------
    name, title
        Short key (``problems()[name]``) and a line of description.
    scene
        The scene to integrate (:class:`~liebody.FreeBody`, :class:`~liebody.HeavyTop`).
    q0, L0
        Initial orientation (scalar-first unit quaternion, body -> space) and body-frame
        angular momentum.
    t_end
        The horizon of the order ladder of :func:`observed_order` (a few periods).
    h_max
        The largest step of that ladder (beyond it the methods are in their large-step
        regime; :func:`observed_order` excludes that regime anyway).
    provenance
        Where the problem and its reference come from.
    uncertainty
        Estimated maximum error of the reference over ``[0, t_end]``, in the units of
        :func:`state_error` (computed references: the difference of two
        resolutions; closed forms: round-off).
    """

    name: str
    title: str
    scene: object
    q0: np.ndarray
    L0: np.ndarray
    t_end: float
    h_max: float
    provenance: str
    uncertainty: float
    _solution: Callable = field(repr=False)
    _spread: Callable | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        for name in ("q0", "L0"):  # shared by every caller: read-only copies
            a = np.array(getattr(self, name), dtype=float)
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    def reference(self, t) -> tuple[np.ndarray, np.ndarray]:
        """The reference state at time(s) ``t`` (``>= 0``).

        Returns
        -------
        q : ndarray, shape ``t.shape + (4,)``
        L : ndarray, shape ``t.shape + (3,)``
        """
        tt = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(tt)) or np.any(tt < 0):
            raise ValueError(f"t must be finite and >= 0, got {t!r}")
        flat = tt.reshape(-1)
        q, L = self._solution(flat)
        return q.reshape(tt.shape + (4,)), L.reshape(tt.shape + (3,))

    def reference_spread(self, t: float) -> float | None:
        """For a computed reference, the difference (:func:`state_error`) between its two
        resolutions at time ``t``: the certificate of ``uncertainty``. ``None`` for
        closed forms."""
        return None if self._spread is None else float(self._spread(float(t)))

    def energy(self, q, L) -> np.ndarray:
        """Total energy of states ``(q, L)`` in this problem's scene."""
        q, L = np.asarray(q, dtype=float), np.asarray(L, dtype=float)
        kinetic = 0.5 * np.sum(L * L / self.scene.moments, axis=-1)
        return kinetic + self.scene.potential(q / np.linalg.norm(q, axis=-1, keepdims=True))

    def __repr__(self) -> str:
        return f"Problem({self.name!r}: {self.title})"


def _exact_free(scene, q0, L0):
    """The exact free-body flow (Jacobi elliptic functions) at given times."""
    from liebody._kernels.exact import exact_flow_times

    moments = np.ascontiguousarray(scene.moments, dtype=float)

    def solution(t):
        q, m = np.empty((t.size, 4)), np.empty((t.size, 3))
        exact_flow_times(moments, q0.copy(), L0.copy(), np.ascontiguousarray(t), q, m)
        return q, m

    return solution


def _symmetric_closed_form(scene, q0, L0):
    """The free symmetric top in closed form (Hand & Finch, ch. 8, the force-free
    symmetric top): with ``I1 = I2 = I_p``, ``T = |L|^2 / (2 I_p) + L3^2 (1/I3 - 1/I_p) / 2``;
    the two parts commute, so the flow is a rotation about ``L`` at rate ``|L| / I_p``
    followed by a rotation about the symmetry axis by ``L3 (1/I3 - 1/I_p) t``."""
    from liebody import quaternion as Q

    I_p, I3 = float(scene.moments[0]), float(scene.moments[2])
    rate = L0[2] * (1.0 / I3 - 1.0 / I_p)

    def solution(t):
        tumble = Q.exp(t[:, None] * (L0 / I_p))
        spin = Q.exp(t[:, None] * np.array([0.0, 0.0, rate]))
        q = Q.multiply(Q.multiply(q0, tumble), spin)
        L_space = Q.rotate(q0, L0)
        return q, Q.rotate_inverse(q, np.broadcast_to(L_space, (t.size, 3)))

    return solution


def _certified(scene, q0, L0, method: str, steps: tuple[float, float]):
    """A high-order method at two fine steps: the finer is the reference, their
    difference (at every requested time) its certified uncertainty."""
    from liebody._integrate import integrate

    @lru_cache(maxsize=64)
    def at(t: float, h: float):
        if t == 0.0:
            return q0.copy(), L0.copy()
        n = max(1, math.ceil(t / h))
        tr = integrate(scene, q0=q0, L0=L0, dt=t / n, steps=n, method=method,
                       save_every=None)
        return np.array(tr.q[-1]), np.array(tr.L[-1])

    def solution(t):
        q, L = np.empty((t.size, 4)), np.empty((t.size, 3))
        for i, ti in enumerate(t):
            q[i], L[i] = at(float(ti), steps[1])
        return q, L

    def spread(t: float) -> float:
        qa, La = at(t, steps[0])
        qb, Lb = at(t, steps[1])
        return state_error(qa, La, qb, Lb, scale=float(np.linalg.norm(L0)))

    return solution, spread


def _lagrange_quadrature(scene, q0, L0):
    """A Lagrange top (symmetric, centre of mass on the axis) released from rest at its
    highest tilt ``theta1`` (Hand & Finch, ch. 8, the heavy symmetric top): ``theta(t)``
    in Jacobi elliptic functions, ``thetadot`` their derivative, ``phi`` and ``psi`` by
    quadrature of ``phidot(theta)`` and ``psidot(theta)``."""
    from scipy import integrate as si
    from scipy import special

    from liebody import lagrange_top as lt

    top = lt.LagrangeTop.from_heavy_top(scene)
    motion = top.motion_from_state(q0, L0)
    tp = motion.turning_points()
    if tp.degenerate or not tp.u3 - tp.u2 >= tp.u1 - tp.u2:
        raise ValueError("the Lagrange problem needs a nutating top (u1 > u2, u3 >= u1)")
    b = 2.0 * top.mgl / top.I1
    m = (tp.u1 - tp.u2) / (tp.u3 - tp.u2)
    c = math.sqrt(b * (tp.u3 - tp.u2)) / 2.0

    def theta_and_rate(t):
        sn, cn, dn, _ = special.ellipj(c * t, m)
        cd = cn / dn
        u = tp.u2 + (tp.u1 - tp.u2) * cd**2
        dudt = -2.0 * (tp.u1 - tp.u2) * (1.0 - m) * c * cd * sn / dn**2  # d cd/dx
        theta = np.arccos(np.clip(u, -1.0, 1.0))
        return theta, -dudt / np.sin(theta)

    def rates(s):
        th = theta_and_rate(np.atleast_1d(s))[0]
        return float(motion.precession_rate(th)[0]), float(motion.spin_rate(th)[0])

    def solution(t):
        order = np.argsort(t)
        phi, psi = np.empty(t.size), np.empty(t.size)
        last, acc_phi, acc_psi = 0.0, 0.0, 0.0
        for i in order:
            ti = float(t[i])
            if ti > last:
                kw = dict(epsabs=1e-14, epsrel=1e-13, limit=400)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", si.IntegrationWarning)
                    acc_phi += si.quad(lambda s: rates(s)[0], last, ti, **kw)[0]
                    acc_psi += si.quad(lambda s: rates(s)[1], last, ti, **kw)[0]
                last = ti
            phi[i], psi[i] = acc_phi, acc_psi
        theta, thetadot = theta_and_rate(t)
        phidot = np.atleast_1d(motion.precession_rate(theta))
        psidot = np.atleast_1d(motion.spin_rate(theta))
        angles = np.stack([phi, theta, psi], axis=-1)
        angle_rates = np.stack([phidot, thetadot, psidot], axis=-1)
        return top.state_from_euler(angles, angle_rates)

    return solution


def _build_problems() -> dict[str, Problem]:
    import liebody
    from liebody import euler
    from liebody import quaternion as Q

    out: dict[str, Problem] = {}
    ident = np.array([1.0, 0.0, 0.0, 0.0])

    hlw = liebody.FreeBody(liebody.RigidBody([2.0, 1.0, 2.0 / 3.0], check_triangle=False))
    L0 = np.array([math.cos(1.1), 0.0, math.sin(1.1)])
    out["hlw"] = Problem(
        "hlw", "free body I = (2, 1, 2/3), L0 = (cos 1.1, 0, sin 1.1): exact flow", hlw,
        ident, L0, 10.0, 0.5,
        "Hairer, Lubich & Wanner, Geometric Numerical Integration (2006), sect. VII.5; "
        "reference: the exact flow in Jacobi elliptic functions (Celledoni, Fasso, "
        "Safstrom & Zanna 2008)", 1e-13, _exact_free(hlw, ident, L0))

    asym = liebody.FreeBody(liebody.RigidBody([0.6, 0.8, 1.0]))
    L0 = np.array([1.8, 0.4, -0.9])
    q0 = Q.normalize([0.9, 0.1, -0.3, 0.2])
    out["asym"] = Problem(
        "asym", "physical asymmetric body I = (0.6, 0.8, 1.0), a tumbling orbit: exact flow",
        asym, q0, L0, 10.0, 0.25,
        "Hairer & Vilmart, J. Phys. A 39 (2006) 13225: a body that satisfies the triangle "
        "inequality; reference: the exact flow in Jacobi elliptic functions (Celledoni, "
        "Fasso, Safstrom & Zanna 2008)", 1e-13,
        _exact_free(asym, q0, L0))

    sym = liebody.FreeBody(liebody.RigidBody([1.0, 1.0, 1.6]))
    L0 = np.array([0.7, -0.4, 1.2])
    q0 = Q.normalize([0.8, -0.2, 0.4, 0.1])
    out["symmetric"] = Problem(
        "symmetric", "free symmetric top I = (1, 1, 1.6): closed form", sym, q0, L0, 10.0,
        0.5, "Hand & Finch, Analytical Mechanics (1998), ch. 8, the force-free symmetric "
        "top: precession about L at |L|/I1 and spin about the axis at L3 (1/I3 - 1/I1)",
        1e-13, _symmetric_closed_form(sym, q0, L0))

    top = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass=20.0, cm=[0.0, 0.0, 1.0],
                           g=1.0)
    q0, L0 = Q.exp([0.05, 0.0, 0.0]), np.array([0.0, 0.0, 50.0])
    solution, spread = _certified(top, q0, L0, "splitting8", (1e-3, 5e-4))
    out["top"] = Problem(
        "top", "Simo & Wong's fast top: I = (5, 5, 1), M g l = 20, spin 50", top, q0, L0,
        10.0, 0.02, "Simo & Wong, Int. J. Numer. Meth. Eng. 31 (1991) 19; reference: "
        "splitting8 at h = 5e-4, certified by its difference to h = 1e-3 (6e-14 at t = 10; "
        "the uncertainty stated is 1e-12)", 1e-12, solution, spread)

    lag = liebody.HeavyTop(liebody.RigidBody([1.0, 1.0, 0.5]), mass=1.0, cm=[0.0, 0.0, 1.0],
                           g=9.81)
    q0 = euler.to_quaternion([0.0, 0.6, 0.0])
    L0 = np.array([0.0, 0.0, 0.5 * 12.0])  # released from rest spinning at 12 rad/s
    out["lagrange"] = Problem(
        "lagrange", "Lagrange top released from rest at theta = 0.6, spin 12 rad/s: cusps",
        lag, q0, L0, 3.0, 0.05,
        "Hand & Finch, Analytical Mechanics (1998), ch. 8, the heavy symmetric top: "
        "theta(t) in Jacobi elliptic functions, phi and psi by adaptive quadrature "
        "(scipy.integrate.quad at 1e-14)", 1e-11, _lagrange_quadrature(lag, q0, L0))
    return out


_PROBLEMS: dict[str, Problem] | None = None


def problems() -> dict[str, Problem]:
    """The named reference problems (built on first use; a fresh dict each call).

    ========== ===========================================================================
    name       problem, reference
    ========== ===========================================================================
    hlw        free body ``I = (2, 1, 2/3)`` of Hairer, Lubich & Wanner; exact flow
    asym       a physical asymmetric free body ``I = (0.6, 0.8, 1.0)``; exact flow
    symmetric  a free symmetric top ``I = (1, 1, 1.6)``; closed form (Hand & Finch, ch. 8)
    top        Simo & Wong's fast heavy top; ``splitting8`` at two fine steps (certified)
    lagrange   a Lagrange top released from rest; elliptic functions and quadrature
    ========== ===========================================================================
    """
    global _PROBLEMS
    if _PROBLEMS is None:
        _PROBLEMS = _build_problems()
    return dict(_PROBLEMS)


def _lookup(problem) -> Problem:
    if isinstance(problem, str):
        return globals()["problem"](problem)
    if not isinstance(problem, Problem):
        raise TypeError(f"problem must be a liebody.testing.Problem or its name, got "
                        f"{type(problem).__name__}")
    return problem


def problem(name: str) -> Problem:
    """One reference problem by name (see :func:`problems`)."""
    table = problems()
    if not isinstance(name, str) or name not in table:
        raise ValueError(f"unknown problem {name!r}; known problems: {', '.join(table)}")
    return table[name]


# ----------------------------------------------------------------------------------------
# errors, user steps
# ----------------------------------------------------------------------------------------


def state_error(q, L, q_ref, L_ref, *, scale: float | None = None) -> float:
    """Error of a state against a reference: the larger of the orientation error
    ``min(|q - q_ref|, |q + q_ref|)`` (max norm, either sign of the quaternion) and
    ``|L - L_ref| / scale`` (max norm; ``scale`` defaults to ``|L_ref|``). Infinite when
    the state is not finite."""
    q, L = np.asarray(q, dtype=float), np.asarray(L, dtype=float)
    q_ref, L_ref = np.asarray(q_ref, dtype=float), np.asarray(L_ref, dtype=float)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(L))):
        return math.inf
    s = float(np.linalg.norm(L_ref)) if scale is None else float(scale)
    dq = min(float(np.abs(q - q_ref).max()), float(np.abs(q + q_ref).max()))
    return max(dq, float(np.abs(L - L_ref).max()) / (s if s > 0 else 1.0))


def _is_step_function(method) -> bool:
    from liebody._methods import Method

    return callable(method) and not isinstance(method, str | Method)


def _user_steps(step, q, L, h: float, n: int, every: int | None = None):
    """``n`` calls of ``step``; the states every ``every`` steps (and the last)."""
    q, L = np.array(q, dtype=float), np.array(L, dtype=float)
    saved = [(q.copy(), L.copy())] if every else None
    for k in range(1, n + 1):
        out = step(q, L, h)
        try:
            q, L = out
        except (TypeError, ValueError):
            raise TypeError("a step function must return (q, L), got "
                            f"{type(out).__name__}") from None
        q, L = np.asarray(q, dtype=float), np.asarray(L, dtype=float)
        if q.shape != (4,) or L.shape != (3,):
            raise ValueError(f"a step function must return q of shape (4,) and L of shape "
                             f"(3,), got {q.shape} and {L.shape}")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(L))):
            return (q, L), saved, k
        if every and (k % every == 0 or k == n):
            saved.append((q.copy(), L.copy()))
    return (q, L), saved, None


def run_step(step: Callable, problem: Problem, *, dt: float, steps: int,
             save_every: int = 1):
    """Run a user step function on a problem and return a :class:`~liebody.Trajectory`.

    Parameters
    ----------
    step
        ``step(q, L, h) -> (q, L)``: one step of size ``h`` of the user's integrator for
        ``problem.scene`` (``q`` scalar-first, body -> space; ``L`` body frame), plain
        Python or a numba-compiled function.
    problem
        A :class:`Problem` or its name (its scene and initial state are used).
    dt, steps
        Step size (> 0) and number of steps (>= 1).
    save_every
        Keep every ``save_every``-th state (and the last).

    Returns
    -------
    Trajectory
        With ``method=None``. As in :func:`liebody.integrate`, nothing fails silently:
        a step that produces a non-finite state ends the run (``status="failed"``,
        ``failed_at`` its time) and warns (``RuntimeWarning``), and a complete run whose
        ``|q|`` is off 1 by more than ``1e-6`` at the end warns
        (:class:`~liebody.InvariantWarning`; the other invariants depend on what the
        step claims to keep: check them with :func:`assert_invariants`).
    """
    from liebody._integrate import QNORM_TOL
    from liebody.errors import InvariantWarning
    from liebody.trajectory import Trajectory

    problem = _lookup(problem)
    dt = _positive("dt", dt)
    steps = _count("steps", steps)
    save_every = _count("save_every", save_every)
    _, saved, bad = _user_steps(step, problem.q0, problem.L0, dt, steps, save_every)
    idx = [0] + [k for k in range(1, steps + 1) if k % save_every == 0 or k == steps]
    idx = idx[:len(saved)]
    t = np.array(idx, dtype=float) * dt
    q = np.array([s[0] for s in saved])
    L = np.array([s[1] for s in saved])
    failed = None if bad is None else bad * dt
    name = getattr(step, "__name__", repr(step))
    traj = Trajectory(t, q, L, problem.scene, None, dt, failed_at=failed,
                      info={"step": name}, status="complete" if bad is None else "failed")
    if bad is not None:
        from liebody._engine import failed_step_times, failed_step_words

        warnings.warn(
            f"{name}: the state became non-finite "
            f"{failed_step_words(bad - 1, *failed_step_times(0.0, bad - 1, dt))}; returning the "
            f"{len(t):,} samples before it (Trajectory.failed_at is set)",
            RuntimeWarning, stacklevel=2)
    else:
        qn = float(np.linalg.norm(q[-1]))
        if not abs(qn - 1.0) <= QNORM_TOL:
            warnings.warn(
                f"{name}: |q| = {qn:.6g} at the end, off 1 by more than {QNORM_TOL:g} (the "
                f"step may be too large for this scene, or the method does not keep this "
                f"invariant)", InvariantWarning, stacklevel=2)
    return traj


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return float(value)


def _count(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {value!r}")
    return int(value)


# ----------------------------------------------------------------------------------------
# observed order
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Order:
    """An observed order and the asymptotic range it was read from.

    Attributes
    ----------
    order
        Least-squares slope of ``log(error)`` against ``log(h)`` over the range used.
    rounded
        ``round(order)``.
    steps
        ``(h_largest, h_smallest)`` of the range used.
    hs, errors
        The whole ladder (``inf`` where a method failed or refused the step).
    slopes
        Local slopes between consecutive steps (NaN outside ``(floor, ceiling)``).
    used
        Indices into ``hs`` of the range used.
    reliable
        At least three steps agree (two or more local slopes within ``settle``).
    """

    order: float
    steps: tuple[float, float]
    hs: np.ndarray
    errors: np.ndarray
    slopes: np.ndarray
    used: tuple[int, ...]
    reliable: bool

    @property
    def rounded(self) -> int:
        return round(self.order)

    def __repr__(self) -> str:
        pairs = ", ".join(f"{h:.3g}: {e:.3g}" for h, e in zip(self.hs, self.errors, strict=True))
        return (f"Order({self.order:.3f} from h = {self.steps[0]:.3g} to {self.steps[1]:.3g}"
                f"{'' if self.reliable else ', UNRELIABLE'}; errors {{{pairs}}})")


def observed_order(method=None, problem: Problem | str | None = None, *,
                   error: Callable[[int], float] | None = None, t_end: float | None = None,
                   h_max: float | None = None, floor: float | None = None,
                   ceiling: float = 1e-2, settle: float = 0.1, levels: int = 16,
                   max_steps: int | None = None) -> Order:
    """The observed order of a method on a reference problem.

    The error at ``t_end`` (:func:`state_error` against ``problem.reference``) is
    measured on a ladder of halved steps ``h = h_max / 2^k``. The asymptotic range is
    found, not assumed: errors above ``ceiling`` (the large-step regime, blow-ups and
    refusals) and below ``floor`` (round-off) are dropped, and the order is the
    least-squares slope over the longest run of consecutive local slopes that agree
    within ``2 * settle`` (ties: the smaller steps). The ladder stops at the floor, at
    ``max_steps``, or once the last three local slopes agree. Any order works (1, 3,
    5, ... 10): no table of step sizes per order.

    Parameters
    ----------
    method
        A registered method name, a :class:`~liebody.Method` (e.g. one returned by
        :func:`liebody.register_composition`), or a user step function
        ``step(q, L, h) -> (q, L)`` for ``problem.scene`` (plain Python or numba).
    problem
        A :class:`Problem` or its name.
    error
        Instead of ``method`` and ``problem``: ``error(n)``, the error after ``n`` steps
        of size ``t_end / n`` against one's own reference (``inf``: the method refused
        or failed at that step). Needs ``t_end``; ``h_max`` defaults to ``t_end``,
        ``floor`` to ``1e-11``.
    t_end, h_max
        Horizon and first step of the ladder; default the problem's. When the errors
        fall to the floor within two halvings (a high order), the ladder also climbs to
        larger steps, until the large-step regime.
    floor
        Errors below it count as round-off; default ``max(1e-11, 10 * uncertainty)``
        of the problem's reference.
    ceiling, settle, levels
        Largest error counted as asymptotic; agreement of local slopes; most halvings.
    max_steps
        Longest run of the ladder: default ``2**22`` for liebody methods and ``error``,
        and ``2**17`` for user step functions (Python loops).

    Returns
    -------
    Order
        ``.order``, ``.rounded`` and the range used.

    Raises
    ------
    ValueError
        When fewer than two errors fall between ``floor`` and ``ceiling``; and when a
        run's result was not finite (a NaN or infinite state, a failed run, a NaN
        error) at a step inside or below the range used, or anywhere when there is no
        range: the message names those steps. Non-finite results at steps larger than
        the range are the large-step regime (blow-ups), and are left out.
    """
    if error is not None:
        if method is not None or problem is not None:
            raise ValueError("give either method and problem, or error (with t_end), "
                             "not both")
        if not callable(error):
            raise TypeError(f"error must be a function error(n) -> float, got "
                            f"{type(error).__name__}")
        if t_end is None:
            raise ValueError("error needs t_end: the step is t_end / n")
        T = _positive("t_end", t_end)
        h0 = T if h_max is None else _positive("h_max", h_max)
        lo = 1e-11 if floor is None else _positive("floor", floor)
        cap = 2**22 if max_steps is None else _count("max_steps", max_steps)

        def run(n: int) -> tuple[float, bool]:
            value = float(error(n))
            return value, not math.isnan(value) and value != math.inf
    else:
        if method is None or problem is None:
            raise ValueError("give a method and a problem (or error and t_end)")
        run, T, h0, lo, cap = _ladder_runs(method, problem, t_end, h_max, floor, max_steps)
    finite: dict[float, bool] = {}

    def measure(n: int) -> float:
        e, ok = run(n)
        finite[T / n] = ok
        return e if math.isfinite(e) and ok else math.inf

    n0 = max(1, math.ceil(T / h0))
    hs: list[float] = []
    errs: list[float] = []
    for k in range(levels):
        n = n0 * 2**k
        if n > cap:
            break
        e = measure(n)
        hs.append(T / n)
        errs.append(e)
        if e <= lo:
            break
        slopes = _slopes(np.array(hs), np.array(errs), lo, ceiling)
        tail = slopes[-3:]
        if len(tail) == 3 and np.all(np.isfinite(tail)) and np.ptp(tail) <= 2 * settle:
            break
    H, E = np.array(hs), np.array(errs)
    slopes = _slopes(H, E, lo, ceiling)
    agree = _longest_agreeing_run(slopes, settle)
    if (agree is None or agree[1] - agree[0] < 2) and math.isfinite(errs[0]) \
            and errs[0] < ceiling:
        # a high order: the errors reach the floor within a few halvings of h_max, so
        # the ladder climbs to larger steps until the large-step regime
        n = n0
        for _ in range(levels):
            n //= 2
            if n < 1:
                break
            e = measure(n)
            hs.insert(0, T / n)
            errs.insert(0, e)
            if not e < ceiling:
                break
        H, E = np.array(hs), np.array(errs)
        slopes = _slopes(H, E, lo, ceiling)
        agree = _longest_agreeing_run(slopes, settle)
    # a result that was not finite is the large-step regime only above the range used
    largest = math.inf if agree is None else float(H[agree[0]])
    bad = sorted((h for h, ok in finite.items() if not ok and h <= largest), reverse=True)
    if bad:
        where = ("the range it was read from" if agree is None
                 else f"the asymptotic range found (h <= {largest:.6g})")
        raise ValueError(
            f"the result was not finite (a NaN or infinite state, or a failed run) at "
            f"h = {', '.join(f'{h:.6g}' for h in bad)}: not the large-step regime, being "
            f"within or below {where}; the method breaks at these steps")
    if agree is None:
        finite_E = E[np.isfinite(E)]
        if finite_E.size and finite_E.max() <= lo:
            raise ValueError(f"no asymptotic range: the error is at round-off "
                             f"({finite_E.max():.3g} <= floor {lo:g}) already at "
                             f"h = {H[0]:.3g}; the method is exact on this problem (or "
                             f"start from a larger h_max)")
        table = ", ".join(f"{h:.3g}: {e:.3g}" for h, e in zip(H, E, strict=True))
        raise ValueError(f"no asymptotic range: fewer than two errors between floor "
                         f"{lo:g} and ceiling {ceiling:g} (h: error = {table}); widen "
                         f"them or change h_max")
    i, j = agree  # slopes i..j-1 agree: points i..j
    used = tuple(range(i, j + 1))
    x, y = np.log(H[list(used)]), np.log(E[list(used)])
    order = float(np.polyfit(x, y, 1)[0])
    return Order(order, (float(H[i]), float(H[j])), H, E, slopes, used, j - i >= 2)


def _ladder_runs(method, problem, t_end, h_max, floor, max_steps):
    """For :func:`observed_order` on a problem: ``run(n) -> (error, finite)`` after ``n``
    steps of ``method`` (``finite``: the run's state stayed finite), and the ladder's
    ``t_end``, ``h_max``, floor and longest run."""
    prob = _lookup(problem)
    T = prob.t_end if t_end is None else _positive("t_end", t_end)
    h0 = prob.h_max if h_max is None else _positive("h_max", h_max)
    lo = max(1e-11, 10.0 * prob.uncertainty) if floor is None else _positive("floor", floor)
    user = _is_step_function(method)
    if not user:
        from liebody._methods import check_supports, get

        m = get(method)
        check_supports(m, prob.scene)
        if m.sampled:
            raise ValueError(f"method {m.name!r} evaluates a closed form at the output "
                             f"times: it has no step and no order")
    cap = (2**17 if user else 2**22) if max_steps is None else _count("max_steps", max_steps)
    q_ref, L_ref = prob.reference(T)
    scale = float(np.linalg.norm(prob.L0)) or 1.0

    def run(n: int) -> tuple[float, bool]:
        h = T / n
        if user:
            (q, L), _, bad = _user_steps(method, prob.q0, prob.L0, h, n)
            if bad is not None:
                return math.inf, False
            return state_error(q, L, q_ref, L_ref, scale=scale), True
        from liebody._integrate import integrate
        from liebody.errors import ConvergenceError

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                tr = integrate(prob.scene, q0=prob.q0, L0=prob.L0, dt=h, steps=n, method=m,
                               save_every=None)
        except (ValueError, ConvergenceError):
            return math.inf, True  # refused or not converged: outside the range
        if tr.status != "complete":
            return math.inf, False
        return state_error(tr.q[-1], tr.L[-1], q_ref, L_ref, scale=scale), True

    return run, T, h0, lo, cap


def _slopes(H: np.ndarray, E: np.ndarray, floor: float, ceiling: float) -> np.ndarray:
    """Local slopes between consecutive ladder points, NaN where either error is outside
    ``(floor, ceiling)``."""
    inside = (E > floor) & (E < ceiling)
    out = np.full(max(len(H) - 1, 0), np.nan)
    for k in range(len(H) - 1):
        if inside[k] and inside[k + 1]:
            out[k] = math.log(E[k] / E[k + 1]) / math.log(H[k] / H[k + 1])
    return out


def _longest_agreeing_run(slopes: np.ndarray, settle: float):
    """``(i, j)``: the longest run ``slopes[i:j]`` of finite slopes whose spread is at
    most ``2 settle`` (ties: the last); ``None`` if there is no finite slope."""
    best = None
    n = len(slopes)
    for i in range(n):
        if not np.isfinite(slopes[i]):
            continue
        j = i + 1
        while j < n and np.isfinite(slopes[j]) and np.ptp(slopes[i:j + 1]) <= 2 * settle:
            j += 1
        if best is None or j - i >= best[1] - best[0]:
            best = (i, j)
    return best


def assert_order(method, problem: Problem | str, expected: int, *, tol: float = 0.2,
                 **kwargs) -> Order:
    """Assert that :func:`observed_order` is ``expected`` within ``tol`` and that the
    range it was read from is reliable; returns the :class:`Order`."""
    found = observed_order(method, problem, **kwargs)
    if not (found.reliable and abs(found.order - expected) <= tol):
        raise AssertionError(f"observed order {found.order:.3f}, expected {expected} "
                             f"(tolerance {tol}): {found!r}")
    return found


# ----------------------------------------------------------------------------------------
# energy drift
# ----------------------------------------------------------------------------------------

#: the verdicts, in the order of the terms c0, c1 w, c2 w^2 of the windowed variance
KINDS = ("bounded", "random walk", "drift")
#: the verdict of a run too short to tell (see :data:`MIN_CYCLES`)
UNDETERMINED = "undetermined"
#: a drift needs a linear trend this many standard errors away from zero
DRIFT_SIGNIFICANCE = 4.0
#: a linear trend this many standard errors away from zero is a drift under a bounded
#: error (or one the windowed variance calls a random walk while the error about the
#: trend stops growing): a drift smaller than the oscillation does not show in the
#: windowed variance, but the 20 block means of the trend's fit average it out
DRIFT_OVERRULE = 10.0
#: a drift's change over the run must also exceed this many times the largest change
#: (slope times run) that a bounded oscillation of the error's size and number of cycles
#: makes a least-squares line show: a sinusoid's own slope, which is not a drift
DRIFT_LEAKAGE = 2.0
#: bounded: the windowed variance grows by at most this factor over its top two octaves
#: (windows of T/8 to T/2; a random walk's factor is 4 in expectation, 1.4 or more in
#: 99 % of walks, measured; a sinusoid's 1.05 or less from 8 periods on)
FLAT = 1.25
#: bounded, for an oscillation of few (3 to 8) periods: the windowed variance grows by at
#: most this factor over its top octave (T/4 to T/2) after a smooth rise below it ...
FLAT_TOP = 1.1
#: ... by at least this factor over the two octaves below (T/32 to T/8: like w^2, a
#: smooth error's growth; a random walk's is like w, a factor 4)
SMOOTH = 8.0
#: the cycles are counted on the error smoothed over T / BLOCKS
BLOCKS = 256
#: a verdict needs the error's fluctuation about its trend to complete at least this many
#: cycles over the run (see ``EnergyDrift.cycles``): over fewer, a slow oscillation
#: cannot be told from a drift or a random walk. A random walk's count is 3.5 or more
#: from 2,000 samples on (measured, 400 walks each of 2,000 and 20,000 samples; 2.6 with
#: 64 samples)
MIN_CYCLES = 3.0


@dataclass(frozen=True)
class EnergyDrift:
    """How the relative energy error ``e(t) = (E(t) - E(0)) / |E(0)|`` grows.

    Attributes
    ----------
    kind
        ``"bounded"`` (``e`` oscillates and does not grow: a symplectic method's
        modified energy), ``"random walk"`` (grows like ``sqrt(t)``: round-off
        accumulating; Brouwer's law), ``"drift"`` (grows like ``t``: a method that is
        not symplectic, or a biased step) or ``"undetermined"`` (the run is too short to
        tell: its error's fluctuation about the trend completes fewer than
        :data:`MIN_CYCLES` cycles, see ``cycles``).
    exponent
        The growth exponent ``H`` of the error's rms within a window of length ``w``,
        ``sqrt(V(w)) ~ w^H``, over the top two octaves (``w`` from ``T/8`` to ``T/2``):
        0 for bounded, 1/2 for a random walk, 1 for a drift. ``V(w)`` is the variance
        of ``e`` within a window of length ``w``, averaged over all the windows (every
        start): a bounded error's stops growing once ``w`` exceeds its periods (a
        sinusoid's is ``A^2/2 (1 - sinc^2(w / P))``, without aliasing: no block means),
        a random walk's grows like ``w``, a drift's like ``w^2``. The error is bounded
        when ``V`` stops growing: by at most 25 % over the top two octaves (a random
        walk's grows 4-fold in expectation, 1.4-fold or more in 99 % of walks), or, for
        an oscillation of few (3 to 8) periods, by at most 10 % over the top octave
        after a smooth rise below it (8-fold or more from ``T/32`` to ``T/8``, like
        ``w^2``; a random walk's rises like ``w``). Otherwise ``V`` is fitted
        (non-negative least squares, relative residuals, windows from ``T/2048`` to
        ``T/2`` by half octaves) by ``c0 + c1 w + c2 w^2``: a bounded part, a random
        walk and a drift, and the verdict is the term that dominates at ``T/2``.
        A drift needs a real linear trend, one that is significant
        (``|rate| > 4 rate_stderr``) and larger than a bounded oscillation's own
        least-squares slope: the change over the run ``|rate| T`` must exceed twice
        ``(12 / (2 pi N) + 24 / (2 pi N)^2) A``, what a sinusoid of the amplitude ``A``
        of the error about its trend (``sqrt(2)`` times its rms) and ``N`` periods
        (Rice's count on the raw samples, or its swings if fewer) can show at most.
        A bounded verdict with a real trend of more than 10 standard errors is a drift
        (a drift smaller than the oscillation does not show in ``V``, but the 20 block
        means of the trend's fit average the oscillation out); so is a random walk's
        when the error about its trend stops growing.
    confidence
        The share of ``V(T/2)`` the verdict explains (between 0 and 1): for a bounded
        error, the share already reached at the start of its flat part (``V(T/8)`` or
        ``V(T/4)`` over ``V(T/2)``); for a fitted verdict, the share of the winning term
        (at least 1/3 unless a drift was set aside for want of a real trend): near 1 a
        clear verdict, near 1/2 a mixture (e.g. a slow drift under a large bounded
        oscillation). For a drift found by its trend alone: the share of the 20 block
        means' variance that the linear trend explains. 0 for ``"undetermined"``.
    rate, rate_stderr
        Least-squares slope of 20 block means of ``e`` against their times (relative
        energy per unit time) and its standard error (from their scatter about the
        line). A bounded oscillation has a slope of its own over a finite run (see
        ``exponent``): a significant rate alone is not a drift.
    max_error
        ``max |e|``.
    cycles
        How many cycles the error's fluctuation about its linear trend completes over
        the run: the larger of two counts. Rice's rms frequency times the run's length,
        on the error smoothed by three passes of a moving average over ``T/256`` (not
        decimated: a fast oscillation is damped, never aliased into a slow one); and
        half the swings of the raw error about its trend between ``-std/2`` and
        ``+std/2`` (a fast oscillation's periods, which the smoothing removes; noise
        far smaller than the fluctuation does not swing). A sinusoid's count is its
        number of periods; a random walk's 3.5 or more (from 2,000 samples on). Fewer
        than :data:`MIN_CYCLES` (3): ``"undetermined"``. ``inf`` when the error has no
        fluctuation about its trend above round-off.
    """

    kind: str
    exponent: float
    confidence: float
    rate: float
    rate_stderr: float
    max_error: float
    cycles: float = math.inf

    def __str__(self) -> str:
        stats = (f"exponent {self.exponent:.2f}, confidence {self.confidence:.2f}; rate "
                 f"{self.rate:.3g} +- {self.rate_stderr:.2g} per unit time; max |dE/E| "
                 f"{self.max_error:.3g}")
        if self.kind == UNDETERMINED:
            return (f"undetermined: the run is too short to tell, its energy error "
                    f"completes {self.cycles:.2g} cycles about its trend, fewer than "
                    f"{MIN_CYCLES:g}; integrate for longer ({stats})")
        return f"{self.kind} ({stats})"


def _block_fit(t: np.ndarray, e: np.ndarray, blocks: int) -> tuple[float, float, float]:
    """Slope of ``blocks`` block means of ``e`` against their times, its standard error
    and the share of the block means' variance the line explains."""
    bt = np.array([b.mean() for b in np.array_split(t, blocks)])
    be = np.array([b.mean() for b in np.array_split(e, blocks)])
    slope, icpt = np.polyfit(bt, be, 1)
    resid = float(np.sum((be - (slope * bt + icpt)) ** 2))
    sxx = float(np.sum((bt - bt.mean()) ** 2))
    syy = float(np.sum((be - be.mean()) ** 2))
    se = math.sqrt(resid / (blocks - 2) / sxx) if sxx > 0 else math.inf
    share = 1.0 - resid / syy if syy > 0 else 1.0
    return float(slope), se, max(0.0, share)


def _detrended(x: np.ndarray) -> np.ndarray:
    """``x`` less its least-squares line against the sample index."""
    i = np.arange(x.size, dtype=float)
    i -= i.mean()
    r = x - x.mean()
    return r - (float(np.dot(i, r)) / float(np.dot(i, i))) * i


def _rice_cycles(r: np.ndarray, samples: int, resolution: float) -> float:
    """Cycles of ``r`` (detrended, one value a sample) over ``samples`` samples: Rice's
    rms frequency ``std(increments) / (2 pi std)``; ``inf`` when ``r`` does not exceed
    ``resolution`` (the round-off of the energies: nothing oscillates)."""
    spread = float(r.std())
    if not spread > resolution:
        return math.inf
    return samples * float(np.diff(r).std()) / (2.0 * math.pi * spread)


def _swings(r: np.ndarray, resolution: float) -> float:
    """Cycles of ``r`` (detrended) counted as its swings from below ``-std/2`` to above
    ``std/2`` and back, halved: an oscillation's periods, whatever its speed, not
    counting noise far smaller than ``r``; ``inf`` when ``r`` does not exceed
    ``resolution``."""
    spread = float(r.std())
    if not spread > resolution:
        return math.inf
    side = np.sign(r) * (np.abs(r) > 0.5 * spread)
    side = side[side != 0]
    return 0.5 * float(np.count_nonzero(np.diff(side)))


def _cycles(e: np.ndarray, swings: float, resolution: float) -> float:
    """Cycles over the run of the error's fluctuation about its trend: the larger of
    Rice's count on ``e`` smoothed by three passes of a moving average of
    ``n / BLOCKS`` samples (not decimated, so that a fast oscillation is damped, not
    aliased into a slow one) and ``swings``, those of the raw residual (``_swings``: a
    fast oscillation, which the smoothing removes; ``inf`` when the residual does not
    exceed the round-off ``resolution``)."""
    n = e.size
    b = max(1, n // BLOCKS)
    s = e
    for _ in range(3):
        c = np.concatenate(([0.0], np.cumsum(s)))
        s = (c[b:] - c[:-b]) / b
    smooth = _rice_cycles(_detrended(s), n - 1, resolution)  # inf: nothing slow left
    return swings if math.isinf(smooth) else max(smooth, swings)


def _window_variance(e: np.ndarray, widths) -> np.ndarray:
    """The variance of ``e`` within a window of ``m`` samples, averaged over all the
    windows (every start), for each ``m`` in ``widths``."""
    x = e - e.mean()
    scale = float(np.abs(x).max()) or 1.0
    x = x / scale
    n = x.size
    c1 = np.concatenate(([0.0], np.cumsum(x)))
    # prefix sums of the windows' sums of squares: sum_s (c2[s + m] - c2[s]) at once
    c2 = np.concatenate(([0.0], np.cumsum(x * x)))
    p2 = np.concatenate(([0.0], np.cumsum(c2)))
    out = np.empty(len(widths))
    for j, m in enumerate(widths):
        k = n - m + 1  # windows
        squares = (p2[n + 1] - p2[m]) - p2[k]
        sums = c1[m:] - c1[:-m]
        out[j] = max((squares / m - float(np.dot(sums, sums)) / (m * m)) / k, 0.0)
    return out * scale * scale


def _stops_growing(V: np.ndarray) -> tuple[bool, float]:
    """Whether a windowed variance ``V[k]`` (windows of ``W / 2^(k/2)``) stops growing
    at the top: flat over two octaves, or over one after a smooth rise (an oscillation
    of few periods); and the share of ``V[0]`` reached at the start of the flat part."""
    if V[0] <= FLAT * V[4]:
        return True, min(1.0, float(V[4] / V[0]))
    if V.size > 8 and V[0] <= FLAT_TOP * V[2] and V[4] >= SMOOTH * V[8]:
        return True, min(1.0, float(V[2] / V[0]))
    return False, 0.0


def energy_drift(traj=None, *, t=None, energy=None, relative: bool = True) -> EnergyDrift:
    """Tell a bounded energy error from a linear drift and from a random walk.

    Parameters
    ----------
    traj
        A :class:`~liebody.Trajectory` of one body (its ``t`` and ``energy``), or of a
        coupled system (:class:`liebody.CoupledBodies`: its total energy), or
        ``None`` and ``t``, ``energy`` given: sample times (increasing; resampled to a
        uniform grid if they are not uniform) and energies.
    relative
        Divide by ``|E(0)|`` (when non-zero).

    Returns
    -------
    EnergyDrift
        The verdict, the growth exponent, a confidence measure and the fitted linear
        rate. Needs at least 64 samples (``ValueError`` for fewer). A run over which
        the error's fluctuation about its trend completes fewer than 3 cycles is
        ``"undetermined"`` (over less than its period a slow oscillation cannot be told
        from a drift). A bounded oscillation is bounded from 3 periods on; a drift
        under it is found once the drift exceeds what the oscillation's own
        least-squares slope can show (see :class:`EnergyDrift`): a thousand periods
        of the error's oscillation or more find drifts of a hundredth of its
        amplitude over the run.
    """
    if traj is not None:
        if t is not None or energy is not None:
            raise ValueError("give either traj or t and energy, not both")
        if getattr(traj, "n_bodies", None) and not getattr(traj, "coupled", False):
            raise ValueError("energy_drift takes one body's trajectory; index the "
                             "ensemble's bodies one at a time")
        t, energy = traj.t, traj.energy
    elif t is None or energy is None:
        raise ValueError("give a trajectory, or both t and energy")
    t = np.asarray(t, dtype=float)
    E = np.asarray(energy, dtype=float)
    if t.ndim != 1 or E.shape != t.shape:
        raise ValueError(f"t and energy must be 1-d of one length, got {t.shape} and "
                         f"{E.shape}")
    if t.size < 64:
        raise ValueError(f"energy_drift needs at least 64 samples, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(E))):
        raise ValueError("t and energy must be finite (a trajectory that failed: use its "
                         "samples before failed_at)")
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise ValueError("t must be strictly increasing")
    if np.ptp(dt) > 1e-6 * dt.mean():
        grid = np.linspace(t[0], t[-1], t.size)
        E, t = np.interp(grid, t, E), grid
    e = E - E[0]
    norm = abs(E[0]) if relative and E[0] != 0.0 else 1.0
    e = e / norm
    n = t.size
    span = float(t[-1] - t[0])
    max_err = float(np.abs(e).max())
    resolution = 64.0 * np.finfo(float).eps * float(np.abs(E).max()) / norm
    # rate, its standard error and the share of variance it explains: 20 block means
    rate, rate_se, trend_share = _block_fit(t - t[0], e, 20)
    resid = _detrended(e)
    swings = _swings(resid, resolution)
    cycles = _cycles(e, swings, resolution)
    # the change over the run a least-squares line shows for a bounded oscillation of
    # the error's size about its trend, A sin(2 pi N t / T + phi): at most
    # (12 / (2 pi N) + 24 / (2 pi N)^2) A; N the fewer of Rice's count and the swings
    periods = max(0.5, min(_rice_cycles(resid, n - 1, resolution), swings))
    leak = (math.sqrt(2.0) * float(resid.std())
            * (12.0 / (2.0 * math.pi * periods) + 24.0 / (2.0 * math.pi * periods) ** 2))
    trend_real = abs(rate) * span > DRIFT_LEAKAGE * leak

    def verdict(kind: str, exponent: float, confidence: float) -> EnergyDrift:
        if cycles < MIN_CYCLES:  # too short to tell, whatever the fit says
            kind, confidence = UNDETERMINED, 0.0
        return EnergyDrift(kind, exponent, confidence, rate, rate_se, max_err, cycles)

    # windowed variance V(w), windows of W = n/2 samples down to T/2^11 by half octaves:
    # a bounded error's stops growing (a sinusoid's: A^2/2 (1 - sinc^2(w / P))), a
    # random walk's grows like w, a drift's like w^2
    W = n // 2
    half_octaves = 2 * min(10, int(math.log2(W / 2)))
    widths = [max(1, round(W / 2.0 ** (k / 2))) for k in range(half_octaves + 1)]
    V = _window_variance(e, widths)
    if max_err == 0.0 or V[0] == 0.0:
        return EnergyDrift("bounded", 0.0, 1.0, rate, rate_se, max_err, cycles)
    exponent = (min(1.0, max(0.0, 0.25 * math.log2(V[0] / V[4]))) if V[4] > 0 else 1.0)
    bounded, share = _stops_growing(V)
    if bounded:
        k, confidence = 0, share
    else:
        # V(w) = c0 + c1 w + c2 w^2, c >= 0 (relative residuals): a bounded part, a
        # random walk and a drift; the verdict is the part that dominates at w = W
        from scipy.optimize import nnls

        ok = V > 0
        x = np.asarray(widths, dtype=float) / widths[0]
        A = np.stack([np.ones_like(x), x, x * x], axis=1)[ok] / V[ok, None]
        parts, _ = nnls(A, np.ones(int(ok.sum())))
        k = int(np.argmax(parts))
        if k == 2 and not (abs(rate) > DRIFT_SIGNIFICANCE * rate_se and trend_real):
            k = int(np.argmax(parts[:2]))  # no real linear trend: a slow oscillation
            parts = parts[:2]
        confidence = float(parts[k] / (float(parts.sum()) or 1.0))
    # a drift under a larger oscillation does not show in V(w), but the 20 block means
    # of the trend's fit average the oscillation out. A bounded verdict with such a
    # trend is a drift; so is a random walk's, when the error about the trend stops
    # growing (a random walk about its own trend does not)
    if (k != 2 and abs(rate) > DRIFT_OVERRULE * rate_se and trend_real
            and (k == 0 or _stops_growing(_window_variance(resid, widths))[0])):
        k, confidence = 2, trend_share
    return verdict(KINDS[k], exponent, confidence)


# ----------------------------------------------------------------------------------------
# invariants
# ----------------------------------------------------------------------------------------


def _worst(dev: np.ndarray, t: np.ndarray) -> tuple[float, float, str]:
    """Largest deviation, its time, and the body it belongs to (ensembles)."""
    flat = np.nan_to_num(dev, nan=-np.inf)
    k = np.unravel_index(int(np.argmax(flat)), dev.shape)
    where = f" of body {k[0]}" if dev.ndim == 2 else ""
    return float(dev[k]), float(t[k[-1]]), where


def _incomplete(traj) -> list[str]:
    """A failure line for a run that did not complete (one body, or bodies of an
    ensemble): its invariants are then checked on the samples before the failure."""
    status = np.asarray(traj.status)
    if status.ndim == 0:
        if str(status) == "complete":
            return []
        at = "" if traj.failed_at is None else f" at t = {float(traj.failed_at):.6g}"
        return [f"the run did not complete: {status}{at}"]
    bad = status != "complete"
    if not bad.any():
        return []
    i = int(np.argmax(bad))
    at = np.asarray(traj.failed_at, dtype=float)[i] if traj.failed_at is not None else np.nan
    when = f" at t = {at:.6g}" if np.isfinite(at) else ""
    return [f"{int(bad.sum())} of {bad.size} bodies did not complete (e.g. body {i}: "
            f"{status[i]}{when})"]


def assert_invariants(traj, *, qnorm: float | None = 1e-10, casimir="auto",
                      spatial_L="auto", energy="auto") -> None:
    """Assert that a trajectory keeps the invariants of its scene.

    Each check compares the largest deviation over the samples with a tolerance;
    ``None`` skips a check. A failure raises one ``AssertionError`` listing every
    broken invariant, by how much, at what time (and for which body of an ensemble). A
    run that did not complete (``status`` other than ``"complete"``: a blow-up, a failed
    solve, an interrupt) fails too; its samples before the failure are checked.

    Parameters
    ----------
    traj
        A :class:`~liebody.Trajectory` (one body or an ensemble), e.g. from
        :func:`liebody.integrate` or :func:`run_step`.
    qnorm
        Bound on ``| |q| - 1 |``.
    casimir
        Bound on the relative change of ``|L|``. ``"auto"``: ``1e-10`` where the scene
        keeps ``|L|`` (no torque: a free or an internally damped body), else skipped.
    spatial_L
        Bound on the change of the spatial angular momentum ``R(q) L`` relative to
        ``|L(0)|``. ``"auto"``: all three components (``1e-10``) for a torque-free,
        undamped scene; the vertical component for a :class:`~liebody.HeavyTop`
        (gravity exerts no torque about the vertical); else skipped.
    energy
        A number: bound on the relative energy error ``|E - E(0)| / |E(0)|``.
        ``"bounded"``: :func:`energy_drift` must find the error bounded or a random
        walk (a drift fails, and so does a run too short to tell, ``"undetermined"``).
        ``"auto"``: ``"bounded"`` for conservative scenes, skipped for the others. A
        run that did not complete and kept fewer than the 64 samples the verdict needs
        fails on its failure alone.
    """
    from liebody.scenes import HeavyTop

    qnorm = None if qnorm is None else _positive("qnorm", qnorm)
    casimir = casimir if casimir is None or casimir == "auto" else _positive("casimir", casimir)
    spatial_L = (spatial_L if spatial_L is None or spatial_L == "auto"
                 else _positive("spatial_L", spatial_L))
    if not (energy is None or (isinstance(energy, str) and energy in ("auto", "bounded"))):
        energy = _positive("energy", energy)
    caps = traj.scene.capabilities
    t = np.asarray(traj.t)
    q, L = np.asarray(traj.q), np.asarray(traj.L)
    if len(t) == 0:
        raise ValueError("the trajectory has no samples")
    fails = _incomplete(traj)

    if qnorm is not None:
        dev = np.abs(np.linalg.norm(q, axis=-1) - 1.0)
        worst, when, who = _worst(dev, t)
        if not worst <= qnorm:
            fails.append(f"| |q| - 1 | reached {worst:.3g} at t = {when:.6g}{who} "
                         f"(tolerance {qnorm:.3g})")

    keeps_L = not caps.torque
    if casimir == "auto":
        casimir = 1e-10 if keeps_L else None
    if casimir is not None:
        norm = np.linalg.norm(L, axis=-1)
        dev = np.abs(norm - norm[..., :1]) / np.where(norm[..., :1] > 0, norm[..., :1], 1.0)
        worst, when, who = _worst(dev, t)
        if not worst <= casimir:
            fails.append(f"|L| changed by {worst:.3g} (relative) at t = {when:.6g}{who} "
                         f"(tolerance {casimir:.3g})")

    components = None
    if spatial_L == "auto":
        if caps.free:
            components, spatial_L = [0, 1, 2], 1e-10
        elif isinstance(traj.scene, HeavyTop):
            components, spatial_L = [2], 1e-10
        else:
            spatial_L = None
    elif spatial_L is not None:
        components = [0, 1, 2]
    if spatial_L is not None:
        Ls = np.asarray(traj.L_space)[..., components]
        scale = np.linalg.norm(L[..., :1, :], axis=-1)
        dev = np.abs(Ls - Ls[..., :1, :]).max(axis=-1) / np.where(scale > 0, scale, 1.0)
        worst, when, who = _worst(dev, t)
        if not worst <= spatial_L:
            name = "L_space" if len(components) == 3 else "the vertical L_space_z"
            fails.append(f"{name} changed by {worst:.3g} (relative to |L(0)|) at "
                         f"t = {when:.6g}{who} (tolerance {spatial_L:.3g})")

    if energy == "auto":
        energy = "bounded" if caps.conservative and not caps.dissipative else None
    if energy is not None:
        E = np.asarray(traj.energy)
        if energy == "bounded":
            status = np.asarray(traj.status).reshape(-1)
            for b, Eb in enumerate(E.reshape(-1, E.shape[-1])):
                tb = t
                if not np.isfinite(Eb).all():  # a failed body (reported above): check its
                    n = int(np.argmin(np.isfinite(Eb)))  # samples before the failure
                    Eb, tb = Eb[:n], t[:n]
                if Eb.size < 64:
                    if status[b if status.size > 1 else 0] != "complete":
                        continue  # the failure, reported above, is the verdict
                    raise ValueError("energy='bounded' needs at least 64 samples; give a "
                                     "tolerance instead")
                verdict = energy_drift(t=tb, energy=Eb)
                who = f" of body {b}" if E.ndim == 2 else ""
                if verdict.kind == "drift":
                    fails.append(f"the energy{who} drifts: {verdict}")
                elif verdict.kind == UNDETERMINED:
                    fails.append(f"the energy{who} could not be shown bounded: {verdict}; "
                                 f"or give energy a tolerance")
        else:
            tol = _positive("energy", energy)
            E0 = E[..., :1]
            dev = np.abs(E - E0) / np.where(E0 != 0, np.abs(E0), 1.0)
            worst, when, who = _worst(dev, t)
            if not worst <= tol:
                fails.append(f"the energy changed by {worst:.3g} (relative) at "
                             f"t = {when:.6g}{who} (tolerance {tol:.3g})")
    if fails:
        raise AssertionError("invariants not kept:\n  " + "\n  ".join(fails))
