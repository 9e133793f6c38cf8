"""Symbolic equations (gibbsimpact.symbolic): two derivation routes against the numeric kernel.

* eqs.numeric() and the module written by eqs.to_python() reproduce model.mass_matrix(q)
  and M qddot = forcing with qddot = model.forward_dynamics, to 1e-12 relative, on the
  published chains and on chains with 1-4 links, planar and spatial, modes and finite
  elements, rotary inertia, a free and a fixed base, a general (two-axis) Rodrigues end
  rotation, and at phi = 0;
* the Gibbs-Appell route (recursive 4x4 moment form) and the Lagrange route (T and V of the
  same moment form, sympy differentiation) agree to 1e-12 for n = 1 ... 3;
* writers (LaTeX, Python), operation counts, bad input, import cost.
"""

import functools
import importlib.util
import shutil
import subprocess
import sys

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.dynamics.kinematics import _rodrigues_coefficients
from gibbsimpact.symbolic.derive import METHODS, rodrigues_coefficient

from conftest import random_state, single_link_sphere_model, two_link_circle_model

RTOL = 1e-12
N_STATES = 6


def _planar_three_mixed():
    # clamped-free mode (tip deflection and Rz(v'(l)) at joint 2), 2 Hermite elements, a rigid tip link
    a = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-free", "y")], rotary_inertia=(1e-3, 2e-3, 3e-3), geometric_stiffening=False)
    b = gi.Link(0.7, 1.5, 12.0, elements=2, rotary_inertia=(0.0, 0.0, 1e-3), geometric_stiffening=False)
    c = gi.Link(0.5, 0.8, 30.0)
    return gi.Model(gi.Chain([a, b, c]), gravity=(0.0, -9.81, 0.0))


def _fixed_base_two():
    a = gi.Link(1.0, 1.2, 25.0, elements=2, geometric_stiffening=False)
    b = gi.Link(0.6, 0.5, 8.0, modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "y", 2)], geometric_stiffening=False)
    return gi.Model(gi.Chain([a, b], base=gi.FixedBase((0.1, 0.2), 0.3)), gravity=(0.0, -9.81, 0.0))


def _spatial_two_rodrigues():
    # link 1: one element in y and z, so phi = (0, -w'(l), v'(l)) has two components:
    # the general Rodrigues rotation with a(s), b(s); link 2 a clamped-free z-mode
    a = gi.Link(0.8, 1.3, (15.0, 25.0), elements=1, element_directions=("y", "z"),
                rotary_inertia=(2e-3, 1e-3, 1.5e-3), geometric_stiffening=False)
    b = gi.Link(0.9, 1.1, 16.0, modes=[gi.Mode("clamped-free", "z")], rotary_inertia=(1e-3, 1e-3, 1e-3), geometric_stiffening=False)
    return gi.Model(gi.Chain([a, b]), gravity=(0.3, -9.81, 0.5))


def _planar_four():
    link = gi.Link(0.5, 1.0, 10.0, modes=[gi.Mode("clamped-clamped", "y")], geometric_stiffening=False)
    tip = gi.Link(0.4, 0.7, 6.0, modes=[gi.Mode("clamped-free", "y")], geometric_stiffening=False)
    return gi.Model(gi.Chain([link, link, link, tip]), gravity=(0.0, -9.81, 0.0))


def _fixed_base_spatial_one():
    link = gi.Link(1.0, 1.0, (20.0, 30.0), modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")],
                   rotary_inertia=(1e-3, 1e-3, 1e-3), geometric_stiffening=False)
    return gi.Model(gi.Chain([link], base=gi.FixedBase((0.0, 0.5, 0.2), -0.4)), gravity=(0.0, 0.0, -9.81))


def _fixed_base_bodies():
    """Attached bodies (docs/theory.md §6.8): an axial payload on a bending link's tip, an off-axis one with
    products of inertia on a rigid link, bent out of plane by link 1's z-mode."""
    tip = gi.RigidBody(0.4, center=(0.1, 0.0, 0.0), inertia=(0.002, 0.01, 0.012))
    off = gi.RigidBody(0.3, center=(0.1, 0.05, -0.03), inertia=[[0.01, 0.001, 0.002], [0.001, 0.02, 0.0],
                                                                  [0.002, 0.0, 0.02]])
    links = [gi.Link(1.0, 1.0, (20.0, 30.0), modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")],
                     rotary_inertia=(1e-3, 1e-3, 1e-3), bodies=[tip], geometric_stiffening=False),
             gi.Link(0.5, 1.0, 1.0, rotary_inertia=(1e-3, 1e-3, 1e-3), bodies=[off])]
    return gi.Model(gi.Chain(links, base=gi.FixedBase((0.0, 0.5, 0.2), -0.4)), gravity=(0.0, -9.81, 0.0))


