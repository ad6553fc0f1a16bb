"""Physics models: one module per model (see ``docs/design.md``, "Physics models").

A model module owns its code (a ``TORQUE_*`` code of :mod:`liebody._kernels.stages`),
the layout of its parameters (a row per body and a block shared by every body), its
compiled torque and potential kernels and its Python-side description
(:class:`liebody.scenes.TorqueModel`). The only place that dispatches on model codes is
:mod:`liebody._models.dispatch`. This package imports no numba: the model modules with
kernels are imported on first use.
"""
