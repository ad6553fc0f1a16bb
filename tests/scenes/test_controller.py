"""Controls and the Stepper: closed loops, agreement with integrate(), the state set
between steps, ensembles and bad input.

The reference for a :class:`liebody.Stepper` is :func:`liebody.integrate`. The contract
(``Stepper``'s notes): ``k`` calls ``step(n)`` give the states that
``integrate(..., steps=k * n, save_every=n)`` saves, bit for bit, for every stepping
method; the exact flow agrees to round-off. Two things of ``integrate()`` matter when
a run is replayed piece by piece: it renormalises ``q0`` (``q0 / |q0|``, which changes
the last bits of a quaternion that has drifted by an ulp) and plans the method for
``L0`` (the axis ordering of the splittings depends on the orbit of ``L0``), and its
clock starts at 0. A stepper whose state is set (``stepper.state = ...``) does the
same: its ``q`` is renormalised by the same arithmetic and its method re-planned for
the new ``L``; so a stepper re-entered at every control period is what a chain of
``integrate()`` calls is, bit for bit.

The controller is the quaternion feedback of Wie, Weiss & Arapostathis (1989),
``u = -Kp sign(q_e,w) vec(q_e) - Kd omega`` with ``q_e = q_target* q``, clipped at an
actuator limit, on a spacecraft with principal moments ``(1200, 1100, 800)`` kg m^2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

import liebody
from liebody import quaternion as Q
from support import stepper_states

EPS = np.finfo(float).eps

# ----------------------------------------------------------------------- the spacecraft

I_CRAFT = np.array([1200.0, 1100.0, 800.0])


@njit
def _commanded(t, q, L, u):
    """Reaction-wheel torques commanded directly (body frame)."""
    return u.copy()


def _craft(free_flow: str = "auto") -> liebody.ControlledBody:
    return liebody.ControlledBody(liebody.RigidBody(I_CRAFT), _commanded, controls=3,
                                  orientation_only=True, free_flow=free_flow)


class PD:
    """Quaternion feedback with gains set per axis from a natural frequency and damping:
    ``Kp = 2 I wn^2``, ``Kd = 2 zeta I wn`` give every axis of the linearised loop
    ``e'' + 2 zeta wn e' + wn^2 e = 0`` (``e = vec(q_e)``, ``e' = omega / 2``)."""

    def __init__(self, wn: float, zeta: float, u_max: float, q_target) -> None:
        self.wn, self.zeta, self.u_max = wn, zeta, u_max
        self.kp = 2.0 * I_CRAFT * wn**2
        self.kd = 2.0 * zeta * I_CRAFT * wn
        self.target_conj = Q.conjugate(q_target)

    def error(self, q) -> np.ndarray:
        """``q_e = q_target* q``, sign chosen so that ``w >= 0`` (the short way round)."""
        e = Q.multiply(self.target_conj, q)
        return e if e[0] >= 0.0 else -e

    def angle(self, q) -> float:
        e = self.error(q)
        return 2.0 * math.atan2(float(np.linalg.norm(e[1:])), float(e[0]))

    def __call__(self, q, omega) -> np.ndarray:
        u = -self.kp * self.error(q)[1:] - self.kd * omega
        return np.clip(u, -self.u_max, self.u_max)

    def linear_period_map(self, period: float) -> np.ndarray:
        """The linearised closed loop over one period with the torque held: per axis,
        ``(e, omega)`` -> ``M (e, omega)`` from ``e' = omega / 2``, ``omega' = u / I`` (the
        same matrix for every axis, since the gains scale with ``I``)."""
        T, wn, z = period, self.wn, self.zeta
        a = 2.0 * wn**2  # Kp / I
        b = 2.0 * z * wn  # Kd / I
        return np.array([[1.0 - T * T * a / 4.0, T / 2.0 - T * T * b / 4.0],
                         [-T * a, 1.0 - T * b]])


def _fly(stepper, pd: PD, periods: int, substeps: int = 1, reenter: bool = False):
    """The closed loop: the states after every period (as the stepper holds them) and the
    torque applied in each. ``reenter``: set the state back after every period, as a
    fresh ``integrate()`` call would take it."""
    q = np.empty((periods + 1, 4))
    L = np.empty((periods + 1, 3))
    u = np.empty((periods, 3))
    q[0], L[0] = stepper.q, stepper.L
    for k in range(periods):
        u[k] = pd(stepper.q, stepper.omega)
        stepper.u = u[k]
        stepper.step(substeps)
        q[k + 1], L[k + 1] = stepper.q, stepper.L
        if reenter:
            stepper.state = (q[k + 1], L[k + 1])
    return q, L, u


PERIOD = 0.1
Q_TARGET = Q.exp([0.2, -0.1, 0.4])
Q0_CRAFT = Q.multiply(Q_TARGET, Q.exp(np.deg2rad([20.0, -15.0, 10.0])))  # 27 deg off
L0_CRAFT = I_CRAFT * np.deg2rad([1.0, -0.5, 0.8])  # tumbling at 1.4 deg/s


# ----------------------------------------------------------------------- closed loops


def test_closed_loop_converges_at_the_rate_its_gains_set():
    """2000 periods of the feedback loop (200 s): the torques saturate at first, then the
    loop is linear, and from there the states follow the linearised closed loop that the
    gains define, period by period; the error ends far below where it started."""
    pd = PD(wn=0.1, zeta=1.0, u_max=1.0, q_target=Q_TARGET)
    periods = 2000
    s = liebody.Stepper(_craft(), q0=Q0_CRAFT, L0=L0_CRAFT, dt=PERIOD)
    q, L, u = _fly(s, pd, periods)
    omega = L / I_CRAFT
    angle = np.array([pd.angle(qk) for qk in q])

    clipped = np.flatnonzero(np.abs(u).max(axis=1) >= pd.u_max)
    assert clipped.size, "the test is meant to start in saturation"
    k1 = clipped[-1] + 1  # the linear loop from here on
    assert (periods - k1) * PERIOD * pd.wn > 8.0, f"still saturated at t = {k1 * PERIOD}"

    # the linearised loop, from where the terms it neglects (second order in e and
    # omega / wn) are small, against the simulated states later on: they agree to those
    # terms, so a torque applied late, early or not at all would show at once (O(wn T))
    k0 = k1 + int(np.argmax(angle[k1:] < np.deg2rad(0.05)))
    e = np.array([pd.error(qk)[1:] for qk in q])
    x0 = np.stack([e[k0], omega[k0]])  # (2, 3): (e, omega) per axis
    scale = np.stack([np.ones(3), np.full(3, 0.5 / pd.wn)])  # omega / (2 wn) ~ e
    M = pd.linear_period_map(PERIOD)
    size0 = float(np.abs(x0 * scale).max())
    nonlinear = max(float(np.abs(e[k0]).max()), float(np.abs(omega[k0]).max()) / pd.wn)
    for k in range(k0 + 100, periods + 1, 100):
        predicted = np.linalg.matrix_power(M, k - k0) @ x0
        simulated = np.stack([e[k], omega[k]])
        err = float(np.abs((simulated - predicted) * scale).max())
        assert err <= nonlinear * size0, (k, err, size0)
    # convergence, with the bound the gains set: the linear decay from k0
    predicted_end = float(np.abs(np.linalg.matrix_power(M, periods - k0) @ x0 * scale).max())
    assert predicted_end < 1e-2 * size0  # a meaningful horizon: several e-foldings
    assert float(np.abs(e[-1]).max()) <= 2.0 * predicted_end
    assert float(np.abs(omega[-1]).max()) * 0.5 / pd.wn <= 2.0 * predicted_end


def test_closed_loop_is_a_chain_of_integrate_calls_bit_for_bit():
    """A loop whose stepper is re-entered after every period (``stepper.state =
    stepper.state``: q renormalised, the splitting re-planned for L) is the chain of
    ``integrate(steps=n, save_every=n, controls=u_k)`` calls, each started from the
    last one's end, with the torques the controller applied: bit for bit. (The torque
    does not read t, so integrate()'s clock, restarted at 0 each call, does not matter.)"""
    pd = PD(wn=0.1, zeta=1.0, u_max=1.0, q_target=Q_TARGET)
    craft, periods, n = _craft(), 400, 2
    s = liebody.Stepper(craft, q0=Q0_CRAFT, L0=L0_CRAFT, dt=PERIOD / n)
    q, L, u = _fly(s, pd, periods, substeps=n, reenter=True)
    assert (np.abs(u) >= pd.u_max).any() and (np.abs(u) < pd.u_max).any()

    qr, Lr = np.empty_like(q), np.empty_like(L)
    qr[0], Lr[0] = q[0], L[0]
    q_in, L_in = Q0_CRAFT, L0_CRAFT
    plans = set()
    for k in range(periods):
        tr = liebody.integrate(craft, q0=q_in, L0=L_in, dt=PERIOD / n, steps=n, save_every=n,
                               controls=u[k])
        assert len(tr) == 2 and tr.t[-1] == n * (PERIOD / n)
        plans.add(str(tr.info))
        q_in, L_in = qr[k + 1], Lr[k + 1] = tr.q[-1], tr.L[-1]
    np.testing.assert_array_equal(qr, q)
    np.testing.assert_array_equal(Lr, L)
    assert len(plans) > 1, "the loop should pass through orbits with different plans"


