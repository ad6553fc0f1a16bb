"""liebody's benchmarks: speed against accuracy, long horizons, and where methods fail.

Not part of the installed package: run from the root of a source checkout,

    python -m bench [--quick] [--only NAME ...] [--out DIR] [--no-progress]

Each benchmark compares liebody's methods with each other and with what users would
otherwise pick (scipy's ``solve_ivp``; MuJoCo where installed) on the same problems
in one run, and writes ``NAME.json``, ``NAME.csv`` and a chart ``NAME.png`` into the
output folder (``bench/results`` by default):

* :mod:`bench.step_cost` — ns per step of every method beside a C reference, compile
  time (empty and filled cache) and import time;
* :mod:`bench.work_precision` — global error against wall time per unit of simulated
  time at ``T = 10`` and ``T = 1e4``, speed ratios at fixed error levels, and the
  horizon beyond which the geometric methods beat ``rk4``;
* :mod:`bench.long_horizon` — energy, ``|q|`` and momentum drift over ``1e8`` steps;
* :mod:`bench.stability` — where each method stops keeping the energy bounded, the
  nutation resonance, and Euler angles against quaternions near gimbal lock;
* :mod:`bench.ensemble` — ns per body-step of ensembles against the number of bodies
  and threads: a loop over ``integrate()``, the scalar and the SIMD batch drivers,
  MuJoCo's threaded ``rollout``, ``liebody.distributed`` on a Dask LocalCluster;
* :mod:`bench.basilisk` — gravity-gradient satellites (a tumble, a libration) in the
  Basilisk astrodynamics framework and in liebody at equal accuracy (without Basilisk
  installed, the liebody side only);
* :mod:`bench.coupled` — ns per body-step of a lattice of dipolar rotors
  (:class:`liebody.DipoleLattice`) against ``N``, its free part alone, and the same
  splitting written as a plain numba loop.

:mod:`bench.core` runs them (command line, timing, files, charts, reports); each module
fills in one :class:`bench.core.Benchmark`. :mod:`bench.problems` holds the shared
problems and references, :mod:`bench.peers` scipy and MuJoCo, :mod:`bench.child` what
runs in fresh processes. This file imports nothing: ``python -m bench.child`` times
``import liebody`` in a process that has loaded nothing else.
"""

#: the benchmark modules, in the order ``python -m bench`` runs them
BENCHMARKS = ("step_cost", "work_precision", "long_horizon", "stability", "ensemble",
              "basilisk", "coupled")
