"""Case-file texts and helpers shared by the tests of gibbsimpact.case: a small valid case (GOOD), a
rod and an arm on a fixed base (ROD, ARM), R-Pb and R-Pa chains (TWO, PB, PA, START, DROP)."""

from __future__ import annotations

from pathlib import Path

import pytest

import gibbsimpact as gi
from gibbsimpact.case import CaseError
from conftest import PB_DROP_CASE

CASES = Path(__file__).resolve().parents[2] / "cases"


# A small valid case (two rigid links would be singular when straight; one flexible
# link with rotary inertia is the smallest regular chain).
GOOD = """
name = "tiny"
gravity_m_per_s2 = [0.0, -9.81, 0.0]
restitution = 1.0

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 20.0
rotary_inertia_kg_m = [5e-5, 2.5e-5, 2.5e-5]
modes = [{ kind = "clamped-clamped", direction = "y" }]

[[walls]]
type = "circle"
radius_m = 1.5

[initial.coordinates]
X1_m = -0.5

[time]
t_end_s = 0.1
"""


def write(tmp_path, text, name="case.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def problems_of(tmp_path, text):
    with pytest.raises(CaseError) as info:
        gi.load_case(write(tmp_path, text))
    return info.value


# A rigid rod on a fixed base, no gravity, driven by a constant motor torque.
ROD = """
name = "rod"
gravity_m_per_s2 = [0.0, 0.0, 0.0]

[base]
type = "fixed"
position_m = [0.5, 1.0]
angle_deg = 30.0

[[links]]
length_m = 0.8
mass_per_length_kg_per_m = 2.0
EI_N_m2 = 10.0

[[inputs]]
coordinate = "theta_1"
kind = "constant"
value_N_m = 0.3

[time]
t_end_s = 0.5
"""


# Two links on a fixed base, the second with one finite element: theta_1, theta_2
# (angles), delta_2_1 (tip deflection, m) and delta_2_2 (tip slope, rad).
ARM = """
gravity_m_per_s2 = [0.0, -9.81, 0.0]

[base]
type = "fixed"

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
EI_N_m2 = 25.0

[[links]]
length_m = 0.6
mass_per_length_kg_per_m = 0.5
EI_N_m2 = 8.0
elements = 1

[time]
t_end_s = 0.1
"""


def with_inputs(text, *tables):
    """text plus one [[inputs]] table per dict."""
    def toml(v):
        return f'"{v}"' if isinstance(v, str) else repr(v)

    return text + "".join("\n[[inputs]]\n" + "".join(f"{k} = {toml(v)}\n" for k, v in t.items()) for t in tables)


# A rigid rod hanging from a guide at the base origin (Pb, joint 1): d_1'' = g, so from
# d_1 = 0.2 m at rest it reaches d_max = 0.5 m at t = sqrt(2 * 0.3 / 9.81) = 0.24731 s.
DROP = PB_DROP_CASE


# An R-Pb chain and an R-Pa chain on a fixed base, finite-element links (linear beams: a Pb link
# and a Pa host must be): the joint tables are appended to the second [[links]] table.
TWO = """
gravity_m_per_s2 = [0.0, -9.81, 0.0]

[base]
type = "fixed"

[[links]]
length_m = 1.0
mass_per_length_kg_per_m = 1.0
geometric_stiffening = false
EI_N_m2 = 25.0
elements = 2

[[links]]
length_m = 0.6
mass_per_length_kg_per_m = 0.5
geometric_stiffening = false
EI_N_m2 = 8.0
elements = 2
"""


PB = TWO + '\n[links.joint]\ntype = "Pb"\nrange_m = [0.2, 0.6]\n'


PA = TWO + '\n[links.joint]\ntype = "Pa"\nangle_rad = 0.6\nhalf_length_m = 0.04\nrange_m = [0.1, 0.95]\n'


START = "\n[initial.coordinates]\nd_2_m = 0.4\n\n[time]\nt_end_s = 0.1\n"
