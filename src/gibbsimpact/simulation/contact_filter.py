"""A user's contact filter: candidates that a run does not watch for a new contact (docs/api.md, simulate).

The compass-gait biped of docs/walking.md is the reason: with straight legs its swing foot passes
through the ground near mid-stance (the "scuff" that the compass-gait literature ignores). A rule
of the run, stated in the case, says where a candidate may meet a wall:

    contact_filter(q) -> (C,) bool        True: candidate c is watched at q (N,) [m, rad]

over the candidates of the gap matrix (simulation.contacts.Contacts.names: "O1" .. "O<P>", then
"link i", "body k"). A pair (wall w, candidate c) that is filtered out at q and is not resting holds
the gap NOT_INTERIOR (1e300 m, "no candidate"): no hit or sink event, no penetration check, no
impact, no resting contact. A resting pair is never filtered out (the stance foot stays on the
ground whatever the rule says): a filter decides where contacts may *begin*, not where they end.

The gap of a pair jumps between NOT_INTERIOR and its value where the rule switches; that is no sign
change while the gap is positive, so the rule must switch a candidate on only where it is above the
wall (a switch at a negative gap is a crossing: the run stops with status "penetration" or takes an
impact below the wall). The compass gait's rule switches a foot on once it is ahead of the other foot
by a clearance, where the straight-legged swing foot is above the slope.
"""

from __future__ import annotations

import numpy as np

from .contacts import NOT_INTERIOR, Contacts


def checked_filter(contact_filter):
    """simulate's ``contact_filter``: None or a callable, else a ValueError naming the argument."""
    if contact_filter is not None and not callable(contact_filter):
        raise ValueError(f"simulate contact_filter={contact_filter!r} must be None or a callable "
                         "contact_filter(q) -> (C,) bool over the contact candidates, in the order O1 .. O<P>, "
                         "'link i', 'body k' (docs/api.md)")
    return contact_filter


class FilteredContacts(Contacts):
    """Contacts whose non-resting pairs are masked where ``contact_filter(q)`` is False (module docstring).

    resting : callable () -> (W, C) bool, the pairs resting now (contact.resting.RestingContacts.active):
        never masked.
    """

    def __init__(self, model, walls, link_contacts, contact_filter, resting=None):
        super().__init__(model, walls, link_contacts)
        self.contact_filter = contact_filter
        self.resting = resting

    def watched(self, q) -> np.ndarray:
        """(C,) bool: the filter's answer at q (N,), checked (one bool per candidate)."""
        rule = self.contact_filter
        w = np.asarray(rule(q, self.n_cols) if isinstance(rule, LeadFilter) else rule(q))
        if w.shape != (self.n_cols,):
            raise ValueError(f"simulate contact_filter returned shape {w.shape} at q = {np.asarray(q).tolist()}; "
                             f"it must return one bool per contact candidate {self.names}")
        return w.astype(bool)

    def _masked(self, q, g) -> np.ndarray:
        """(W, C) bool, the pairs of state q (N,) whose gaps g (W, C) the filter hides."""
        hidden = np.broadcast_to(~self.watched(q)[None, :], g.shape)
        return hidden & ~self.resting() if self.resting is not None else hidden

    def gaps_batch(self, qs: np.ndarray) -> np.ndarray:
        """g (K, W, C) [m] of Contacts.gaps_batch, NOT_INTERIOR at the filtered pairs."""
        g = super().gaps_batch(qs)
        for k, q in enumerate(qs):
            g[k][self._masked(q, g[k])] = NOT_INTERIOR
        return g

    def gap_single(self, q: np.ndarray, w: int, c: int, full=None) -> float:
        """g[w, c] at q [m] (Contacts.gap_single), NOT_INTERIOR where the filter hides the pair."""
        g = super().gap_single(q, w, c, full)
        if w < len(self.walls) and self._masked(q, np.zeros((len(self.walls), self.n_cols)))[w, c]:
            return NOT_INTERIOR
        return g

    def full(self, q: np.ndarray):
        """Contacts.full at q (N,), the filtered pairs with gap NOT_INTERIOR and valid False."""
        g, nrm, J, pts, valid = super().full(q)
        hidden = self._masked(q, g)
        return np.where(hidden, NOT_INTERIOR, g), nrm, J, pts, valid & ~hidden


class LeadFilter:
    """The rule "a listed point may begin a contact only where it leads the other listed points".

        watched(c) = s_c >= s_k + clearance for every other listed point k,    s = (p - O) . direction

    for the listed joint points c (indices into O1 .. O<P>, 0-based); every other candidate is watched
    always. A compass gait's feet with direction = downhill along the slope: the swing foot may strike
    only once it is ``clearance`` [m] ahead of the stance foot, past the scuff of straight legs.

    Parameters
    ----------
    model : Model; points : sequence of >= 2 joint indices (0-based: O1 is 0)
    direction : (3,) the direction of travel (normalised here); clearance : [m] >= 0
    """

    __name__ = "lead"

    def __init__(self, model, points, direction, clearance: float):
        self.model, self.points = model, np.asarray(points, dtype=int)
        d = np.asarray(direction, dtype=float)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0.0:
            raise ValueError(f"LeadFilter direction={direction!r} must be a non-zero 3-vector")
        if len(self.points) < 2 or np.any((self.points < 0) | (self.points >= model.n_joints)):
            raise ValueError(f"LeadFilter points={points!r} must be >= 2 joint indices in 0 .. {model.n_joints - 1}")
        if not (np.isfinite(clearance) and clearance >= 0.0):
            raise ValueError(f"LeadFilter clearance={clearance!r} must be a length >= 0 in metres")
        self.direction, self.clearance = d / np.linalg.norm(d), float(clearance)

    def describe(self) -> str:
        """One line for `gibbsimpact show`: the rule, its points, clearance and direction."""
        points = ", ".join(f"O{j + 1}" for j in self.points)
        d = ", ".join(f"{c:.6g}" for c in self.direction)
        return (f"lead: {points} may begin a contact only {self.clearance:g} m ahead of the other(s) along ({d}); "
                "resting contacts are never filtered")

    def __call__(self, q, n_cols=None) -> np.ndarray:
        """(C,) bool at q (N,): the listed points that lead the others by the clearance, every other candidate."""
        from ..dynamics.kinematics import joint_positions

        s = joint_positions(self.model, np.asarray(q, dtype=float))[self.points] @ self.direction  # (k,) [m]
        watched = np.ones(self.model.n_joints if n_cols is None else n_cols, dtype=bool)
        others = np.array([np.max(np.delete(s, k)) for k in range(len(s))])
        watched[self.points] = s >= others + self.clearance
        return watched
