"""What users would otherwise pick: scipy's ``solve_ivp`` and MuJoCo, on the same problems.

* scipy: ``solve_ivp`` (RK45, DOP853) on the 7-dimensional equations
  ``q' = q (0, omega) / 2``, ``L' = L x omega + tau(q)`` with ``omega = L / I``
  (body frame, scalar-first q), the right-hand side compiled with numba so that the
  comparison measures the solvers, not Python arithmetic. The quaternion is not
  renormalised: that is what the equations do.
* MuJoCo (optional, ``pip install -e '.[bench]'``): one body on a free joint (free
  bodies, gravity off) or a ball joint at the fixed point (the heavy top), integrators
  Euler (semi-implicit), RK4 and implicitfast. MuJoCo's quaternions are scalar-first
  like liebody's and its joint angular velocity is in the body frame, so states map
  one to one. MuJoCo refuses inertias that break the triangle inequality, so it runs
  only the physical problems. The heavy top's inertia is given about the fixed point
  (``J``); MuJoCo wants it about the centre of mass, ``J - M l^2`` on the transverse
  axes, which is negative for Simo and Wong's ``M = 20, l = 1``. Only ``M g l`` and
  ``J`` enter the equations of motion, so MuJoCo gets the same top with ``l = 0.1``
  and ``M = 200`` (``J_cm = (3, 3, 1)``): the same dynamics, a physical body.
  MuJoCo's warnings (a blow-up) are collected in :data:`MUJOCO_WARNINGS`, not written
  to ``MUJOCO_LOG.TXT`` in the working directory.
"""

from __future__ import annotations

import re
from collections import Counter

import numpy as np
from numba import njit

from bench.problems import Problem

# the one private kernel the benchmarks use: Gamma = R(q)^T e_z inside a numba RHS
from liebody._models.uniform_gravity import vertical_in_body

SCIPY_METHODS = ("RK45", "DOP853")
MUJOCO_INTEGRATORS = ("Euler", "RK4", "implicitfast")


@njit(cache=True)
def _rhs(t, y, inv_moments, c):  # pragma: no cover - compiled
    """(q, L)' for a body with torque Gamma x c, Gamma = R(q)^T e_z (c = 0: free body)."""
    w, x, yq, z = y[0], y[1], y[2], y[3]
    L0, L1, L2 = y[4], y[5], y[6]
    o0, o1, o2 = L0 * inv_moments[0], L1 * inv_moments[1], L2 * inv_moments[2]
    out = np.empty(7)
    out[0] = 0.5 * (-x * o0 - yq * o1 - z * o2)
    out[1] = 0.5 * (w * o0 + yq * o2 - z * o1)
    out[2] = 0.5 * (w * o1 + z * o0 - x * o2)
    out[3] = 0.5 * (w * o2 + x * o1 - yq * o0)
    g0, g1, g2 = vertical_in_body(w, x, yq, z)
    out[4] = L1 * o2 - L2 * o1 + g1 * c[2] - g2 * c[1]
    out[5] = L2 * o0 - L0 * o2 + g2 * c[0] - g0 * c[2]
    out[6] = L0 * o1 - L1 * o0 + g0 * c[1] - g1 * c[0]
    return out


def _weight_arm(problem: Problem) -> np.ndarray:
    """``c = M g cm`` of a heavy top (zero for a free body): the torque is ``Gamma x c``."""
    return np.zeros(3) if problem.free else np.asarray(problem.scene.weight_arm, dtype=float)


def contenders(problem: Problem, have_mujoco: bool | None = None) -> list[tuple[str, str]]:
    """``(source, name)`` of everything run on a problem: liebody's methods that support
    it, scipy's solvers, and MuJoCo's integrators where installed and the body physical."""
    if have_mujoco is None:
        have_mujoco = mujoco_available()
    jobs = [("liebody", m) for m in problem.methods()]
    jobs += [("scipy", m) for m in SCIPY_METHODS]
    if have_mujoco and problem.physical:
        jobs += [("MuJoCo", m) for m in MUJOCO_INTEGRATORS]
    return jobs


def label(source: str, name: str) -> str:
    """How a run is named in the files: ``rk4``, ``scipy DOP853``, ``MuJoCo RK4``."""
    return name if source == "liebody" else f"{source} {name}"


def scipy_solve(problem: Problem, t_end: float, method: str, rtol: float,
                t_eval: np.ndarray | None = None) -> dict:
    """Integrate with ``scipy.integrate.solve_ivp`` from 0 to ``t_end``.

    ``atol`` is ``rtol`` on the quaternion and ``rtol |L0|`` on ``L``. Returns the states
    at ``t_eval`` (dense output; the final state when ``None``), the number of steps
    and of right-hand-side evaluations.
    """
    from scipy.integrate import solve_ivp

    y0 = np.concatenate([problem.q0, problem.L0])
    scale = np.r_[np.ones(4), np.full(3, np.linalg.norm(problem.L0))]
    args = (1.0 / problem.moments, _weight_arm(problem))
    _rhs(0.0, y0, *args)  # compile (or load the cache) outside any timing
    sol = solve_ivp(_rhs, (0.0, t_end), y0, method=method, rtol=rtol, atol=rtol * scale,
                    args=args, t_eval=t_eval)
    if sol.status != 0:
        raise RuntimeError(f"solve_ivp {method} failed: {sol.message}")
    y = sol.y if t_eval is not None else sol.y[:, -1:]
    return {"t": sol.t if t_eval is not None else sol.t[-1:], "q": y[:4].T, "L": y[4:].T,
            "steps": int(sol.t.size - 1) if t_eval is None else None, "nfev": int(sol.nfev)}


