"""Residual generators and banks: the objects the synthesis delivers (Hou, Wen & Chen 2011, §3.4).

A generator reads the **measured** output ``y`` and the known input ``u``::

    w' = F w - E y + G u          (w[k+1] = ... when dt > 0)
    r  = M w - H y + K u

(sign convention of Hou, Wen & Chen 2011, eq. 23).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import as_choice, as_float, as_matrix
from geomfdi.errors import GeomFDIError

__all__ = ["ResidualGenerator", "ResidualBank"]


@dataclass
class ResidualGenerator:
    """One residual generator ``(F, E, G, M, H, K)`` acting on measured ``y`` and ``u``.

    Attributes
    ----------
    F, E, G, M, H, K : ndarray
        ``w' = F w - E y + G u``, ``r = M w - H y + K u``.  Shapes: F (nw, nw),
        E (nw, q), G (nw, m), M (nr, nw), H (nr, q), K (nr, m).
    dt : float
        0 for continuous time, else the sampling period.
    target : tuple of int
        Indices (into the design's fault list) the residual must see.
    decoupled : tuple of int
        Indices the residual must ignore.
    method : str
        Sensor-fault transform used (``"exact"``, ``"paper"``, ``"mvw"``).
    info : dict
        Numbers of the design (subspace dimensions, orders, poles, conditioning,
        DC gains, identity residuals ...), for the user to see why the design came out
        as it did.
    """

    F: np.ndarray
    E: np.ndarray
    G: np.ndarray
    M: np.ndarray
    H: np.ndarray
    K: np.ndarray
    dt: float = 0.0
    target: tuple[int, ...] = ()
    decoupled: tuple[int, ...] = ()
    method: str = "exact"
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in "FEGMHK":
            setattr(self, name, as_matrix(getattr(self, name), name, allow_empty=True))
        self.dt = as_float(self.dt, "dt", minimum=0.0)
        nw, nr = self.F.shape[0], self.M.shape[0]
        q, m = self.H.shape[1], self.K.shape[1]
        expected = {
            "F": (nw, nw),
            "E": (nw, q),
            "G": (nw, m),
            "M": (nr, nw),
            "H": (nr, q),
            "K": (nr, m),
        }
        for name, shape in expected.items():
            if getattr(self, name).shape != shape:
                raise GeomFDIError(
                    f"{name}: expected shape {shape}, got {getattr(self, name).shape}",
                    argument=name,
                )

    # ----------------------------------------------------------------- sizes
    @property
    def order(self) -> int:
        """Number of generator states (dimension of ``w``)."""
        return self.F.shape[0]

    @property
    def n_outputs(self) -> int:
        """Number of residual components (rows of ``r``)."""
        return self.M.shape[0]

    @property
    def q(self) -> int:
        """Number of measured outputs read."""
        return self.H.shape[1]

    @property
    def m(self) -> int:
        """Number of known inputs read."""
        return self.K.shape[1]

    @property
    def is_discrete(self) -> bool:
        return self.dt > 0

    @property
    def gap(self) -> float | None:
        """Fault-to-noise gap ``β/γ`` of an approximate design (``info["gap"]``, measured on
        the design model; ``inf`` when the noise is decoupled exactly), ``None`` for a design
        that did not consider noise."""
        value = self.info.get("gap")
        return None if value is None else float(value)

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of ``F``."""
        return np.linalg.eigvals(self.F) if self.order else np.zeros(0, dtype=complex)

    # --------------------------------------------------------------- methods
    def scaled(self, c: float) -> ResidualGenerator:
        """The same generator with its residual multiplied by ``c`` (``E, G, H, K`` scaled).

        Residual generators are defined up to such a factor; use it to match a paper's
        normalisation or to put residuals on a common scale.
        """
        c = as_float(c, "c")
        if c == 0:
            raise GeomFDIError(f"c: must be a finite non-zero number, got {c}", argument="c")
        return ResidualGenerator(
            self.F.copy(),
            c * self.E,
            c * self.G,
            self.M.copy(),
            c * self.H,
            c * self.K,
            dt=self.dt,
            target=self.target,
            decoupled=self.decoupled,
            method=self.method,
            info={**self.info, "scale": self.info.get("scale", 1.0) * c},
        )

    def normalized(self, kind: str = "dc") -> ResidualGenerator:
        """The generator rescaled so that its response to its (first) target is unit.

        Parameters
        ----------
        kind : {"dc", "markov"}
            ``"dc"``: unit DC gain from the target fault on the physical model.
            ``"markov"``: unit first non-zero Markov parameter of the target's transfer
            on the design model, ``−H Df_j`` or ``−M F^k (P L_j + E Df_j)`` — the
            normalisation of the example of Hou, Wen & Chen 2011 (M = 1 and
            ``p_j L_j = ±1`` for its rows p_1 = (0,1,0), p_2 = (−2,2,1), p_3 = (−3,3,1)).
        """
        kind = as_choice(kind, "kind", ("dc", "markov"))
        if not self.target:
            raise GeomFDIError("normalized: the generator has no target fault", argument="kind")
        j = self.target[0]
        if kind == "dc":
            dc = self.info.get("dc_gain")
            value = None if dc is None else float(dc[j])
            what = "DC gain"
        elif kind == "markov":
            value = self.info.get("markov_gain")
            what = "first Markov parameter"
        else:
            raise GeomFDIError(f"kind: must be 'dc' or 'markov', got {kind!r}", argument="kind")
        if value is None or not np.isfinite(value) or value <= 0:
            raise GeomFDIError(
                f"kind: cannot normalise by the {what} (value {value}); choose another kind",
                argument="kind",
            )
        return self.scaled(1.0 / value)

    def to_statespace(self) -> Any:
        """python-control ``StateSpace`` with inputs ``[y; u]`` and outputs ``r``.

        ``A = F``, ``B = [-E, G]``, ``C = M``, ``D = [-H, K]``.
        """
        import control

        B = np.hstack([-self.E, self.G])
        D = np.hstack([-self.H, self.K])
        F = self.F
        if self.order == 0:  # a static residual: python-control wants a 0-state system
            F = np.zeros((0, 0))
        return control.ss(
            F,
            B.reshape(self.order, self.q + self.m),
            self.M.reshape(self.n_outputs, self.order),
            D,
            self.dt,
            inputs=[f"y[{i}]" for i in range(self.q)] + [f"u[{i}]" for i in range(self.m)],
            outputs=[f"r[{i}]" for i in range(self.n_outputs)],
        )

    def __repr__(self) -> str:
        kind = f"dt={self.dt:g}" if self.dt else "continuous"
        return (
            f"ResidualGenerator(order={self.order}, outputs={self.n_outputs}, "
            f"target={list(self.target)}, decoupled={list(self.decoupled)}, "
            f"method={self.method!r}, {kind})"
        )


@dataclass
class ResidualBank:
    """A bank of residual generators, one per row of a structure matrix.

    Attributes
    ----------
    generators : list of ResidualGenerator or None
        Aligned with the rows of the requested structure; ``None`` where the requested
        residual does not exist (reason in :attr:`diagnostics`).
    requested : ndarray of bool, (rows, n_faults)
        The requested structure matrix (1 = must see, 0 = must ignore).
    structure : ndarray of bool, (rows, n_faults)
        Achieved structure: entry (r, j) is True when residual r sees fault j (transfer
        not identically zero).  Rows of missing generators are all False.
    isolable : ndarray of bool, (n_faults,)
        Fault j is isolable when its column of :attr:`structure` is non-zero and differs
        from every other fault's column.
    diagnostics : list of str
        Per row: ``"ok"``, ``"weak: zero DC gain from fault j"``, or why the residual
        is missing.
    faults : list
        The design's fault list (columns).
    dt : float
        Sampling period of the generators (0: continuous).
    method : str
        Sensor-fault transform used.
    info : dict
        Design-wide numbers.
    """

    generators: list[ResidualGenerator | None]
    requested: np.ndarray
    structure: np.ndarray
    isolable: np.ndarray
    diagnostics: list[str]
    faults: list[Any]
    dt: float = 0.0
    method: str = "exact"
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def n_residuals(self) -> int:
        return len(self.generators)

    def normalized(self, kind: str = "dc") -> ResidualBank:
        """Every generator rescaled with :meth:`ResidualGenerator.normalized`."""
        gens = [None if g is None else g.normalized(kind) for g in self.generators]
        return ResidualBank(
            gens,
            self.requested,
            self.structure,
            self.isolable,
            self.diagnostics,
            self.faults,
            self.dt,
            self.method,
            {**self.info, "normalized": kind},
        )

    @property
    def n_faults(self) -> int:
        return self.structure.shape[1]

    @property
    def residual_index_sets(self) -> list[set[int]]:
        """``Omega_i`` of Hou, Wen & Chen 2011, Definition 4: the residuals that see fault i."""
        return [set(np.flatnonzero(self.structure[:, j]).tolist()) for j in range(self.n_faults)]

    @property
    def present(self) -> list[int]:
        """Row indices of the generators that exist."""
        return [k for k, g in enumerate(self.generators) if g is not None]

    def to_statespace(self) -> Any:
        """All existing generators stacked: inputs ``[y; u]``, outputs ``r[k]`` per row.

        Only rows whose generator exists appear (see :attr:`present`); output names carry
        the row index.
        """
        import control

        rows = self.present
        if not rows:
            raise GeomFDIError("bank: no residual generator exists in this bank", argument="bank")
        gens = [self.generators[k] for k in rows]
        q, m = gens[0].q, gens[0].m
        A, B, C, D = stacked_matrices(gens)
        outputs = [
            f"r{k}[{c}]" if g.n_outputs > 1 else f"r[{k}]"
            for k, g in zip(rows, gens, strict=True)
            for c in range(g.n_outputs)
        ]
        return control.ss(
            A,
            B,
            C,
            D,
            self.dt,
            inputs=[f"y[{j}]" for j in range(q)] + [f"u[{j}]" for j in range(m)],
            outputs=outputs,
        )

    # ------------------------------------------- sampling and saving
    def discretize(self, dt: float, method: str = "zoh") -> ResidualBank:
        """The bank sampled at ``dt`` (``"zoh"`` or ``"tustin"``), keeping its faults,
        structure, diagnostics and info; see :func:`geomfdi.generators.discretize.discretize_bank`.
        """
        from geomfdi.generators.discretize import discretize_bank

        return discretize_bank(self, dt, method)

    def save(self, path: Any) -> Any:
        """Write the bank to a versioned JSON file (read back with ``gf.load_bank``)."""
        from geomfdi.generators.bankfile import save_bank

        return save_bank(self, path)

    def __repr__(self) -> str:
        return (
            f"ResidualBank(rows={self.n_residuals}, faults={self.n_faults}, "
            f"present={self.present}, isolable={self.isolable.tolist()}, method={self.method!r})"
        )


def stacked_matrices(
    gens: list[ResidualGenerator],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The generators ``gens`` side by side as one system with inputs ``[y; u]``.

    Block-diagonal ``F``, stacked ``[-E_k, G_k]``, block-diagonal ``M`` and stacked
    ``[-H_k, K_k]``, in the order of ``gens``: ``w' = F w + B [y; u]``,
    ``r = M w + D [y; u]`` (the sign convention of Hou, Wen & Chen 2011, eq. 23, row by row).
    """
    q, m = gens[0].q, gens[0].m
    nw = sum(g.order for g in gens)
    nr = sum(g.n_outputs for g in gens)
    F = np.zeros((nw, nw))
    B = np.zeros((nw, q + m))
    M = np.zeros((nr, nw))
    D = np.zeros((nr, q + m))
    i = o = 0
    for g in gens:
        F[i : i + g.order, i : i + g.order] = g.F
        B[i : i + g.order] = np.hstack([-g.E, g.G])
        M[o : o + g.n_outputs, i : i + g.order] = g.M
        D[o : o + g.n_outputs] = np.hstack([-g.H, g.K])
        i += g.order
        o += g.n_outputs
    return F, B, M, D
