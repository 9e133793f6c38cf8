"""Every script in examples/ runs to completion (exit 0, prints something) at a short end time."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCRIPTS = sorted(EXAMPLES.glob("*.py"))

# Short end times [s] that still reach the first impact(s); any other script gets DEFAULT_T_END.
T_END = {
    "published_case_1.py": 0.5,                  # impacts at 0.4515 s and 0.4749 s
    "published_case_2_from_case_file.py": 0.6,   # impact at 0.540 s
    "own_chain_in_a_sphere.py": 0.1,             # impact at 0.065 s
    "restitution_study.py": 0.25,                # impact at 0.202 s
    "fixed_base_fe_arm.py": 0.25,                # tip strikes at 0.194 s, chatter, zeno
    "symbolic_equations.py": 0.1,
    "telescoping_arm.py": 0.4,                   # first end-stop impact at 0.386 s
    "rod_on_a_frictional_incline.py": 1.5,       # 13 bounces, then resting: sticks (mu 0.6) / slides (mu 0.2)
    "compliant_vs_newton_arm.py": 0.06,          # the compliant contact lasts to 56 ms; n_e = 1, 2 only
    "compass_gait.py": 0.95,                     # one heel strike at 0.899 s per model; no limit-cycle search
    "rimless_wheel.py": 1.0,                     # a strike or two per initial speed (with trees)
}
DEFAULT_T_END = 0.05


def test_there_are_at_least_six_examples():
    assert len(SCRIPTS) >= 6, [p.name for p in SCRIPTS]


@pytest.mark.parametrize("script", SCRIPTS, ids=[p.name for p in SCRIPTS])
def test_example_runs(script, tmp_path):
    env = dict(os.environ, GIBBSIMPACT_EXAMPLE_T_END=str(T_END.get(script.name, DEFAULT_T_END)),
               GIBBSIMPACT_EXAMPLE_OUT=str(tmp_path), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, f"{script.name} exited {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    assert proc.stdout.strip(), f"{script.name} printed nothing"


def test_spin_up_figure_spans_the_time_simulated(tmp_path, monkeypatch):
    """examples/spin_up.py's figure of a short run (GIBBSIMPACT_EXAMPLE_T_END = 6 s, spin-up T_s = 15 s): the time
    axis ends at the last sample, not at T_s (no marker past the data), and the linear panel's limit follows its
    0.7 m deflection (1 m) instead of the +-1e4 m a full run needs."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("spin_up_example", EXAMPLES / "spin_up.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    figures = []
    monkeypatch.setattr(mod.plt, "close", figures.append)
    t = mod.np.linspace(0.0, 6.0, 61)
    curves = {(beam, src): (t, -0.7 * (t / 6.0) ** 2) for beam in ("linear", "stiffened")
              for src in ("reference", "gibbsimpact")}
    mod.figure(curves, tmp_path / "spin_up.png")
    linear, stiffened = figures[0].axes
    assert linear.get_xlim() == stiffened.get_xlim() == (0.0, 6.0)
    assert linear.get_ylim() == (-1.0, 1.0)
    assert not [line for line in linear.lines if line.get_xdata()[0] == mod.T_S]
