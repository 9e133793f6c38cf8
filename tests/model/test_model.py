"""Model.check_state: the cheap check of the common case (a shape compare and one dot product) accepts and
refuses exactly what the full check does, so the alias methods (Model.forward_dynamics, ...) keep their
messages at the kernel's cost."""

import numpy as np
import pytest

import gibbsimpact as gi


@pytest.fixture(scope="module")
def model():
    return gi.Model(gi.Chain([gi.Link(1.0, 1.0, 20.0, modes=[gi.Mode("clamped-clamped", "y")])] * 2))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("k", [0, 5, 8])
def test_a_non_finite_entry_is_named_through_every_alias(model, bad, k):
    q = np.zeros(model.n_dof)
    q[k] = bad
    name = model.coordinate_names[k]
    for call in (lambda: model.forward_dynamics(q, np.zeros(model.n_dof)), lambda: model.mass_matrix(q),
                 lambda: model.energy(np.zeros(model.n_dof), q), lambda: model.joint_positions(q)):
        with pytest.raises(ValueError, match=f"non-finite entries: {name}$"):
            call()
    z = np.zeros(model.n_dof)
    for call in (lambda: model.bias_forces(q, z), lambda: model.potential_forces(q), lambda: model.joint_jacobians(q),
                 lambda: model.joint_velocities(z, q), lambda: model.linear_momentum(z, q),
                 lambda: model.angular_momentum(q, z), lambda: model.center_of_mass(q)):
        with pytest.raises(ValueError, match=f"non-finite entries: {name}$"):
            call()


def test_aliases_take_lists_and_refuse_wrong_shapes_with_check_states_messages(model):
    N = model.n_dof
    q = np.linspace(-0.3, 0.3, N)
    np.testing.assert_array_equal(model.mass_matrix(q.tolist()), model.mass_matrix(q))
    np.testing.assert_array_equal(model.forward_dynamics(q.tolist(), [0.0] * N), model.forward_dynamics(q, np.zeros(N)))
    for call in (lambda: model.forward_dynamics(q[:-1], q[:-1]), lambda: model.mass_matrix(np.zeros(N + 1)),
                 lambda: model.energy(q, np.zeros(3)), lambda: model.joint_positions(np.zeros(2 * N))):
        with pytest.raises(ValueError, match="has shape"):
            call()


@pytest.mark.filterwarnings("ignore:overflow encountered")  # numpy's, from the dot product that overflows
def test_huge_finite_entries_overflow_the_dot_product_but_pass(model):
    # 1e200^2 overflows q.q to inf: the cheap check falls through to the full one, which accepts.
    q = np.zeros(model.n_dof)
    q[0] = 1e200
    assert not np.isfinite(q @ q)
    assert model.check_state(q) is q
    qa, qd = model.check_state(q, q)
    assert qa is q and qd is q


def test_shapes_dtypes_and_lists(model):
    N = model.n_dof
    with pytest.raises(ValueError, match=rf"q has shape \(3,\); this model needs shape \({N},\) ordered as X1"):
        model.check_state(np.zeros(3))
    with pytest.raises(ValueError, match=rf"qdot has shape \(2, {N}\)"):
        model.check_state(np.zeros(N), np.zeros((2, N)))
    q = model.check_state(list(range(N)))  # a list, and integers: converted
    assert q.dtype == float and np.array_equal(q, np.arange(N))
    q32 = np.ones(N, dtype=np.float32)
    assert model.check_state(q32).dtype == float