def test_plain_closed_loop_replayed_period_by_period():
    """The loop as a controller runs it (the state never set): each period replayed by
    ``integrate()`` from the stepper's own state at the start of the period, with the
    exact free flow between the kicks (its plan does not depend on L). L never sees q
    (the torque is u, the free flow of L is q-free), so L agrees bit for bit; q differs
    by integrate()'s renormalisation of q0 only: the free flow and the kicks act on q by
    multiplication on the right, so q scales with 1/|q0|, to a few roundings."""
    pd = PD(wn=0.1, zeta=1.0, u_max=1.0, q_target=Q_TARGET)
    craft, periods, n = _craft(free_flow="exact"), 300, 3
    s = liebody.Stepper(craft, q0=Q0_CRAFT, L0=L0_CRAFT, dt=PERIOD / n)
    q, L, u = _fly(s, pd, periods, substeps=n)
    drift = np.abs(np.linalg.norm(q, axis=1) - 1.0)
    assert drift.max() > 0.0  # the renormalisation is exercised
    for k in range(periods):
        tr = liebody.integrate(craft, q0=q[k], L0=L[k], dt=PERIOD / n, steps=n, save_every=n,
                               controls=u[k])
        np.testing.assert_array_equal(tr.L[-1], L[k + 1])
        np.testing.assert_allclose(tr.q[-1], q[k + 1], rtol=0, atol=drift[k] + 16 * EPS)


