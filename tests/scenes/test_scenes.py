"""Scenes declare capabilities; methods match them by capability, never by name.

New scenes are subclasses (of a concrete scene, or of :class:`liebody.Scene` itself),
and every method that can handle what they declare integrates them with no change
anywhere else. References: scipy's DOP853 at rtol 1e-13 on the equations of motion
written out here, and the energy of a conservative torque.
"""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from scipy.integrate import solve_ivp

import liebody
from liebody import quaternion as Q
from liebody.scenes import TorqueModel
from support import rotation_distance

N_GG = 0.7  # orbital rate of the gravity-gradient field


@njit
def _gravity_gradient(t, q, L):
    """3 n^2 c x (I c), c = R(q)^T e_x, for I = (1, 2, 3) (the field direction fixed)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    c1 = w * w + x * x - y * y - z * z
    c2 = 2.0 * (x * y - w * z)
    c3 = 2.0 * (x * z + w * y)
    k = 3.0 * 0.7 * 0.7
    return np.array([k * (c2 * 3.0 * c3 - c3 * 2.0 * c2), k * (c3 * 1.0 * c1 - c1 * 3.0 * c3),
                     k * (c1 * 2.0 * c2 - c2 * 1.0 * c1)])


class GravityGradientSatellite(liebody.TorqueBody):
    """A new scene in one place: a rigid satellite in a (frozen) gravity-gradient field.

    ``V = (3 n^2 / 2) c . I c`` with ``c`` the field direction in the body frame.
    """

    def __init__(self) -> None:
        super().__init__(liebody.RigidBody([1.0, 2.0, 3.0]), _gravity_gradient,
                         potential=self._potential, orientation_only=True)

    @staticmethod
    def _potential(q):
        c = Q.rotate_inverse(q, [1.0, 0.0, 0.0])
        return 1.5 * N_GG**2 * c @ (np.array([1.0, 2.0, 3.0]) * c)


def _reference(scene, q0, L0, t_end, torque):
    I = scene.body.moments

    def rhs(t, y):
        q, L = y[:4], y[4:]
        om = L / I
        dq = 0.5 * Q.multiply(q / np.linalg.norm(q), np.r_[0.0, om])
        return np.concatenate([dq, np.cross(L, om) + torque(t, q, L)])

    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate([q0, L0]), method="DOP853",
                    rtol=1e-13, atol=1e-13)
    return sol.y[:4, -1], sol.y[4:, -1]


def test_capabilities_are_declared_and_validated():
    body = liebody.RigidBody([1.0, 2.0, 2.5])
    assert liebody.FreeBody(body).capabilities.free
    top = liebody.HeavyTop(body, 1.0, [0, 0, 1])
    assert top.capabilities.torque == {"orientation"} and top.capabilities.conservative
    damped = liebody.DampedBody(body, 0.1).capabilities
    assert damped.dissipative and not damped.conservative and damped.describe() == "dissipation"
    tb = liebody.TorqueBody(body, _gravity_gradient)
    assert tb.capabilities.torque == {"time", "orientation", "momentum"}
    assert tb.capabilities.describe() == "torque(t, q, L)"
    with pytest.raises(ValueError, match="dependencies must be among"):
        liebody.Capabilities(torque={"temperature"})
    with pytest.raises(ValueError, match="not conservative"):
        liebody.Capabilities(dissipative=True)


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")  # euler's |q| grows
def test_a_subclassed_top_works_with_every_method_that_handles_tops():
    """``class MyTop(HeavyTop)`` is a heavy top to every method: same numbers, same methods."""

    class MyTop(liebody.HeavyTop):
        """A user's top: a subclass with a convenience constructor."""

        def __init__(self, spin_axis_length: float) -> None:
            super().__init__(liebody.RigidBody([5.0, 5.0, 1.0]), 20.0,
                             [0.0, 0.0, spin_axis_length], g=1.0)

    mine, base = MyTop(1.0), liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), 20.0,
                                              [0, 0, 1.0], g=1.0)
    able = [m.name for m in liebody.methods() if m.supports(base)]
    assert able == [m.name for m in liebody.methods() if m.supports(mine)]
    assert {"splitting2", "rattle", "splitting4", "rk4"} <= set(able)
    q0, w0 = Q.exp([0.05, 0.0, 0.0]), [0.0, 0.0, 50.0]
    for name in able:
        a = liebody.integrate(mine, q0=q0, omega0=w0, dt=1e-3, steps=200, method=name)
        b = liebody.integrate(base, q0=q0, omega0=w0, dt=1e-3, steps=200, method=name)
        np.testing.assert_array_equal(a.L, b.L)
        np.testing.assert_array_equal(a.q, b.q)
    assert "MyTop(" in repr(mine)


