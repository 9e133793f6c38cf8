"""Parametric models for derive_equations(symbols=...): link data as expressions of named parameters."""

from __future__ import annotations

import re

import numpy as np

#: Names of the model parameters that symbols=... may keep (the rest of ``constants`` are modal integrals).
PARAMETER_NAME = re.compile(r"(l|mu|EI[yz]|j[xyz])_\d+|g_\d")


class _ParametricLink:
    """The LinkData arrays of one uniform link as expressions of its parameters (object arrays).

    With l, mu, EI and the length exponent a_k of each shape function (0 for
    a mode or an element deflection function, 1 for an element slope function,
    whose values are lengths), every moment is a parameter monomial times a
    dimensionless named constant:

        int mu psi_k = mu l^(1+a_k) c_k          int mu x psi_k = mu l^(2+a_k) cx_k
        int mu psi_k psi_l = mu l^(1+a_k+a_l) d_kl    K_kl = EI l^(a_k+a_l-3) kappa_kl
        psi_k(l) = l^(a_k) e_k                   psi_k'(l) = l^(a_k-1) s_k
        P0 = mu [[l^3/3, l^2/2], [l^2/2, l]] (x and 1 entries),  J = l diag(j_x, j_y, j_z)
    """

    def __init__(self, sp, link, ld, i: int, values: dict):
        if callable(link.mass_per_length) or any(callable(e) for e in link.EI):
            raise ValueError(f"derive_equations symbols=True needs uniform links; link {i} has a callable "
                             "mass_per_length or EI")
        if link.bodies:
            raise ValueError(f"derive_equations symbols=True writes a uniform link's tables from mu and l; link {i} "
                             "carries RigidBody entries (bodies): use symbols=False, which takes its numeric tables")
        self.end_is_rigid, self.has_rotary, self.directions = ld.end_is_rigid, ld.has_rotary, ld.directions
        l_v, mu_v = link.length, link.mass_per_length
        l, mu = self._par(sp, values, f"l_{i}", l_v), self._par(sp, values, f"mu_{i}", mu_v)
        EI = {"y": (f"EIz_{i}", link.EI_z), "z": (f"EIy_{i}", link.EI_y)}  # y-bending resists with EI_z
        m = len(ld.directions)
        a = np.array([(k % 2) if link.elements else 0 for k in range(m)])  # element slopes: odd 0-based k
        obj = lambda shape: np.full(shape, sp.S.Zero, dtype=object)  # noqa: E731
        self.P0, self.m_r0, self.E0 = obj((4, 4)), obj(4), obj((4, 4))
        self.P0[0, 0], self.P0[0, 3] = mu * l**3 / 3, mu * l**2 / 2
        self.P0[3, 0], self.P0[3, 3] = mu * l**2 / 2, mu * l
        self.m_r0[0], self.m_r0[3] = mu * l**2 / 2, mu * l
        for k in range(4):
            self.E0[k, k] = sp.S.One
        self.E0[0, 3] = l

        self.C, self.D, self.m_psi = obj((m, 4, 4)), obj((m, m, 4, 4)), obj((m, 4))
        self.K, self.M_dd, self.end_t, self.end_phi = obj((m, m)), obj((m, m)), obj((m, 3)), obj((m, 3))
        for k in range(m):
            ak = int(a[k])
            ax = 1 if ld.directions[k] == "y" else 2
            c1 = self._const(sp, values, f"c_{i}_{k + 1}", ld.C[k, 3, ax] / (mu_v * l_v ** (1 + ak)))
            cx = self._const(sp, values, f"cx_{i}_{k + 1}", ld.C[k, 0, ax] / (mu_v * l_v ** (2 + ak)))
            self.C[k, 3, ax] = mu * l ** (1 + ak) * c1
            self.C[k, 0, ax] = mu * l ** (2 + ak) * cx
            self.m_psi[k, ax] = mu * l ** (1 + ak) * c1
            for j in range(m):
                aj = int(a[j])
                axj = 1 if ld.directions[j] == "y" else 2
                lo, hi = min(k, j), max(k, j)
                dv = ld.D[k, j, ax, axj]
                dk = self._const(sp, values, f"d_{i}_{lo + 1}_{hi + 1}", dv / (mu_v * l_v ** (1 + ak + aj)))
                self.D[k, j, ax, axj] = mu * l ** (1 + ak + aj) * dk
                if ax == axj:
                    self.M_dd[k, j] = self.D[k, j, ax, axj]
                if ld.directions[k] == ld.directions[j] and ld.K[k, j] != 0.0:
                    nm, ei_v = EI[ld.directions[k]]
                    ei = self._par(sp, values, nm, ei_v)
                    kk = self._const(sp, values, f"kappa_{i}_{lo + 1}_{hi + 1}", ld.K[k, j] / (ei_v * l_v ** (ak + aj - 3)))
                    self.K[k, j] = ei * l ** (ak + aj - 3) * kk
            e = self._const(sp, values, f"e_{i}_{k + 1}", ld.end_t[k, ax] / l_v ** ak)
            self.end_t[k, ax] = l ** ak * e
            rot = 2 if ld.directions[k] == "y" else 1
            sv = self._const(sp, values, f"s_{i}_{k + 1}", ld.end_phi[k, rot] / l_v ** (ak - 1))
            self.end_phi[k, rot] = l ** (ak - 1) * sv
        self.J_body = obj((3, 3))
        for r, (nm, jv) in enumerate(zip(("jx", "jy", "jz"), link.rotary_inertia)):
            if jv != 0.0:
                self.J_body[r, r] = l * self._par(sp, values, f"{nm}_{i}", jv)

    @staticmethod
    def _par(sp, values, name, v):
        x = sp.Symbol(name, positive=True)
        values[x] = float(v)
        return x

    @staticmethod
    def _const(sp, values, name, v):
        if v == 0.0:
            return sp.S.Zero
        x = sp.Symbol(name, real=True)
        values[x] = float(v)
        return x


class ParametricModel:
    """A Model whose link data and gravity are expressions of named parameters (attributes else delegated)."""

    def __init__(self, sp, model, values: dict):
        self._model = model
        self.link_data = tuple(_ParametricLink(sp, lk, ld, i, values)
                               for i, (lk, ld) in enumerate(zip(model.chain.links, model.link_data), start=1))
        g = np.full(3, sp.S.Zero, dtype=object)
        for a, gv in enumerate(model.gravity):
            if gv != 0.0:
                g[a] = sp.Symbol(f"g_{a + 1}", real=True)
                values[g[a]] = float(gv)
        self.gravity = g

    def __getattr__(self, name):
        return getattr(self._model, name)


def fix_parameters(sp, symbols, constants: dict) -> dict:
    """symbols=<names>: {parameter symbol: its value} for every parameter not named, removed from ``constants``.

    ``symbols`` is a str or a sequence of str among the model's parameters (l_i, mu_i, EIz_i,
    EIy_i, jx_i ..., g_1 .. g_3 present in ``constants``); an unknown name raises ValueError.
    """
    keep = {str(x) for x in ([symbols] if isinstance(symbols, str) else symbols)}
    params = {str(k): k for k in constants if PARAMETER_NAME.fullmatch(str(k))}
    unknown = sorted(keep - set(params))
    if unknown:
        raise ValueError(f"derive_equations symbols={tuple(sorted(keep))!r}: {', '.join(unknown)} not parameters "
                         f"of this model; choose from {', '.join(params)}")
    return {k: sp.Float(constants.pop(k), 17) for name, k in params.items() if name not in keep}
