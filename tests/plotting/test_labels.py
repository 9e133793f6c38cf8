"""Texts of the figures: points that coincide are named once (plotting/labels.py)."""

from __future__ import annotations

import numpy as np

from gibbsimpact.plotting.labels import SAME_POINT, _joint_list, _shared_label, coincident_groups


def test_coincident_groups_within_the_tolerance_at_every_sample():
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0 + 0.1 * SAME_POINT, 0.0, 0.0], [2.0, 0.0, 0.0],
                  [1.0, 10 * SAME_POINT, 0.0]])
    assert coincident_groups(P) == [[0], [1, 2], [3], [4]]
    # Paths: points 1 and 2 together at one sample and apart at the other are two points.
    paths = np.stack([P, P + np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0], [0, 0, 0], [0, 0, 0]])])
    assert coincident_groups(paths) == [[0], [1], [2], [3], [4]]
    assert coincident_groups(np.zeros((0, 3))) == []


def test_shared_labels_and_contacts_name_one_point_once():
    assert _shared_label([3]) == "$O_{3}$"
    assert _shared_label([2, 3]) == "$O_{2} = O_{3}$"
    assert _shared_label([1, 2, 3, 4, 5, 6]) == "$O_{1}$\u2013$O_{6}$"
    assert _shared_label([2, 5, 7]) == "$O_{2} = O_{5} = O_{7}$"
    # Two branches ending at one tip (O2, O3) strike the wall there with O4 elsewhere: one point, then another.
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [1.0, 0.5, 0.0], [0.0, 1.0, 0.0]])
    assert _joint_list([2, 3, 4], P) == "O2=O3+O4"
    assert _joint_list([1, 4], P) == "O1+O4" and _joint_list([2, 3]) == "O2+O3"
