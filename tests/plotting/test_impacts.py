"""Impact marks of long runs: contact episodes, labels that never overlap once drawn, a rug past
twelve impacts, a footnote per episode."""

from __future__ import annotations

import itertools

import pytest

from conftest import FE_ARM_BURSTS, burst_result
from gibbsimpact.plotting import plot_angles, plot_modes
from gibbsimpact.plotting.impacts import EPISODE_GAP, MAX_LABELLED, _impact_note, contact_episodes


@pytest.fixture(scope="module")
def bursts():
    """101 impacts in the 7 accumulations of fixed_base_fe_arm run to 1 s."""
    return burst_result()


def _number_row(ax):
    """The texts of the row of numbers above ``ax`` (at axes height 1.015, in data x)."""
    return [t for t in ax.texts if t.get_position()[1] == pytest.approx(1.015)]


def test_episodes_are_the_bursts(bursts):
    episodes = contact_episodes(bursts.impact_times, 0.0, 1.0)
    assert [b - a + 1 for a, b in episodes] == [n for _, n in FE_ARM_BURSTS]
    # The rule: a gap above EPISODE_GAP of the run starts an episode, one at or below it does not.
    span = 2.0
    gap = EPISODE_GAP * span
    assert contact_episodes([0.1, 0.1 + gap * (1 - 1e-9)], 0.0, span) == [(0, 1)]
    assert contact_episodes([0.1, 0.1 + gap * (1 + 1e-9)], 0.0, span) == [(0, 0), (1, 1)]
    assert contact_episodes([], 0.0, 1.0) == []


@pytest.mark.parametrize("plot", [plot_angles, plot_modes])
def test_labels_of_101_impacts_do_not_overlap_once_drawn(bursts, plot):
    # fixed_base_fe_arm to 1 s printed "1-3146-56": two episode labels touching above modes.png,
    # laid out for the axes' widths before tight_layout narrowed them.
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plot(bursts)
    fig.set_dpi(120)  # as saved by gibbsimpact run
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    rows = [_number_row(ax) for ax in fig.axes]
    assert any(rows)
    allowed = {f"{a + 1}\u2013{b + 1}" for a, b in contact_episodes(bursts.impact_times, 0.0, 1.0)}
    for row in rows:
        assert len(row) <= len(FE_ARM_BURSTS) and {t.get_text() for t in row} <= allowed
        boxes = sorted((t.get_window_extent(renderer) for t in row), key=lambda b: b.x0)
        # Rendered extents (not the estimate the labels were placed by) at least half an em of the 7 pt
        # font apart, more than a space (0.32 em): two labels never read as one number.
        for a, b in itertools.pairwise(boxes):
            assert b.x0 - a.x1 >= 0.5 * 7.0 * 120 / 72, (a, b)


def test_rug_past_twelve_impacts_lines_up_to_twelve(bursts):
    import dataclasses

    fig = plot_angles(bursts)
    ax = fig.axes[0]
    full = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2 and len(set(ln.get_xdata())) == 1]
    assert full == []  # no dotted line per impact
    (rug,) = [c for c in ax.collections if c.get_gid() == "impact rug"]
    segs = rug.get_segments()
    assert len(segs) == 101
    assert sorted(s[0, 0] for s in segs) == pytest.approx(sorted(bursts.impact_times), abs=0.0)
    assert all(s[1, 1] - s[0, 1] < 0.05 for s in segs)  # short ticks (axes fraction), not lines across
    starts = [c for c in ax.collections if c is not rug and len(c.get_segments()) == len(FE_ARM_BURSTS)]
    assert len(starts) == 1  # one dotted line at the start of each episode
    # Up to MAX_LABELLED impacts: one dotted line each, numbered one by one.
    few = dataclasses.replace(bursts, impacts=bursts.impacts[:MAX_LABELLED])
    ax = plot_angles(few).axes[0]
    full = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2 and len(set(ln.get_xdata())) == 1]
    assert len(full) == MAX_LABELLED and not [c for c in ax.collections if c.get_gid() == "impact rug"]


def test_footnote_lists_episodes_past_twelve_impacts(bursts):
    note = _impact_note(bursts)
    assert note.startswith("101 impacts (ticks at the bottom), numbered per contact episode")
    assert "1\u201315: O3 at 0.525317\u2013" in note and "16\u201331: O3 at 0.537676\u2013" in note
    assert "(7 episodes in all)" in note


def test_figures_label_the_collision_episodes_of_a_run():
    # A Result of simulate groups its impacts by Result.episodes (not by time), and the footnote says what each
    # collision did: the 23 impacts of the issue-26 arm (one element) are one episode.
    from conftest import issue26_arm
    from gibbsimpact.plotting import plot_configurations
    from gibbsimpact.plotting.impacts import impact_groups

    res = issue26_arm()
    (ep,) = res.episodes
    assert impact_groups(res) == ([(0, 22)], True)
    note = _impact_note(res)
    assert note.startswith("23 impacts (ticks at the bottom) in 1 collision episode, numbered per episode")
    assert (f"1\u201323: O2 at {res.impacts[0].time:.6f}\u2013{res.impacts[-1].time:.6f} s (impulse "
            f"{ep.impulse:.3g} N s, e_eff {ep.restitution:.3g}, {ep.energy_lost:.3g} J lost)") in note
    fig = plot_angles(res)
    fig.canvas.draw()
    assert [t.get_text() for t in _number_row(fig.axes[0])] == ["1\u201323"]
    title = plot_configurations(res, n_points=5)._suptitle.get_text().replace("\n", " ")
    assert "23 impacts in 1 collision episode, one panel each" in title


def test_a_few_impacts_are_numbered_one_by_one_and_their_episodes_named():
    # Up to 12 impacts each has its number; the footnote adds the episodes that hold several of them.
    import dataclasses

    from conftest import issue26_arm

    res = issue26_arm()
    few = dataclasses.replace(res, impacts=res.impacts[:5])  # the first 5 of the one episode
    (ep,) = few.episodes
    assert ep.impacts == (0, 1, 2, 3, 4)
    note = _impact_note(few)
    assert note.startswith("impacts (dotted lines): 1: O2 at 0.268002 s; 2: O2 at")
    assert f"; collision episodes: 1\u20135 (impulse {ep.impulse:.3g} N s, e_eff {ep.restitution:.3g}" in note
    assert note.endswith(f"{ep.energy_lost:.3g} J lost)")
    # Each impact its own episode (the rigid rod): nothing added.
    assert "collision episodes" not in _impact_note(issue26_arm(elements=0, t_end=0.7))
