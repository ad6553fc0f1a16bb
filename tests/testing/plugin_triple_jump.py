"""A user's module that registers a method, for ``python -m bench --register MODULE``."""

import liebody

G1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
liebody.register_composition("plugin_triple_jump", [G1, 1.0 - 2.0 * G1, G1], replace=True)
