"""The jit policy's wrappers: no kernel gets numba's C wrapper, and an inner helper (called
only from kernels) has no Python entry point, so a call from Python must raise instead
of jumping to the missing wrapper."""

from __future__ import annotations

import numpy as np
import pytest
from numba.core import config

from liebody._kernels import exact, quat

pytestmark = pytest.mark.skipif(config.DISABLE_JIT, reason="wrappers exist only compiled")


def test_an_inner_helper_called_from_python_raises_a_type_error():
    with pytest.raises(TypeError, match="only from other kernels"):
        quat.qaxis_rotation(1.0, 0.0, 0.0, 0.0, 2, 0.0, 1.0)
    with pytest.raises(TypeError, match="only from other kernels"):
        exact._eval(np.zeros(exact.PLAN_SIZE), 0.0)


def test_kernels_compile_with_the_wrapper_options():
    assert quat.qaxis_rotation.targetoptions.get("no_cpython_wrapper") is True
    for kernel in (quat.qmul, exact.exact_flow, exact.exact_flow_times):
        options = kernel.targetoptions
        assert options.get("no_cfunc_wrapper") is True
        assert not options.get("no_cpython_wrapper"), kernel


def test_entry_points_built_on_inner_helpers_run_from_python():
    """exact_flow calls the inner plan and evaluation (and its plan lives on its stack):
    at t = 0 it returns its input; a spherical body turns about L at |L| / I."""
    r = exact.exact_flow(1.0, 2.0, 3.0, 1.0, 0.0, 0.0, 0.0, 0.3, 1.0, 0.2, 0.0)
    np.testing.assert_array_equal(r, (1.0, 0.0, 0.0, 0.0, 0.3, 1.0, 0.2))
    w, x, y, z, *_ = exact.exact_flow(2.0, 2.0, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0)
    np.testing.assert_allclose((w, x, y, z), (np.cos(0.25), 0.0, 0.0, np.sin(0.25)),
                               rtol=0, atol=1e-16)