def test_constant_controls_replayed_by_one_integrate_call():
    """No controller: k calls step(n) with u held equal one integrate() with
    ``controls=u``, saving every n steps, bit for bit, and ``step()`` repeated equals
    ``save_every=1``."""
    u = np.array([0.3, -0.2, 0.1])
    craft = _craft()
    for n, k in ((7, 20), (1, 50)):
        tr = liebody.integrate(craft, q0=Q0_CRAFT, L0=L0_CRAFT, dt=PERIOD, steps=k * n,
                               save_every=n, controls=u)
        s = liebody.Stepper(craft, q0=Q0_CRAFT, L0=L0_CRAFT, dt=PERIOD, controls=u)
        qs, Ls, ts = stepper_states(s, k, n)
        np.testing.assert_array_equal(qs, tr.q)
        np.testing.assert_array_equal(Ls, tr.L)
        np.testing.assert_array_equal(ts, tr.t)
        assert s.steps == k * n
        # the controls acted (a free body keeps |L|)
        assert abs(np.linalg.norm(Ls[-1]) - np.linalg.norm(Ls[0])) > 1.0


# ----------------------------------------------------------------------- every method,
# every scene

MOMENTS = np.array([1.0, 2.0, 2.5])


@njit
def _drag(t, q, L):
    """Depends on the momentum and the time."""
    return -0.2 * L + np.array([0.0, 0.0, 0.05 * np.sin(t)])


