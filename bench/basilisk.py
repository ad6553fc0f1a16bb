"""Basilisk against liebody on gravity-gradient satellites, at equal accuracy.

Basilisk (Kenneally, Piggott & Schaub, "Basilisk: A Flexible, Scalable and Modular
Astrodynamics Simulation Framework", J. Aerosp. Inf. Syst. 17 (2020) 496–507) is the
astrodynamics framework a spacecraft engineer would otherwise reach for. Its
``spacecraft.Spacecraft`` rigid hub with a ``GravityGradientEffector`` and the Earth's
point-mass gravity body, integrated by its default fixed-step RK4, against
``liebody.GravityGradient`` (one source, the Earth, on a ``liebody.orbits.Circular``
orbit), on two scenes of one spacecraft (``I = diag(100, 120, 80) kg m^2``, circular
orbit of radius 7000 km):

* ``tumbling`` — a fast rotation near the intermediate axis (``omega0 = (0.5, 0.01,
  0.02) rad/s``, body frame): the body flips every few minutes (the
  Dzhanibekov effect), the gravity-gradient torque a small perturbation; half an
  orbit (49 minutes);
* ``libration`` — a slow libration about the gravity-gradient equilibrium (the axis of
  least inertia along the radius, of greatest inertia along the orbit normal, turning
  once per orbit): the equilibrium attitude tilted by 0.1 rad in pitch and 0.05 rad in
  roll, with small rate offsets, for ten orbits (16 hours).

**Same physics.** Both integrate Euler's equations with the torque
``3 mu / r^5 (r_b x I r_b)`` (``r_b`` the Earth's position in the body frame) and the
attitude kinematics; Basilisk integrates the orbit too (RK4, with the attitude), liebody
is given it. ``mu`` is Basilisk's own Earth value, in both. The **reference** is scipy's
``solve_ivp`` DOP853 at ``rtol = atol = 1e-13`` on the 7-dimensional ``(q, L)``
equations with the circular orbit given (numba right-hand side), cross-checked against
liebody's ``splitting8`` at a fine step; the larger difference is the reference's
uncertainty. Basilisk's and liebody's errors at their smallest steps, both far below
their coarse-step errors, show that the two model the same motion (a wrong ``mu``, frame
or quaternion convention would leave a floor).

**Equal accuracy.** The error is the rotation angle between the final attitude and the
reference's. Each method runs a ladder of steps; its cost is the wall time of one run
(the minimum over ``repeat`` repetitions, interleaved over all runs of a scene so that
the machine's load hits them alike): for Basilisk ``ExecuteSimulation`` only (building
the simulation in Python is not counted), for liebody the whole ``integrate()`` call
(validation and set-up included). The cost at which each line reaches an error level is
interpolated log-log (:func:`bench.work_precision.cost_at`); the ratio
``cost(Basilisk RK4) / cost(best liebody method)`` is reported per scene and level. The
liebody methods are every registered method of order 2 or more that supports the scene,
each with the scene's default free flow (``free_flow="auto"``) and, for the splittings,
with ``free_flow="axes"`` too (labelled ``method (axes)``).

Without Basilisk (``pip install -e '.[basilisk]'``) the liebody side and the reference
still run, and the report says that Basilisk is not installed (CI does not need it).

Run ``python -m bench --only basilisk [--quick]``.
"""

from __future__ import annotations

import importlib.util
import math
import time
from dataclasses import dataclass

import numpy as np
from numba import njit

import liebody
from bench import core
from bench.work_precision import cost_at
from liebody import quaternion
from liebody.orbits import Circular

#: the Earth's gravitational parameter when Basilisk is not installed [m^3/s^2]: the value
#: of Basilisk 2.x's ``createEarth()`` (with Basilisk, its own value is read and used)
MU_EARTH = 3.98600436e14
#: the spacecraft's principal moments [kg m^2] and its orbit radius [m]
INERTIA = (100.0, 120.0, 80.0)
RADIUS = 7.0e6
BASILISK = "Basilisk RK4"


@dataclass(frozen=True)
class Satellite:
    """One scene: the initial attitude (body -> inertial, scalar-first), body rates, the
    horizon and the step ladders (Basilisk's steps are whole nanoseconds)."""

    key: str
    title: str
    q0: tuple
    omega0: tuple
    orbits: float  # horizon in orbital periods (full run)
    orbits_quick: float
    bsk_h: tuple  # Basilisk's steps [s]
    bsk_h_quick: tuple
    h_max: float  # liebody's largest step [s]; the ladder halves it
    levels: tuple  # the error levels of the ratios [rad]


