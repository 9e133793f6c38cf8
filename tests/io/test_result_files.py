"""Result files: NPZ round trips exactly (every field, the model, the walls), CSV columns
read back to the same doubles, summary.json is strict JSON with the required fields."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import gibbsimpact as gi
from gibbsimpact.io import result_files as io
from gibbsimpact.io.contact_force_files import stop_force_columns

CASES = Path(__file__).resolve().parents[2] / "cases"


@pytest.fixture(scope="module")
def case():
    return gi.load_case(CASES / "circle_two_link.toml")


@pytest.fixture(scope="module")
def result(case):
    # t_end 0.5 s holds impact 1 (O2) and impact 2 (O1 and O3 together: two contacts).
    res = case.simulate(t_end=0.5, rtol=1e-8, atol=1e-10, output_dt=5e-3)
    assert [r.joints for r in res.impacts] == [(2,), (1, 3)]
    return res


def assert_same_result(a, b):
    for name in ("t", "q", "qdot", "phase"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), name
    for name in ("status", "message", "settings", "nfev", "n_steps", "wall_time"):
        assert getattr(a, name) == getattr(b, name), name
    assert a.energy_error == b.energy_error or (math.isnan(a.energy_error) and math.isnan(b.energy_error))
    assert a.energy_error_whole_run_J == b.energy_error_whole_run_J or (
        math.isnan(a.energy_error_whole_run_J) and math.isnan(b.energy_error_whole_run_J))
    assert a.walls == b.walls
    assert a.model.coordinate_names == b.model.coordinate_names
    assert np.array_equal(a.model.gravity, b.model.gravity)
    assert a.model.chain == b.model.chain
    assert len(a.impacts) == len(b.impacts)
    for ra, rb in zip(a.impacts, b.impacts):
        for f in ra._fields:
            va, vb = getattr(ra, f), getattr(rb, f)
            if isinstance(va, np.ndarray):
                assert np.array_equal(va, vb), f
            else:
                assert va == vb and type(va) is type(vb), f


def test_npz_round_trip_is_exact(result, tmp_path):
    path = result.save(tmp_path / "r.npz")
    back = gi.load_result(path)
    assert_same_result(result, back)
    # The rebuilt model gives the same dynamics, so derived quantities agree exactly.
    ea, eb = result.energy(), back.energy()
    assert all(np.array_equal(x, y) for x, y in zip(ea, eb))
    assert np.array_equal(result.joint_positions(), back.joint_positions())
    assert back.settings["max_step"] == math.inf and back.settings["wall_restitution"] == [None]


def test_npz_metadata_and_suffix(result, tmp_path):
    path = gi.Result.save(result, tmp_path / "noext", metadata={"case": "x", "numbers": (1, 2.5)})
    assert path.name == "noext.npz"
    back, meta = gi.load_result(path, with_metadata=True)
    assert meta == {"case": "x", "numbers": (1, 2.5)}


def test_npz_round_trip_without_impacts_and_3d_walls(tmp_path):
    link = gi.Link(1.0, 1.0, (20.0, 30.0), modes=[gi.Mode("clamped-free", "z", 2)], rotary_inertia=(1e-4, 5e-5, 5e-5))
    model = gi.Model([link], gravity=(0.0, 0.0, -9.81))
    walls = (gi.Sphere(5.0, (0.1, 0.2, 0.3), restitution=0.7), gi.Plane((0, 0, -3.0), (0.0, 0.3, 1.0)))
    res = gi.simulate(model, model.state(theta_0=0.3), model.state(X1=1.0, theta_1=1.0), (0.0, 0.02), walls,
                      rtol=1e-8, atol=1e-10)
    assert res.impacts == []
    back = gi.load_result(res.save(tmp_path / "r"))
    assert_same_result(res, back)
    assert back.walls[1].normal_vector == res.walls[1].normal_vector


def test_round_trip_of_a_driven_damped_fe_run(tmp_path):
    # FE link, damping, inputs: the model, the work columns and the impact rounds come back.
    link = gi.Link(1.0, 1.0, 10.0, elements=2, damping=0.05)
    model = gi.Model([link, link], gravity=(0.0, -9.81, 0.0))
    res = gi.simulate(model, model.state(X2=0.05, theta_2=0.4), model.state(X2=-1.0, theta_2=1.0), (0.0, 0.06),
                      walls=[gi.Plane((0, 0, 0), (0, 1, 0))], inputs={"theta_2": 0.2}, rtol=1e-8, atol=1e-10)
    assert res.impacts and res.work is not None
    back = gi.load_result(res.save(tmp_path / "fe"))
    assert_same_result(res, back)
    assert back.model.chain.links[0].elements == 2 and back.model.chain.links[0].damping == 0.05
    assert np.array_equal(back.work, res.work)
    csv_path = res.to_csv(tmp_path)["timeseries"]
    header = csv_path.read_text().splitlines()[0].split(",")
    assert header[-2:] == ["work_inputs_J", "work_damping_J"]
    # FE node slopes are angles: delta_1_2 (slope at node 1) is in rad, delta_1_1 in m.
    assert "delta_1_1_m" in header and "delta_1_2_rad" in header and "delta_1_2_dot_rad_per_s" in header


def test_round_trip_of_a_fixed_base_run(tmp_path):
    link = gi.Link(0.8, 1.0, 10.0, elements=1)
    model = gi.Model(gi.Chain([link, link], base=gi.FixedBase((0.1, 0.9), 0.3)), gravity=(0.0, -9.81, 0.0))
    res = gi.simulate(model, model.state(theta_1=-0.5), np.zeros(model.n_dof), (0.0, 0.02), rtol=1e-8, atol=1e-10)
    back = gi.load_result(res.save(tmp_path / "fixed"))
    assert_same_result(res, back)
    assert back.model.base_transform is not None
    np.testing.assert_array_equal(back.model.base_transform, model.base_transform)
    np.testing.assert_array_equal(back.model.mass_matrix(res.q[-1]), model.mass_matrix(res.q[-1]))


def test_round_trip_keeps_the_attached_bodies():
    hub = gi.RigidBody(2.0, inertia=[[0.1, 0.01, 0.0], [0.01, 0.1, 0.0], [0.0, 0.0, 0.15]], at=0.0)
    payload = gi.RigidBody(0.5, center=(0.05, 0.0, 0.0), inertia=(0.001, 0.002, 0.002))
    model = gi.Model(gi.Chain([gi.Link(0.8, 1.0, 10.0, bodies=[hub]), gi.Link(0.6, 1.0, 10.0, elements=1,
                                                                               bodies=[payload])],
                              base=gi.FixedBase()))
    back = io.model_from_dict(json.loads(json.dumps(io.model_to_dict(model))))
    assert back.chain == model.chain


def test_npz_rejects_foreign_files_and_callable_links(tmp_path):
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(ValueError, match="not a gibbsimpact result"):
        gi.load_result(tmp_path / "other.npz")
    link = gi.Link(1.0, lambda x: 1.0 + 0.0 * x, 20.0, rotary_inertia=(1e-4, 1e-4, 1e-4))
    model = gi.Model([link])
    res = gi.simulate(model, model.state(), model.state(), (0.0, 0.001))
    with pytest.raises(ValueError, match="callable"):
        res.save(tmp_path / "c.npz")


def test_timeseries_csv_round_trip(result, tmp_path):
    paths = result.to_csv(tmp_path)
    cols = io.read_csv(paths["timeseries"])
    m = result.model
    assert np.array_equal(cols["t_s"], result.t)
    assert np.array_equal(cols["phase"], result.phase)
    for k, name in enumerate(m.coordinate_names):
        unit = "rad" if name.startswith("theta") else "m"
        assert np.array_equal(cols[f"{name}_{unit}"], result.q[:, k]), name
        assert np.array_equal(cols[f"{name}_dot_{unit}_per_s"], result.qdot[:, k]), name
    E = result.energy()
    for f, col in zip(E._fields, ("kinetic_J", "gravity_J", "strain_J", "total_J")):
        assert np.array_equal(cols[col], getattr(E, f))
    P = result.joint_positions()
    assert np.array_equal(cols["O3_X2_m"], P[:, 2, 1])
    assert list(cols)[:3] == ["t_s", "phase", "X1_m"]


def test_csv_every_k_keeps_the_full_rows_at_those_samples(result, tmp_path):
    # --csv-every K / to_csv(every=K): rows 0, K, 2K, ... and the last, each the full file's row.
    import dataclasses

    K = len(result.t)
    F = np.zeros((K, len(result.walls), result.model.n_joints))
    F[K // 3:K // 2, 0, 1] = np.linspace(1.0, 2.0, K // 2 - K // 3)  # some resting contact
    res = dataclasses.replace(result, contact_forces=F)
    full, part = io.to_csv(res, tmp_path / "full"), io.to_csv(res, tmp_path / "part", every=7)
    assert set(full) == set(part) == {"timeseries", "impacts", "episodes", "contact_forces"}
    rows = list(range(0, K, 7)) + ([] if (K - 1) % 7 == 0 else [K - 1])
    for name in ("timeseries", "contact_forces"):
        a, b = full[name].read_text().splitlines(), part[name].read_text().splitlines()
        assert len(b) == 1 + len(rows) == 1 + -(-K // 7) + ((K - 1) % 7 != 0)
        assert b == [a[0]] + [a[1 + r] for r in rows]
    assert full["impacts"].read_text() == part["impacts"].read_text()
    assert full["episodes"].read_text() == part["episodes"].read_text()  # whole, as impacts.csv
    assert res.to_csv(tmp_path / "alias", every=7)["timeseries"].read_text() == part["timeseries"].read_text()
    for bad in (0, -2, 1.5, True, "3"):
        with pytest.raises(ValueError, match="every="):
            io.to_csv(res, tmp_path / "bad", every=bad)
    assert not (tmp_path / "bad").exists()  # checked before any file is written


def test_impacts_csv_one_row_per_contact(result, tmp_path):
    cols = io.read_csv(result.to_csv(tmp_path)["impacts"])
    assert list(cols) == io.IMPACT_COLUMNS
    assert cols["impact"].tolist() == [1, 2, 2]
    assert cols["joint"].tolist() == [2, 1, 3]
    assert cols["wall"].tolist() == [1, 1, 1]
    assert cols["n_contacts"].tolist() == [1, 2, 2]
    rows = [(rec, c) for rec in result.impacts for c in range(len(rec.joints))]
    for k, (rec, c) in enumerate(rows):
        assert cols["time_s"][k] == rec.time
        assert cols["impulse_N_s"][k] == rec.impulses[c]
        assert cols["v_before_m_per_s"][k] == rec.v_before[c] and cols["v_after_m_per_s"][k] == rec.v_after[c]
        assert [cols[f"normal_X{a}"][k] for a in (1, 2, 3)] == list(np.asarray(rec.normals)[c])
        assert cols["total_before_J"][k] == rec.energy_before.total
        assert cols["kinetic_after_J"][k] == rec.energy_after.kinetic
    assert cols["wall_description"][0] == "circle R=1.5 m centre (0, 0)"


def test_summary_json_is_strict_and_complete(result, case, tmp_path):
    path = io.write_summary_json(result, tmp_path / "summary.json", case)

    def no_constants(name):
        raise AssertionError(f"non-standard JSON constant {name}")

    d = json.loads(path.read_text(), parse_constant=no_constants)
    assert d["case"] == "circle_two_link"
    assert set(d["versions"]) >= {"gibbsimpact", "python", "numpy", "scipy"}
    assert d["settings"]["rtol"] == 1e-8 and d["settings"]["max_step"] == "inf"
    assert d["n_impacts"] == 2
    assert d["impact_times_s"] == [r.time for r in result.impacts]
    assert d["impact_joints"] == [[2], [1, 3]]
    assert d["energy_initial_J"]["total"] == pytest.approx(-4.905, abs=1e-12)
    assert d["energy_final_J"]["total"] == pytest.approx(-4.905, abs=1e-5)
    assert d["max_relative_energy_error"] == result.energy_error
    # The energy balance error both ways, named apart: over the whole run (and what it is relative to),
    # and the largest of one flight phase (also under its first name, max_relative_energy_error).
    assert d["relative_energy_error_whole_run"] == result.energy_error_whole_run
    assert d["energy_error_whole_run_J"] == result.energy_error_whole_run_J
    # m |g| sum l of case 1, larger than |E0| = 4.905 J
    assert d["energy_scale_J"] == result.energy_scale == pytest.approx(2.0 * 9.81 * 2.0, rel=4e-16)
    assert d["relative_energy_error_max_per_phase"] == result.energy_error_per_phase == result.energy_error
    E = result.energy().total
    assert d["energy_error_whole_run_J"] == pytest.approx(E[-1] - E[0], abs=16 * np.finfo(float).eps * abs(E[0]))
    assert d["status"] == "finished" and d["message"] == result.message
    for key in ("wall_time_s", "nfev", "n_steps", "model", "walls"):
        assert key in d
    assert d["model"]["n_odes"] == 18
    # Each wall says which restitution it used (its own, or the global one).
    assert d["walls"] == [f"circle R=1.5 m centre (0, 0), restitution {result.settings['restitution']:g} (global)"]
    assert result.summary(case) == d


def test_episodes_in_the_files(tmp_path):
    # The flexible arm of issue 26 (one element): 23 impacts and resting phases in one episode.
    from conftest import issue26_arm
    from gibbsimpact.io.episode_files import EPISODE_COLUMNS

    res = issue26_arm()
    (ep,) = res.episodes
    # result.npz keeps what the episodes are computed from, exactly: the same episodes come back.
    assert gi.load_result(res.save(tmp_path / "r.npz")).episodes == res.episodes
    cols = io.read_csv(res.to_csv(tmp_path)["episodes"])
    assert list(cols) == EPISODE_COLUMNS
    assert cols["episode"].tolist() == [1] and cols["contact_points"].tolist() == ["O2"]
    assert (cols["first_impact"][0], cols["last_impact"][0], cols["n_impacts"][0]) == (1, 23, 23)
    for name, value in (("start_s", ep.start), ("end_s", ep.end), ("impulse_N_s", ep.impulse),
                        ("energy_lost_J", ep.energy_lost), ("restitution", ep.restitution),
                        ("max_force_N", ep.max_force), ("max_penetration_m", ep.max_penetration)):
        assert cols[name][0] == value, name  # the shortest text that reads back to the same double
    assert cols["ended"].tolist() == ["true"] and cols["walls"].tolist() == [1]
    s = json.loads(io.write_summary_json(res, tmp_path / "summary.json").read_text())
    assert s["n_episodes"] == 1 and s["episodes"][0]["restitution"] == ep.restitution
    assert s["episodes"][0]["contact_points"] == ["O2"] and s["episodes"][0]["walls"] == [1]


def test_tagged_json_keeps_types():
    x = {"a": (1, 2.0, None), "b": [math.inf, -math.inf], "c": np.arange(3.0), "d": np.int64(4), "e": {1: "x"}}
    back = io._untag(json.loads(json.dumps(io._tag(x))))
    assert back["a"] == (1, 2.0, None) and isinstance(back["a"], tuple)
    assert back["b"] == [math.inf, -math.inf]
    assert np.array_equal(back["c"], x["c"]) and back["c"].dtype == x["c"].dtype
    assert back["d"] == 4 and type(back["d"]) is np.int64
    assert back["e"] == {1: "x"}


def test_a_file_without_the_whole_run_energy_error_reads_as_nan(result, tmp_path):
    # Files written before the whole-run error existed: NaN, and null in summary.json (not a made-up number).
    path = result.save(tmp_path / "r.npz")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    del meta["energy_error_whole_run_J"]
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez_compressed(tmp_path / "old.npz", **arrays)
    old = gi.load_result(tmp_path / "old.npz")
    assert math.isnan(old.energy_error_whole_run_J) and math.isnan(old.energy_error_whole_run)
    assert old.energy_error == result.energy_error
    d = io.summary(old)
    assert d["relative_energy_error_whole_run"] is None and d["max_relative_energy_error"] == result.energy_error


def test_end_stop_forces_in_contact_forces_csv_and_npz(tmp_path):
    # A slide held at its stop (tests/simulation/test_joint_limits.py: mu = F = 2 N) writes its stop
    # force into contact_forces.csv (columns Fstop_<coordinate>_<min|max>_N) and result.npz.
    rod = gi.Link(0.6, 1.0, 1.0)
    model = gi.Model(gi.Chain([rod], joints=[gi.FixedPrismatic(range=(0.1, 0.5))], base=gi.FixedBase((0.0, 0.0), 0.0)),
                     gravity=(0.0, 0.0, 0.0))
    res = gi.simulate(model, model.state(d_1=0.45), np.zeros(1), (0.0, 0.4), joint_limit="impact",
                      joint_restitution=0.0, inputs={"d_1": 2.0})
    assert res.has_resting_forces
    out = io.to_csv(res, tmp_path)
    rows = io.read_csv(out["contact_forces"])
    assert stop_force_columns(res) == ["Fstop_d_1_min_N", "Fstop_d_1_max_N"]
    np.testing.assert_array_equal(np.asarray(rows["Fstop_d_1_max_N"], dtype=float), res.stop_forces[:, 1])
    assert float(rows["Fstop_d_1_max_N"][-1]) == pytest.approx(2.0, rel=1e-8)
    back = io.load_result(io.save_result(res, tmp_path / "r.npz"))
    assert np.array_equal(back.stop_forces, res.stop_forces)


def test_compliant_columns_of_a_rod_resting_on_a_post_with_a_payload(tmp_path):
    """A rigid rod (l = 1 m, mu = 1 kg/m) on a pivot, a 0.5 kg payload 5 cm beyond its tip, falls onto a compliant
    post (R = 0.05 m at (0.6, -0.1) m, k = 1e5 N/m^1.5, e = 0.5) and comes to rest on it. The gap matrix has the
    joints O1, O2, the rod's span (an obstacle) and the payload's centre: contact_forces.csv names those four
    columns (it raised IndexError on the body column, and named the Xc columns of links only), every row is as long
    as the header, and the resting force balances gravity's moment about the pivot (statics, no shared code):
    (X - O1) x F_n n = g cos(theta) (mu l^2 / 2 + m_p (l + c))."""
    import csv
    import warnings

    payload = gi.RigidBody(mass=0.5, center=(0.05, 0.0, 0.0))
    rod = gi.Link(1.0, 1.0, 1e4, bodies=[payload])
    model = gi.Model(gi.Chain([rod], base=gi.FixedBase((0.0, 0.0))), gravity=(0.0, -9.81, 0.0))
    centre = np.array([0.6, -0.1, 0.0])
    post = gi.Circle(0.05, tuple(centre[:2]), inside=False, restitution=0.5, stiffness=1e5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gi.ValidityWarning)
        res = gi.simulate(model, np.zeros(1), np.zeros(1), (0.0, 1.5), walls=[post], output_dt=0.01)
    rows = list(csv.reader(io.write_contact_forces_csv(res, tmp_path / "cf.csv").open()))
    fc = [c for c in rows[0] if c.startswith("Fc_")]
    assert fc == ["Fc_w1_O1_N", "Fc_w1_O2_N", "Fc_w1_link1_N", "Fc_w1_body1_N"]
    assert [c for c in rows[0] if c.startswith("Xc_")] == [f"Xc_w1_{p}_X{a}_m" for p in ("link1", "body1")
                                                           for a in (1, 2, 3)]
    assert {len(r) for r in rows} == {len(rows[0])}
    last = dict(zip(rows[0], map(float, rows[-1][:len(rows[0])])))
    assert last["Fc_w1_link1_N"] == res.compliant_forces[-1, 0, 2] > 0.0
    assert abs(res.qdot[-1, 0]) < 1e-9  # at rest on the post
    X = res.compliant_points[-1, 0, 2]
    n = (X - centre) / np.linalg.norm(X - centre)
    moment = last["Fc_w1_link1_N"] * (X[0] * n[1] - X[1] * n[0])
    gravity = 9.81 * np.cos(res.q[-1, 0]) * (1.0 * 1.0 ** 2 / 2 + 0.5 * 1.05)
    assert moment == pytest.approx(gravity, rel=1e-6)
