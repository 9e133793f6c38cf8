"""Trees and welds in the kernel (formulation §17): a path tree is the chain, branches share no
mass-matrix entry, a weld is a revolute held at its angle, a rotated revolute axis."""

import numpy as np
import pytest

import gibbsimpact as gi

CF_Y, CF_Z = gi.Mode("clamped-free", "y"), gi.Mode("clamped-free", "z")


def _flex(l, stiff=True):
    return gi.Link(l, 1.1, (12.0, 18.0), modes=[CF_Y, CF_Z], rotary_inertia=(1e-4, 2e-4, 2e-4),
                   geometric_stiffening=stiff)


def _fe(l):
    return gi.Link(l, 0.9, 10.0, elements=2, element_directions=("y", "z"), rotary_inertia=(1e-4, 1e-4, 1e-4))


@pytest.fixture(scope="module")
def path_pair():
    """The serial chain and the same chain as a tree whose branches form one path, each child
    attached explicitly at its parent's tip (so the tree's attachment tables A_p(x_a = l_p) are
    used instead of the end tables E_p: a second route to the same transforms)."""
    links = [_flex(1.0), _fe(0.8), _flex(0.6, stiff=False)]
    chain = gi.Model(gi.Chain(links), gravity=(0.3, -9.81, 0.5))
    tree = gi.Model(gi.Chain(links, parents=[-1, 0, 1], attach=[None, 1.0, 0.8]), gravity=(0.3, -9.81, 0.5))
    return chain, tree


def test_path_tree_equals_chain(path_pair):
    """M, qddot and the contact points' Jacobians of the path tree equal the chain's to round-off
    (the two differ only in how t(l), phi(l), H(l) are tabulated)."""
    chain, tree = path_pair
    assert not tree.chain.serial and chain.chain.serial
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = rng.uniform(-0.4, 0.4, chain.n_dof)
        qd = rng.uniform(-1.0, 1.0, chain.n_dof)
        M = chain.mass_matrix(q)
        np.testing.assert_allclose(tree.mass_matrix(q), M, rtol=0, atol=1e-13 * np.abs(M).max())
        a = chain.forward_dynamics(q, qd)
        np.testing.assert_allclose(tree.forward_dynamics(q, qd), a, rtol=0, atol=1e-11 * np.abs(a).max())
        J = chain.joint_jacobians(q)
        np.testing.assert_allclose(tree.joint_jacobians(q), J, rtol=0, atol=1e-13 * np.abs(J).max())


@pytest.fixture(scope="module")
def branched():
    """A free-floating flexible tree: root 0; 1 at x = 0.6 on 0; 2 at 0's tip; 3 at 1's tip;
    4 welded at x = 0.3 on 2 (links 1, 2 share the root's deltas through two attachments)."""
    links = [_flex(1.0), _flex(0.8), _fe(0.7), _flex(0.5), gi.Link(0.4, 0.5, 8.0, modes=[CF_Y])]
    joints = [gi.Revolute(), gi.Revolute(), gi.Revolute(), gi.Revolute(), gi.Weld(angle=0.7)]
    return gi.Model(gi.Chain(links, joints=joints, parents=[-1, 0, 0, 1, 2], attach=[None, 0.6, None, None, 0.3]),
                    gravity=(0.0, 0.0, 0.0))


def _branch_coordinates(model, links):
    """Indices of the coordinates whose first frame is in the subtree of any of ``links``: their
    joint variables and deltas."""
    out = []
    for i in links:
        if model.theta_index[i] >= 0:
            out.append(model.theta_index[i])
        out += list(model.delta_index[i])
    return out


def test_branches_share_no_mass_matrix_entry(branched):
    """M_cd == 0 exactly for c, d on different branches (formulation §17): the subtree {1, 3} and
    the subtree {2, 4} of the root have no frame in common."""
    rng = np.random.default_rng(2)
    q = rng.uniform(-0.5, 0.5, branched.n_dof)
    M = branched.mass_matrix(q)
    a = _branch_coordinates(branched, [1, 3])
    b = _branch_coordinates(branched, [2, 4])
    assert np.all(M[np.ix_(a, b)] == 0.0)
    assert np.linalg.eigvalsh(M).min() > 0


def _lagrange_bias(model, q, qd, h=1e-6):
    """Second route to h: Mdot qdot - 1/2 d(qdot^T M qdot)/dq by central differences of M."""
    N = q.size
    dM = np.array([(model.mass_matrix(q + h * e) - model.mass_matrix(q - h * e)) / (2 * h) for e in np.eye(N)])
    return np.einsum("kij,k,j->i", dM, qd, qd) - 0.5 * np.einsum("kij,i,j->k", dM, qd, qd)


def test_tree_bias_forces_match_lagrange_route(branched):
    """h of the tree (a parent's deltas twisting two children, a weld, an FE parent with a child at
    x_a) from the kernel equals the Lagrange route through M: truncation of the central differences
    ~h^2 |M'''| (h = 1e-6) and round-off ~1e-16 |M| / h, both well under 1e-7 relative."""
    rng = np.random.default_rng(8)
    q = rng.uniform(-0.4, 0.4, branched.n_dof)
    qd = rng.uniform(-1.0, 1.0, branched.n_dof)
    h = branched.bias_forces(q, qd)
    ref = _lagrange_bias(branched, q, qd)
    assert np.linalg.norm(h - ref) <= 1e-7 * np.linalg.norm(ref)


