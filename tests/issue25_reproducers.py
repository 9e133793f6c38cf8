"""The random tester's reproducers of issue 25, each key mapped one-to-one to gi.Link, gi.Chain,
gi.Model, the walls and gi.simulate (the tests of items 6, 7 and 9 build their runs here)."""

import math

import numpy as np

import gibbsimpact as gi
from gibbsimpact.dynamics.inputs import InputSpec, named_inputs

_JOINTS = {"R": lambda d: gi.Revolute(),
           "Pa": lambda d: gi.SlidingPrismatic(angle=d.get("angle", 0.0), half_length=d.get("half_length", 0.0),
                                               range=tuple(d["range"])),
           "Pb": lambda d: gi.FixedPrismatic(angle=d.get("angle", 0.0), range=tuple(d["range"]))}


def _link(d):
    # The random tester's format predates foreshortening: its links are linear beams (geometric_stiffening=False,
    # the default before issue 24), and the reproducers are those runs.
    modes = [gi.Mode(kind, direction, number) for kind, direction, number in d.get("modes", [])]
    return gi.Link(d["length"], d["mass_per_length"], tuple(d["EI"]), modes=modes,
                   geometric_stiffening=d.get("geometric_stiffening", False),
                   rotary_inertia=tuple(d.get("rotary_inertia", (0.0, 0.0, 0.0))), elements=d.get("elements", 0),
                   element_directions=tuple(d.get("element_directions", ("y",))))


def _wall(d):
    if d["type"] == "plane":
        return gi.Plane(d["point"], d["normal"], restitution=d.get("restitution"), friction=d.get("friction", 0.0))
    if d["type"] == "circle":
        return gi.Circle(d["radius"], tuple(d["center"][:2]), restitution=d.get("restitution"), friction=d.get("friction", 0.0))
    return gi.Sphere(d["radius"], d["center"], restitution=d.get("restitution"), friction=d.get("friction", 0.0))


def build(case: dict):
    """(model, walls, simulate keyword arguments) of one reproducer."""
    base = case.get("base", "free")
    if isinstance(base, dict):
        base = gi.FixedBase(tuple(base["position"]), base["angle"])
    joints = [_JOINTS[j["type"]](j) for j in case["joints"]] if "joints" in case else None
    model = gi.Model(gi.Chain([_link(d) for d in case["links"]], joints=joints, base=base),
                     gravity=tuple(case["gravity"]))
    walls = [_wall(w) for w in case["walls"]]
    kw = dict(q0=np.array(case["q0"]), qdot0=np.array(case["qdot0"]), t_span=tuple(case["t_span"]),
              restitution=case["restitution"], **case.get("solver", {}))
    specs = [InputSpec(i["coordinate"], i["kind"], {k: (math.inf if v == "inf" else v) for k, v in i.items()
                                                     if k not in ("coordinate", "kind")})
             for i in case.get("inputs", [])]
    if specs:
        kw["inputs"] = named_inputs(specs, model.coordinate_names)
    return model, walls, kw


#: Item 6: a rod with one clamped-clamped mode dropped flat 5 mm onto a floor (e = 0).
ITEM6 = {"links": [{"length": 1.0, "mass_per_length": 1.0, "EI": [20.0, 20.0],
                    "modes": [["clamped-clamped", "y", 1]], "rotary_inertia": [0.0001, 5e-05, 5e-05]}],
         "gravity": [0.0, -9.81, 0.0], "walls": [{"type": "plane", "point": [0.0, 0.0, 0.0],
                                                  "normal": [0.0, 1.0, 0.0]}],
         "q0": [-0.5, 0.005, 0.0, 0.0, 0.0, 0.0, 0.0], "qdot0": [0.0] * 7, "restitution": 0.0,
         "t_span": [0.0, 0.1], "solver": {}}

#: Item 7: an FE arm in a circle with mu = 0.053 and ramp torques.
ITEM7 = {"links": [{"length": 0.3159126176362062, "mass_per_length": 2.911522841387032,
                    "EI": [184.4340433491308, 184.4340433491308], "modes": [], "rotary_inertia": [0.0, 0.0, 0.0],
                    "elements": 1, "element_directions": ["y"]},
                   {"length": 1.1170237575199542, "mass_per_length": 0.20700283329051805,
                    "EI": [100.78559604767294, 100.78559604767294], "modes": [], "rotary_inertia": [0.0, 0.0, 0.0],
                    "elements": 1, "element_directions": ["y"]}],
         "base": {"position": [0.4047558581929188, -0.614358501649833, 0.0], "angle": -2.432424429512353},
         "gravity": [0.0, -9.81, 0.0],
         "walls": [{"type": "circle", "radius": 0.621815081173743, "center": [0.2512969934097621, -0.012074919409083562],
                    "restitution": 0.11907218972445777, "friction": 0.05325148695797131}],
         "inputs": [{"coordinate": "theta_1", "kind": "ramp", "slope": -2.0278395411291528,
                     "start": 0.03499928030867866, "end": "inf"},
                    {"coordinate": "theta_2", "kind": "ramp", "slope": 0.5917994197664376,
                     "start": 0.024257858997894444, "end": 0.17501566712448485}],
         "q0": [-0.9649883468186435, -1.4110263662215186, 0.0008346366934907845, 0.0061393672007721885,
                0.004635548338688559, -0.0023516976309980956],
         "qdot0": [-1.7453439447626444, -0.5279540386192045, 0.0, -0.08848445421897788, 0.29360951877577607,
                   -0.42570314955350785],
         "restitution": 1.0, "t_span": [0.0, 0.19478241749718514], "solver": {}}
