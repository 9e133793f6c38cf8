"""The one table of joint kinds (model.joints.JOINT_KINDS) against what each joint class and the
kernel say, and the coordinates a Model names from it (docs/theory.md §7, formulation §17)."""

import pytest

import gibbsimpact as gi
from gibbsimpact.kernel.layout import JOINT_PA, JOINT_PB, JOINT_R, JOINT_WELD
from gibbsimpact.model.joints import JOINT_KINDS, JOINT_TYPES

JOINTS = {"R": gi.Revolute(), "Pa": gi.SlidingPrismatic(range=(0.1, 0.5)), "Pb": gi.FixedPrismatic(range=(0.2, 0.8)),
          "W": gi.Weld(0.2)}


def test_every_joint_class_has_its_row():
    assert sorted(cls.kind for cls in JOINT_TYPES) == sorted(JOINT_KINDS)
    for code, jt in JOINTS.items():
        spec = jt.spec
        assert spec is JOINT_KINDS[code] and spec.code == jt.kind == code
        assert spec.name == type(jt).__name__
        # a joint turns, slides, or (a weld) has no coordinate; a prismatic one is a carriage or a guide
        assert spec.has_coordinate == (spec.turns or spec.prismatic) and not (spec.turns and spec.prismatic)
        assert spec.prismatic == (spec.carriage or spec.guide) and not (spec.carriage and spec.guide)
        # the prismatic joints have a travel, the others none
        assert hasattr(jt, "range") == spec.prismatic


def test_kernel_codes_are_the_kernels():
    assert {c: k.kernel_code for c, k in JOINT_KINDS.items()} == {
        "R": JOINT_R, "Pa": JOINT_PA, "Pb": JOINT_PB, "W": JOINT_WELD}


@pytest.mark.parametrize("kinds, names, units", [
    (("R", "Pb", "Pa"), ("theta_1", "d_2", "d_3"), ("rad", "m", "m")),
    (("Pb", "R"), ("d_1", "theta_2"), ("m", "rad")),
    (("R", "W", "R"), ("theta_1", "theta_3"), ("rad", "rad")),
])
def test_coordinate_names_and_units_of_a_model(kinds, names, units):
    rigid = gi.Link(1.0, 1.0, 20.0)
    joints = [{"R": gi.Revolute(), "W": gi.Weld(0.3), "Pa": gi.SlidingPrismatic(range=(0.1, 0.5)),
               "Pb": gi.FixedPrismatic(range=(0.2, 0.8))}[k] for k in kinds]
    model = gi.Model(gi.Chain([rigid] * len(kinds), joints=joints, base=gi.FixedBase((0.0, 0.0))))
    assert model.coordinate_names == names and model.coordinate_units == units
    assert model.joint_kinds == kinds and tuple(s.code for s in model.joint_specs) == kinds
    assert model.theta_index == tuple(-1 if k == "W" else names.index(JOINT_KINDS[k].coordinate_name(i))
                                      for i, k in enumerate(kinds, start=1))