@njit
def _tilt(t, q, L):
    """Depends on the orientation and the time: gravity on a mass 0.3 up the body z axis,
    ``Gamma x (0, 0, 0.3)`` with ``Gamma = R(q)^T e_z``, plus a beat about x."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    g1, g2 = 2.0 * (x * z - w * y), 2.0 * (y * z + w * x)
    return np.array([0.3 * g2 + 0.1 * np.cos(t), -0.3 * g1, 0.0])


@njit
def _controlled_q(t, q, L, u):
    """Controls, orientation and time (no momentum)."""
    return np.array([u[0] + 0.1 * q[1], u[1] - 0.1 * q[2], u[2] + 0.05 * np.sin(3.0 * t)])


@njit
def _controlled_L(t, q, L, u):
    """Two controls, the momentum and the time."""
    return np.array([u[0] - 0.1 * L[0], u[1] - 0.1 * L[1], 0.05 * np.cos(t) - 0.1 * L[2]])


def _scenes():
    """name -> (scene, initial state and controls, dt)."""
    body = liebody.RigidBody(MOMENTS)
    q0 = Q.exp([0.3, -0.2, 0.5])
    L0 = np.array([0.3, -1.0, 0.6])
    top = liebody.HeavyTop(liebody.RigidBody([5.0, 4.0, 1.0]), mass=1.0, cm=[0.05, 0.0, 0.5])
    return {
        "free": (liebody.FreeBody(body), {"q0": q0, "L0": L0}, 0.05),
        "top": (top, {"q0": Q.exp([0.4, 0.0, 0.0]), "L0": [2.5, 0.8, 20.0]}, 2e-3),
        "torque(t,q,L)": (liebody.TorqueBody(body, _drag), {"q0": q0, "L0": L0}, 0.05),
        "torque(t,q)": (liebody.TorqueBody(body, _tilt, orientation_only=True),
                        {"q0": q0, "L0": L0}, 0.05),
        "damped": (liebody.DampedBody(body, 0.3), {"q0": q0, "L0": L0}, 0.05),
        "controlled(t,q,u)": (liebody.ControlledBody(body, _controlled_q, controls=3,
                                                     orientation_only=True),
                              {"q0": q0, "L0": L0, "controls": [0.2, -0.1, 0.3]}, 0.05),
        "controlled(t,q,L,u)": (liebody.ControlledBody(body, _controlled_L, controls=2),
                                {"q0": q0, "L0": L0, "controls": [0.2, -0.4]}, 0.05),
    }


SCENES = _scenes()
CASES = [(name, m.name) for name, (scene, _, _) in SCENES.items() for m in liebody.methods()
         if m.supports(scene)]


def _assert_same(method, got, ref, scale):
    """Bit for bit for a stepping method; to round-off for the exact flow, whose stepper
    composes one flow of ``n dt`` per call where integrate() evaluates each sample from
    the start: the elliptic functions are good to a few ulps per evaluation, and we allow
    16 ulps per composed evaluation."""
    q, L, t = got
    np.testing.assert_array_equal(t, ref.t)
    if liebody.methods()[method].sampled:
        tol = 16 * EPS * (len(t) - 1)
        np.testing.assert_allclose(q, ref.q, rtol=0, atol=tol)
        np.testing.assert_allclose(L, ref.L, rtol=0, atol=tol * scale)
    else:
        np.testing.assert_array_equal(q, ref.q)
        np.testing.assert_array_equal(L, ref.L)


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")  # baselines drift
@pytest.mark.parametrize(("scene", "method"), CASES)
def test_stepper_equals_integrate(scene, method):
    """k calls step(n) are integrate(steps=k n, save_every=n); step() repeated is
    save_every=1 (the one-call fast path)."""
    sc, kw, dt = SCENES[scene]
    scale = float(np.linalg.norm(kw["L0"]))
    for calls, n in ((4, 3), (6, 1)):
        ref = liebody.integrate(sc, dt=dt, steps=calls * n, save_every=n, method=method, **kw)
        s = liebody.Stepper(sc, dt=dt, method=method, **kw)
        _assert_same(method, stepper_states(s, calls, n), ref, scale)
        assert s.steps == calls * n


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")
@pytest.mark.parametrize(("scene", "method"), CASES)
def test_a_stepper_set_to_a_state_equals_integrate_from_it(scene, method):
    """After some steps, set q, L, t = 0 (and u): the stepper then runs as integrate()
    started from that state, bit for bit: q is renormalised by the same arithmetic, the
    method is re-planned for the new L, and the clock the torque sees restarts at 0."""
    sc, kw, dt = SCENES[scene]
    s = liebody.Stepper(sc, dt=dt, method=method, **kw)
    s.step(5)
    s.step()
    q1 = Q.exp([-0.7, 0.4, 0.1]) * (1.0 + 3e-11)  # within integrate()'s unit tolerance
    L1 = np.asarray(kw["L0"], dtype=float)[[2, 0, 1]] * np.array([1.3, -0.8, 1.1])
    new = {"q0": q1, "L0": L1}
    s.q, s.L, s.t = q1, L1, 0.0
    if scene == "top":  # set omega instead: L = I omega by the same arithmetic
        new = {"q0": q1, "omega0": L1 / sc.moments}
        s.omega = new["omega0"]
    if "controls" in kw:
        new["controls"] = -2.0 * np.asarray(kw["controls"])
        s.u = new["controls"]
    assert s.t == 0.0 and s.steps == 6
    ref = liebody.integrate(sc, dt=dt, steps=12, save_every=4, method=method, **new)
    _assert_same(method, stepper_states(s, 3, 4), ref, float(np.linalg.norm(L1)))


def test_setting_L_replans_and_setting_q_does_not():
    """The axis ordering of splitting2 and the modified moments of dmv4 are made for the
    orbit of L: setting L re-plans at the next step (as integrate() from that L plans),
    setting q keeps the plan."""
    free = liebody.FreeBody(liebody.RigidBody(MOMENTS))
    L0, L1 = np.array([1.0, 0.1, 0.1]), np.array([0.1, 0.1, 1.0])
    for method in ("splitting2", "dmv4"):
        s = liebody.Stepper(free, L0=L0, dt=0.1, method=method)
        before = dict(s.info)
        s.step()
        s.q = Q.exp([0.1, 0.2, 0.3])
        s.step()
        assert s.info == before
        s.L = L1
        s.step()
        after = liebody.integrate(free, L0=L1, dt=0.1, steps=1, method=method).info
        assert s.info == after and after != before, (method, before, after)


def _choices(info: dict) -> dict:
    return {k: v for k, v in info.items() if k != "energy_error_constant"}


def test_setting_q_alone_continues_with_the_same_plan_and_clock():
    """On a free body the orbit, and so the plan, survive a change of q: a stepper whose q
    is set mid-run equals integrate() from that q and its current L, bit for bit."""
    free = liebody.FreeBody(liebody.RigidBody(MOMENTS))
    L0 = np.array([0.3, -1.0, 0.6])
    s = liebody.Stepper(free, L0=L0, dt=0.05, method="splitting4")
    s.step(17)
    q1, L_now = Q.exp([1.0, -0.5, 0.2]), s.L
    s.q = q1
    ref = liebody.integrate(free, q0=q1, L0=L_now, dt=0.05, steps=30, save_every=10,
                            method="splitting4")
    # the same base and ordering (the info's energy-error constant, a number computed
    # from L, differs in its last digits; the plan's stages do not depend on it)
    assert _choices(ref.info) == _choices(s.info)
    np.testing.assert_array_equal(stepper_states(s, 3, 10)[0], ref.q)
    assert s.t == (17 + 30) * 0.05


@njit
def _ramp(t, q, L):
    """A torque about the symmetry axis growing linearly in time: N3 = 0.2 t."""
    return np.array([0.0, 0.0, 0.2 * t])


@pytest.mark.parametrize("method", ["splitting2", "rk4"])
def test_setting_t_continues_the_clock_from_there(method):
    """A symmetric body spinning about its axis under N3 = c t: L3 obeys L3' = c t exactly
    (Euler's equation, I1 = I2), so L3(t) = L3(t0) + c (t^2 - t0^2) / 2. The kicks of the
    splitting are the trapezoidal rule of the torque and RK4 is Simpson's: both exact for
    a linear torque. Set t = t0 mid-run: L3 follows the formula from t0, not from 0."""
    c = 0.2
    scene = liebody.TorqueBody(liebody.RigidBody([2.0, 2.0, 1.0]), _ramp, orientation_only=True)
    s = liebody.Stepper(scene, L0=[0.0, 0.0, 1.5], dt=0.125, method=method)
    s.step(8)
    L3 = s.L[2]
    np.testing.assert_allclose(L3, 1.5 + c * 1.0**2 / 2, rtol=1e-14)
    t0 = 37.5
    s.t = t0
    s.step(24)
    t1 = t0 + 24 * 0.125
    assert s.t == t1
    expected = L3 + c * (t1**2 - t0**2) / 2
    np.testing.assert_allclose(s.L[2], expected, rtol=1e-13)
    assert abs(s.L[2] - (L3 + c * 3.0**2 / 2)) > 1.0  # a restarted clock would be far off
    np.testing.assert_array_equal(s.L[:2], [0.0, 0.0])


@pytest.mark.parametrize("method", ["splitting2", "rattle"])
def test_integrate_starts_its_clock_at_t0(method):
    """``integrate(t0=...)``: samples at ``t0 + k dt``, and the torque sees that clock, so
    L3 follows ``L3(t0) + c (t^2 - t0^2) / 2`` (the closed form above) from ``t0``."""
    c, t0, dt = 0.2, 7.5, 0.0625
    scene = liebody.TorqueBody(liebody.RigidBody([2.0, 2.0, 1.0]), _ramp, orientation_only=True)
    tr = liebody.integrate(scene, L0=[0.0, 0.0, 1.5], dt=dt, steps=48, method=method, t0=t0)
    np.testing.assert_array_equal(tr.t, t0 + dt * np.arange(49))
    np.testing.assert_allclose(tr.L[:, 2], 1.5 + c * (tr.t**2 - t0**2) / 2, rtol=1e-13)


def test_chained_integrate_calls_continue_the_clock():
    """Two runs, the second from the first one's end at its end time, equal one run to
    round-off: the clock ``t0 + k dt`` instead of ``k dt`` and the renormalised ``q0`` move
    the run no more than a perturbation of the state by an ulp does. (``no_squish``: a
    fixed axis ordering, so that the second run's plan, made for its own initial state,
    is the first one's.)"""
    scene = liebody.TorqueBody(liebody.RigidBody(MOMENTS), _ramp, orientation_only=True)
    L0, dt = np.array([0.3, -1.0, 0.6]), 0.01
    whole = liebody.integrate(scene, L0=L0, dt=dt, steps=600, method="no_squish")
    first = liebody.integrate(scene, L0=L0, dt=dt, steps=250, method="no_squish")
    second = liebody.integrate(scene, q0=first.q[-1], L0=first.L[-1], dt=dt, steps=350,
                               method="no_squish", t0=first.t[-1])
    np.testing.assert_allclose(second.t, whole.t[250:], rtol=1e-15, atol=0)
    nudged = liebody.integrate(scene, q0=first.q[-1], L0=first.L[-1] * (1 + 2.0**-52), dt=dt,
                               steps=350, method="no_squish", t0=first.t[-1])
    spread = max(np.max(np.abs(nudged.L - second.L)), np.max(np.abs(nudged.q - second.q)))
    assert 0 < spread < 1e-9  # how far an ulp of the state carries
    np.testing.assert_allclose(second.L, whole.L[250:], rtol=0, atol=10 * spread)
    np.testing.assert_allclose(second.q, whole.q[250:], rtol=0, atol=10 * spread)
    restart = liebody.integrate(scene, q0=first.q[-1], L0=first.L[-1], dt=dt, steps=350,
                                method="no_squish")  # the clock restarted at 0: far off
    assert np.max(np.abs(restart.L[-1] - whole.L[-1])) > 0.1


def test_the_exact_flow_is_the_same_from_any_t0():
    free = liebody.FreeBody(liebody.RigidBody(MOMENTS))
    a = liebody.integrate(free, L0=[0.3, -1.0, 0.6], dt=0.1, steps=50)
    b = liebody.integrate(free, L0=[0.3, -1.0, 0.6], dt=0.1, steps=50, t0=-7.25)
    np.testing.assert_array_equal(b.t, a.t - 7.25)
    np.testing.assert_array_equal(b.q, a.q)
    np.testing.assert_array_equal(b.L, a.L)


@pytest.mark.parametrize(("t0", "error"), [(np.nan, ValueError), (np.inf, ValueError),
                                            ("1", TypeError), ([1.0, 2.0], ValueError)])
def test_bad_t0_is_refused(t0, error):
    free = liebody.FreeBody(liebody.RigidBody(MOMENTS))
    with pytest.raises(error, match="t0"):
        liebody.integrate(free, L0=[0.3, -1.0, 0.6], dt=0.1, steps=5, t0=t0)


def test_t_reads_back_what_was_set():
    scene = liebody.FreeBody(liebody.RigidBody(MOMENTS))
    s = liebody.Stepper(scene, L0=[0.3, -1.0, 0.6], dt=0.1, method="splitting2")
    for t in (0.3, 1.7, 3.3, 12.9):
        s.t = t
        assert s.t == t, (t, s.t)


# ----------------------------------------------------------------------- ensembles

ENS_MOMENTS = np.array([[1200.0, 1100.0, 800.0],
                        [1000.0, 1000.0, 700.0],  # symmetric: another plan group
                        [900.0, 1300.0, 1100.0],
                        [1500.0, 1200.0, 900.0],
                        [800.0, 700.0, 600.0]])
ENS_N = len(ENS_MOMENTS)
ENS_RNG = np.random.default_rng(7)
ENS_Q0 = Q.random(ENS_N, rng=8)
ENS_L0 = ENS_RNG.normal(scale=20.0, size=(ENS_N, 3))
ENS_U = ENS_RNG.normal(scale=0.5, size=(ENS_N, 2))


def _ensemble(torque=_controlled_L, controls=2, n=ENS_N, moments=ENS_MOMENTS):
    bodies = liebody.RigidBody.batch(moments[:n])
    return (liebody.ControlledBody(bodies, torque, controls=controls),
            [liebody.ControlledBody(bodies[i], torque, controls=controls) for i in range(n)])


ENS_METHODS = [m.name for m in liebody.methods() if m.supports(_ensemble()[0])]


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")
@pytest.mark.parametrize("method", ENS_METHODS)
def test_ensemble_stepper_equals_one_body_steppers(method):
    """N bodies with their own inertia, state and controls in one stepper: body i is the
    one-body stepper of body i, bit for bit, through per-body and shared settings of u."""
    ens, singles = _ensemble()
    dt = 0.01
    s = liebody.Stepper(ens, q0=ENS_Q0, L0=ENS_L0, dt=dt, method=method, controls=ENS_U)
    one = [liebody.Stepper(sc, q0=ENS_Q0[i], L0=ENS_L0[i], dt=dt, method=method,
                           controls=ENS_U[i]) for i, sc in enumerate(singles)]
    assert s.n_bodies == ENS_N and s.u.shape == (ENS_N, 2)

    def check():
        np.testing.assert_array_equal(s.q, np.array([o.q for o in one]))
        np.testing.assert_array_equal(s.L, np.array([o.L for o in one]))
        assert all(o.t == s.t for o in one)

    def step(n):
        s.step(n)
        for o in one:
            o.step(n)

    step(3)
    check()
    u2 = -ENS_U[::-1] * 1.5  # per body
    s.u = u2
    for o, row in zip(one, u2, strict=True):
        o.u = row
    np.testing.assert_array_equal(s.u, u2)
    step(1)
    step(4)
    check()
    shared = np.array([0.7, -0.3])  # one row for every body
    s.u = shared
    for o in one:
        o.u = shared
    np.testing.assert_array_equal(s.u, np.tile(shared, (ENS_N, 1)))
    step(2)
    check()
    # and the ensemble stepper is integrate() of the ensemble with those controls held
    q1, L1 = Q.normalize(s.q), s.L  # (the baselines let |q| drift past q0's tolerance)
    ref = liebody.integrate(ens, q0=q1, L0=L1, dt=dt, steps=6, save_every=3,
                            method=method, controls=shared)
    s.state = (q1, L1)  # integrate() renormalises q0 and plans for L0: so does this
    s.t = 0.0
    got = stepper_states(s, 2, 3)
    np.testing.assert_array_equal(got[0], np.moveaxis(ref.q, 1, 0))
    np.testing.assert_array_equal(got[1], np.moveaxis(ref.L, 1, 0))


def test_free_ensemble_with_the_exact_flow():
    bodies = liebody.RigidBody.batch(ENS_MOMENTS)
    s = liebody.Stepper(liebody.FreeBody(bodies), q0=ENS_Q0, L0=ENS_L0, dt=0.02)
    assert s.method.name == "exact"
    one = [liebody.Stepper(liebody.FreeBody(bodies[i]), q0=ENS_Q0[i], L0=ENS_L0[i], dt=0.02)
           for i in range(ENS_N)]
    for _ in range(3):
        s.step(5)
        for o in one:
            o.step(5)
    np.testing.assert_array_equal(s.q, np.array([o.q for o in one]))
    np.testing.assert_array_equal(s.L, np.array([o.L for o in one]))


def test_threads_do_not_change_a_bit():
    """Enough bodies for two chunks on two threads: the same numbers as one thread."""
    n = 150
    moments = ENS_RNG.uniform(700.0, 1500.0, size=(n, 3))
    ens, singles = _ensemble(n=n, moments=moments)
    q0 = Q.random(n, rng=3)
    L0 = ENS_RNG.normal(scale=20.0, size=(n, 3))
    u = ENS_RNG.normal(size=(n, 2))
    a = liebody.Stepper(ens, q0=q0, L0=L0, dt=0.01, controls=u, threads=1)
    b = liebody.Stepper(ens, q0=q0, L0=L0, dt=0.01, controls=u, threads=2)
    for s in (a, b):
        s.step(20)
        s.u = -u
        s.step(20)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.L, b.L)
    i = 97
    o = liebody.Stepper(singles[i], q0=q0[i], L0=L0[i], dt=0.01, controls=u[i])
    o.step(20)
    o.u = -u[i]
    o.step(20)
    np.testing.assert_array_equal(b.q[i], o.q)


# ----------------------------------------------------------------------- bad input


def _controlled_stepper(**kw):
    return liebody.Stepper(_craft(), q0=Q0_CRAFT, L0=L0_CRAFT, dt=PERIOD, **kw)


@pytest.mark.parametrize(("value", "error", "match"), [
    ([1.0, 2.0], ValueError, r"{} must have shape \(\.\.\., 3\)"),
    ([[1.0, 2.0, 3.0]], ValueError, r"{} of shape \(1, 3\) .* one body"),
    (np.zeros((2, 3)), ValueError, r"{} of shape \(2, 3\)"),
    ([np.nan, 0.0, 0.0], ValueError, r"{} must be finite"),
    ([0.0, np.inf, 0.0], ValueError, r"{} must be finite"),
    ("abc", TypeError, r"{} must contain real numbers"),
    (None, TypeError, r"u must be the control inputs"),
])
def test_bad_controls_are_refused_and_change_nothing(value, error, match):
    """The setter names ``u``, the constructor ``controls``; nothing changes."""
    s = _controlled_stepper(controls=[0.1, 0.2, 0.3])
    twin = _controlled_stepper(controls=[0.1, 0.2, 0.3])
    with pytest.raises(error, match=match.format("u")):
        s.u = value
    np.testing.assert_array_equal(s.u, [0.1, 0.2, 0.3])
    s.step(3)
    twin.step(3)
    np.testing.assert_array_equal(s.q, twin.q)
    np.testing.assert_array_equal(s.L, twin.L)
    if value is not None:  # None is the default: zeros
        with pytest.raises(error, match=match.format("controls")):
            _controlled_stepper(controls=value)


def test_bad_controls_of_an_ensemble():
    ens, _ = _ensemble()
    s = liebody.Stepper(ens, q0=ENS_Q0, L0=ENS_L0, dt=0.01)
    np.testing.assert_array_equal(s.u, np.zeros((ENS_N, 2)))  # zeros when not given
    with pytest.raises(ValueError, match=rf"u of shape \(3, 2\) .* {ENS_N} bodies"):
        s.u = np.zeros((3, 2))
    bad = np.zeros((ENS_N, 2))
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="u must be finite"):
        s.u = bad
    np.testing.assert_array_equal(s.u, np.zeros((ENS_N, 2)))


