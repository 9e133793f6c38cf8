"""Walls as plain data (gibbsimpact.io.plain_data): every kind, containers and obstacles, read back equal."""

from __future__ import annotations

import json

import pytest

import gibbsimpact as gi
from gibbsimpact.io.plain_data import wall_from_dict, wall_to_dict


@pytest.mark.parametrize("wall", [gi.Circle(1.5), gi.Circle(0.1, (0.3, 0.4), inside=False, friction=0.2),
                                  gi.Sphere(0.2, (-0.3, 0.5, 0.1), restitution=0.5, inside=False), gi.Sphere(2.0),
                                  gi.Plane((0.0, -1.0, 0.0), (0.0, 2.0, 0.0))])
def test_walls_round_trip_through_json(wall):
    d = json.loads(json.dumps(wall_to_dict(wall)))
    assert wall_from_dict(d) == wall
    # A container's dict has no "inside" key (files of earlier versions read the same); an obstacle's says false.
    assert d.get("inside", True) is getattr(wall, "inside", True)