def _rigid(l):
    return gi.Link(l, 2.0)


def test_weld_is_a_revolute_held_at_its_angle():
    """The weld's M is the revolute's M at theta = angle with theta's row and column removed, and
    its qddot is the revolute model's with theta held (M_ff qddot_f = -(h + dV)_f)."""
    links = [gi.Link(1.0, 1.0, 20.0, modes=[CF_Y]), gi.Link(0.6, 0.8, 15.0, modes=[CF_Y]), _rigid(0.5)]
    g = (0.0, -9.81, 0.0)
    weld = gi.Model(gi.Chain(links, joints=[gi.Revolute(), gi.Weld(angle=0.4), gi.Revolute()], base="planar"), g)
    rev = gi.Model(gi.Chain(links, base="planar"), g)
    k = rev.coordinate_names.index("theta_2")
    keep = [i for i in range(rev.n_dof) if i != k]
    rng = np.random.default_rng(4)
    for _ in range(2):
        qw = rng.uniform(-0.3, 0.3, weld.n_dof)
        qdw = rng.uniform(-1.0, 1.0, weld.n_dof)
        q = np.insert(qw, k, 0.4)
        qd = np.insert(qdw, k, 0.0)
        M = rev.mass_matrix(q)
        np.testing.assert_allclose(weld.mass_matrix(qw), M[np.ix_(keep, keep)], rtol=0, atol=1e-14 * np.abs(M).max())
        rhs = -(rev.bias_forces(q, qd) + rev.potential_forces(q))[keep]
        a = np.linalg.solve(M[np.ix_(keep, keep)], rhs)
        np.testing.assert_allclose(weld.forward_dynamics(qw, qdw), a, rtol=0, atol=1e-12 * np.abs(a).max())


def test_two_welded_halves_are_one_rigid_link():
    """A rigid link of length 1.0 made of two halves welded at angle 0 has the mass matrix of one
    rigid link of length 1.0 (an independent closed form: the uniform rod)."""
    one = gi.Model(gi.Chain([_rigid(1.0)], base="planar"), (0.0, -9.81, 0.0))
    two = gi.Model(gi.Chain([_rigid(0.5), _rigid(0.5)], joints=[gi.Revolute(), gi.Weld()], base="planar"),
                   (0.0, -9.81, 0.0))
    q = np.array([0.2, -0.1, 0.7])
    M = one.mass_matrix(q)
    np.testing.assert_allclose(two.mass_matrix(q), M, rtol=0, atol=1e-15 * np.abs(M).max())
    # the rod's own closed form: m = 2 kg, l = 1 m about its end: m l^2 / 3
    assert M[2, 2] == pytest.approx(2.0 / 3.0, rel=1e-14)
    np.testing.assert_allclose(two.potential_forces(q), one.potential_forces(q), rtol=1e-15, atol=1e-15)


def test_rotated_revolute_axis_swings_in_the_x1_x3_plane():
    """Revolute(axis_rotation=Rx(pi/2)): the link turns about the base's -y axis, so its tip is at
    l (cos theta, 0, sin theta); with gravity along -X3, qddot = -3 g cos(theta) / (2 l) for a
    uniform rod about its end (closed form)."""
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    model = gi.Model(gi.Chain([_rigid(0.8)], joints=[gi.Revolute(axis_rotation=Rx)], base=gi.FixedBase()),
                     gravity=(0.0, 0.0, -9.81))
    th = 0.3
    tip = model.joint_positions(np.array([th]))[1]
    np.testing.assert_allclose(tip, 0.8 * np.array([np.cos(th), 0.0, np.sin(th)]), atol=1e-15)
    a = model.forward_dynamics(np.array([th]), np.array([1.3]))
    assert a[0] == pytest.approx(-3.0 * 9.81 * np.cos(th) / (2.0 * 0.8), rel=1e-13)


def test_several_roots_on_a_fixed_base_are_independent():
    """Two roots on a fixed base share no coordinate's frame: M is block diagonal, and each block
    is the single link's."""
    lk = gi.Link(0.7, 1.0, 10.0, modes=[CF_Y])
    one = gi.Model(gi.Chain([lk], base=gi.FixedBase()))
    two = gi.Model(gi.Chain([lk, lk], joints=[gi.Revolute(), gi.Weld(angle=1.0)], parents=[-1, -1],
                            base=gi.FixedBase()))
    q2 = np.array([0.3, 0.02, -0.01])  # theta_1, delta_1_1, delta_2_1
    M2 = two.mass_matrix(q2)
    M1 = one.mass_matrix(q2[:2])
    np.testing.assert_array_equal(M2[:2, 2], 0.0)
    np.testing.assert_allclose(M2[:2, :2], M1, rtol=0, atol=1e-15 * np.abs(M1).max())