def test_a_subclass_named_freebody_keeps_its_torque():
    """The old name-based matching integrated a class called FreeBody with its torque ignored."""

    class FreeBody(liebody.TorqueBody):
        pass

    scene = FreeBody(liebody.RigidBody([1.0, 2.0, 3.0]), _gravity_gradient,
                     orientation_only=True)
    q0, L0 = Q.random(rng=8), np.array([0.4, -0.3, 0.9])
    qr, Lr = _reference(scene, q0, L0, 1.0, _gravity_gradient.py_func)
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=1e-3, steps=1000)
    assert np.abs(tr.L[-1] - Lr).max() < 1e-6 and rotation_distance(tr.q[-1], qr) < 1e-6
    with pytest.raises(ValueError, match="cannot integrate this FreeBody"):
        liebody.integrate(scene, q0=q0, L0=L0, dt=1e-3, steps=10, method="exact")


@pytest.mark.parametrize("name", ["splitting2", "no_squish", "rattle", "splitting4", "rk4",
                                  "rkmk4"])
def test_a_new_scene_integrates_with_every_capable_method(name):
    """The gravity-gradient satellite, defined in this file only, against DOP853 and its energy."""
    scene = GravityGradientSatellite()
    assert liebody.methods()[name].supports(scene)
    assert scene.capabilities.conservative and "momentum" not in scene.capabilities.torque
    q0, L0, t_end = Q.random(rng=9), np.array([0.5, -0.8, 1.1]), 2.0
    qr, Lr = _reference(scene, q0, L0, t_end, _gravity_gradient.py_func)
    order = liebody.methods()[name].order
    h = 1e-3 if order == 2 else 1e-2
    tr = liebody.integrate(scene, q0=q0, L0=L0, dt=h, t_end=t_end, method=name)
    tol = 0.5 * h**order  # a few times the method's error at this step (~0.1 h^2, ~0.02 h^4)
    assert np.abs(tr.L[-1] - Lr).max() < tol and rotation_distance(tr.q[-1], qr) < tol
    dE = np.abs(tr.energy - tr.energy[0]).max()
    assert dE < tol and np.ptp(tr.potential_energy) > 0.01  # the field does work on the body


def test_a_direct_scene_subclass_implements_the_contract():
    """A scene written from the contract alone: body, capabilities, torque model."""

    @njit
    def spin_up(t, q, L):  # a constant body torque about axis 3 (a thruster)
        return np.array([0.0, 0.0, 0.2])

    class Thruster(liebody.Scene):
        def __init__(self, body):
            self.body = body

        @property
        def capabilities(self):
            return liebody.Capabilities(torque={"time"}, conservative=False)

        def torque_model(self):
            return TorqueModel.user(spin_up)

    scene = Thruster(liebody.RigidBody([2.0, 2.0, 1.0]))
    tr = liebody.integrate(scene, L0=[0.0, 0.0, 1.0], dt=0.01, steps=500)
    np.testing.assert_allclose(tr.L[:, 2], 1.0 + 0.2 * tr.t, atol=1e-12, rtol=0)
    assert tr.method.name == "splitting2"
    with pytest.raises(ValueError, match="cannot integrate this Thruster"):
        liebody.integrate(scene, L0=[0.0, 0.0, 1.0], dt=0.01, steps=5, method="sr2")


def test_end_of_run_gravity_potential_is_the_scenes():
    """The end-of-run energy check evaluates uniform gravity in scalar arithmetic; it must
    be the scene's potential (also for a quaternion off the unit sphere)."""
    from liebody import quaternion
    from liebody._integrate import _end_potentials

    rng = np.random.default_rng(3)
    top = liebody.HeavyTop(liebody.RigidBody([2.0, 3.0, 4.0]), mass=1.5,
                           cm=[0.2, -0.4, 0.7], g=9.81)
    for _ in range(20):
        q0, q1 = quaternion.random(2, rng=rng)
        V0, V1 = _end_potentials(top, (1.3 * q0).tolist(), q1.tolist())
        np.testing.assert_allclose([V0, V1], top.potential(np.stack([q0, q1])),
                                   rtol=1e-13, atol=1e-14)