def _equilibrium() -> np.ndarray:
    """The gravity-gradient equilibrium at ``t = 0`` (spacecraft at ``(R, 0, 0)``, moving
    along ``+y``): body z (least inertia) along the radius, body y (greatest) along the
    orbit normal ``+z``, body x along the velocity."""
    R = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # columns: body axes
    return quaternion.from_matrix(R)


def satellites() -> dict[str, Satellite]:
    n = math.sqrt(MU_EARTH / RADIUS**3)
    tilt = quaternion.exp(np.array([0.05, 0.1, 0.0]))  # roll 0.05, pitch 0.1 rad (body)
    lib_q = quaternion.multiply(_equilibrium(), tilt)
    tumbling = Satellite(
        key="tumbling", title="tumbling near the intermediate axis, |omega| = 0.5 rad/s",
        q0=tuple(quaternion.normalize(np.array([0.9, 0.1, -0.2, 0.3]))),
        omega0=(0.5, 0.01, 0.02), orbits=0.5, orbits_quick=0.02,
        bsk_h=(0.4, 0.2, 0.1, 0.05, 0.025, 0.0125),
        bsk_h_quick=(0.4, 0.1, 0.025), h_max=16.0, levels=(1e-4, 1e-6, 1e-8))
    libration = Satellite(
        key="libration", title="libration about the gravity-gradient equilibrium",
        q0=tuple(lib_q), omega0=(2e-4, n + 1e-4, -1e-4), orbits=10.0, orbits_quick=0.5,
        bsk_h=(400.0, 200.0, 100.0, 50.0, 25.0, 12.5, 6.25, 3.125),
        bsk_h_quick=(200.0, 50.0, 12.5), h_max=800.0, levels=(1e-4, 1e-6, 1e-8))
    return {s.key: s for s in (tumbling, libration)}


def settings(quick: bool) -> dict:
    if quick:
        return {"scenes": list(satellites()), "halvings": [0, 2, 4, 6], "repeat": 2,
                "min_batch": 0.005, "cap_s": 0.05, "quick": True}
    return {"scenes": list(satellites()), "halvings": list(range(0, 13)), "repeat": 3,
            "min_batch": 0.02, "cap_s": 0.5, "quick": False}


# ------------------------------------------------------------------------- the scenes


def basilisk_available() -> bool:
    return importlib.util.find_spec("Basilisk") is not None


def earth_mu() -> float:
    """Basilisk's Earth ``mu`` (both sides use it), or :data:`MU_EARTH` without Basilisk."""
    if not basilisk_available():
        return MU_EARTH
    from Basilisk.utilities import simIncludeGravBody

    return float(simIncludeGravBody.gravBodyFactory().createEarth().mu)


def horizon(sat: Satellite, mu: float, quick: bool) -> float:
    """The horizon [s], a whole number of Basilisk's smallest steps (in ns)."""
    period = 2.0 * math.pi / math.sqrt(mu / RADIUS**3)
    T = (sat.orbits_quick if quick else sat.orbits) * period
    unit = 2.0 * max(sat.bsk_h)  # a whole multiple of every step on Basilisk's ladders
    return max(1, round(T / unit)) * unit


def liebody_scene(mu: float, free_flow: str = "auto") -> liebody.GravityGradient:
    """The Earth seen from the spacecraft, which starts at ``(R, 0, 0)`` moving along +y
    on a circular orbit: ``r_earth(t) = -r_sc(t)``, a circular orbit of phase ``pi``."""
    n = math.sqrt(mu / RADIUS**3)
    return liebody.GravityGradient(liebody.RigidBody(list(INERTIA)),
                                   [(mu, Circular(n, RADIUS, phase=math.pi))],
                                   free_flow=free_flow)


def rotation_angle(q: np.ndarray, q_ref: np.ndarray) -> float:
    """The angle of the rotation between two attitudes (sign-blind, accurate near 0)."""
    return float(quaternion.angle_between(quaternion.normalize(q), q_ref))


# ------------------------------------------------------------------------- reference