def _planar_chain(n):
    """n links, one clamped-free y-mode each, small rotary inertia (the benchmark chain)."""
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-free", "y")], rotary_inertia=(1e-3, 1e-3, 1e-3), geometric_stiffening=False)
    return gi.Model(gi.Chain([link] * n), gravity=(0.0, -9.81, 0.0))


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return ((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c))


def _fixed_tree():
    """A tree on a fixed base (formulation §17): a bending root (y and z modes), a child at its tip on a revolute
    axis turned by Rx(0.4), a welded flexible child at x_a = 0.6 m on the root, and a rigid grandchild."""
    root = gi.Link(1.0, 1.0, (20.0, 30.0), modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")],
                   rotary_inertia=(1e-3, 1e-3, 1e-3), geometric_stiffening=False)
    arm = gi.Link(0.6, 0.8, 12.0, modes=[gi.Mode("clamped-free", "y")], rotary_inertia=(1e-3, 2e-3, 1e-3),
                  geometric_stiffening=False)
    twig = gi.Link(0.4, 0.5, 10.0, elements=1, element_directions=("y", "z"), geometric_stiffening=False)
    tip = gi.Link(0.3, 0.7, 1.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
    joints = [gi.Revolute(), gi.Revolute(axis_rotation=_rx(0.4)), gi.Weld(angle=0.5, rotation=_rx(-0.3)), gi.Revolute()]
    chain = gi.Chain([root, arm, twig, tip], joints=joints, parents=[-1, 0, 0, 1], attach=[None, None, 0.6, None],
                     base=gi.FixedBase((0.0, 0.5, 0.2), -0.4))
    return gi.Model(chain, gravity=(0.0, -9.81, 0.0))


def _free_tree():
    """A free-flying tree: a rigid root with a welded rigid branch at its start and a bending branch at x_a = 0.3 m."""
    root = gi.Link(0.8, 1.2, 1.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
    stub = gi.Link(0.5, 1.0, 1.0, rotary_inertia=(2e-3, 1e-3, 1e-3))
    limb = gi.Link(0.7, 0.9, 15.0, modes=[gi.Mode("clamped-free", "y")], geometric_stiffening=False)
    chain = gi.Chain([root, stub, limb], joints=[gi.Revolute(), gi.Weld(angle=2.0), gi.Revolute(axis_rotation=_rx(0.7))],
                     parents=[-1, 0, 0], attach=[None, 0.0, 0.3])
    return gi.Model(chain, gravity=(0.2, -9.81, 0.1))


CHAINS = {
    "two_link_circle": two_link_circle_model,
    "single_link_sphere": single_link_sphere_model,
    "planar_three_mixed": _planar_three_mixed,
    "fixed_base_two_fe": _fixed_base_two,
    "spatial_two_rodrigues": _spatial_two_rodrigues,
    "planar_four": _planar_four,
    "fixed_base_spatial_one": _fixed_base_spatial_one,
    "fixed_base_bodies": _fixed_base_bodies,
    "fixed_tree": _fixed_tree,
    "free_tree": _free_tree,
}


@functools.lru_cache(maxsize=None)
def model_of(name):
    return CHAINS[name]() if name in CHAINS else _planar_chain(int(name.split("_")[-1]))


@functools.lru_cache(maxsize=None)
def equations(name, method="gibbs-appell"):
    return gi.derive_equations(model_of(name), method=method)


def _reference(model, q, qd):
    M = model.mass_matrix(q)
    return M, M @ model.forward_dynamics(q, qd)


def _rel(a, b):
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def _states(model, seed):
    rng = np.random.default_rng(seed)
    out = [random_state(model, rng) for _ in range(N_STATES)]
    q, qd = out[0]
    out.append((q, np.zeros_like(qd)))  # gravity and strain only
    return out


@pytest.mark.parametrize("name", list(CHAINS))
def test_numeric_and_python_module_match_the_kernel(name, tmp_path):
    model = model_of(name)
    eqs = equations(name)
    M_fun, f_fun = eqs.numeric()
    path = eqs.to_python(tmp_path / f"eqs_{name}.py")
    spec = importlib.util.spec_from_file_location(f"eqs_{name}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.N == model.n_dof and mod.COORDINATES == model.coordinate_names
    worst = 0.0
    for q, qd in _states(model, 11):
        M, f = _reference(model, q, qd)
        for Ms, fs in ((M_fun(q), f_fun(q, qd)), (mod.mass_matrix(q), mod.forcing(q, qd)),
                       mod.mass_matrix_and_forcing(q, qd)):
            assert Ms.shape == (model.n_dof, model.n_dof) and fs.shape == (model.n_dof,)
            worst = max(worst, _rel(Ms, M), _rel(fs, f))
        np.testing.assert_allclose(mod.forward_dynamics(q, qd), model.forward_dynamics(q, qd),
                                   rtol=1e-9, atol=1e-9 * np.abs(model.forward_dynamics(q, qd)).max())
    assert worst <= RTOL, f"{name}: max relative error {worst:.2e}"


def test_symbols_and_shapes():
    model = model_of("fixed_base_two_fe")
    eqs = equations("fixed_base_two_fe")
    N = model.n_dof
    assert tuple(c.name for c in eqs.coordinates) == model.coordinate_names
    assert tuple(c.name for c in eqs.speeds) == tuple(f"{n}_dot" for n in model.coordinate_names)
    assert eqs.mass_matrix.shape == (N, N) and eqs.forcing.shape == (N, 1)
    assert eqs.mass_matrix == eqs.mass_matrix.T
    # M depends on q only; the forcing on both
    assert not (eqs.mass_matrix.free_symbols & set(eqs.speeds))
    assert eqs.forcing.free_symbols & set(eqs.speeds)
    assert eqs.derivation_seconds > 0 and eqs.method == "gibbs-appell"


def test_general_rodrigues_finite_at_zero_rotation():
    # phi = 0 exactly (every delta zero) on the two-axis Rodrigues chain: a(0), b(0) from the series
    name = "spatial_two_rodrigues"
    model, eqs = model_of(name), equations(name)
    assert "rodrigues_a0(" in eqs.python_source() and "rodrigues_b0(" in eqs.python_source()
    num = eqs.numeric()
    rng = np.random.default_rng(3)
    q, qd = random_state(model, rng)
    for idx in model.delta_index:
        q[idx] = 0.0
    M, f = num.mass_matrix_and_forcing(q, qd)
    assert np.all(np.isfinite(M)) and np.all(np.isfinite(f))
    Mr, fr = _reference(model, q, qd)
    assert _rel(M, Mr) <= RTOL and _rel(f, fr) <= RTOL


@pytest.mark.parametrize("kind", ["a", "b"])
def test_rodrigues_coefficients_match_the_kernel(kind):
    col = {"a": (0, 1, 2), "b": (3, 4, 5)}[kind]
    for s in (0.0, 1e-12, 1e-4, 0.3, 0.999999, 1.0, 1.7, 9.0):
        ref = _rodrigues_coefficients(s)
        for order in range(3):
            v = rodrigues_coefficient(kind, order, s)
            assert abs(v - ref[col[order]]) <= 1e-13 * max(1.0, abs(ref[col[order]])), (kind, order, s)
    # third derivative (the Lagrange route needs it for a spatial chain): finite differences
    for s in (0.2, 2.0):
        h = 1e-4
        fd = (rodrigues_coefficient(kind, 2, s + h) - rodrigues_coefficient(kind, 2, s - h)) / (2 * h)
        assert abs(rodrigues_coefficient(kind, 3, s) - fd) <= 1e-7


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_gibbs_appell_and_lagrange_agree(n):
    name = f"planar_{n}"
    model = model_of(name)
    ga, lg = equations(name, "gibbs-appell").numeric(), equations(name, "lagrange").numeric()
    worst = 0.0
    for q, qd in _states(model, 100 + n):
        Mg, fg = ga.mass_matrix_and_forcing(q, qd)
        Ml, fl = lg.mass_matrix_and_forcing(q, qd)
        worst = max(worst, _rel(Mg, Ml), _rel(fg, fl))
    assert worst <= RTOL, f"n = {n}: max relative difference {worst:.2e}"


def test_lagrange_route_on_spatial_rodrigues_chain():
    name = "spatial_two_rodrigues"
    model = model_of(name)
    lg = equations(name, "lagrange").numeric()
    for q, qd in _states(model, 7)[:3]:
        M, f = _reference(model, q, qd)
        Ml, fl = lg.mass_matrix_and_forcing(q, qd)
        assert _rel(Ml, M) <= RTOL and _rel(fl, f) <= RTOL


def test_rational_constants():
    model = model_of("planar_1")
    eqs = gi.derive_equations(model, rational=True)
    import sympy as sp

    assert not any(isinstance(a, sp.Float) for a in eqs.mass_matrix.atoms(sp.Number))
    num = eqs.numeric()
    for q, qd in _states(model, 5)[:3]:
        M, f = _reference(model, q, qd)
        Mn, fn = num.mass_matrix_and_forcing(q, qd)
        assert _rel(Mn, M) <= RTOL and _rel(fn, f) <= RTOL


def test_operation_count():
    ga = equations("two_link_circle").operation_count()
    lg = equations("two_link_circle", "lagrange").operation_count()
    for c in (ga, lg):
        assert c.adds > 0 and c.muls > 0 and c.functions > 0 and c.total == c.adds + c.muls + c.functions
    # measured: gibbs-appell (497, 1068, 8), lagrange (2045, 4004, 8)
    assert ga.total <= lg.total


def test_to_latex(tmp_path):
    eqs = equations("two_link_circle")
    path = eqs.to_latex(tmp_path / "eqs.tex")
    text = path.read_text()
    assert text.startswith(r"\documentclass") and r"\begin{document}" in text and r"\end{document}" in text
    assert text.count(r"\begin{align*}") == text.count(r"\end{align*}") == 3
    _, Mred, fred = eqs.cse()
    for (j, k), _ in Mred:
        assert f"M_{{{j + 1},{k + 1}}} &=" in text
    assert all(f"f_{{{j + 1}}} &=" in text for j in range(len(fred)))
    assert r"\theta_{-1}" in text and r"\delta_{1,1}" in text
    if shutil.which("pdflatex"):
        out = subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", path.name],
                             cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stdout[-2000:]


def test_latex_entries_parse_back():
    pytest.importorskip("antlr4")
    import sympy as sp
    from sympy.parsing.latex import parse_latex

    eqs = equations("planar_1")
    e = eqs.mass_matrix[0, 0]
    assert sp.simplify(parse_latex(sp.latex(e)) - e) == 0


def test_bad_method_names_the_choices():
    model = model_of("planar_1")
    with pytest.raises(ValueError, match=r"method='euler'.*'gibbs-appell', 'lagrange'"):
        gi.derive_equations(model, method="euler")
    assert METHODS == ("gibbs-appell", "lagrange")
    with pytest.raises(ValueError, match="model"):
        gi.derive_equations("not a model")


def test_stiffened_link_is_refused_with_the_fix():
    # The foreshortening terms (formulation §15) are not derived symbolically: refused, naming the fix.
    link = gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-free", "y")])
    with pytest.raises(NotImplementedError, match=r"link\(s\) 1 foreshorten.*geometric_stiffening=False"):
        gi.derive_equations(gi.Model(gi.Chain([link, gi.Link(0.5, 1.0, 1.0)])))


def test_import_does_not_load_sympy():
    code = "import sys, gibbsimpact; gibbsimpact.derive_equations; print('sympy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _parametric_chain(l1=1.0, mu1=1.2, EI1=25.0, l2=0.6, mu2=0.5, EI2=(7.0, 8.0), jz2=2e-3, g=-9.81):
    a = gi.Link(l1, mu1, EI1, elements=2, geometric_stiffening=False)
    b = gi.Link(l2, mu2, EI2, modes=[gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "y", 2)],
                rotary_inertia=(0.0, 0.0, jz2), geometric_stiffening=False)
    return gi.Model(gi.Chain([a, b], base=gi.FixedBase((0.1, 0.2), 0.3)), gravity=(0.0, g, 0.0))


def test_parametric_equations_match_the_model_and_scale_with_the_parameters(tmp_path):
    # symbols=True: lengths, masses, stiffnesses, rotary inertia and gravity stay symbols, the
    # dimensionless modal integrals are named constants. (1) With the recorded values they are
    # the model's equations; (2) with other values of l, mu, EI, j, g (same constants) they are
    # the equations of the model built with those parameters: the parameter powers are right.
    import sympy as sp

    model = _parametric_chain()
    eqs = gi.derive_equations(model, symbols=True)
    names = {str(k) for k in eqs.constants}
    assert {"l_1", "mu_1", "EIz_1", "l_2", "mu_2", "EIz_2", "jz_2", "g_2"} <= names
    assert "EIy_2" not in names  # no z bending: its stiffness never appears
    assert any(n.startswith("kappa_1_") for n in names) and any(n.startswith("d_2_") for n in names)
    assert sp.Symbol("l_1", positive=True) in eqs.mass_matrix[0, 0].free_symbols
    other = dict(l1=1.3, mu1=0.7, EI1=40.0, l2=0.45, mu2=0.9, EI2=(7.0, 3.0), jz2=5e-3, g=-3.7)
    changed = _parametric_chain(**other)
    values = dict(eqs.constants)
    for k in list(values):
        new = {"l_1": other["l1"], "mu_1": other["mu1"], "EIz_1": other["EI1"], "l_2": other["l2"],
               "mu_2": other["mu2"], "EIz_2": other["EI2"][1], "jz_2": other["jz2"], "g_2": other["g"]}.get(str(k))
        if new is not None:
            values[k] = new
    for ref, consts in ((model, eqs.constants), (changed, values)):
        eqs.constants, eqs._evaluated_copy = consts, None
        num = eqs.numeric()
        for q, qd in _states(ref, 7):
            M, f = num.mass_matrix_and_forcing(q, qd)
            Mref = ref.mass_matrix(q)
            assert _rel(M, Mref) <= RTOL
            assert _rel(f, Mref @ ref.forward_dynamics(q, qd)) <= 1e-11
    tex = eqs.to_latex(tmp_path / "p.tex").read_text()
    assert "Parameters and named constants" in tex and "kappa" in tex and "l_{1}" in tex


def test_progress_reports_every_link_and_equation(capsys):
    seen = []
    model = model_of("planar_2")
    gi.derive_equations(model, progress=lambda stage, done, total: seen.append((stage, done, total)))
    assert seen == [("gibbs-appell: link", k, 2) for k in (1, 2)]
    seen.clear()
    gi.derive_equations(model, method="lagrange", progress=lambda *a: seen.append(a))
    N = model.n_dof
    assert seen[-1] == ("lagrange: equation", N, N) and len(seen) == 2 + N
    gi.derive_equations(model, progress=True)
    assert "deriving (gibbs-appell: link 2/2)" in capsys.readouterr().err


def test_chosen_parameters_stay_symbolic():
    import sympy as sp

    model = _parametric_chain()
    eqs = gi.derive_equations(model, symbols=("l_1", "EIz_2"))
    free = set().union(*[e.free_symbols for e in eqs.mass_matrix]) | set().union(*[e.free_symbols for e in eqs.forcing])
    names = {str(x) for x in free}
    assert {"l_1", "EIz_2"} <= names and not names & {"mu_1", "l_2", "g_2", "jz_2"}
    assert any(n.startswith("d_1_") for n in names)  # modal integrals stay named constants
    assert "mu_1" not in {str(k) for k in eqs.constants}
    num = eqs.numeric()
    for q, qd in _states(model, 11):
        M, f = num.mass_matrix_and_forcing(q, qd)
        assert _rel(M, model.mass_matrix(q)) <= RTOL
    with pytest.raises(ValueError, match=r"L_1 not parameters of this model; choose from"):
        gi.derive_equations(model, symbols=("L_1",))
    assert sp.Symbol("l_1", positive=True) in eqs.constants


def test_attached_bodies_both_routes_and_no_parametric_tables():
    # The bodies live in the numeric link tables (P0, C, D, m_r0): Lagrange's route agrees with Gibbs-Appell's;
    # symbols=True writes a uniform link's tables from mu and l, so it refuses a link with bodies.
    model = model_of("fixed_base_bodies")
    ga = tuple(equations("fixed_base_bodies").numeric())
    la = tuple(equations("fixed_base_bodies", "lagrange").numeric())
    for q, qd in _states(model, 5):
        assert _rel(la[0](q), ga[0](q)) <= RTOL and _rel(la[1](q, qd), ga[1](q, qd)) <= RTOL
    with pytest.raises(ValueError, match="carries RigidBody entries"):
        gi.derive_equations(model, symbols=True)


def test_tree_gibbs_appell_and_lagrange_agree_and_parametric_attach_is_refused():
    """The two symbolic routes on a tree (a weld, a turned axis, a child along a bending parent) agree to
    1e-12; symbols=True refuses a child attached along its parent (its section is numeric), naming attach."""
    ga, lg = equations("fixed_tree", "gibbs-appell").numeric(), equations("fixed_tree", "lagrange").numeric()
    for q, qd in _states(model_of("fixed_tree"), 5)[:3]:
        (Mg, fg), (Ml, fl) = ga.mass_matrix_and_forcing(q, qd), lg.mass_matrix_and_forcing(q, qd)
        assert _rel(Ml, Mg) <= RTOL and _rel(fl, fg) <= RTOL
    with pytest.raises(NotImplementedError, match="attach"):
        gi.derive_equations(model_of("fixed_tree"), symbols=True)

