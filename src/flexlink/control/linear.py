"""A continuous linear time-invariant plant with named states, inputs and outputs (SI units):

    ẋ = A x + B u,   y = C x + D u,

x, u, y deviations from an operating point (docs/control.md). Plain numpy arrays; a
python-control ``StateSpace`` on request (the optional extra ``flexlink[control]``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

# A zero transfer: |G| below this fraction of its bound ‖c‖ ‖x‖ + |D| at every frequency
# (an exact cancellation), or below ZERO_GAIN in SI units (−400 dB: an output row of C that
# is round-off of finite differences, far below any transfer of a mechanism)
ZERO_TRANSFER, ZERO_GAIN = 1e-12, 1e-20


@dataclass(frozen=True)
class LinearPlant:
    """ẋ = A x + B u, y = C x + D u about ``operating_point``.

    A (n, n) in 1/s, B (n, m), C (p, n), D (p, m); ``state_names``, ``input_names``,
    ``output_names`` name the rows and columns; ``input_units``/``output_units`` (UDUNITS)
    their units; ``operating_point``: what the plant is linearised about (plain values:
    strings, numbers, lists), ``equilibrium``: whether that point is one (else the plant is
    the frozen-time Jacobian of a moving state)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]
    input_units: tuple[str, ...]
    output_units: tuple[str, ...]
    operating_point: Mapping[str, Any] = field(default_factory=dict)
    equilibrium: bool = True

    def __post_init__(self) -> None:
        n, m, p = len(self.state_names), len(self.input_names), len(self.output_names)
        for name, arr, shape in (("A", self.A, (n, n)), ("B", self.B, (n, m)),
                                 ("C", self.C, (p, n)), ("D", self.D, (p, m))):
            if np.shape(arr) != shape:
                raise ValueError(f"{name} has shape {np.shape(arr)}, expected {shape}")
        if len(self.input_units) != m or len(self.output_units) != p:
            raise ValueError("one unit per input and per output")

    # -- selection --------------------------------------------------------------------------
    def select(self, inputs: Sequence[str] | None = None,
               outputs: Sequence[str] | None = None) -> LinearPlant:
        """The plant restricted to the named inputs and outputs (in that order)."""
        ii = _indices("input", inputs, self.input_names)
        oo = _indices("output", outputs, self.output_names)
        return LinearPlant(self.A, self.B[:, ii], self.C[oo], self.D[np.ix_(oo, ii)],
                           self.state_names, tuple(self.input_names[i] for i in ii),
                           tuple(self.output_names[i] for i in oo),
                           tuple(self.input_units[i] for i in ii),
                           tuple(self.output_units[i] for i in oo),
                           self.operating_point, self.equilibrium)

    # -- analysis ---------------------------------------------------------------------------
    def frequency_response(self, f_hz: Sequence[float] | np.ndarray) -> np.ndarray:
        """G(j 2π f) = C (j2πf I − A)⁻¹ B + D, complex (n_out, n_in, n_f)."""
        return self._response(f_hz)[0]

    def zero_transfers(self, f_hz: Sequence[float] | np.ndarray) -> np.ndarray:
        """(n_out, n_in) booleans: the pairs whose response is zero at every frequency of
        ``f_hz``, |G| within round-off (`ZERO_TRANSFER`) of its bound ‖cᵢ‖ ‖xⱼ‖ + |Dᵢⱼ|,
        x = (j2πf I − A)⁻¹ B, or below `ZERO_GAIN`: an output the input does not reach (a
        closed loop's dependent joint while its crank is prescribed), whose magnitude is
        round-off."""
        G, bound = self._response(f_hz)
        magnitude = np.abs(G)
        return np.all((magnitude <= ZERO_TRANSFER * bound) | (magnitude <= ZERO_GAIN), axis=2)

    def _response(self, f_hz: Sequence[float] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(G, the bound of |G| from the norms of C's rows and of the state responses)."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=float))
        n = self.A.shape[0]
        out = np.empty((self.C.shape[0], self.B.shape[1], f.size), dtype=complex)
        bound = np.empty(out.shape)
        rows = np.linalg.norm(self.C, axis=1)
        for i, fi in enumerate(f):
            X = np.linalg.solve(2j * np.pi * fi * np.eye(n) - self.A, self.B)
            out[:, :, i] = self.C @ X + self.D
            bound[:, :, i] = np.outer(rows, np.linalg.norm(X, axis=0)) + np.abs(self.D)
        return out, bound

    def poles(self) -> np.ndarray:
        """Eigenvalues of A (1/s), sorted by magnitude then imaginary part."""
        lam = np.linalg.eigvals(self.A)
        return lam[np.lexsort((lam.imag, np.abs(lam)))]

    def modes(self, rigid_tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Natural frequencies (Hz), damping ratios and state eigenvectors (n, k) of the
        oscillatory poles (one per conjugate pair, Im λ > 0), ascending in frequency.
        Poles with |λ| below ``rigid_tol`` times the largest (rigid-body, integrators) and
        real poles are left out."""
        lam, vec = np.linalg.eig(self.A)
        scale = max(np.abs(lam).max(initial=0.0), 1.0)
        keep = (lam.imag > 1e-9 * scale) & (np.abs(lam) > rigid_tol * scale)
        lam, vec = lam[keep], vec[:, keep]
        order = np.argsort(np.abs(lam))
        lam, vec = lam[order], vec[:, order]
        wn = np.abs(lam)
        return wn / (2 * np.pi), -lam.real / wn, vec

    # -- conversions ------------------------------------------------------------------------
    def to_statespace(self) -> Any:
        """A python-control ``StateSpace`` with the names of states, inputs and outputs."""
        try:
            import control
        except ImportError as exc:  # an optional extra
            raise ImportError("python-control is not installed: pip install flexlink[control]"
                              ) from exc
        return control.ss(self.A, self.B, self.C, self.D, states=list(self.state_names),
                          inputs=list(self.input_names), outputs=list(self.output_names),
                          name="flexlink")

    def _arrays(self) -> dict[str, Any]:
        return {"A": self.A, "B": self.B, "C": self.C, "D": self.D,
                "state_names": np.array(self.state_names, dtype=str),
                "input_names": np.array(self.input_names, dtype=str),
                "output_names": np.array(self.output_names, dtype=str),
                "input_units": np.array(self.input_units, dtype=str),
                "output_units": np.array(self.output_units, dtype=str)}

    def to_npz(self, path: Path | str) -> Path:
        """Write A, B, C, D, the names, units and the operating point (JSON text) to .npz."""
        import json

        path = Path(path)
        np.savez(path, **self._arrays(),
                 operating_point=np.array(json.dumps(dict(self.operating_point))),
                 equilibrium=np.array(self.equilibrium))
        return path

    @classmethod
    def from_npz(cls, path: Path | str) -> LinearPlant:
        """Read a plant written by ``to_npz``."""
        import json

        with np.load(Path(path), allow_pickle=False) as data:
            return cls(data["A"], data["B"], data["C"], data["D"],
                       *(tuple(str(s) for s in data[k]) for k in
                         ("state_names", "input_names", "output_names", "input_units",
                          "output_units")),
                       operating_point=json.loads(str(data["operating_point"])),
                       equilibrium=bool(data["equilibrium"]))

    def to_mat(self, path: Path | str) -> Path:
        """Write A, B, C, D and the names and units (cell arrays of char) to a MATLAB .mat
        file: ``ss(A, B, C, D, 'StateName', state_names, 'InputName', input_names, …)``."""
        from scipy.io import savemat

        path = Path(path)
        arrays = self._arrays()
        for key, value in arrays.items():
            if value.dtype.kind == "U":  # cellstr, not a char matrix
                arrays[key] = np.array([str(s) for s in value], dtype=object).reshape(-1, 1)
        arrays["operating_point"] = "; ".join(f"{k} = {v}"
                                              for k, v in self.operating_point.items())
        arrays["equilibrium"] = float(self.equilibrium)
        savemat(path, arrays, oned_as="column")
        return path


def _indices(kind: str, wanted: Sequence[str] | None, names: tuple[str, ...]) -> list[int]:
    if wanted is None:
        return list(range(len(names)))
    unknown = [w for w in wanted if w not in names]
    if unknown:
        raise ValueError(f"unknown {kind}(s) {', '.join(map(repr, unknown))}; the plant's "
                         f"{kind}s are: {', '.join(names) or '(none)'}")
    return [names.index(w) for w in wanted]
