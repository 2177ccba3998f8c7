"""Sub-commands of ``fringe3d``: one module each, each with ``register(app)``."""