@njit(cache=True)
def _rhs(t, y, inertia, mu, radius, n):  # pragma: no cover - compiled
    """(q, L)' with the gravity-gradient torque of the Earth on the circular orbit."""
    w, x, yq, z = y[0], y[1], y[2], y[3]
    o0, o1, o2 = y[4] / inertia[0], y[5] / inertia[1], y[6] / inertia[2]
    out = np.empty(7)
    out[0] = 0.5 * (-x * o0 - yq * o1 - z * o2)
    out[1] = 0.5 * (w * o0 + yq * o2 - z * o1)
    out[2] = 0.5 * (w * o1 + z * o0 - x * o2)
    out[3] = 0.5 * (w * o2 + x * o1 - yq * o0)
    s = 1.0 / (w * w + x * x + yq * yq + z * z)  # R(q) / |q|^2: a rotation
    X = -radius * math.cos(n * t)  # the Earth seen from the spacecraft
    Y = -radius * math.sin(n * t)
    # r_b = R(q)^T r
    r1 = s * ((w * w + x * x - yq * yq - z * z) * X + 2 * (x * yq + w * z) * Y)
    r2 = s * (2 * (x * yq - w * z) * X + (w * w - x * x + yq * yq - z * z) * Y)
    r3 = s * (2 * (x * z + w * yq) * X + 2 * (yq * z - w * x) * Y)
    rr = r1 * r1 + r2 * r2 + r3 * r3
    f = 3.0 * mu / (rr * rr * math.sqrt(rr))
    a1, a2, a3 = inertia[0] * r1, inertia[1] * r2, inertia[2] * r3
    out[4] = y[5] * o2 - y[6] * o1 + f * (r2 * a3 - r3 * a2)
    out[5] = y[6] * o0 - y[4] * o2 + f * (r3 * a1 - r1 * a3)
    out[6] = y[4] * o1 - y[5] * o0 + f * (r1 * a2 - r2 * a1)
    return out


def reference(sat: Satellite, mu: float, T: float) -> dict:
    """The final attitude by DOP853 (rtol = atol = 1e-13), cross-checked against liebody's
    ``splitting8`` at a fine step; ``uncertainty`` is their difference (rad)."""
    from scipy.integrate import solve_ivp

    inertia = np.array(INERTIA)
    L0 = inertia * np.array(sat.omega0)
    y0 = np.concatenate([sat.q0, L0])
    args = (inertia, mu, RADIUS, math.sqrt(mu / RADIUS**3))
    sol = solve_ivp(_rhs, (0.0, T), y0, method="DOP853", rtol=1e-13, atol=1e-13, args=args)
    if sol.status != 0:
        raise RuntimeError(f"the DOP853 reference failed: {sol.message}")
    q_ref = quaternion.normalize(sol.y[:4, -1])
    h_fine = sat.h_max / 2**10
    steps = round(T / h_fine)
    tr = liebody.integrate(liebody_scene(mu), q0=np.array(sat.q0), L0=L0, dt=T / steps,
                           steps=steps, method="splitting8", save_every=None)
    check = rotation_angle(tr.q[-1], q_ref)
    return {"q": q_ref, "dop853_steps": int(sol.t.size - 1), "check": f"splitting8, h = "
            f"{T / steps:.4g} s", "vs_check": check, "uncertainty": max(check, 1e-14)}


# ------------------------------------------------------------------------- Basilisk


