"""The source distribution and the package's typing marker (pyproject.toml, MANIFEST.in).

Reference: the archive that ``python -m build --sdist`` writes, against the files git tracks:
the sdist holds every tracked test, example, document, benchmark and generated module, the
FMU layer's C sources and headers with their license, and ``py.typed`` (PEP 561)."""

from __future__ import annotations

import subprocess
import sys
import tarfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _tracked(*folders: str) -> set[str]:
    out = subprocess.run(["git", "ls-files", "--", *folders], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout
    return {line for line in out.splitlines() if line}


def test_sdist_holds_tests_examples_docs_and_the_typing_marker(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "build", "--sdist", "--no-isolation", "--skip-dependency-check",
         "--outdir", str(tmp_path), str(ROOT)], capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    [archive] = tmp_path.glob("neweul_py-*.tar.gz")
    with tarfile.open(archive) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    wanted = _tracked("tests", "examples", "docs", "benchmarks", "generated")
    assert wanted and wanted <= names, sorted(wanted - names)[:10]
    assert {"neweul_py/py.typed", "neweul_py/codegen/fmi2/neweul_fmi2.c",
            "neweul_py/codegen/fmi2/fmi2Functions.h", "neweul_py/codegen/fmi2/LICENSE.txt",
            "README.md", "LICENSE", "CHANGELOG.md", "pyproject.toml"} <= names
    assert not any("__pycache__" in n or n.endswith((".pyc", ".so")) for n in names)
    assert (ROOT / "neweul_py" / "py.typed").is_file()