def test_scenes_without_controls_refuse_them():
    free = liebody.FreeBody(liebody.RigidBody(MOMENTS))
    s = liebody.Stepper(free, L0=[0.3, -1.0, 0.6], dt=0.1)
    assert s.u is None
    with pytest.raises(ValueError, match=r"u: the scene FreeBody takes no control inputs"):
        s.u = [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match=r"controls: the scene FreeBody takes no control"):
        liebody.Stepper(free, L0=[0.3, -1.0, 0.6], dt=0.1, controls=[1.0])
    top = SCENES["top"]
    s = liebody.Stepper(top[0], dt=top[2], **top[1])
    with pytest.raises(ValueError, match="the scene HeavyTop takes no control inputs"):
        s.u = [0.0]


@pytest.mark.parametrize("n", [0, -1, 1.5, "2"])
def test_step_refuses_a_count_that_is_not_positive(n):
    s = _controlled_stepper()
    with pytest.raises(ValueError, match="n must be a positive integer"):
        s.step(n)
    assert s.steps == 0 and s.t == 0.0


def test_step_refuses_a_bool():
    s = _controlled_stepper()
    with pytest.raises(TypeError, match="got a bool"):
        s.step(True)


@njit
def _fragile(t, q, L, u):
    """Commanded torque u[0] about x; raises for u[0] > 1 ("overspeed") and returns NaN
    from t > u[1] on (a failing sensor model, say)."""
    if u[0] > 1.0:
        raise ValueError("wheel overspeed")
    if t > u[1]:
        return np.array([np.nan, 0.0, 0.0])
    return np.array([u[0], 0.0, 0.0])


