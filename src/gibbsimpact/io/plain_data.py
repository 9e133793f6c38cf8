"""Models and walls as plain data (JSON-ready dicts): what result.npz stores of them, read back exactly.

Numbers from 1 in the files; a model with a callable mass_per_length or EI cannot be stored.
"""

from __future__ import annotations

from ..contact.walls import WALL_KINDS
from ..model import Chain, FixedBase, FixedPrismatic, Link, Model, Revolute, RigidBody, SlidingPrismatic, Weld
from ..model.joints import JOINT_KINDS
from ..model.modes import Mode

__all__ = ["model_from_dict", "model_to_dict", "wall_from_dict", "wall_to_dict"]


def model_to_dict(model: Model) -> dict:
    """Plain-data description of a model from which :func:`model_from_dict` rebuilds it.

    Raises ValueError for links with callable mass_per_length or EI (not storable).
    """
    links = []
    for i, lk in enumerate(model.chain.links, start=1):
        if callable(lk.mass_per_length) or any(callable(e) for e in lk.EI):
            raise ValueError(
                f"link {i} has a callable mass_per_length or EI, which cannot be stored; "
                "save the trajectory with to_csv instead"
            )
        links.append({
            "length": lk.length, "mass_per_length": lk.mass_per_length, "EI": list(lk.EI),
            "modes": [[m.kind, m.direction, int(m.number)] for m in lk.modes],
            "rotary_inertia": list(lk.rotary_inertia),
            "elements": int(lk.elements), "element_directions": list(lk.element_directions),
            "damping": float(lk.damping), "geometric_stiffening": bool(lk.geometric_stiffening),
            "bodies": [{"mass": b.mass, "center": list(b.center), "inertia": [list(r) for r in b.inertia], "at": b.at}
                       for b in lk.bodies],
        })
    d = {"links": links, "gravity": [float(g) for g in model.gravity]}
    base = model.chain.base
    if not model.free_base:
        d["base"] = {"type": "fixed", "position": list(base.position), "angle": float(base.angle)}
    elif base == "planar":
        d["base"] = {"type": "planar"}
    joints = []
    for jt in model.chain.joints:
        j = {"kind": jt.kind}
        if jt.spec.prismatic:
            j.update(angle=float(jt.angle), range=[float(v) for v in jt.range])
        if jt.spec.carriage:
            j["half_length"] = float(jt.half_length)
        if not jt.spec.has_coordinate:
            j["angle"] = float(jt.angle)
        R = getattr(jt, "axis_rotation", None) or getattr(jt, "rotation", None)
        if R is not None:
            j["rotation"] = [list(r) for r in R]
        joints.append(j)
    d["joints"] = joints
    if not model.chain.serial:  # a tree (formulation §17)
        d["parents"] = list(model.chain.parents)
        d["attach"] = list(model.chain.attach)
    quad = getattr(model, "quadrature", None)
    if quad is not None:
        d["quadrature"] = [int(v) for v in quad]
    return d


def model_from_dict(d: dict) -> Model:
    """Inverse of :func:`model_to_dict`."""
    links = [
        Link(length=lk["length"], mass_per_length=lk["mass_per_length"], EI=tuple(lk["EI"]),
             modes=tuple(Mode(k, dr, n) for k, dr, n in lk["modes"]), rotary_inertia=tuple(lk["rotary_inertia"]),
             elements=int(lk.get("elements", 0)), element_directions=tuple(lk.get("element_directions", ("y",))),
             damping=float(lk.get("damping", 0.0)),
             bodies=tuple(RigidBody(b["mass"], tuple(b["center"]), b["inertia"], b["at"]) for b in lk.get("bodies", ())),
             # files written before foreshortening existed hold linear beams
             geometric_stiffening=bool(lk.get("geometric_stiffening", False)))
        for lk in d["links"]
    ]
    kw = {"quadrature": tuple(d["quadrature"])} if "quadrature" in d else {}
    b = d.get("base")
    if b is None:
        base = "free"
    elif b.get("type") == "planar":
        base = "planar"
    else:
        base = FixedBase(tuple(b["position"]), b["angle"])
    joints = []
    for j in d.get("joints", ["R"] * len(links)):
        j = {"kind": j} if isinstance(j, str) else j  # files written before prismatic joints: kinds only
        joints.append(_joint_from_dict(j))
    chain = Chain(tuple(links), joints=tuple(joints), base=base, parents=d.get("parents"), attach=d.get("attach"))
    return Model(chain, gravity=tuple(d["gravity"]), **kw)


def _joint_from_dict(j: dict):
    """The joint of one entry of model_to_dict's "joints" (the inverse of its writer, by JOINT_KINDS)."""
    spec = JOINT_KINDS[j["kind"]]
    if spec.turns:
        return Revolute(axis_rotation=j.get("rotation"))
    if not spec.has_coordinate:
        return Weld(angle=j["angle"], rotation=j.get("rotation"))
    if spec.carriage:
        return SlidingPrismatic(angle=j["angle"], half_length=j["half_length"], range=tuple(j["range"]))
    return FixedPrismatic(angle=j["angle"], range=tuple(j["range"]))


def wall_to_dict(w) -> dict:
    """A wall as the result files store it: its kind (walls.WALL_KINDS), parameters, restitution and friction."""
    if WALL_KINDS.get(getattr(w, "kind", None)) is not type(w):
        raise ValueError(f"cannot store wall {w!r}")
    d = {"type": w.kind, **w.parameters(), "restitution": w.restitution}
    if w.friction:
        d["friction"] = w.friction
    if getattr(w, "stiffness", None) is not None:  # the compliant law (contact.compliant)
        d.update(stiffness=w.stiffness, exponent=w.exponent, damping=w.damping)
    return d


def wall_from_dict(d: dict):
    """The wall of a wall_to_dict dict."""
    kind = WALL_KINDS[d["type"]]
    given = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items() if k not in ("type", "friction")}
    w = kind(**given, friction=d.get("friction", 0.0))
    if "normal" in d:  # the stored normal is already unit length: keep its exact digits
        object.__setattr__(w, "normal_vector", tuple(float(v) for v in d["normal"]))
    return w
