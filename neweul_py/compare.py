"""Compare results against references: ``neweul_py.compare.compare(result, reference, ...)``.

The implementation lives in :mod:`neweul_py.analysis.compare` (NumPy/SciPy only); this module
is its public home at the top level, as ``neweul compare`` is on the command line.

Examples
--------
>>> from neweul_py.compare import compare
>>> cmp = compare("out/run.csv", "exudyn_run.csv", rtol={"phi": 1e-2})   # doctest: +SKIP
>>> print(cmp.table()); assert cmp.passed                                # doctest: +SKIP
"""

from __future__ import annotations

from .analysis.compare import Comparison, SignalError, compare, mac_matrix
from .analysis.compare_io import Table, as_table, read_table

__all__ = ["Comparison", "SignalError", "Table", "as_table", "compare", "mac_matrix",
           "read_table"]