def _snapshot(s):
    return s.q, s.L, s.t, s.steps


def _assert_unchanged(s, snap):
    q, L, t, steps = snap
    np.testing.assert_array_equal(s.q, q)
    np.testing.assert_array_equal(s.L, L)
    assert s.t == t and s.steps == steps


@pytest.mark.parametrize("method", ["splitting2", "rk4"])
def test_a_failing_torque_raises_and_leaves_the_stepper_as_it_was(method):
    """TorqueError (the torque's own error as the cause) from step() and from a step(n)
    that fails part-way; the stepper is as before the call, and goes on exactly as a twin
    that never failed."""
    scene = liebody.ControlledBody(liebody.RigidBody(I_CRAFT), _fragile, controls=2,
                                   orientation_only=True)
    kw = {"q0": Q0_CRAFT, "L0": L0_CRAFT, "dt": PERIOD, "method": method,
          "controls": [0.2, 1e9]}
    s, twin = liebody.Stepper(scene, **kw), liebody.Stepper(scene, **kw)
    for x in (s, twin):
        x.step(3)
        x.step()

    snap = _snapshot(s)
    s.u = [2.0, 1e9]
    with pytest.raises(liebody.TorqueError, match="wheel overspeed") as info:
        s.step()  # the one-call path
    assert isinstance(info.value.__cause__, ValueError) and info.value.step == 0
    _assert_unchanged(s, snap)
    with pytest.raises(liebody.TorqueError, match="wheel overspeed"):
        s.step(5)
    _assert_unchanged(s, snap)

    # NaN from t_fail on: the steps whose torque is evaluated only at t <= t_fail succeed
    # (every method here evaluates it at the step's ends and between them)
    t_fail = s.t + 6.5 * PERIOD
    s.u = [0.2, t_fail]
    with pytest.raises(liebody.TorqueError, match="non-finite") as info:
        s.step(10)
    assert info.value.step == 6
    _assert_unchanged(s, snap)

    s.u = [0.2, 1e9]  # and it goes on: one step right after the failed call, then more
    for x in (s, twin):
        x.step()
        x.step(10)
        x.step()
    np.testing.assert_array_equal(s.q, twin.q)
    np.testing.assert_array_equal(s.L, twin.L)
    assert s.t == twin.t and s.steps == twin.steps