class BasiliskRun:
    """A Basilisk simulation of one scene at one step, built and ready to execute."""

    def __init__(self, sat: Satellite, h: float, T: float) -> None:
        from Basilisk.simulation import GravityGradientEffector, spacecraft
        from Basilisk.utilities import (
            RigidBodyKinematics,
            SimulationBaseClass,
            macros,
            simIncludeGravBody,
        )

        t0 = time.perf_counter()
        self.rbk = RigidBodyKinematics
        sim = SimulationBaseClass.SimBaseClass()
        proc = sim.CreateNewProcess("dynamics")
        proc.addTask(sim.CreateNewTask("step", macros.sec2nano(h)))
        sc = spacecraft.Spacecraft()
        sc.ModelTag = "satellite"
        sc.hub.mHub = 500.0  # does not enter the attitude motion
        sc.hub.IHubPntBc_B = np.diag(INERTIA).tolist()
        mu = earth_mu()
        sc.hub.r_CN_NInit = [[RADIUS], [0.0], [0.0]]
        sc.hub.v_CN_NInit = [[0.0], [math.sqrt(mu / RADIUS)], [0.0]]
        # Basilisk's attitude: the MRPs of [BN] (Schaub & Junkins); its Euler parameters
        # are liebody's scalar-first body -> inertial quaternion
        sc.hub.sigma_BNInit = [[float(v)] for v in RigidBodyKinematics.EP2MRP(list(sat.q0))]
        sc.hub.omega_BN_BInit = [[float(v)] for v in sat.omega0]
        sim.AddModelToTask("step", sc)
        grav = simIncludeGravBody.gravBodyFactory()
        earth = grav.createEarth()
        earth.isCentralBody = True
        grav.addBodiesTo(sc)
        gg = GravityGradientEffector.GravityGradientEffector()
        gg.ModelTag = "gravityGradient"
        gg.addPlanetName(earth.planetName)
        sc.addDynamicEffector(gg)
        sim.AddModelToTask("step", gg)
        sim.InitializeSimulation()
        sim.ConfigureStopTime(macros.sec2nano(T))
        self.sim, self.sc, self._keep = sim, sc, (grav, earth, gg)
        self.steps = round(T / h)
        self.build_s = time.perf_counter() - t0

    def execute(self) -> float:
        """Run to ``T``; returns the wall time of ``ExecuteSimulation``."""
        t0 = time.perf_counter()
        self.sim.ExecuteSimulation()
        return time.perf_counter() - t0

    def final_q(self) -> np.ndarray:
        st = self.sc.scStateOutMsg.read()
        return np.array(self.rbk.MRP2EP(st.sigma_BN), dtype=float)


# ------------------------------------------------------------------------- measuring


def contenders(scene) -> list[tuple[str, str, str]]:
    """``(label, method, free_flow)`` of every liebody run on the scene."""
    out = []
    for m in liebody.methods():
        if m.family == "exact" or m.order < 2 or not m.supports(scene):
            continue
        out.append((m.name, m.name, "auto"))
        # the axis splitting as the drift (SABA_n's drift is the exact flow whatever it)
        if m.family in ("splitting", "composition") and m.name not in ("sr2",) \
                and m.weak_order is None:
            out.append((f"{m.name} (axes)", m.name, "axes"))
    return out


def _batch_time(fn, min_batch: float) -> float:
    """Seconds per call of ``fn``, repeated until the batch lasts ``min_batch``."""
    t0 = time.perf_counter()
    fn()
    first = time.perf_counter() - t0
    inner = 1 if first >= min_batch else max(1, int(min_batch / max(first, 1e-7)))
    t0 = time.perf_counter()
    for _ in range(inner):
        fn()
    return (time.perf_counter() - t0) / inner


