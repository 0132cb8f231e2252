"""The example notebooks (``examples/notebooks/*.py``, jupytext percent format) run from top to
bottom, as a documentation build executes them.

Reference: each notebook's own checks (energy conservation of the double pendulum, FMPy's
validation and simulation of the four-bar's FMU against ``simulate``, the quarter car's two
natural frequencies and the unit of its Bode magnitude, the middle-ear chain's stapes peak in
the band of normal ears, the two-sided elastic body against its unreduced FE model); here they
must run without error in a fresh namespace, from another working directory, with matplotlib's
Agg backend."""

from __future__ import annotations

import runpy
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[2] / "examples" / "notebooks").glob("*.py"))


def test_every_notebook_is_a_jupytext_percent_script():
    assert [p.name for p in NOTEBOOKS] == ["double_pendulum.py", "elastic_body.py",
                                           "four_bar_fmu.py", "middle_ear_chain_frf.py",
                                           "quarter_car_frf.py"]
    for path in NOTEBOOKS:
        text = path.read_text(encoding="utf-8")
        assert text.startswith("# ---\n# jupyter:\n#   jupytext:\n#     formats: py:percent")
        assert text.count("\n# %% [markdown]\n") >= 2 and text.count("\n# %%\n") >= 3


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs(path, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))
    namespace = runpy.run_path(str(path), run_name="__main__")
    assert namespace  # ran to its end