def test_a_failing_torque_in_an_ensemble_marks_that_body():
    scene = liebody.ControlledBody(liebody.RigidBody.batch(ENS_MOMENTS[:3]), _fragile,
                                   controls=2)
    u = np.array([[0.2, 1e9], [0.2, 1e9], [0.2, 1e9]])
    s = liebody.Stepper(scene, q0=ENS_Q0[:3], L0=ENS_L0[:3], dt=0.01, controls=u)
    twin = liebody.Stepper(scene, q0=ENS_Q0[:3], L0=ENS_L0[:3], dt=0.01, controls=u)
    s.step(2)
    twin.step(2)
    before = s.L
    u[1, 0] = 5.0
    s.u = u
    with pytest.warns(RuntimeWarning, match=r"1 of 3 bodies failed"):
        s.step(3)
    np.testing.assert_array_equal(s.failed, [False, True, False])
    np.testing.assert_array_equal(s.L[1], before[1])
    twin.step(3)
    np.testing.assert_array_equal(s.L[[0, 2]], twin.L[[0, 2]])
    s.step(1)  # the failed body is skipped, quietly
    np.testing.assert_array_equal(s.L[1], before[1])
    s.L = s.L  # setting the state clears the marks
    assert not s.failed.any()


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")
@pytest.mark.parametrize("scene", ["free", "controlled"])
def test_a_blow_up_raises_integration_error_and_changes_nothing(scene):
    """Explicit Euler with a step far too large overflows: IntegrationError (not a
    TorqueError: the torque is finite at the last good state), from the one-step path
    and from step(n), with the stepper left as before the call."""
    if scene == "free":
        sc, kw = liebody.FreeBody(liebody.RigidBody(MOMENTS)), {"L0": [0.3, -1.0, 0.6]}
        dt = 5.0
    else:
        sc, kw = _craft(), {"L0": L0_CRAFT, "controls": [0.5, -0.5, 0.5]}
        dt = 2000.0
    s = liebody.Stepper(sc, dt=dt, method="euler", **kw)
    for _ in range(100_000):
        snap = _snapshot(s)
        try:
            s.step()
        except liebody.IntegrationError as exc:
            assert type(exc) is liebody.IntegrationError
            assert "non-finite" in str(exc) and exc.step == 0
            break
    else:
        pytest.fail("explicit Euler did not blow up")
    _assert_unchanged(s, snap)
    failed_at = snap[3]

    s = liebody.Stepper(sc, dt=dt, method="euler", **kw)
    snap = _snapshot(s)
    with pytest.raises(liebody.IntegrationError, match="non-finite") as info:
        s.step(2 * failed_at + 10)
    assert type(info.value) is liebody.IntegrationError and info.value.step == failed_at
    _assert_unchanged(s, snap)