def run_scene(sat: Satellite, cfg: dict, mu: float, have_bsk: bool, progress) -> dict:
    T = horizon(sat, mu, cfg["quick"])
    ref = reference(sat, mu, T)
    L0 = np.array(INERTIA) * np.array(sat.omega0)
    q0 = np.array(sat.q0)
    jobs = []  # (label, method, setting h, callable returning (seconds, q_final))
    scenes = {ff: liebody_scene(mu, ff) for ff in ("auto", "axes")}
    for label, method, ff in contenders(scenes["auto"]):
        scene = scenes[ff]
        for k in cfg["halvings"]:
            steps = round(T / (sat.h_max / 2**k))
            h = T / steps

            def call(scene=scene, method=method, h=h, steps=steps):
                return liebody.integrate(scene, q0=q0, L0=L0, dt=h, steps=steps,
                                         method=method, save_every=None)

            jobs.append({"method": label, "source": "liebody", "h": h, "steps": steps,
                         "call": call})
    if have_bsk:
        for h in (sat.bsk_h_quick if cfg["quick"] else sat.bsk_h):
            jobs.append({"method": BASILISK, "source": "Basilisk", "h": h,
                         "steps": round(T / h), "call": None})
    # first pass: errors (and the kernels compiled). A liebody line stops (the rest of
    # its ladder is not run) after a run over the cap or at the reference's floor
    done: set[str] = set()
    for job in progress(jobs, desc=f"{sat.key}: errors"):
        if job["source"] == "liebody":
            if job["method"] in done:
                job["first_s"], job["error"] = math.inf, math.nan
                continue
            try:
                with core.quiet_runtime_warnings():
                    t0 = time.perf_counter()
                    tr = job["call"]()
                    job["first_s"] = time.perf_counter() - t0
            except (liebody.ConvergenceError, ValueError):  # rattle, dmv: step too large
                job["first_s"], job["error"], job["info"] = math.inf, math.inf, {}
                continue
            ok = tr.failed_at is None
            job["error"] = rotation_angle(tr.q[-1], ref["q"]) if ok else math.inf
            job["info"] = {k: str(v) for k, v in tr.info.items() if k in ("free_flow",)}
            if job["first_s"] > cfg["cap_s"] or job["error"] < 10 * ref["uncertainty"]:
                done.add(job["method"])
        else:
            b = BasiliskRun(sat, job["h"], T)
            job["first_s"] = b.execute()
            job["build_s"] = b.build_s
            job["error"] = rotation_angle(b.final_q(), ref["q"])
        job["seconds"] = []
    # liebody runs that would exceed the cap are not timed (their line ends there)
    timed = [j for j in jobs if j["source"] == "Basilisk" or j["first_s"] <= cfg["cap_s"]]
    for _ in progress(range(cfg["repeat"]), desc=f"{sat.key}: timing"):
        for job in timed:  # interleaved: every run once per round
            if job["source"] == "liebody":
                with core.quiet_runtime_warnings():
                    job["seconds"].append(_batch_time(job["call"], cfg["min_batch"]))
            else:
                b = BasiliskRun(sat, job["h"], T)
                job["seconds"].append(b.execute())
    rows = []
    for job in timed:
        s = min(job["seconds"])
        rows.append({"scene": sat.key, "method": job["method"], "source": job["source"],
                     "h": job["h"], "steps": job["steps"], "seconds": s,
                     "ns_per_step": 1e9 * s / job["steps"], "error": job["error"],
                     **({"build_s": job["build_s"]} if "build_s" in job else {}),
                     **({"free_flow": job["info"].get("free_flow")} if "info" in job
                        else {})})
    return {"T": T, "reference": {k: v for k, v in ref.items() if k != "q"},
            "rows": rows, "ratios": ratios(rows, sat.levels, ref["uncertainty"])}


def ratios(rows: list[dict], levels: tuple, floor: float) -> dict:
    """Per error level: the best liebody line's cost, Basilisk's, and their ratio."""
    lines: dict[str, list[tuple[float, float]]] = {}
    for r in rows:
        lines.setdefault(r["method"], []).append((r["seconds"], r["error"]))
    out = {}
    for level in levels:
        if level < 10 * floor:
            continue
        costs = {m: cost_at(pts, level) for m, pts in lines.items()}
        ours = {m: c for m, c in costs.items() if m != BASILISK and c is not None}
        best = min(ours, key=ours.get) if ours else None
        bsk = costs.get(BASILISK)
        # Basilisk's coarsest run already below the level: its cost is an upper bound
        bsk_pts = sorted(lines.get(BASILISK, []))
        bound = bool(bsk_pts and bsk_pts[0][1] <= level)
        out[f"{level:g}"] = {
            "best": best, "best_s": ours.get(best), "basilisk_s": bsk,
            "ratio": bsk / ours[best] if (bsk and best) else None,
            "ratio_is_upper_bound": bound,
            "costs": costs,
            "splitting2_ratio": (bsk / costs["splitting2"]) if bsk and costs.get("splitting2")
            else None}
    return out


def run(cfg: dict, progress) -> dict:
    have_bsk = basilisk_available()
    mu = earth_mu()
    sats = satellites()
    scenes = {}
    for key in cfg["scenes"]:
        scenes[key] = {"title": sats[key].title, **run_scene(sats[key], cfg, mu, have_bsk,
                                                             progress)}
    notes = []
    if not have_bsk:
        notes.append("Basilisk is not installed (pip install -e '.[basilisk]'): liebody "
                     "and the reference only, no ratios")
    version = None
    if have_bsk:
        from importlib.metadata import PackageNotFoundError
        from importlib.metadata import version as _v

        try:
            version = _v("bsk")
        except PackageNotFoundError:  # pragma: no cover - a source build
            version = "unknown"
    return {"basilisk": version, "mu": mu, "inertia": list(INERTIA), "radius": RADIUS,
            "default_method": liebody.GravityGradient.default_method,
            "scenes": scenes, "notes": notes}


# ------------------------------------------------------------------------- files