def test_a_scenes_memoised_model_follows_take():
    """A heavy top memoises its torque model and batch shape; the scene of some of its
    bodies (take) derives its own."""
    tops = liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass=[1.0, 2.0, 3.0],
                            cm=[0.0, 0.0, 1.0], g=1.0)
    assert tops.batch_shape == (3,) and tops.torque_model().params.shape == (3, 3)
    one = tops.take(slice(1, 2))
    assert one.batch_shape == (1,)
    np.testing.assert_array_equal(one.torque_model().params, [[0.0, 0.0, 2.0]])
    assert tops.torque_model() is tops.torque_model()
    with pytest.raises(ValueError, match="read-only"):
        tops.torque_model().params[0, 0] = 1.0


def test_take_keeps_a_parameter_of_one_row_as_every_bodys(monkeypatch):
    """A parameter of one row in a batch of more bodies (a centre of mass ``(1, 3)``, an
    inertia ``RigidBody.batch`` of one, beside a mass per body) broadcasts to every body,
    and so to every part of the batch that ``take`` makes: it was sliced (no row for a
    part past the first body, ``IndexError`` for one body past it), so a body's
    trajectory could not be made and the ensemble check in chunks failed."""
    from liebody import _engine

    mass = np.array([1.0, 1.0, 300.0, 1.0, 300.0])
    tops = [liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), mass,
                             np.array([[0.0, 0.0, 1.0]]), g=1.0),
            liebody.HeavyTop(liebody.RigidBody.batch([[5.0, 5.0, 1.0]]), mass,
                             [0.0, 0.0, 1.0], g=1.0)]
    for top in tops:
        for idx, n in ((slice(2, 4), 2), (np.array([4, 1]), 2), (3, None)):
            part = top.take(idx)
            assert part.batch_shape == (() if n is None else (n,))
            np.testing.assert_array_equal(part.weight_arm, top.weight_arm[idx])
            np.testing.assert_array_equal(np.broadcast_to(part.moments, (n or 1, 3)),
                                          np.broadcast_to(top.moments, (5, 3))[:n or 1])
        L0 = np.tile([0.0, 0.0, 10.0], (5, 1))
        with pytest.warns(liebody.InvariantWarning) as caught:
            tr = liebody.integrate(top, q0=Q.exp([0.5, 0, 0]), L0=L0, dt=0.3, steps=200)
        whole = [str(w.message) for w in caught]
        assert len(whole) == 1 and whole[0].startswith("splitting2: 2 of 5 bodies (e.g. body 2)")
        monkeypatch.setattr(_engine, "CHECK_CHUNK", 2)
        with pytest.warns(liebody.InvariantWarning) as caught:
            liebody.integrate(top, q0=Q.exp([0.5, 0, 0]), L0=L0, dt=0.3, steps=200)
        assert [str(w.message) for w in caught] == whole
        monkeypatch.undo()
        one = tr.body(4)
        assert one.scene.mass == 300.0 and one.scene.batch_shape == ()
        np.testing.assert_array_equal(one.q, tr.q[4])
        np.testing.assert_allclose(one.potential_energy, tr.potential_energy[4], rtol=1e-15)


def test_pickled_scenes_leave_their_memos_behind():
    """A scene memoises what it derives from its parameters. A user torque's model holds
    the address of a callback compiled in this process: pickled (a Dask worker gets the
    scene so), it would point at nothing there. The pickle keeps the parameters only,
    and the unpickled scene integrates to the same bits."""
    import pickle

    body = liebody.RigidBody([1.0, 2.0, 2.5])
    scenes = [liebody.TorqueBody(body, _gravity_gradient, orientation_only=True),
              liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), 20.0, [0, 0, 1.0], g=1.0)]
    for scene in scenes:
        before = liebody.integrate(scene, L0=[0.3, 1.0, 2.0], dt=0.01, steps=20,
                                   method="splitting2")
        assert any(k.startswith("_memo_") for k in vars(scene))  # memoised by the run
        again = pickle.loads(pickle.dumps(scene))
        assert not any(k.startswith("_memo_") for k in vars(again))
        after = liebody.integrate(again, L0=[0.3, 1.0, 2.0], dt=0.01, steps=20,
                                  method="splitting2")
        np.testing.assert_array_equal(before.q, after.q)


