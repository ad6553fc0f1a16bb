"""What :mod:`bench.step_cost` runs in fresh processes: ``python -m bench.child NAME ARGS``.

Each child prints one line on stdout: numbers separated by spaces, or a JSON object
(``first_calls``). Nothing is imported at the top of this module (nor in
``bench/__init__.py``), so that ``import liebody`` is timed in a process that has loaded
only the interpreter; :mod:`bench.step_cost` starts these processes with a fresh
``NUMBA_CACHE_DIR``.

* ``pass`` — nothing (the interpreter's start-up, for scale);
* ``import`` — seconds of ``import liebody``;
* ``integrate_attr`` — seconds of ``import liebody; liebody.integrate`` (loads numba);
* ``first_call DT STEPS METHOD I1 I2 I3 L1 L2 L3`` — seconds from just before
  ``import liebody`` to the end of the first ``integrate()`` on that free body, and of
  that call alone;
* ``first_call_spec JSON`` — seconds from just before ``import liebody`` to the end of the
  first ``integrate()`` of the scene and method the JSON describes (a free body or a
  heavy top, built here without the benchmark problems), and of that call alone;
* ``first_calls STEPS DT_FREE DT_TOP METHOD ...`` — the set-up of the benchmark problems
  (the process's first numba call), then the first ``integrate()`` of each method on the
  HLW body and on the heavy top, as JSON.
"""

from __future__ import annotations

import sys
import time


def child_pass(args: list[str]) -> str:
    return ""


def child_import(args: list[str]) -> str:
    t0 = time.perf_counter()
    import liebody  # noqa: F401

    return f"{time.perf_counter() - t0!r}"


def child_integrate_attr(args: list[str]) -> str:
    t0 = time.perf_counter()
    import liebody

    liebody.integrate  # noqa: B018 - the lazy attribute that loads numba
    return f"{time.perf_counter() - t0!r}"


def child_first_call(args: list[str]) -> str:
    t0 = time.perf_counter()
    import liebody

    integrate = liebody.integrate
    dt, steps, method = float(args[0]), int(args[1]), args[2]
    moments, L0 = [float(v) for v in args[3:6]], [float(v) for v in args[6:9]]
    scene = liebody.FreeBody(liebody.RigidBody(moments, check_triangle=False))
    t = time.perf_counter()
    integrate(scene, L0=L0, dt=dt, steps=steps, method=method)
    return f"{time.perf_counter() - t0!r} {time.perf_counter() - t!r}"


def child_first_call_spec(args: list[str]) -> str:
    import json

    spec = json.loads(args[0])
    t0 = time.perf_counter()
    import liebody

    body = liebody.RigidBody(spec["moments"], check_triangle=False)
    if spec["scene"] == "top":
        scene = liebody.HeavyTop(body, spec["mass"], spec["cm"], g=spec["g"])
    else:
        scene = liebody.FreeBody(body)
    t = time.perf_counter()
    liebody.integrate(scene, q0=spec["q0"], L0=spec["L0"], dt=spec["dt"], steps=spec["steps"],
                      method=spec["method"])
    return f"{time.perf_counter() - t0!r} {time.perf_counter() - t!r}"


def child_first_calls(args: list[str]) -> str:
    import json
    import warnings

    t0 = time.perf_counter()
    import liebody

    integrate = liebody.integrate
    t_import = time.perf_counter() - t0
    from bench.problems import problems

    warnings.simplefilter("ignore", RuntimeWarning)
    steps, dt_free, dt_top = int(args[0]), float(args[1]), float(args[2])
    t0 = time.perf_counter()
    cases = (("free", problems()["hlw"], dt_free), ("top", problems()["top"], dt_top))
    out = {"import_s": t_import, "setup_s": time.perf_counter() - t0, "methods": {}}
    for name in args[3:]:
        m = liebody.methods()[name]
        row = {}
        for key, pb, dt in cases:
            if not m.supports(pb.scene):
                row[key] = None
                continue
            t = time.perf_counter()
            try:
                integrate(pb.scene, q0=pb.q0, L0=pb.L0, dt=dt, steps=steps, method=name)
            except Exception as exc:
                row[key + "_error"] = f"{type(exc).__name__}: {exc}"
            row[key] = time.perf_counter() - t
        out["methods"][name] = row
    return json.dumps(out)


CHILDREN = {"pass": child_pass, "import": child_import, "integrate_attr": child_integrate_attr,
            "first_call": child_first_call, "first_call_spec": child_first_call_spec,
            "first_calls": child_first_calls}


if __name__ == "__main__":
    print(CHILDREN[sys.argv[1]](sys.argv[2:]))
