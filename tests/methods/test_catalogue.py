"""The method catalogue: records, composition tables, registration, capability matching.

Every registered method is exercised by the generic tests of this tier, so a method
is tested the moment it is registered (``no_squish`` below is one ``register`` call
in ``liebody._methods`` and nothing else).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import liebody
from liebody import _methods
from liebody import _plan as P


def test_registry_public_names():
    names = set(liebody.methods().names())
    assert {"splitting2", "sr2", "rattle", "splitting4", "splitting6", "splitting8", "exact",
            "euler", "rk4", "lie_euler", "rkmk4", "no_squish"} <= names


@pytest.mark.parametrize("name", sorted(_methods.COMPOSITIONS))
def test_composition_tables_palindromic_consistent(name):
    g = np.array(_methods.COMPOSITIONS[name])
    np.testing.assert_array_equal(g, g[::-1])
    assert abs(g.sum() - 1.0) < 1e-15
    if len(g) > 1:  # order >= 4 needs the cubic condition
        assert abs(np.sum(g**3)) < 1e-15


def test_methods_table_reads_the_registry():
    table = liebody.methods()
    text = str(table)
    for m in table:
        assert m.name in text
        assert m.order >= 1
        assert m.handles.describe() in text
        if m.family == "composition":
            assert m.coefficients in _methods.COMPOSITIONS.values()
            assert m.symplectic and m.reversible
    assert table["rattle"].keeps_energy and not table["rk4"].keeps_casimir
    # an unknown name: a KeyError that names the known methods (before: KeyError('nope'))
    with pytest.raises(KeyError, match=r"unknown method 'nope'; known methods: .*rattle, "
                                       r"rk4, .*splitting2"):
        table["nope"]
    assert table[0] is next(iter(table)) and "rattle" in table and "nope" not in table


# --------------------------------------------------------------------------- registering


def _strang(name: str, ordering=(0, 1, 2)) -> liebody.Method:
    return liebody.Method(name, P.AxisSplitting(ordering=ordering), 2, "splitting", True, True,
                          True, False, liebody.Handles.ALL, "4 axis rotations")


def test_a_new_base_splitting_is_one_register_call(hlw):
    """A fixed-ordering Strang splitting registered at run time integrates at once, at
    order 2, and is the 5-rotation splitting in that ordering (the ordering is recorded)."""
    scene, L0 = hlw
    method = liebody.register(_strang("strang_021", (0, 2, 1)))
    try:
        assert "strang_021" in liebody.methods().names()
        tr = liebody.integrate(scene, L0=L0, dt=0.01, steps=100, method="strang_021")
        assert tr.info["axis_ordering"] == (0, 2, 1) and tr.method is method
        plan = method.plan(scene, L0, 0.01)
        assert plan.axes.tolist() == [0, 2, 1, 2, 0] and plan.merge_ends
        ref = liebody.integrate(scene, L0=L0, dt=1.0, steps=1)
        err = [np.abs(liebody.integrate(scene, L0=L0, dt=h, steps=round(1 / h),
                                        method="strang_021").L[-1] - ref.L[-1]).max()
               for h in (0.02, 0.01)]
        assert abs(np.log2(err[0] / err[1]) - 2.0) < 0.05
    finally:
        _methods._REGISTRY.pop("strang_021")


def test_register_validates():
    with pytest.raises(ValueError, match="registered already"):
        liebody.register(_strang("splitting2"))
    with pytest.raises(ValueError, match="identifier"):
        liebody.register(_strang("my method"))
    with pytest.raises(TypeError, match=r"liebody\.Method"):
        liebody.register("splitting2")
    with pytest.raises(ValueError, match="permutation"):
        P.AxisSplitting(ordering=(0, 0, 1))
    bad = liebody.Method("bad4", P.Composition(P.BestSplitting(), (0.5, 0.5)), 4,
                         "composition", True, True, True, False, liebody.Handles.TORQUES, "")
    with pytest.raises(ValueError, match=r"sum g\^3"):
        liebody.register(bad)
    lopsided = liebody.Method("lop", P.Composition(P.BestSplitting(), (0.3, 0.7)), 2,
                              "composition", True, True, True, False, liebody.Handles.TORQUES, "")
    with pytest.raises(ValueError, match="palindromic"):
        liebody.register(lopsided)
    assert "bad4" not in liebody.methods().names()


@pytest.mark.parametrize(("coefficients", "order", "ok"), [
    ((1.0,), 2, True),
    (_methods.COMPOSITIONS["suzuki4"], 4, True),
    (_methods.COMPOSITIONS["kahanli8"], 8, True),
    ((1 / (2 - 2 ** (1 / 3)), -(2 ** (1 / 3)) / (2 - 2 ** (1 / 3)), 1 / (2 - 2 ** (1 / 3))), 4,
     True),
    (_methods.COMPOSITIONS["suzuki4"], 6, False),  # order 4 only: sum g^5 != 0
    ((0.5, 0.6), 2, False),  # not consistent, not palindromic
    ((1.0, math.nan, 1.0), 2, False),
])
def test_check_composition(coefficients, order, ok):
    if ok:
        assert _methods.check_composition(coefficients, order) == tuple(coefficients)
    else:
        with pytest.raises(ValueError):
            _methods.check_composition(coefficients, order)


# ---------------------------------------------------------------------- capability match


@pytest.mark.parametrize(("method", "scene", "words"), [
    ("sr2", lambda: liebody.HeavyTop(liebody.RigidBody([1, 1, 0.5]), 1.0, [0, 0, 1]),
     r"torque\(q\).*sr2 handles free body only"),
    ("exact", lambda: liebody.DampedBody(liebody.RigidBody([1, 2, 2.5]), 0.1),
     "dissipation"),
    ("rattle", lambda: liebody.DampedBody(liebody.RigidBody([1, 2, 2.5]), 0.1),
     "rattle handles any torque only"),
])
def test_methods_that_cannot_handle_the_scene_say_why(method, scene, words):
    with pytest.raises(ValueError, match=words):
        liebody.integrate(scene(), L0=(1.0, 0.5, 0.2), dt=0.1, steps=1, method=method)


#: what each built-in method integrates, written out from the methods' definitions (a
#: free body only: the exact flow, the symmetric-body splitting and the modified-moment
#: DMV; torques but no dissipation: RATTLE and the compositions; everything: the axis
#: splittings and the baselines), independent of Handles
HANDLES = {
    "free": {"exact", "sr2", "dmv4", "dmv6", "dmv8", "dmv10"},
    "torques": {"rattle", "splitting4", "splitting6", "splitting8"},
    "kicks": {"saba2", "saba3", "saba4"},  # torques of the orientation and the time
    "all": {"splitting2", "no_squish", "euler", "rk4", "lie_euler", "rkmk4"},
}


def test_every_method_declares_what_it_handles():
    """Each built-in method accepts exactly the scenes the table above says, and
    integrate agrees: it runs them, and refuses the others naming the rule (before: a
    check that every method accepts a free body, which every Handles does)."""
    scenes = {
        "free": liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5])),
        "top": liebody.HeavyTop(liebody.RigidBody([1.0, 1.0, 0.5]), 1.0, [0.0, 0.0, 1.0]),
        "damped": liebody.DampedBody(liebody.RigidBody([1.0, 2.0, 2.5]), 0.1),
    }
    can = {"free": {"free", "torques", "kicks", "all"}, "top": {"torques", "kicks", "all"},
           "damped": {"all"}}
    assert set().union(*HANDLES.values()) == set(_methods._BUILTIN)
    for group, names in HANDLES.items():
        for name in sorted(names):
            m = liebody.methods()[name]
            for key, scene in scenes.items():
                expected = group in can[key]
                assert m.supports(scene) == expected, (name, key)
                if expected:
                    with warnings.catch_warnings():  # the baselines leave |q| = 1
                        warnings.simplefilter("ignore", liebody.InvariantWarning)
                        tr = liebody.integrate(scene, L0=(1.0, 0.5, 0.2), dt=0.01, steps=2,
                                               method=name)
                    assert tr.status == "complete", (name, key)
                else:
                    with pytest.raises(ValueError, match=f"method '{name}' cannot integrate"):
                        liebody.integrate(scene, L0=(1.0, 0.5, 0.2), dt=0.01, steps=2,
                                          method=name)


def _plan_arrays(plan):
    return (plan.kinds, plan.axes, plan.coefs, plan.clock, plan.params, plan.slots)


@pytest.mark.parametrize(("name", "scene", "per_state"), [
    ("rk4", "free", False), ("rattle", "free", False), ("no_squish", "free", False),
    ("splitting4", "top", False), ("splitting2", "top", False),  # a symmetric top's drift
    ("splitting2", "free", True), ("dmv4", "free", True),  # ordering; modified moments
])
def test_plans_are_shared_between_initial_states_when_they_do_not_depend_on_them(
        name, scene, per_state):
    """A plan whose recipe never read the initial momenta is cached for every initial
    state (a new state costs no set-up); one that did (the axis ordering chosen for the
    orbit, Hairer-Vilmart's modified moments) is made per state. Either way a cached plan
    equals the plan made afresh."""
    scenes = {"free": liebody.FreeBody(liebody.RigidBody([1.0, 2.0, 2.5])),
              "top": liebody.HeavyTop(liebody.RigidBody([5.0, 5.0, 1.0]), 20.0,
                                      [0.0, 0.0, 1.0], g=1.0)}
    sc = scenes[scene]
    m = _methods.get(name)
    a, b = np.array([0.3, 1.0, 0.2]), np.array([0.9, -0.1, 0.4])  # orbits about axes 2, 1
    first = m.plan(sc, a, 0.01)
    second = m.plan(sc, b, 0.01)
    assert (second is not first) == per_state
    (_, fresh), = m.plans(sc, b[None], 0.01)
    for x, y in zip(_plan_arrays(second), _plan_arrays(fresh), strict=True):
        np.testing.assert_array_equal(x, y)
    assert second.info.keys() == fresh.info.keys()
    assert m.plan(sc, a, 0.01) is first  # and the first state's plan is still cached


def _counting_compiles(monkeypatch) -> list:
    """Count the plans compiled (every recipe's plan goes through ``compile_plan``)."""
    calls = []
    compile_plan = P.compile_plan

    def counted(*args, **kwargs):
        calls.append(1)
        return compile_plan(*args, **kwargs)

    monkeypatch.setattr(P, "compile_plan", counted)
    return calls


def _scene(kind: str):
    body = liebody.RigidBody([1.0, 2.0, 3.0])  # asymmetric
    if kind == "free":
        return liebody.FreeBody(body)
    return liebody.HeavyTop(body, mass=1.0, cm=[0.0, 0.0, 0.1])


#: states on neighbouring orbits about axis 2 (the same key: ordering, base, drift)
_NEIGHBOURS = [np.array([0.3, 1.0, 0.2]) * (1.0 + 0.01 * k) + np.array([0.0, 0.0, 0.003 * k])
               for k in range(4)]


@pytest.mark.parametrize(("name", "scene"), [
    ("splitting2", "free"), ("splitting2", "top"), ("sr2", "free"), ("no_squish", "free"),
    ("splitting4", "free"), ("splitting4", "top"), ("splitting6", "free")])
def test_a_new_state_of_a_known_key_compiles_no_plan(monkeypatch, name, scene):
    """A splitting's plan depends on the initial state only through its recipe's key (the
    axis ordering or SR2 variant chosen for the orbit, the drift): a new initial state of
    a key already planned reuses that plan's arrays and compiles nothing, and its plan
    equals the plan made afresh for it, ``info`` included (its own energy-error
    constant)."""
    sc, m = _scene(scene), _methods.get(name)
    keys = [int(m.recipe.keys(P.Bodies.of(sc, x[None]), 0.01)[0]) for x in _NEIGHBOURS]
    assert len(set(keys)) == 1  # (the premise: one key)
    calls = _counting_compiles(monkeypatch)
    first = m.plan(sc, _NEIGHBOURS[0], 0.01)
    assert len(calls) == 1
    for x in _NEIGHBOURS[1:]:
        before = len(calls)
        plan = m.plan(sc, x, 0.01)
        assert len(calls) == before, "a new state of a known key compiled a plan"
        assert plan.params is first.params and plan.kinds is first.kinds
        (_, fresh), = m.plans(sc, x[None], 0.01)
        for a, b in zip(_plan_arrays(plan), _plan_arrays(fresh), strict=True):
            np.testing.assert_array_equal(a, b)
        assert (plan.merge_ends, plan.family) == (fresh.merge_ends, fresh.family)
        assert repr(plan.info) == repr(fresh.info)  # the same entries, in the same order
        assert m.plan(sc, x, 0.01) is plan  # (and it is cached for its state)


@pytest.mark.parametrize("name", ["splitting2", "sr2", "splitting4"])
def test_plans_shared_by_a_key_give_each_state_its_own_info(name):
    """The states of one key share a plan's arrays but each gets its own ``info``: the
    energy-error constant of its orbit (the range of Fasso's ``H3`` over it,
    :mod:`liebody._ordering`), which differs from state to state; ``Trajectory.info`` is
    the state's, whichever state planned first."""
    sc, m = _scene("free"), _methods.get(name)
    plans = [m.plan(sc, x, 0.01) for x in _NEIGHBOURS]
    constants = [p.info["energy_error_constant"] for p in plans]
    assert len(set(constants)) == len(constants)
    for x, plan, c in zip(_NEIGHBOURS, plans, constants, strict=True):
        if name == "sr2" or plan.info.get("base") == "sr2":
            variant, ref = _ordering_best("sr2", sc.moments, x)
            assert plan.info["sr2_variant"] == variant
        else:
            variant, ref = _ordering_best("axes", sc.moments, x)
            assert plan.info["axis_ordering"] == variant
        assert c == ref
        tr = liebody.integrate(sc, L0=x, dt=0.01, steps=2, method=name)
        assert tr.info["energy_error_constant"] == c


def _ordering_best(family, moments, m0):
    from liebody import _ordering as O
    pieces = O.axis_pieces if family == "axes" else O.sr2_pieces
    k, score = O._best_rows(pieces, np.array([moments]), np.abs(np.array([m0], dtype=float)))
    return O.ORDERINGS[int(k[0])], float(score[0])


def test_recipes_declare_whether_their_plans_are_shared_by_key(monkeypatch):
    """Which recipes share a plan among the states of one key is the recipe's declared
    property: not Hairer-Vilmart's preprocessed DMV (its modified moments vary with the
    state continuously), nor a composition of it, nor a recipe that does not say; a new
    state of those is planned afresh."""
    assert P.DMVFlow(2).keyed_by_state and not P.DMVFlow(4).keyed_by_state
    assert not P.Composition(P.DMVFlow(4), (1.0,)).keyed_by_state
    assert P.Composition(P.BestSplitting(), (1.0,)).keyed_by_state
    assert not P.Recipe.keyed_by_state
    sc, m = _scene("free"), _methods.get("dmv4")
    calls = _counting_compiles(monkeypatch)
    a, b = m.plan(sc, _NEIGHBOURS[0], 0.01), m.plan(sc, _NEIGHBOURS[1], 0.01)
    assert len(calls) == 2
    assert a.info["modified_moments"] != b.info["modified_moments"]


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_saba_nodes_and_weights_are_the_gauss_legendre_rule(n):
    """The closed-form nodes and weights (Abramowitz & Stegun, table 25.4) against numpy's
    Golub-Welsch ``leggauss`` and against exactness for polynomials of degree ``2n - 1``
    on ``[0, 1]``; SABA_n's sub-flows are palindromic, each part runs one step, and the
    kicks sit at the nodes of the step with the weights (the clock before each kick)."""
    nodes, weights = _methods.gauss_legendre(n)
    x, w = np.polynomial.legendre.leggauss(n)
    np.testing.assert_allclose(nodes, 0.5 * (1.0 + x), rtol=0, atol=4e-16)
    np.testing.assert_allclose(weights, 0.5 * w, rtol=0, atol=4e-16)
    for k in range(2 * n):  # integral of t^k over [0, 1]
        assert abs(sum(wi * c**k for c, wi in zip(nodes, weights, strict=True))
                   - 1.0 / (k + 1)) < 1e-15
    k = 2 * n  # and not beyond: the rule's degree is 2n - 1
    assert abs(sum(wi * c**k for c, wi in zip(nodes, weights, strict=True))
               - 1.0 / (k + 1)) > 1e-6
    recipe = P.FlowSequence(_methods.saba_flows(n))
    assert recipe.palindromic and recipe.parts() == pytest.approx({"free": 1.0, "kick": 1.0})
    clock, kicks = 0.0, []
    for name, frac, tick in recipe.flows:
        if name == "kick":
            kicks.append((clock, frac))
        clock += tick
    assert abs(clock - 1.0) < 1e-15
    np.testing.assert_allclose([c for c, _ in kicks], nodes, rtol=0, atol=1e-15)
    np.testing.assert_allclose([f for _, f in kicks], weights, rtol=0, atol=0)
    with pytest.raises(ValueError, match="n must be 1 to 4"):
        _methods.gauss_legendre(5)


def test_the_catalogue_splittings_of_sub_flows_are_symmetric_as_they_run():
    """Every catalogue method written as sub-flows (SABA_n) declares itself reversible,
    and register_splitting's judgement of its compiled plan (on a rigid body with a torque
    of the time and without one) agrees; Lie-Trotter, written the same way, is not."""
    found = [m for m in liebody.methods() if isinstance(m.recipe, P.FlowSequence)]
    assert {"saba2", "saba3", "saba4"} <= {m.name for m in found}
    for m in found:
        assert _methods._symmetric_as_run(m.recipe) == m.reversible, m.name
    assert not _methods._symmetric_as_run(P.FlowSequence((("free", 1.0, 1.0), ("kick", 1.0))))