class _DampedTop(liebody.HeavyTop):
    """A heavy top with internal dissipation too: a torque and a dissipation at once."""

    @property
    def capabilities(self):
        return liebody.Capabilities(torque=frozenset({"orientation"}), conservative=False,
                                    dissipative=True)

    @property
    def dissipation(self):
        return 0.1


@pytest.mark.filterwarnings("ignore::liebody.InvariantWarning")
@pytest.mark.parametrize("method", ["splitting2", "no_squish"])
def test_a_scene_with_a_torque_and_dissipation_gets_both(method):
    """Before: the splittings ran the dissipation and dropped the torque (an error of
    0.84 that did not shrink with h). Reference: rk4 at a 64 times smaller step (rk4
    evaluates torque and dissipation in one vector field)."""
    scene = _DampedTop(liebody.RigidBody([1.0, 2.0, 3.0]), mass=1.0, cm=[0.3, -0.2, 1.0],
                       g=1.0)
    q0, L0 = Q.exp([0.2, -0.1, 0.05]), [0.5, 1.0, 2.0]
    ref = liebody.integrate(scene, q0=q0, L0=L0, dt=0.005 / 64, t_end=2.0, method="rk4")
    errors = []
    for h in (0.01, 0.005):
        tr = liebody.integrate(scene, q0=q0, L0=L0, dt=h, t_end=2.0, method=method)
        errors.append(np.abs(tr.L[-1] - ref.L[-1]).max())
    assert errors[0] < 1e-3, errors
    assert 3.0 < errors[0] / errors[1] < 5.0, errors  # second order


def test_running_energy_error_is_nan_for_a_user_potential():
    """The kernel cannot call a Python potential: the documented NaN (before: 0.0, while
    the energy changed)."""
    scene = GravityGradientSatellite()
    body = scene.body
    kw = {"dt": 0.01, "steps": 100, "method": "splitting2", "diagnostics": True}
    one = liebody.integrate(scene, L0=[0.3, 1.0, 0.2], **kw)
    assert np.isnan(one.diagnostics["max_energy_error"])
    assert one.diagnostics["max_qnorm_error"] < 1e-14
    ens = liebody.integrate(scene, L0=[[0.3, 1.0, 0.2], [1.0, 0.1, 0.2]], **kw)
    assert np.isnan(ens.diagnostics["max_energy_error"]).all()
    free = liebody.integrate(liebody.FreeBody(body), L0=[0.3, 1.0, 0.2], **kw)
    assert 0.0 < free.diagnostics["max_energy_error"] < 1e-3


def test_capabilities_and_torque_model_must_agree():
    """A scene that declares a torque but gives no torque model ran as a free body, and one
    that gives a torque model but declares none had it applied by rk4 and ignored by the
    splittings. Both are refused, naming the contract."""

    class Forgot(liebody.Scene):  # a torque declared, no torque_model()
        def __init__(self, body):
            self.body = body

        @property
        def capabilities(self):
            return liebody.Capabilities(torque=frozenset({"orientation"}), conservative=False)

    class Undeclared(Forgot):  # a torque model, capabilities of a free body
        @property
        def capabilities(self):
            return liebody.Capabilities()

        def torque_model(self):
            return TorqueModel.user(_gravity_gradient)

    body = liebody.RigidBody([1.0, 2.0, 2.5])
    for scene, words in ((Forgot(body), "declares torque .* gives no torque model"),
                         (Undeclared(body), "declares no torque .* gives a torque model")):
        for method in ("splitting2", "rk4"):
            with pytest.raises(ValueError, match=words):
                liebody.integrate(scene, L0=[0.3, 1.0, 0.2], dt=0.01, steps=10, method=method)
        with pytest.raises(ValueError, match=words):
            liebody.Stepper(scene, L0=[0.3, 1.0, 0.2], dt=0.01, method="rk4")