# ------------------------------------------------------------------------------ MuJoCo


def mujoco_available() -> bool:
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


class WarningLog:
    """MuJoCo's warnings by message (the trailing ``Time = ...`` dropped), in memory.

    Installed as MuJoCo's warning handler by :class:`MujocoRun`, in place of the default
    that prints each warning and appends it to ``MUJOCO_LOG.TXT`` in the working
    directory. :meth:`take` returns the counts so far and starts afresh.
    """

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()

    def __call__(self, message: str) -> None:
        self.counts[re.sub(r"\s*Time = \S*\s*$", "", message.strip())] += 1

    def take(self) -> dict[str, int]:
        out = dict(self.counts)
        self.counts.clear()
        return out


#: the warnings of every MuJoCo run in this process (see :class:`WarningLog`)
MUJOCO_WARNINGS = WarningLog()


def _mujoco_xml(problem: Problem, integrator: str, h: float) -> str:
    I = [float(v) for v in problem.moments]
    if problem.free:
        joint, gravity = "<freejoint/>", "0 0 0"
        inertial = (f'<inertial pos="0 0 0" mass="1" '
                    f'diaginertia="{I[0]!r} {I[1]!r} {I[2]!r}"/>')
    else:
        scene = problem.scene
        cm = np.asarray(scene.cm, dtype=float)
        mgl = scene.mass * scene.g * np.linalg.norm(cm)
        if not (np.allclose(cm[:2], 0.0) and np.isclose(I[0], I[1])):
            raise ValueError("the MuJoCo heavy top is built for a Lagrange top")
        l_mj, g_mj = 0.1, float(scene.g)
        m_mj = mgl / (g_mj * l_mj)
        Icm = np.array(I) - m_mj * l_mj**2 * np.array([1.0, 1.0, 0.0])
        joint, gravity = '<joint type="ball" pos="0 0 0"/>', f"0 0 {-g_mj!r}"
        Icm = [float(v) for v in Icm]
        inertial = (f'<inertial pos="0 0 {l_mj!r}" mass="{float(m_mj)!r}" '
                    f'diaginertia="{Icm[0]!r} {Icm[1]!r} {Icm[2]!r}"/>')
    return (f'<mujoco><option timestep="{float(h)!r}" integrator="{integrator}" '
            f'gravity="{gravity}"><flag contact="disable" autoreset="disable"/></option>'
            f'<worldbody><body name="b">{joint}{inertial}</body></worldbody></mujoco>')


class MujocoRun:
    """A MuJoCo model of a problem with one integrator and time step, ready to run."""

    def __init__(self, problem: Problem, integrator: str, h: float) -> None:
        import mujoco

        # MuJoCo warns and, by default, silently resets the state when a run blows up;
        # here auto-reset is off (the blow-up shows as non-finite states, and `unstable`
        # says so) and the warnings go to MUJOCO_WARNINGS, not to MUJOCO_LOG.TXT.
        mujoco.set_mju_user_warning(MUJOCO_WARNINGS)
        self.mujoco = mujoco
        self.problem = problem
        self.model = mujoco.MjModel.from_xml_string(_mujoco_xml(problem, integrator, h))
        self.data = mujoco.MjData(self.model)
        self.h = h
        free = problem.free
        self._q = slice(3, 7) if free else slice(0, 4)
        self._w = slice(3, 6) if free else slice(0, 3)
        # the model's inertia about the joint, as MuJoCo sees it (checks the set-up)
        mujoco.mj_setConst(self.model, self.data)

    def reset(self) -> None:
        self.mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self._q] = self.problem.q0
        self.data.qvel[self._w] = self.problem.L0 / self.problem.moments

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, L): MuJoCo's scalar-first quaternion and body-frame L = J omega."""
        q = np.array(self.data.qpos[self._q])
        L = np.array(self.data.qvel[self._w]) * self.problem.moments
        return q, L

    @property
    def unstable(self) -> bool:
        """Whether MuJoCo flagged a non-finite or huge acceleration since the reset."""
        bad = self.mujoco.mjtWarning.mjWARN_BADQACC
        return bool(self.data.warning[bad].number > 0)

    def advance(self, n: int) -> None:
        self.mujoco.mj_step(self.model, self.data, nstep=int(n))

    def run(self, n_steps: int, n_saves: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Reset, then ``n_steps`` steps saving ``n_saves`` evenly spaced states."""
        self.reset()
        qs, Ls = np.empty((n_saves, 4)), np.empty((n_saves, 3))
        done = 0
        for k in range(n_saves):
            target = (k + 1) * n_steps // n_saves
            self.advance(target - done)
            done = target
            qs[k], Ls[k] = self.state()
        if self.unstable:  # from the first flagged step on, MuJoCo's state is meaningless
            first = np.argmax(~np.all(np.isfinite(qs), axis=1)) if not np.all(
                np.isfinite(qs)) else n_saves - 1
            qs[first:], Ls[first:] = np.nan, np.nan
        return qs, Ls