@pytest.mark.parametrize(("attr", "value", "words"), [
    ("state", ([0.0, 1.0, 0.0, 0.0], [np.nan, 0.0, 0.0]), "L must be finite"),
    ("state", ([0.0, 1.0, 0.0, 0.0], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
     "L must be one state"),
    ("state", ([0.0, 2.0, 0.0, 0.0], [0.2, 0.1, 0.3]), "q must be a unit quaternion"),
    ("L", [np.nan, 0.0, 0.0], "L must be finite"),
    ("omega", [np.inf, 0.0, 0.0], "omega must be finite"),
])
def test_setting_a_bad_state_names_it_and_changes_nothing(attr, value, words):
    """Before: ``state = (q, bad L)`` set q and then failed, and the messages named the
    constructor's L0/omega0."""
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
    s = liebody.Stepper(scene, L0=[0.1, 1.0, 0.0], dt=0.01, method="splitting2")
    q, L = s.state
    with pytest.raises(ValueError, match=words):
        setattr(s, attr, value)
    np.testing.assert_array_equal(s.q, q)
    np.testing.assert_array_equal(s.L, L)


def test_empty_ensembles_are_refused_by_name():
    scene = liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5]))
    for kwargs, name in (({"L0": np.zeros((0, 3))}, "L0"),
                         ({"omega0": np.zeros((0, 3))}, "omega0"),
                         ({"q0": np.zeros((0, 4)), "L0": [1.0, 0.0, 0.0]}, "q0")):
        with pytest.raises(ValueError, match=f"{name} holds no body"):
            liebody.integrate(scene, dt=0.1, steps=10, method="splitting2", **kwargs)
        with pytest.raises(ValueError, match=f"{name} holds no body"):
            liebody.Stepper(scene, dt=0.1, method="splitting2", **kwargs)
    with pytest.raises(ValueError, match="at least one body"):
        liebody.RigidBody.batch(np.zeros((0, 3)))


def test_take_with_an_integer_gives_that_body_as_a_one_body_scene():
    """Before: ``take(1)`` failed with 'Cannot set flags on array scalars'."""
    body = liebody.RigidBody([1.0, 1.0, 0.5])
    tops = liebody.HeavyTop(body, mass=[1.0, 2.0], cm=[0.0, 0.0, 1.0])
    one = tops.take(1)
    assert one.batch_shape == () and one.mass == 2.0
    ref = liebody.HeavyTop(body, mass=2.0, cm=[0.0, 0.0, 1.0])
    a = liebody.integrate(one, L0=[0.1, 0.0, 3.0], dt=0.01, steps=50, method="splitting2")
    b = liebody.integrate(ref, L0=[0.1, 0.0, 3.0], dt=0.01, steps=50, method="splitting2")
    np.testing.assert_array_equal(a.q, b.q)
    damped = liebody.DampedBody(liebody.RigidBody([1.0, 2.0, 2.5]), [0.1, 0.2]).take(0)
    assert damped.batch_shape == ()
