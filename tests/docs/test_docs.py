"""The documentation (docs/, mkdocs.yml, the API reference from the docstrings) builds without warnings.

Runs ``mkdocs build --strict`` as CI would; skipped when the docs tools (the
``test`` or ``docs`` extra: mkdocs, mkdocstrings[python]) are not installed.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mkdocs")
pytest.importorskip("mkdocstrings")
pytest.importorskip("mkdocstrings_handlers.python")

import gibbsimpact  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    site_dir = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site_dir)],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )
    return proc, site_dir


def test_mkdocs_build_strict_without_warnings(site):
    proc, _ = site
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, output
    warnings = [line for line in output.splitlines() if "WARNING" in line or "ERROR" in line]
    assert not warnings, "\n".join(warnings)


def test_api_reference_documents_the_public_api(site):
    proc, site_dir = site
    assert proc.returncode == 0, proc.stdout + proc.stderr
    page = (site_dir / "api" / "index.html").read_text(encoding="utf-8")
    ids = set(re.findall(r'id="(gibbsimpact\.[\w.]+)"', page))
    names = {i.rsplit(".", 1)[-1] for i in ids}
    missing = [n for n in gibbsimpact.__all__ if n != "__version__" and n not in names]
    assert not missing, f"public names without an entry in docs/api.md: {missing}"
    for required in ("gibbsimpact.dynamics.gibbs_appell.forward_dynamics", "gibbsimpact.dynamics.kinematics.frames",
                     "gibbsimpact.simulation.validity.check_state", "gibbsimpact.study.sweep.sweep"):
        assert required in ids