def csv_table(summary: dict) -> tuple[list[str], list[list]]:
    header = ["scene", "method", "source", "h_s", "steps", "seconds", "ns_per_step",
              "error_rad"]
    rows = []
    for key, sc in summary["scenes"].items():
        for r in sc["rows"]:
            rows.append([key, r["method"], r["source"], r["h"], r["steps"], r["seconds"],
                         r["ns_per_step"], r["error"]])
    return header, rows


def plot(summary: dict, plt):
    keys = list(summary["scenes"])
    fig, axes = plt.subplots(1, len(keys), figsize=(6.5 * len(keys), 5.5), squeeze=False)
    for ax, key in zip(axes[0], keys, strict=True):
        sc = summary["scenes"][key]
        lines: dict[str, list] = {}
        for r in sc["rows"]:
            if r["error"] is not None and r["error"] > 0:
                lines.setdefault(r["method"], []).append((r["seconds"], r["error"]))
        for name, pts in lines.items():
            pts.sort()
            if name == BASILISK:
                st = {"color": "#d62728", "ls": "-", "marker": "D", "ms": 4, "lw": 2,
                      "label": name}
            else:
                base = name.split(" ")[0]
                st = core.style(base)
                st["label"] = name
                if name.endswith("(axes)"):
                    st["ls"] = "--"
            ax.plot(*zip(*pts, strict=True), **st)
        floor = sc["reference"]["uncertainty"]
        ax.axhline(floor, color="0.5", lw=0.6, ls=":", label="reference uncertainty")
        ax.set_xscale("log")
        ax.set_yscale("log")
        words = [f"{lv}: x{v['ratio']:.0f} ({v['best']})" for lv, v in sc["ratios"].items()
                 if v["ratio"]]
        core.label_axes(ax, "wall time per run [s]", "final attitude error [rad]",
                        title=f"{sc['title']}, T = {sc['T']:g} s\nBasilisk / best liebody: "
                        + (", ".join(words) or "-"), title_size=8)
        ax.legend(fontsize=6, ncol=2)
    fig.suptitle("Gravity-gradient satellites: Basilisk (RK4) and liebody at equal accuracy")
    return fig


def report(summary: dict) -> str:
    lines = [f"== Basilisk {summary['basilisk'] or '(not installed)'} against liebody, "
             f"gravity-gradient satellite, I = {summary['inertia']}, r = "
             f"{summary['radius'] / 1e3:g} km, mu = {summary['mu']:.9g}; GravityGradient's "
             f"default method: {summary['default_method']}"]
    for key, sc in summary["scenes"].items():
        ref = sc["reference"]
        lines.append(f"-- {key}: {sc['title']}, T = {sc['T']:g} s; reference DOP853 "
                     f"({ref['dop853_steps']} steps) vs {ref['check']}: {ref['vs_check']:.1e}"
                     f" rad")
        by: dict[str, list] = {}
        for r in sc["rows"]:
            by.setdefault(r["method"], []).append(r)
        for name, rs in by.items():
            rs.sort(key=lambda r: -r["h"])
            finest = max(rs, key=lambda r: r["steps"])  # the least call overhead per step
            cells = ", ".join(f"h={r['h']:.3g}: {r['error']:.1e} in {r['seconds'] * 1e3:.3g} ms"
                              for r in rs)
            lines.append(f"{name:22s} {finest['ns_per_step']:7.0f} ns/step | {cells}")
        for lv, v in sc["ratios"].items():
            if v["ratio"] is None:
                lines.append(f"error {lv} rad: best liebody {v['best']}, Basilisk "
                             f"{'-' if v['basilisk_s'] is None else 'ok'}: no ratio")
                continue
            s2 = v["splitting2_ratio"]
            lines.append(
                f"error {lv} rad: Basilisk {v['basilisk_s'] * 1e3:.3g} ms, best liebody "
                f"{v['best']} {v['best_s'] * 1e6:.3g} us: x{v['ratio']:.0f}"
                f"{' (Basilisk cost an upper bound)' if v['ratio_is_upper_bound'] else ''}"
                + (f"; splitting2 x{s2:.0f}" if s2 else ""))
    lines += summary["notes"]
    return "\n".join(lines)


BENCHMARK = core.Benchmark(name="basilisk", settings=settings, run=run, csv=csv_table,
                           plot=plot, report=report)
