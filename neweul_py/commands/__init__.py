"""Sub-commands of the ``neweul`` CLI, one module each (see :mod:`neweul_py.cli`)."""
