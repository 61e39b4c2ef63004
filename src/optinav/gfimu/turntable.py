"""Turntable calibration of the 5 installation errors per accelerometer (Hao & Liu 2011, §3).

Scheme: the array sits on a wedge of angle γ on a horizontal turntable turning at a constant rate w about
the vertical; three mountings put the table axis ``u`` in the body x–z, y–z and x–y planes:

    u₁ = (sin γ, 0, cos γ),   u₂ = (0, sin γ, cos γ),   u₃ = (cos γ, sin γ, 0)

and each is run at two rates w₁, w₂: six cases. Earth rate neglected, ω = w u, ω̇ = 0, and the body-fixed
up direction is u, so with the array reference point at a body offset ``d`` from the table axis

    f_i = θ_iᵀ (g u + w² (u uᵀ − I)(r_i + d))                                   (m/s², constant per case)

Within a case the outputs are constant: the case means (6 per sensor) are sufficient statistics under white
noise, and every estimator here works on them (σ/√n each).

* :func:`closed_form` — the paper's baseline: per mounting, differences between the two rates give
  ``c = θᵀ(uuᵀ − I) r = (f(w₂) − f(w₁))/(w₂² − w₁²)`` and ``g θᵀu = (w₂² f(w₁) − w₁² f(w₂))/(w₂² − w₁²)``; the
  three mountings give θ (3 × 3 inverse of [u₁ u₂ u₃]ᵀ, invertible for γ = 30°) and then r (3 × 3 inverse
  of the rows θᵀ(u_m u_mᵀ − I)). Needs d = 0.
* :func:`calibrate` — our default: nonlinear least squares (Levenberg–Marquardt, analytic Jacobian) of all
  case means for the 50 coefficients (θ unit by construction: 5 unknowns, 6 equations per sensor), started
  from the closed form, with covariance and CRLB from :func:`optinav.core.observability.analyze`.

Ambiguity: only ``r_i + d`` enters, so with ``d`` not known (``offset="unknown"``, the default) a common shift of
all positions is not observable and Δr are reported relative to their mean (gauge mean(Δr) = 0); ``"zero"`` or a
measured ``d`` gives absolute Δr. The common shift does not change the rate solution (ω, ω̇): it only moves the
reference point of A (f_i depends on A + ω̇×c + ω×(ω×c) and r_i − c). With ``offset="estimate"`` the offset of
each mounting (its 2 components across the table axis) would be estimated too (not separable on this scheme).
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from optinav.core.files import atomic_open, atomic_path, csv_writer
from optinav.core.imu_model import SampleDraws, draw_key
from optinav.core.observability import analyze
from optinav.core.optimize import Problem, minimize
from optinav.core.results import (
    Estimate,
    Parameter,
    Truth,
    convergence,
    gate,
    nested_kwargs,
    register_legacy,
    register_truth_legacy,
)
from optinav.core.units import G_STANDARD
from optinav.core.validate import as_float_array, as_rng, check_positive
from optinav.errors import OptinavError
from optinav.gfimu.array import AccelerometerArray
from optinav.gfimu.solve import noise_sigma
from optinav.gfimu.errors import (
    InstallationErrors,
    direction,
    direction_derivatives,
    errors_from_geometry,
    local_frames,
    perturb,
)

__all__ = [
    "table_axes",
    "TurntableData",
    "TurntableStream",
    "turntable_csv_writer",
    "simulate",
    "case_means",
    "closed_form",
    "calibrate",
    "TurntableCalibration",
    "scheme_identifiability",
    "PAPER",
    "MICRO_G",
    "required_samples",
    "BLOCK_ROWS",
]

MICRO_G = 1e-6 * G_STANDARD
#: the paper's simulation (Hao & Liu 2011, §3) and its published results
PAPER = {
    "gamma_deg": 30.0,
    "dr": 0.001,
    "dangle": 0.01,
    "noise": MICRO_G,
    "rates": {"low": (0.1, 0.2), "high": (0.5, 1.0)},
    "max_rel_err_position_pct": {"low": 243.9, "high": 12.2},
    "max_rel_err_direction_pct": {"low": 0.042, "high": 0.041},
}
MOUNTING_NAMES = ("x-z", "y-z", "x-y")
#: rows per block of :class:`TurntableStream` and of the CSV :meth:`TurntableData.save` writes (memory grows with
#: it, not with the log; the rows do not depend on it)
BLOCK_ROWS = 1 << 16


def table_axes(gamma: float, mountings=(1, 2, 3)) -> np.ndarray:
    """Table axis in body coordinates (M, 3) for wedge angle γ (rad) and mountings 1 (x–z), 2 (y–z), 3 (x–y)."""
    s, c = np.sin(gamma), np.cos(gamma)
    u = {1: (s, 0.0, c), 2: (0.0, s, c), 3: (c, s, 0.0)}
    try:
        return np.array([u[int(m)] for m in mountings], float)
    except KeyError:
        bad = sorted({int(m) for m in mountings} - {1, 2, 3})
        raise OptinavError(
            f"mounting(s) {', '.join(map(str, bad))} are not among 1, 2, 3", "use 1 (axis in x-z), 2 (y-z), 3 (x-y)"
        ) from None


def _perp_basis(u) -> np.ndarray:
    """Two unit vectors (2, 3) across the axis u (the offset components that matter)."""
    a = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(u, a)
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(u, e1)])


@dataclass
class TurntableData:
    """Turntable log: t (T,) s, acc (T, N) m/s², mounting (T,) in 1..3, table_rate (T,) rad/s, wedge γ rad,
    gravity m/s², sigma (N,) m/s² if known (simulation)."""

    t: np.ndarray
    acc: np.ndarray
    mounting: np.ndarray
    table_rate: np.ndarray
    gamma: float
    gravity: float = G_STANDARD
    sigma: np.ndarray | None = None

    @property
    def case(self) -> np.ndarray:
        """Case label 1..K in order of appearance of (mounting, rate)."""
        return case_labels(self.mounting, self.table_rate)

    def save(self, path) -> Path:
        """Write the log atomically, by suffix.

        NPZ (arrays t, f, case, mounting, table_rate, wedge, gravity), CSV (t, f1..fN, case, mounting, table_rate,
        wedge, gravity) or HDF5.

        Parameters
        ----------
        path : str or Path
            Output file (.npz, .csv, .h5).

        Returns
        -------
        Path
            The file written.
        """
        from pathlib import Path

        path = Path(path)
        n = len(self.t)
        case = self.case

        def columns():
            return {
                "t": self.t,
                "case": case.astype(float),
                "mounting": self.mounting.astype(float),
                "table_rate": self.table_rate,
                "wedge": np.full(n, self.gamma),
                "gravity": np.full(n, self.gravity),
            }

        suf = path.suffix.lower()
        if suf == ".npz":
            with atomic_open(path, "wb") as fh:
                np.savez(fh, f=self.acc, **columns())
        elif suf in (".csv", ".txt"):
            # in blocks through the streamed writer: the layout of optinav simulate gfimu-turntable's CSV
            with turntable_csv_writer(path, self.acc.shape[1], self.gamma, self.gravity) as write:
                for i0 in range(0, n, BLOCK_ROWS):
                    s = slice(i0, i0 + BLOCK_ROWS)
                    write(self.t[s], self.acc[s], case[s], self.mounting[s], self.table_rate[s])
        elif suf in (".h5", ".hdf5"):
            try:
                import h5py
            except ImportError:
                raise OptinavError("writing HDF5 needs h5py", "pip install h5py, or use .npz/.csv") from None
            with atomic_path(path) as tmp, h5py.File(tmp, "w") as fh:
                fh["f"] = self.acc
                for k, v in columns().items():
                    fh[k] = v
        else:
            raise OptinavError(f"cannot write {path.suffix or 'a file without suffix'}", "use .npz, .csv or .h5")
        return path

    @classmethod
    def load(cls, path, n_accelerometers: int | None = None) -> "TurntableData":
        """Read a log written by :meth:`save` (or in its columns).

        Parameters
        ----------
        path : str or Path
            .npz, .csv or .h5 file.
        n_accelerometers : int or None
            Expected number of sensors (checked when given).

        Returns
        -------
        TurntableData
            ``t`` [s], ``f`` [m/s^2], mounting, ``table_rate`` [rad/s], wedge γ [rad], gravity [m/s^2].
        """
        from optinav.io.readers import load_table

        tab = load_table(path)
        gamma, g = _turntable_constants(tab, path)
        check_finite_columns(tab, path)
        f = array_outputs(tab, path, n_accelerometers)
        t = np.asarray(tab.get("t"), float)
        return cls(
            t,
            f,
            np.asarray(tab.get("mounting"), float).astype(int),
            np.asarray(tab.get("table_rate"), float),
            gamma,
            g,
        )


#: units a turntable column may carry in its name (recognized to name the column, not converted)
_NAMED_UNITS = ("deg", "rad", "degps", "radps", "rpm", "s", "ms", "us", "ns")


def _turntable_constants(tab, path) -> tuple[float, float]:
    """The wedge angle [rad] and gravity [m/s^2] of a turntable table, its required columns checked."""
    from optinav.io.readers import find_with_unit

    missing = [k for k in ("t", "mounting", "table_rate", "wedge") if tab.find(k) is None]
    # a column named with its unit (table_rate_deg, wedge [deg]): the columns are read by their names only
    named = {k: find_with_unit(tab, k, _NAMED_UNITS) for k in missing}
    named = {k: v for k, v in named.items() if v[0] is not None}
    if named:
        k, (key, unit) = next(iter(named.items()))
        fix = {
            "table_rate": "name it table_rate, in rad/s or deg/s with --rate-unit deg/s",
            "wedge": "name it wedge, in rad",
            "t": "name it t, in s",
        }.get(k, f"name it {k}")
        raise OptinavError(
            f"{path} names its {k} column {key!r} (in {unit}); the turntable columns are read by their names",
            f"{fix} (see docs/methods/gfimu.md)",
        )
    if missing:
        raise OptinavError(
            f"{path} has no {', '.join(missing)} (found: {tab.names()})",
            "write it with optinav simulate gfimu-turntable or see docs/methods/gfimu.md",
        )
    g = float(np.asarray(tab.get("gravity"), float).ravel()[0]) if tab.find("gravity") is not None else G_STANDARD
    return float(np.asarray(tab.get("wedge"), float).ravel()[0]), g


def case_labels(mounting, table_rate) -> np.ndarray:
    """Case label 1..K of every row: the order of first appearance of its (mounting, rate rounded to 1e-12 rad/s).

    Vectorized over the runs of equal rows (a log's cases are long runs), so it takes a few bytes per row.

    Parameters
    ----------
    mounting : (T,) array
        Mounting of each row (1..3).
    table_rate : (T,) array
        Table rate of each row [rad/s].

    Returns
    -------
    (T,) int ndarray
        The case labels [-].
    """
    m = np.asarray(mounting).astype(int, copy=False).ravel()
    w = np.round(np.asarray(table_rate, float).ravel(), 12)
    if m.size == 0:
        return np.zeros(0, int)
    starts = np.flatnonzero(np.r_[True, (m[1:] != m[:-1]) | (w[1:] != w[:-1])])
    order: dict = {}
    run_labels = [order.setdefault((int(m[i]), float(w[i])), len(order) + 1) for i in starts]
    return np.repeat(np.asarray(run_labels, int), np.diff(np.r_[starts, m.size]))


@contextlib.contextmanager
def turntable_csv_writer(path, n_accelerometers: int, gamma: float, gravity: float = G_STANDARD):
    """A turntable CSV file written block by block, atomically (:func:`optinav.core.files.csv_writer`): the layout
    of :meth:`TurntableData.save` (header ``t,f1..fN,case,mounting,table_rate,wedge,gravity``, ``%.12g``), so the
    blocks of a log give the same bytes as the whole.

    Parameters
    ----------
    path : str or Path
        Output file (.csv); it appears when the ``with`` block ends without an error.
    n_accelerometers : int
        Number of outputs N.
    gamma : float
        Wedge angle γ [rad] (the ``wedge`` column).
    gravity : float
        Gravity [m/s^2] (the ``gravity`` column).

    Yields
    ------
    callable
        ``write(t, acc, case, mounting, table_rate)`` appends rows: t [s], acc (m, N) [m/s^2], case label,
        mounting (1..3) and table rate [rad/s].
    """
    header = ",".join(
        ["t"]
        + [f"f{i + 1}" for i in range(int(n_accelerometers))]
        + ["case", "mounting", "table_rate", "wedge", "gravity"]
    )
    wedge, grav = float(gamma), float(gravity)

    def write(t, acc, case, mounting, table_rate):
        m = len(t)
        block = np.column_stack([t, acc, case, mounting, table_rate, np.full(m, wedge), np.full(m, grav)]).astype(
            float, copy=False
        )
        put(block)

    with csv_writer(path, header, "%.12g") as put:
        yield write


#: the columns of a turntable log besides the outputs (``wedge`` and ``gravity`` may hold a single value)
LOG_COLUMNS = ("t", "case", "mounting", "table_rate", "wedge", "gravity")


def nonfinite_rows_error(path, column: str, bad_rows, row0: int = 0) -> OptinavError:
    """The one-line error for NaN/inf in a column of a data file, naming the column and its first bad rows.

    Parameters
    ----------
    path : str or Path
        The file (named in the message).
    column : str
        The column's name (or a phrase naming it, e.g. ``"output 4 of the f array"``).
    bad_rows : (k,) int array
        The bad rows of the block read [-], counted from 0.
    row0 : int
        Rows of the file before that block [-].

    Returns
    -------
    OptinavError
        The error to raise; data rows are numbered from 1.
    """
    rows = np.asarray(bad_rows, int) + int(row0) + 1
    first = ", ".join(str(int(r)) for r in rows[:3]) + (", ..." if rows.size > 3 else "")
    what = column if " " in column else f"the {column} column"
    return OptinavError(
        f"{path}: {what} holds NaN/inf in {rows.size} row(s) (data row{'s' if rows.size > 1 else ''} {first}, "
        "counted from 1)",
        "remove those rows or fill in their values",
    )


def check_finite_columns(tab, path, row0: int = 0) -> None:
    """Refuse NaN/inf in a turntable table's :data:`LOG_COLUMNS` (those present), naming the column and its first
    bad rows (:func:`nonfinite_rows_error`), before they reach the case means and the fit.

    Parameters
    ----------
    tab : Table
        A table (or block) read by :func:`optinav.io.readers.iter_table`.
    path : str or Path
        Its file (named in the message).
    row0 : int
        Rows of the file before this block [-].

    Returns
    -------
    None
    """
    for name in LOG_COLUMNS:
        if tab.find(name) is None:
            continue
        v = np.asarray(tab.get(name), float)
        bad = np.flatnonzero(~np.isfinite(v.reshape(v.shape[0], -1)).all(axis=1)) if v.ndim else []
        if v.ndim == 0 and not np.isfinite(v):
            bad = [0]
        if len(bad):
            raise nonfinite_rows_error(path, name, bad, row0)


def array_outputs(tab, path, n_accelerometers: int | None = None, row0: int = 0) -> np.ndarray:
    """The accelerometer outputs (T, N) m/s² of a table read by :func:`optinav.io.readers.load_table`: its array
    ``f`` or its columns ``f1..fN``; checked finite (NaN/inf named by column and first rows, the table's rows
    starting at file row ``row0``) and, when given, ``n_accelerometers`` wide."""
    named = tab.find("f") is None
    if not named:
        f = np.asarray(tab.get("f"), float)
        if f.ndim == 1:
            f = f[:, None]
    else:
        from optinav.core.units import UNITS
        from optinav.io.readers import find_with_unit

        if tab.find("f0") is not None:
            raise OptinavError(
                f"{path} numbers its outputs from f0: optinav reads f1..fN, f1 the configuration's first sensor",
                "rename the output columns f1, f2, ... in the configuration's order",
            )
        k, cols, g_units = 1, [], ("g", "mg", "ug")
        while True:  # f1, f01, 'f1 [g]', f1_mg; a unit in g, mg or µg is converted
            key, unit = find_with_unit(tab, f"f{k}", g_units)
            if key is None:
                key, unit = find_with_unit(tab, f"f{k:02d}", g_units)
            if key is None:
                break
            unit = unit or tab.units.get(key)
            cols.append(np.asarray(tab.get(key), float) * (UNITS[unit] if unit in g_units else 1.0))
            k += 1
        if not cols:
            raise OptinavError(
                f"{path} has no accelerometer outputs f1..fN (or an array f)", "name the output columns f1, f2, ..."
            )
        f = np.column_stack(cols)
    if n_accelerometers is not None and f.shape[1] != n_accelerometers:
        raise OptinavError(
            f"{path} has {f.shape[1]} accelerometer columns, the configuration {n_accelerometers}",
            "pass the configuration the data was recorded with",
        )
    if not np.all(np.isfinite(f)):
        k = int(np.flatnonzero(~np.isfinite(f).all(axis=0))[0])
        name = f"f{k + 1}" if named else f"output {k + 1} of the f array"
        raise nonfinite_rows_error(path, name, np.flatnonzero(~np.isfinite(f[:, k])), row0)
    return f


def model_outputs(positions, directions, u, w, g, offset=None) -> np.ndarray:
    """Noise-free case outputs (N,) for axis u (3,), table rate w rad/s, optional body offset d (3,) m."""
    r = np.asarray(positions, float) + (0.0 if offset is None else np.asarray(offset, float))
    P = np.outer(u, u) - np.eye(3)
    return np.asarray(directions, float) @ (g * u) + w * w * np.einsum("ni,ij,nj->n", directions, P, r)


class TurntableStream:
    """The turntable cases (mountings × rates, ``duration`` each at ``rate_hz``) generated block by block, so that
    memory does not grow with the length of the log (``optinav simulate gfimu-turntable``); :func:`simulate` gathers
    the same blocks.

    Within a case the noise-free outputs are constant (:func:`model_outputs`); one key is drawn from ``rng`` (where
    the noise was drawn before), from which the white noise of every sample is drawn by sample index
    (:class:`~optinav.core.imu_model.SampleDraws`, N values per sample): the same seed gives the same log whatever
    the block length.

    Parameters
    ----------
    nominal, errors, rates, gamma, mountings, rate_hz, duration, noise, offset, gravity, rng
        As :func:`simulate`.

    Attributes
    ----------
    n : int
        Rows of the log (samples per case × cases).
    n_case : int
        Samples per case.
    n_accelerometers : int
        Outputs N per row.
    gamma, gravity : float
        Wedge angle [rad] and gravity [m/s^2].
    sigma : (N,) ndarray
        Noise std [m/s^2].
    """

    def __init__(
        self,
        nominal: AccelerometerArray,
        errors: InstallationErrors | None = None,
        *,
        rates=(0.5, 1.0),
        gamma: float = np.radians(30.0),
        mountings=(1, 2, 3),
        rate_hz: float = 100.0,
        duration: float = 10.0,
        noise=MICRO_G,
        offset=None,
        gravity: float = G_STANDARD,
        rng=None,
    ):
        rng = as_rng(rng)
        errors = InstallationErrors.zeros(nominal.n) if errors is None else errors
        actual = perturb(nominal, errors)
        rates = as_float_array(rates, "rates").ravel()
        if rates.size < 1 or np.any(rates <= 0):
            raise OptinavError("table rates must be positive", "give e.g. rates=(0.5, 1.0) rad/s")
        check_positive(rate_hz, "rate_hz")
        check_positive(duration, "duration")
        U = table_axes(gamma, mountings)
        off = (
            np.zeros((len(U), 3)) if offset is None else np.broadcast_to(as_float_array(offset, "offset"), (len(U), 3))
        )
        self.sigma = np.broadcast_to(as_float_array(noise, "noise"), (nominal.n,)).astype(float)
        self.n_case = n = max(int(round(duration * rate_hz)), 1)
        self.rate_hz, self.gamma, self.gravity = float(rate_hz), float(gamma), float(gravity)
        self.n_accelerometers = nominal.n
        f0, mnt, ws, t0 = [], [], [], []
        start = 0.0
        for k, (m, u) in enumerate(zip(mountings, U)):
            for w in rates:
                f0.append(model_outputs(actual.positions, actual.directions, u, w, gravity, off[k]))
                mnt.append(int(m))
                ws.append(float(w))
                t0.append(start)
                start += n / rate_hz
        self._f0, self._mounting, self._rate = np.array(f0), np.array(mnt), np.array(ws)
        self._t0, self._case = np.array(t0), case_labels(self._mounting, self._rate)
        self.n = n * len(f0)
        self._draws = SampleDraws(draw_key(rng), 0, width=nominal.n)

    def blocks(self, block_rows: int | None = None):
        """Generate the log's rows in order, ``block_rows`` at a time.

        Parameters
        ----------
        block_rows : int or None
            Rows per block (default :data:`BLOCK_ROWS`; memory grows with it, not with the log; the rows do not
            depend on it).

        Yields
        ------
        t : (m,) ndarray
            Sample times [s] (cases back to back).
        acc : (m, N) ndarray
            Accelerometer outputs [m/s^2].
        case : (m,) int ndarray
            Case label 1..K (as :attr:`TurntableData.case`).
        mounting : (m,) int ndarray
            Mounting 1..3.
        table_rate : (m,) ndarray
            Table rate [rad/s].
        """
        step = int(check_positive(BLOCK_ROWS if block_rows is None else block_rows, "block_rows"))
        for i0 in range(0, self.n, step):
            i1 = min(i0 + step, self.n)
            k, j = np.divmod(np.arange(i0, i1), self.n_case)
            t = self._t0[k] + j / self.rate_hz
            acc = self._f0[k] + self._draws.take(i0, i1) * self.sigma
            yield t, acc, self._case[k], self._mounting[k], self._rate[k]

    def n_blocks(self, block_rows: int | None = None) -> int:
        """Number of blocks :meth:`blocks` yields for ``block_rows`` (default :data:`BLOCK_ROWS`)."""
        return -(-self.n // int(BLOCK_ROWS if block_rows is None else block_rows))

    def gather(self, blocks=None) -> TurntableData:
        """The whole log in memory: ``blocks`` (default :meth:`blocks`; e.g. wrapped in a progress bar) filled into
        arrays of :attr:`n` rows.

        Returns
        -------
        TurntableData
            As :func:`simulate` returns it.
        """
        n, N = self.n, self.n_accelerometers
        t, acc, mnt, rate = np.empty(n), np.empty((n, N)), np.empty(n, int), np.empty(n)
        i = 0
        for bt, bacc, _, bm, bw in self.blocks() if blocks is None else blocks:
            j = i + bt.size
            t[i:j], acc[i:j], mnt[i:j], rate[i:j] = bt, bacc, bm, bw
            i = j
        if i != n:
            raise OptinavError(f"the blocks gave {i} of the log's {n} rows", "pass all the blocks of this stream")
        return TurntableData(t, acc, mnt, rate, self.gamma, self.gravity, self.sigma)


def simulate(nominal: AccelerometerArray, errors: InstallationErrors | None = None, **options) -> TurntableData:
    """Simulate the turntable cases (mountings × rates), ``duration`` each at ``rate_hz``: the blocks of a
    :class:`TurntableStream` with the same arguments gathered (a seed gives the same rows).

    Parameters
    ----------
    nominal : AccelerometerArray
        The design array.
    errors : InstallationErrors or None
        True installation errors; None: zero.
    **options
        The keywords of :class:`TurntableStream`: ``rates`` [rad/s], ``gamma`` [rad], ``mountings`` (1..3),
        ``rate_hz`` [Hz], ``duration`` [s per case], ``noise`` [m/s^2], ``offset`` [m], ``gravity`` [m/s^2],
        ``rng``.

    Returns
    -------
    TurntableData
        ``t`` [s], ``f`` [m/s^2], mounting, ``table_rate`` [rad/s].
    """
    return TurntableStream(nominal, errors, **options).gather()


@dataclass
class CaseMeans:
    mounting: np.ndarray  # (K,)
    rate: np.ndarray  # (K,) rad/s
    mean: np.ndarray  # (K, N) m/s²
    count: np.ndarray  # (K,)
    sigma: np.ndarray  # (N,) pooled within-case std, m/s²


class CaseAccumulator:
    """Per-case counts, means and within-case sums of squares of a turntable log given block by block (cases: the
    (mounting, rate rounded to 1e-12 rad/s) pairs in order of first appearance, as :func:`case_labels`), merged
    with Chan et al.'s pairwise update, so a log of any length is summarized in O(cases) memory
    (:func:`read_cases`); :func:`case_means` is one block of it."""

    def __init__(self):
        self._keys: dict = {}
        self._n: list = []
        self._mean: list = []
        self._m2: list = []
        self.samples = 0

    def add(self, mounting, table_rate, acc) -> None:
        """Add a block: mounting (m,) 1..3, table rate (m,) [rad/s], outputs (m, N) [m/s^2]."""
        m = np.asarray(mounting).astype(int, copy=False).ravel()
        w = np.round(np.asarray(table_rate, float).ravel(), 12)
        f = np.asarray(acc, float)
        self.samples += m.size
        if m.size == 0:
            return
        starts = np.flatnonzero(np.r_[True, (m[1:] != m[:-1]) | (w[1:] != w[:-1])])
        ends = np.r_[starts[1:], m.size]
        for a, b in zip(starts, ends):
            k = self._keys.setdefault((int(m[a]), float(w[a])), len(self._keys))
            x = f[a:b]
            nb, mb = b - a, x.mean(axis=0)
            m2b = ((x - mb) ** 2).sum(axis=0)
            if k == len(self._n):
                self._n.append(nb)
                self._mean.append(mb)
                self._m2.append(m2b)
                continue
            na, d = self._n[k], mb - self._mean[k]
            n = na + nb
            self._mean[k] = self._mean[k] + d * (nb / n)
            self._m2[k] = self._m2[k] + m2b + d**2 * (na * nb / n)
            self._n[k] = n

    def result(self) -> CaseMeans:
        """The :class:`CaseMeans` of what was added."""
        if not self._n:
            raise OptinavError("the turntable log has no samples", "pass a recording with data rows")
        keys = list(self._keys)
        cnt = np.asarray(self._n, int)
        dof = int(np.sum(cnt - 1))
        m2 = np.sum(self._m2, axis=0)
        sigma = np.sqrt(m2 / dof) if dof > 0 else np.full(m2.shape, np.nan)
        return CaseMeans(
            np.array([k[0] for k in keys], int), np.array([k[1] for k in keys], float), np.array(self._mean), cnt, sigma
        )


def case_means(data: TurntableData) -> CaseMeans:
    """Per-case means, counts and the pooled within-case std of a whole log (:class:`CaseAccumulator`); NaN/inf in
    its mounting, table rate or outputs named by column and first rows."""
    for name, v in (("mounting", data.mounting), ("table_rate", data.table_rate), ("acc", data.acc)):
        v = np.asarray(v, float)
        v = v.reshape(v.shape[0], -1)
        if not np.all(np.isfinite(v)):
            raise nonfinite_rows_error("the turntable data", name, np.flatnonzero(~np.isfinite(v).all(axis=1)))
    acc = CaseAccumulator()
    acc.add(data.mounting, data.table_rate, data.acc)
    return acc.result()


@dataclass
class TurntableCases:
    """A turntable log summarized per case (what the calibration needs): the case means ``cases``, the wedge
    ``gamma`` [rad], ``gravity`` [m/s^2], the number of outputs ``n_outputs`` and of rows ``samples``."""

    cases: CaseMeans
    gamma: float
    gravity: float
    n_outputs: int
    samples: int


def read_cases(path, n_accelerometers: int | None = None, rate_factor: float = 1.0) -> TurntableCases:
    """Summarize a turntable log per case while reading it block by block (text) or whole (other formats), so
    calibrating a long log needs memory for one block, not the log.

    Parameters
    ----------
    path : str or Path
        .npz, .csv or .h5 file in :meth:`TurntableData.save`'s columns.
    n_accelerometers : int or None
        Expected number of outputs (checked when given).
    rate_factor : float
        Factor from the file's table rate to rad/s (π/180 for deg/s).

    Returns
    -------
    TurntableCases
        The case means, wedge [rad], gravity [m/s^2] and sizes.
    """
    from optinav.io.readers import iter_table

    acc, head = CaseAccumulator(), None
    for tab in iter_table(path):
        if head is None:
            head = _turntable_constants(tab, path)
        check_finite_columns(tab, path, acc.samples)
        f = array_outputs(tab, path, n_accelerometers, acc.samples)
        rate = np.asarray(tab.get("table_rate"), float) * rate_factor
        acc.add(np.asarray(tab.get("mounting"), float).astype(int), rate, f)
        n_out = f.shape[1]
    if head is None:
        raise OptinavError(f"{path} holds no data rows", "pass a recording with data rows")
    return TurntableCases(acc.result(), head[0], head[1], n_out, acc.samples)


#: plausible installation errors: a position error up to 5 cm and a direction error up to 0.2 rad (11°); the
#: paper's are 1 mm and 0.01 rad, so anything beyond is a wrong configuration, wrong units or broken data
MAX_DR_M, MAX_DANGLE_RAD = 0.05, 0.2
#: and position errors about their mean (a common shift is the array's centre off the axis) below this fraction of
#: the smallest spacing of distinct sensor positions: two output columns swapped move a sensor by a full spacing
#: (cylinder10: 40 mm, fitted "exactly" with a perfect χ²)
MAX_DR_SPACING = 0.25
#: largest accepted reduced χ² of the case-mean fit (residual RMS 3σ); below it the std are scaled by √χ²
MAX_REDUCED_CHI2 = 9.0
#: the measured rate-dependent change of the outputs against the nominal array's: a table rate 12 % off scales it
#: by 0.8 or 1.25 and was fitted as millimetres of position error with a perfect χ²; a real array's installation
#: errors move the least-squares scale by a few per cent
RATE_SCALE_RANGE = (0.8, 1.25)


def dr_limit(nominal: AccelerometerArray) -> float:
    """The largest plausible position error (m): :data:`MAX_DR_M`, or less than :data:`MAX_DR_SPACING` of the
    smallest spacing between distinct sensor positions (sensors sharing a position count once)."""
    p = np.asarray(nominal.positions, float)
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    d = d[d > 1e-9]
    return float(min(MAX_DR_M, MAX_DR_SPACING * d.min())) if d.size else MAX_DR_M


def nominal_case_means(nominal: AccelerometerArray, cm: CaseMeans, gamma: float, g: float, offsets=None) -> np.ndarray:
    """Case means (K, N) m/s² the nominal array would read (no installation errors; its centre on the axis, or
    ``offsets`` (K, 3) m off it per case)."""
    U = table_axes(gamma, cm.mounting)
    offs = [None] * len(U) if offsets is None else offsets
    return np.array(
        [model_outputs(nominal.positions, nominal.directions, u, w, g, o) for u, w, o in zip(U, cm.rate, offs)]
    )


def g_unit(reading: float) -> str | None:
    """``"g"`` or ``"mg"`` when a specific force that should be about g in m/s² reads ``reading`` ≈ 1 or 1000
    (outputs in g or mg), else None. Shared by the calibration's data check and ``optinav apply``."""
    for unit, g in (("g", 1.0), ("mg", 1000.0)):
        if 0.9 * g < reading < 1.1 * g:
            return unit
    return None


def check_data(
    nominal: AccelerometerArray, cm: CaseMeans, gamma: float, g: float, offsets=None, offset_known: bool = True
) -> None:
    """Checks of the turntable data against the nominal array before a fit (one-line errors):

    * stuck or constant outputs: a sensor whose case means span less than a tenth of what the nominal geometry
      predicts (the cases turn gravity through the wedge angle, so every sensor's output must change);
    * the table-rate unit: per mounting, the change of the case means between two rates is
      ``(w₂² − w₁²) θᵀ(uuᵀ − I) r`` (eq. above); fitted against the nominal geometry its scale must be 1
      (within :data:`RATE_SCALE_RANGE`, with the array's centre where ``offsets`` (K, 3) m puts it; 0.5–2 when
      the offsets are to be estimated, ``offset_known`` False); (π/180)² means rates in deg/s labelled rad/s;
    * the units of the gravity column (≈ 1: g, ≈ 1000: mg) and of the outputs, and the wedge in rad;
    * a few output columns that do not read their sensor while the others do (a sign inverted, two columns
      swapped), named per column (:func:`_check_channels`);
    * the table axis the outputs of each mounting see (gravity alone at rate 0) against the labelled one:
      swapped mounting labels or a wrong wedge column (:func:`_check_axes`);
    * a reversed rate-dependent change (scale ≈ −1): swapped table-rate labels when gravity's part of the case
      means agrees with the nominal (their scale ≈ +1), negated outputs when it flips too (≈ −1).

    Parameters
    ----------
    nominal : AccelerometerArray
        The design array.
    cm : CaseMeans
        The case means [m/s^2] with their rates [rad/s].
    gamma : float
        Wedge angle γ [rad].
    g : float
        Gravity [m/s^2].
    offsets : (K, 3) array or None
        The array centre's offset from the table axis per case [m]; None: on the axis.
    offset_known : bool
        False when the offsets are to be estimated (a wider rate-scale range).

    Returns
    -------
    None
    """
    wedge = np.abs(np.asarray(gamma, float))
    if np.nanmax(wedge) > np.pi / 2:
        raise OptinavError(
            f"the wedge column reads {float(np.nanmax(wedge)):.4g}, beyond π/2 rad: it is in degrees, not rad",
            "write the wedge column in rad",
        )
    grav = float(np.median(g))
    unit = g_unit(grav)
    if unit is not None:
        raise OptinavError(
            f"the gravity column reads {grav:.4g}: it is in {unit}, not m/s^2",
            f"write the gravity column in m/s^2 (the local gravity, e.g. {G_STANDARD})",
        )
    pred = nominal_case_means(nominal, cm, gamma, g, offsets)
    # the outputs' size against the nominal geometry's, as gravity in m/s² (the rates move it by far less)
    reading = float(np.linalg.norm(cm.mean) / np.linalg.norm(pred)) * float(np.median(g))
    unit = g_unit(reading)
    if unit is not None:
        raise OptinavError(
            f"the accelerometer outputs are {reading / float(np.median(g)):.3g}× the size the configuration "
            f"predicts in m/s² (gravity reads {reading:.4g}): the outputs look like {unit}, not m/s^2",
            "convert the f columns to m/s^2",
        )
    s = _rate_scale(cm, pred)
    deg = s is not None and abs(s / np.radians(1) ** 2 - 1) < 0.5
    if deg:
        raise OptinavError(
            f"the table_rate column looks like deg/s labelled rad/s (the rate-dependent change of the "
            f"outputs is {s:.3g}× the predicted, (π/180)² = {np.radians(1) ** 2:.3g})",
            "pass --rate-unit deg/s",
        )
    rpm = (2 * np.pi / 60) ** 2  # 0.011: within 10 % of a configuration in cm, told apart at 5 %
    if s is not None and abs(s / rpm - 1) < 0.05:
        raise OptinavError(
            f"the table_rate column looks like rpm labelled rad/s (the rate-dependent change of the outputs is "
            f"{s:.3g}× the predicted, (2π/60)² = {rpm:.3g})",
            "convert the table_rate column to rad/s (rpm × 2π/60)",
        )
    for unit, k in (("mm", 1e-3), ("cm", 1e-2)):  # the centripetal terms scale with the positions
        if s is not None and abs(s / k - 1) < 0.05:
            raise OptinavError(
                f"the rate-dependent change of the outputs is {s:.3g}× what the configuration's positions predict: "
                f"they look like {unit}, not m",
                "write the positions of the configuration in m",
            )
    if s is not None and abs(s * np.radians(1) ** 2 - 1) < 0.5:
        raise OptinavError(
            f"the table rates look like rad/s read as deg/s (the rate-dependent change of the outputs is {s:.3g}× "
            f"the predicted, (180/π)² = {np.degrees(1) ** 2:.4g})",
            "drop --rate-unit deg/s: the table_rate column is in rad/s",
        )
    span_m, span_p = np.ptp(cm.mean, axis=0), np.ptp(pred, axis=0)
    stuck = np.flatnonzero(span_m < 0.1 * span_p)
    if stuck.size:
        i = int(stuck[0])
        raise OptinavError(
            f"accelerometer(s) {', '.join(str(k + 1) for k in stuck)} barely change between the "
            f"turntable cases (accelerometer {i + 1}: {span_m[i]:.3g} m/s² where the nominal array "
            f"changes by {span_p[i]:.3g}): stuck or constant outputs",
            "check those channels (or pass the configuration the data was recorded with)",
        )
    _check_channels(cm.mean, pred)
    lo, hi = RATE_SCALE_RANGE if offset_known else (0.5, 2.0)
    # the case means against the nominal ones: gravity's part dominates them and is the same at both rates, so
    # swapped rate labels leave it (scale +1) and reverse only the change between the rates; negated outputs
    # flip both
    s_all = float(np.sum(cm.mean * pred) / np.sum(pred * pred))
    if s is not None and -hi < s < -lo and s_all > 0.5:
        raise OptinavError(
            f"the table-rate labels look swapped: the change of the outputs between the two rates is {s:.3g}× the "
            f"predicted (reversed) while gravity's part of the case means agrees ({s_all:.3g}×), so the case "
            "recorded at the higher rate is labelled with the lower",
            "give each case's rows the table_rate they were recorded at (swap the two rate values in the file)",
        )
    if s is not None and -hi < s < -lo and s_all < -0.5:
        raise OptinavError(
            f"the rate-dependent change of the outputs is {s:.3g}× the one the configuration predicts: the outputs "
            "look negated (every sensor reads the opposite of its specific force along its direction)",
            "negate the f columns, or the directions in the configuration if the sensors point the other way",
        )
    if s is not None and s <= 0:
        raise OptinavError(
            f"the rate-dependent change of the outputs is {s:.3g}× the one the configuration predicts (its sign "
            "opposite): the outputs do not follow the centripetal terms of this array",
            "check the f columns' order and sign against the configuration, and the table_rate column",
        )
    _check_axes(nominal, cm, float(np.median(gamma)), float(np.median(g)))
    if s is not None and not lo < s < hi:
        raise OptinavError(
            f"the table rates disagree with the centripetal terms the accelerometers measure (the "
            f"rate-dependent change of the outputs is {s:.3g}× the predicted, i.e. rates {np.sqrt(s):.3g}× the "
            "stated ones, or the array's centre is off the table axis)",
            "check the table_rate column (rad/s; --rate-unit deg/s if it is in deg/s), the configuration, and give "
            "the centre's offset from the axis (--offset X,Y,Z in m, or estimate)",
        )


#: a sensor whose case means differ from the nominal array's by more than this share of their size does not read
#: its configured channel (installation errors within the gates move them by at most about a third of it)
CHANNEL_MISFIT = 0.5


def _check_channels(mean: np.ndarray, pred: np.ndarray) -> None:
    """A few output columns (at most a third) that do not read what their sensor of the nominal array would, while
    the others do: a sensor's sign inverted, or two columns swapped (each reads the other's sensor), named per
    column. ``mean``, ``pred``: (K, N) case means measured and of the nominal array [m/s^2]. Gravity dominates
    the case means, so this holds whatever the table rates or the centre's offset; a whole array that disagrees
    is left to the checks of rates and units."""
    size = np.linalg.norm(pred, axis=0)
    size = np.maximum(size, 0.1 * np.median(size))  # a sensor the nominal cases barely move is judged by the others'
    off = np.linalg.norm(mean[:, :, None] - pred[:, None, :], axis=0) / size  # [i, j]: column i as sensor j
    bad = np.flatnonzero(np.diag(off) > CHANNEL_MISFIT)
    if not bad.size or bad.size > mean.shape[1] // 3:
        return
    why, told = [], set()
    for i in bad:
        fits = np.flatnonzero(off[i] < CHANNEL_MISFIT)  # sensors of one direction read alike: several may fit
        mate = [j for j in fits if j in bad and off[j, i] < CHANNEL_MISFIT]
        if i in told:
            continue
        if np.linalg.norm(mean[:, i] + pred[:, i]) / size[i] < CHANNEL_MISFIT:
            why.append(f"f{i + 1} reads the negative of accelerometer {i + 1} (its sign inverted)")
        elif mate:
            told.add(mate[0])
            why.append(f"f{i + 1} and f{mate[0] + 1} read each other's accelerometers (swapped)")
        elif fits.size:
            why.append(
                f"f{i + 1} reads what accelerometer {' or '.join(str(j + 1) for j in fits)} would (out of order)"
            )
        else:
            why.append(f"f{i + 1} is off accelerometer {i + 1}'s case means by {off[i, i]:.2g}× their size")
    raise OptinavError(
        f"output column(s) {', '.join(f'f{i + 1}' for i in bad)} do not follow their accelerometers while the "
        f"others do: {'; '.join(why)}",
        "put the f columns in the configuration's order and negate a sensor written with the opposite sign (or "
        "pass the configuration the data was recorded with)",
    )


#: the table axis the outputs see farther than this (unit vectors) from the labelled one is another axis; within
#: :data:`AXIS_FIT` of another mounting's (or the wedge's) it is named (installation errors move it by ~0.01)
AXIS_OFF, AXIS_FIT = 0.1, 0.05


def _check_axes(nominal: AccelerometerArray, cm: CaseMeans, gamma: float, g: float) -> None:
    """The table axis each mounting's outputs see must be the labelled one: per mounting with two rates the
    outputs extrapolated to rate 0, ``(w₂² f(w₁) − w₁² f(w₂)) / (w₂² − w₁²)``, are gravity alone, ``g Θ u`` (no
    centripetal term, whatever the centre's offset), so ``u`` follows by least squares over the nominal directions
    Θ. Named: mounting labels swapped (u is another mounting's) and a wedge column other than the wedge the outputs
    see. ``gamma`` [rad], ``g`` [m/s^2]."""
    theta = np.asarray(nominal.directions, float)
    for m in np.unique(cm.mounting):
        k = np.flatnonzero(cm.mounting == m)
        if len(k) < 2 or np.ptp(cm.rate[k]) == 0:
            continue
        a, b = k[np.argmin(cm.rate[k])], k[np.argmax(cm.rate[k])]
        w1, w2 = cm.rate[a] ** 2, cm.rate[b] ** 2
        grav = (w2 * cm.mean[a] - w1 * cm.mean[b]) / (w2 - w1)
        u = np.linalg.lstsq(g * theta, grav, rcond=None)[0]
        axes = table_axes(gamma)
        if np.linalg.norm(u - axes[int(m) - 1]) < AXIS_OFF:
            continue
        other = [j + 1 for j in range(3) if j + 1 != m and np.linalg.norm(u - axes[j]) < AXIS_FIT]
        if other:
            raise OptinavError(
                f"the cases labelled mounting {int(m)} see the table axis of mounting {other[0]} (gravity in the "
                f"outputs along body {np.round(u / np.linalg.norm(u), 3).tolist()}): the mounting labels are swapped",
                f"give those rows mounting {other[0]} (1: axis in x-z, 2: y-z, 3: x-y)",
            )
        i, j = {1: (0, 2), 2: (1, 2), 3: (1, 0)}[int(m)]  # u = (…sin γ at i…, cos γ at j)
        seen = float(np.arctan2(u[i], u[j]))
        if np.linalg.norm(u - table_axes(seen, [m])[0]) < AXIS_FIT:
            raise OptinavError(
                f"the wedge column says {np.degrees(gamma):.4g}°, but the gravity the outputs of mounting {int(m)} "
                f"see puts the table axis at a wedge of {np.degrees(seen):.4g}°",
                "write the wedge angle the array was mounted on in the wedge column (rad)",
            )


def _rate_scale(cm: CaseMeans, pred: np.ndarray) -> float | None:
    """Least-squares scale of the measured against the predicted change of the case means between the two rates
    of each mounting; None when that change is not well above the noise."""
    num = den = var = mm = var_m = 0.0
    for m in np.unique(cm.mounting):
        k = np.flatnonzero(cm.mounting == m)
        if len(k) < 2 or np.ptp(cm.rate[k]) == 0:
            continue
        a, b = k[np.argmin(cm.rate[k])], k[np.argmax(cm.rate[k])]
        d_meas, d_pred = cm.mean[b] - cm.mean[a], pred[b] - pred[a]
        num, den, mm = num + d_meas @ d_pred, den + d_pred @ d_pred, mm + d_meas @ d_meas
        w = (cm.sigma**2) * (1 / cm.count[a] + 1 / cm.count[b])
        var, var_m = var + np.sum(d_pred**2 * w), var_m + np.sum(d_meas**2 * w)
    # the change is well above the noise, predicted or measured (rates in rad/s read as deg/s predict almost none)
    if den > 0 and np.all(np.isfinite(cm.sigma)) and (den > 100 * np.sqrt(var) or mm > 100 * np.sqrt(var_m)):
        return float(num / den)
    return None


def closed_form(
    nominal: AccelerometerArray,
    data: TurntableData | CaseMeans,
    gamma: float | None = None,
    gravity: float | None = None,
) -> InstallationErrors:
    """The paper's closed-form solution (two rates per mounting, three mountings, offset 0).

    Parameters
    ----------
    nominal : AccelerometerArray
        The design array.
    data : TurntableData or CaseMeans
        The log or its case means.
    gamma : float or None
        Wedge angle γ [rad]; None: the log's.
    gravity : float or None
        Gravity [m/s^2]; None: the log's (standard gravity for case means).

    Returns
    -------
    InstallationErrors
        Δr [m], Δα, Δβ [rad] per sensor.
    """
    cm = data if isinstance(data, CaseMeans) else case_means(data)
    gamma = data.gamma if gamma is None else gamma
    g = (data.gravity if isinstance(data, TurntableData) else G_STANDARD) if gravity is None else gravity
    G, C, U = [], [], []
    for m in (1, 2, 3):
        idx = np.flatnonzero(cm.mounting == m)
        if idx.size < 2:
            raise OptinavError(
                f"the closed form needs two rates in mounting {m} ({MOUNTING_NAMES[m - 1]}), the data has {idx.size}",
                "record all six cases, or use the least-squares default",
            )
        i1, i2 = idx[np.argsort(cm.rate[idx])[[0, -1]]]
        w1, w2 = cm.rate[i1], cm.rate[i2]
        den = w2**2 - w1**2
        C.append((cm.mean[i2] - cm.mean[i1]) / den)
        G.append((w2**2 * cm.mean[i1] - w1**2 * cm.mean[i2]) / den / g)
        U.append(table_axes(gamma, (m,))[0])
    U, G, C = np.array(U), np.array(G), np.array(C)  # (3,3), (3,N), (3,N)
    if abs(np.linalg.det(U)) < 1e-6:
        raise OptinavError(
            f"the table axes of the three mountings are dependent for wedge {np.degrees(gamma):.3g}°",
            "use a wedge angle such as 30°",
        )
    th = np.linalg.solve(U, G).T  # (N, 3), unnormalized as in the paper
    pos = np.empty_like(th)
    for i in range(nominal.n):
        M = np.array([th[i] @ (np.outer(u, u) - np.eye(3)) for u in U])
        pos[i] = np.linalg.lstsq(M, C[:, i], rcond=None)[0]
    return errors_from_geometry(nominal, pos, th)


@dataclass
class TurntableCalibration(Estimate):
    """Installation errors from a turntable calibration (RESULT.json of ``optinav calibrate gfimu``;
    docs/results.md). :meth:`parameters`: ``dr_x_1`` … ``dbeta_N`` (m, rad) and the estimated offsets."""

    SCHEMA = "optinav.gfimu.calibration"
    VERSION = 3
    SYSTEM = "gfimu"
    KIND = "calibration"

    method: str = field(metadata={"unit": "-"})
    names: list = field(metadata={"unit": "-"})
    estimate: np.ndarray = field(metadata={"unit": "m or rad (per name)"})
    std: np.ndarray = field(metadata={"unit": "m or rad"})
    crlb_std: np.ndarray = field(metadata={"unit": "m or rad"})
    covariance: np.ndarray = field(metadata={"unit": "(m or rad)^2"})
    dr: np.ndarray = field(metadata={"unit": "m"})
    dalpha: np.ndarray = field(metadata={"unit": "rad"})
    dbeta: np.ndarray = field(metadata={"unit": "rad"})
    positions: np.ndarray = field(metadata={"unit": "m"})
    directions: np.ndarray = field(metadata={"unit": ""})
    offsets: np.ndarray = field(metadata={"unit": "m"})
    rank: int = field(metadata={"unit": ""})
    n_params: int = field(metadata={"unit": ""})
    statements: list = field(metadata={"unit": "-"})
    samples_per_case: np.ndarray = field(metadata={"unit": ""})
    sigma: np.ndarray = field(metadata={"unit": "m/s^2"})
    residual_rms: float = field(metadata={"unit": "sigma"})
    gamma: float = field(metadata={"unit": "rad"})
    elapsed_s: float = field(default=0.0, metadata={"unit": "s"})
    gauge: str = field(default="", metadata={"unit": "-"})
    #: mean of the fitted Δr before the gauge mean(Δr) = 0 was applied (m, body): the mean installation displacement
    #: plus the array centre's offset from the table axis, which the data cannot separate; None without a gauge
    common_shift_m: list | None = field(default=None, metadata={"unit": "m"})
    convergence: dict = field(default_factory=dict, metadata={"unit": "-"})
    gates: list = field(default_factory=list, metadata={"unit": "-"})

    def __post_init__(self):
        # one entry per name in estimate, std (>= 0) and crlb_std, one per sensor in dalpha, dbeta, dr and the
        # calibrated geometry; names and statements text: a damaged value is named on loading, not an IndexError
        # or a TypeError in the report
        from optinav.core.results import nested_array, nested_strings

        self.names = nested_strings(self.names, "names")
        n = len(self.names)
        for name in ("estimate", "std", "crlb_std"):
            setattr(self, name, nested_array(getattr(self, name), name, (n,), std=name != "estimate"))
        self.dalpha = nested_array(self.dalpha, "dalpha", (None,))
        m = len(self.dalpha)
        for name, shape in (("dbeta", (m,)), ("dr", (m, 3)), ("positions", (m, 3)), ("directions", (m, 3))):
            setattr(self, name, nested_array(getattr(self, name), name, shape))
        self.covariance = nested_array(self.covariance, "covariance", (n, n))
        self.statements = nested_strings(self.statements, "statements")

    def parameters(self) -> dict[str, Parameter]:
        units = _unit_names(len(self.dalpha), len(self.names) - 5 * len(self.dalpha))
        est, std, crlb = (np.asarray(a, float) for a in (self.estimate, self.std, self.crlb_std))
        out = {}
        for k, nm in enumerate(self.names):
            p = Parameter(float(est[k]), units[k], std=float(std[k]), crlb_std=float(crlb[k]))
            if self.gauge and nm.startswith("dr_"):
                # Δr relative to their mean: observable; Δr itself holds the unknown common shift
                out[nm] = Parameter(None, "m", observable=False, reason=self.gauge)
                out[gauge_name(nm)] = p
            else:
                out[nm] = p
        if self.gauge:
            out.update({f"mean(dr_{c})": Parameter(None, "m", observable=False, reason=self.gauge) for c in "xyz"})
        return out

    def errors(self) -> InstallationErrors:
        """The estimated installation errors.

        Returns
        -------
        InstallationErrors
            Δr [m], Δα, Δβ [rad] per sensor.
        """
        return InstallationErrors(self.dr, self.dalpha, self.dbeta)

    def array(self, nominal: AccelerometerArray) -> AccelerometerArray:
        """The calibrated array (for compensation: pass it to the rate solvers).

        Parameters
        ----------
        nominal : AccelerometerArray
            The design array (its noise and name are kept).

        Returns
        -------
        AccelerometerArray
            Calibrated positions [m] and directions.
        """
        return AccelerometerArray(self.positions, self.directions, nominal.noise, nominal.name + "-calibrated")

    def calibrated_array(self) -> AccelerometerArray:
        """The calibrated array from this result alone (no nominal array needed).

        Returns
        -------
        AccelerometerArray
            Calibrated positions [m] and directions, weighted by the noise the calibration used (``sigma``
            [m/s²]).
        """
        return AccelerometerArray(self.positions, self.directions, np.asarray(self.sigma, float), "calibrated")

    def summary(self) -> str:
        """A human-readable report: rank, residual, and the errors of each sensor.

        Returns
        -------
        str
            The report.
        """
        lines = [
            f"gfimu turntable calibration ({self.method}): {len(self.dalpha)} accelerometers, "
            f"rank {self.rank}/{self.n_params}, residual rms {self.residual_rms:.3g} σ, "
            f"samples per case {', '.join(str(int(x)) for x in self.samples_per_case)}"
        ]
        lines += ["  " + s for s in self.statements]
        label = "dr - mean dr" if self.gauge else "dr"
        for i in range(len(self.dalpha)):
            s = self.std[5 * i : 5 * i + 5]
            lines.append(
                f"  #{i + 1:<2} {label} = [{self.dr[i, 0] * 1e3:+.4f} {self.dr[i, 1] * 1e3:+.4f} "
                f"{self.dr[i, 2] * 1e3:+.4f}] ± [{s[0] * 1e3:.2g} {s[1] * 1e3:.2g} {s[2] * 1e3:.2g}] mm, "
                f"dalpha = {self.dalpha[i] * 1e3:+.4f} ± {s[3] * 1e3:.2g} mrad, "
                f"dbeta = {self.dbeta[i] * 1e3:+.4f} ± {s[4] * 1e3:.2g} mrad"
            )
        return "\n".join(lines)


def gauge_name(name: str) -> str:
    """The parameter name of a position error relative to the mean of all of them: ``dr_x_3`` →
    ``dr_x_3 - mean(dr_x)`` (what the result reports when the common shift is not observable)."""
    return f"{name} - mean({name.rsplit('_', 1)[0]})"


def _unit_names(n, n_off):
    units = ["m", "m", "m", "rad", "rad"] * n + ["m"] * n_off
    return units


class _Model:
    """Residuals and analytic Jacobian of the case means (whitened by σ_i/√n_k)."""

    def __init__(self, nominal, cm: CaseMeans, gamma, g, sigma, estimate_offset, bias_scale=False, fixed_offset=None):
        self.nom = nominal
        self.fixed = np.zeros((len(cm.rate), 3)) if fixed_offset is None else fixed_offset
        self.fr = local_frames(nominal.directions)
        self.cm = cm
        self.U = table_axes(gamma, cm.mounting)
        self.P = np.einsum("ki,kj->kij", self.U, self.U) - np.eye(3)
        self.w2 = cm.rate**2
        self.g = g
        self.mounts = sorted(set(int(m) for m in cm.mounting))
        self.perp = {m: _perp_basis(table_axes(gamma, (m,))[0]) for m in self.mounts}
        self.off = estimate_offset
        self.bs = bias_scale
        self.n = nominal.n
        self.n_off = 2 * len(self.mounts) if estimate_offset else 0
        self.n_bs = 2 * self.n if bias_scale else 0
        self.W = np.sqrt(cm.count)[:, None] / sigma[None, :]  # (K, N)

    @property
    def n_params(self):
        return 5 * self.n + self.n_off + self.n_bs

    def unpack(self, x):
        e = x[: 5 * self.n].reshape(self.n, 5)
        d = self.fixed.copy()
        if self.off:
            o = x[5 * self.n : 5 * self.n + self.n_off].reshape(-1, 2)
            for k, m in enumerate(self.cm.mounting):
                j = self.mounts.index(int(m))
                d[k] = o[j] @ self.perp[int(m)]
        return e, d

    def predict(self, x):
        e, d = self.unpack(x)
        th = direction(self.fr, e[:, 3], e[:, 4])
        r = self.nom.positions + e[:, :3]
        rr = r[None, :, :] + d[:, None, :]  # (K, N, 3)
        v = self.g * self.U[:, None, :] + self.w2[:, None, None] * np.einsum("kij,knj->kni", self.P, rr)
        f = np.einsum("ni,kni->kn", th, v)
        if self.bs:
            bs = x[5 * self.n + self.n_off :].reshape(self.n, 2)
            f = f * (1 + bs[:, 1]) + bs[:, 0]
        return f, th, v

    def residuals(self, x):
        f, _, _ = self.predict(x)
        return ((f - self.cm.mean) * self.W).ravel()

    def jacobian(self, x):
        e, d = self.unpack(x)
        f, th, v = self.predict(x)
        da, db = direction_derivatives(self.fr, e[:, 3], e[:, 4])
        K, N = self.cm.mean.shape
        J = np.zeros((K, N, self.n_params))
        Pth = self.w2[:, None, None] * np.einsum("kij,nj->kni", self.P, th)  # ∂f/∂r (K, N, 3)
        scale = 1.0
        if self.bs:
            bs = x[5 * self.n + self.n_off :].reshape(self.n, 2)
            scale = (1 + bs[:, 1])[None, :]
        idx = np.arange(N)
        for c in range(3):
            J[:, idx, 5 * idx + c] = Pth[:, :, c] * scale
        J[:, idx, 5 * idx + 3] = np.einsum("ni,kni->kn", da, v) * scale
        J[:, idx, 5 * idx + 4] = np.einsum("ni,kni->kn", db, v) * scale
        if self.off:
            for k, m in enumerate(self.cm.mounting):
                j = self.mounts.index(int(m))
                J[k, :, 5 * N + 2 * j : 5 * N + 2 * j + 2] = (Pth[k] @ self.perp[int(m)].T) * (
                    scale[0][:, None] if self.bs else 1.0
                )
        if self.bs:
            f0 = np.einsum("ni,kni->kn", th, v)
            o = 5 * N + self.n_off
            J[:, idx, o + 2 * idx] = 1.0
            J[:, idx, o + 2 * idx + 1] = f0
        return (J * self.W[:, :, None]).reshape(K * N, -1)

    def names(self):
        nm = InstallationErrors.names(self.n)
        if self.off:
            nm += [f"offset{m}_{c}" for m in self.mounts for c in ("a", "b")]
        if self.bs:
            nm += [f"{c}_{i + 1}" for i in range(self.n) for c in ("bias", "scale")]
        return nm


#: what a result without a known centre offset reports (``gauge``; ``{shift}`` the fitted common shift in mm)
GAUGE_UNKNOWN_OFFSET = (
    "mean(dr) = 0: the array centre's offset from the table axis is not given (--offset X,Y,Z, or --offset zero "
    "for a centred array), and only r_i + offset enters the outputs, so a common shift of all positions is not "
    "observable; dr are reported relative to their mean (the fitted common shift, mean dr + offset, is "
    "[{shift[0]:+.4g} {shift[1]:+.4g} {shift[2]:+.4g}] mm). The compensated rate solution (omega, omega-dot) does "
    "not depend on the common shift; the specific force A is that at the origin of the calibrated positions, whose "
    "centroid is the nominal one"
)


def calibrate(
    nominal: AccelerometerArray,
    data: TurntableData | TurntableCases,
    *,
    method: str = "lm",
    offset: str = "unknown",
    sigma=None,
    rate_accuracy: float = 0.0,
) -> TurntableCalibration:
    """Estimate the installation errors (5 per sensor) from turntable data (module docstring).

    Parameters
    ----------
    nominal : AccelerometerArray
        The design array.
    data : TurntableData or TurntableCases
        The log, or its per-case summary (:func:`read_cases`: a long log read block by block).
    method : str
        ``"lm"`` (default, nonlinear least squares) or ``"closed-form"`` (the paper's baseline; its covariance is
        reported from the least-squares Jacobian at its solution).
    offset : str or array
        ``"unknown"`` (default: the array centre's body offset from the table axis not known; only ``r_i + d``
        enters, so the common shift of all Δr is not observable and Δr are reported relative to their mean,
        gauge mean Δr = 0, :data:`GAUGE_UNKNOWN_OFFSET`), ``"zero"`` (the array reference point on the table
        axis, the paper's assumption: absolute Δr), a measured (3,) or per-mounting (3, 3) offset [m, body],
        or ``"estimate"`` (per-mounting offsets, gauge mean Δr = 0; not separable on the paper's scheme).
    sigma : float, (N,) array or None
        Accelerometer noise std [m/s^2]; None: the within-case scatter.
    rate_accuracy : float
        Relative 1σ of the table rates [-] (0: exact). A rate error e scales every centripetal term by 1 + 2e,
        which the positions absorb (Δr_i ≈ 2e·r_i, not separable from the data): its effect is added to the
        covariance, and stated either way.

    Returns
    -------
    TurntableCalibration
        Δr [m], Δα, Δβ [rad] with std and CRLB std, rank, residual and gates.
    """
    t0 = time.perf_counter()
    if method not in ("lm", "closed-form"):
        raise OptinavError(f"unknown calibration method {method!r}", "use 'lm' or 'closed-form'")
    fixed = None
    if isinstance(offset, str):
        if offset not in ("unknown", "zero", "estimate"):
            raise OptinavError(
                f"offset={offset!r} is not understood", "use 'unknown', 'zero', 'estimate' or a known (3,) in m"
            )
    else:
        fixed = as_float_array(offset, "offset")
        if fixed.shape not in ((3,), (3, 3)):
            raise OptinavError(
                f"offset has shape {fixed.shape}", "give the measured offset (3,) m, or one per mounting"
            )
        offset = "known"
    summary = isinstance(data, TurntableCases)
    n_out = data.n_outputs if summary else data.acc.shape[1]
    if n_out != nominal.n:
        raise OptinavError(
            f"the data has {n_out} accelerometer outputs, the configuration {nominal.n}",
            "pass the configuration the data was recorded with",
        )
    cm = data.cases if summary else case_means(data)
    case_offsets = None
    if fixed is not None:
        fk = np.broadcast_to(fixed, (3, 3))
        case_offsets = np.array([fk[int(m) - 1] for m in cm.mounting])
    check_data(nominal, cm, data.gamma, data.gravity, case_offsets, offset != "estimate")
    if sigma is None:
        sig = cm.sigma
        if not np.all(np.isfinite(sig)) or np.any(sig <= 0):
            raise OptinavError(
                "cannot estimate the accelerometer noise (one sample per case or constant outputs)",
                "give the noise std (sigma / --noise)",
            )
    else:
        sig = noise_sigma(sigma, nominal.n)  # a wrong σ would give a plausible result with a wrong std
    fixed = case_offsets
    model = _Model(nominal, cm, data.gamma, data.gravity, sig, offset == "estimate", fixed_offset=fixed)
    names = model.names()
    units = _unit_names(nominal.n, model.n_off)
    # identifiability of the scheme at the nominal geometry (rank of the whitened Jacobian)
    x_nom = np.zeros(model.n_params)
    rep0 = analyze(model.jacobian(x_nom), 1.0, names=names, units=units)
    if offset == "estimate" and rep0.rank < model.n_params - 3:
        raise OptinavError(
            f"the centre offset cannot be separated from the positions in this scheme (rank {rep0.rank} of "
            f"{model.n_params}: {model.n_params - rep0.rank} unobservable directions, only 3 of them the "
            "common shift; each mounting gives one centripetal equation per sensor, exactly what its 3 position "
            "errors need)",
            "leave --offset out (dr relative to their mean), centre the array (--offset zero) or measure the offset "
            "and pass it (--offset X,Y,Z)",
        )
    if rep0.rank < model.n_params - (3 if offset == "estimate" else 0):
        raise OptinavError(
            f"the turntable data cannot determine the installation errors (rank {rep0.rank} of "
            f"{model.n_params}; unobservable: {'; '.join(rep0.unobservable_directions[:4])})",
            "record three mountings with a wedge (e.g. 30°) at two rates each",
        )
    gauge = ""
    if method == "closed-form":
        if offset not in ("zero", "unknown"):
            raise OptinavError("the closed form assumes the array centre on the table axis", "use method 'lm'")
        x = closed_form(nominal, cm, data.gamma, data.gravity).vector()
    else:
        try:
            x0 = (
                closed_form(nominal, cm, data.gamma, data.gravity).vector()
                if offset in ("zero", "unknown")
                else np.zeros(5 * nominal.n)
            )
        except OptinavError:
            x0 = np.zeros(5 * nominal.n)
        if offset == "estimate":
            x0 = np.r_[x0, np.zeros(model.n_off)]
            G = np.zeros((3, model.n_params))
            for i in range(nominal.n):
                G[:, 5 * i : 5 * i + 3] = np.eye(3)
            wg = 1e3 * np.sqrt(np.mean(np.sum(model.jacobian(x0) ** 2, axis=0)))
            res = lambda x: np.r_[model.residuals(x), wg * (G @ x)]  # noqa: E731 - gauge rows
            jac = lambda x: np.vstack([model.jacobian(x), wg * G])  # noqa: E731
            gauge = (
                "mean(dr) = 0: positions relative to the mean installation displacement (common shift "
                "not observable with unknown offsets)"
            )
        else:
            res, jac = model.residuals, model.jacobian
        scale = np.r_[np.tile([1e-3, 1e-3, 1e-3, 1e-2, 1e-2], nominal.n), np.full(model.n_off, 1e-3)]
        out = minimize(
            Problem(residuals=res, jacobian=jac, x0=x0, names=names, x_scale=scale),
            "lm",
            xtol=1e-14,
            ftol=1e-14,
            gtol=1e-14,
        )
        x = out.x
    J = model.jacobian(x)
    r = model.residuals(x)
    rep = analyze(J, 1.0, names=names, units=units)
    lm = out if method == "lm" else None
    gates, chi2 = _quality_gates(method, lm, x[: 5 * nominal.n], r, int(rep.rank), sigma is None, dr_limit(nominal))
    conv = (
        convergence(out.success, iterations=getattr(out, "nit", None), evaluations=out.nfev, message=out.message)
        if method == "lm"
        else convergence(None, message="closed form")
    )
    std, crlb, cov = np.array(rep.std), np.array(rep.crlb_std), np.array(rep.covariance)
    if chi2 > 1.0:  # residuals beyond the noise (an unmodelled error below the gate): the std widen with them
        std, cov = std * np.sqrt(chi2), cov * chi2
    # the table rate is an input: a relative error e moves the estimate by e·s (s from the linearized fit; the
    # centripetal terms go with ω², so their residuals move by 2e × their size)
    f_fit, th_fit, _ = model.predict(x)
    centripetal = f_fit - data.gravity * np.einsum("ni,ki->kn", th_fit, model.U)
    s_rate = -np.linalg.lstsq(J, (2.0 * centripetal * model.W).ravel(), rcond=None)[0]
    if rate_accuracy > 0.0:
        cov = cov + rate_accuracy**2 * np.outer(s_rate, s_rate)
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    # m per unit of e is mm per 0.1 % (× 1e-3 for 0.1 %, × 1e3 for mm)
    dr_mm_per_permille = float(np.max(np.abs(s_rate[: 5 * nominal.n].reshape(nominal.n, 5)[:, :3])))
    rate_statement = (
        f"the table rates are taken as exact within {rate_accuracy:.3g} (relative 1σ, in the std): a rate error e "
        if rate_accuracy > 0.0
        else "the table rates are taken as exact (pass --rate-accuracy to put their accuracy in the std): a rate "
        "error e "
    ) + (
        f"moves the positions by up to {dr_mm_per_permille:.3g} mm per 0.1 % (Δr_i ≈ 2e·r_i), which the data "
        "cannot tell from installation errors"
    )
    shift = None
    if offset in ("estimate", "unknown"):
        # positions are reported in the gauge mean(dr) = 0: dr_i − mean(dr) and its std from the full covariance
        M = np.zeros((model.n_params, model.n_params))
        for i in range(nominal.n):
            for j in range(nominal.n):
                M[5 * i : 5 * i + 3, 5 * j : 5 * j + 3] = np.eye(3) / nominal.n
        T = np.eye(model.n_params) - M
        shift = x[: 5 * nominal.n].reshape(nominal.n, 5)[:, :3].mean(axis=0)
        x = T @ x
        cov = T @ cov @ T.T
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
        crlb = np.sqrt(np.clip(np.diag(T @ np.asarray(rep.crlb) @ T.T), 0, None))
    if offset == "unknown":
        gauge = GAUGE_UNKNOWN_OFFSET.format(shift=shift * 1e3)
    e = InstallationErrors.from_vector(x[: 5 * nominal.n])
    actual = perturb(nominal, e)
    offs = np.zeros((len(model.mounts), 3))
    if offset == "estimate":
        o = x[5 * nominal.n :].reshape(-1, 2)
        offs = np.array([o[j] @ model.perp[m] for j, m in enumerate(model.mounts)])
    statements = (
        list(rep.statements)
        if offset != "unknown"
        else [
            f"unobservable: the common shift of all dr (rank {rep.rank - 3} of {model.n_params} without the centre offset)"
        ]
    )
    statements += ([gauge] if gauge else []) + [rate_statement]
    if chi2 > 1.0:
        statements.append(f"std scaled by √(reduced χ²) = {np.sqrt(chi2):.3g}: residuals beyond the noise")
    if fixed is not None or offset == "zero":
        statements.append(
            "offset of the array centre from the table axis fixed at the given value"
            + (" (zero: on the axis)" if fixed is None else "")
            + ": dr are absolute, and an error δd of that offset shifts every dr by −δd (not in the std)"
        )
    if fixed is not None:
        offs = fixed[[list(cm.mounting).index(m) for m in model.mounts]]
    return TurntableCalibration(
        method=method,
        names=names,
        estimate=x,
        std=std,
        crlb_std=crlb,
        covariance=cov,
        dr=e.dr,
        dalpha=e.dalpha,
        dbeta=e.dbeta,
        positions=actual.positions,
        directions=actual.directions,
        offsets=offs,
        rank=int(rep.rank),
        n_params=model.n_params,
        statements=statements,
        samples_per_case=cm.count,
        sigma=sig,
        residual_rms=float(np.sqrt(np.mean(r**2))),
        gamma=float(data.gamma),
        elapsed_s=time.perf_counter() - t0,
        gauge=gauge,
        common_shift_m=None if shift is None else shift.tolist(),
        convergence=conv,
        gates=gates,
    )


#: a reduced χ² against a given noise std this improbable (or less) means the std is too large
MIN_CHI2_PROBABILITY = 1e-6


def _chi2_too_small(chi2: float, dof: int) -> bool:
    """Whether a reduced χ² ``chi2`` with ``dof`` degrees of freedom is below its :data:`MIN_CHI2_PROBABILITY`
    quantile: residuals far smaller than the noise std they were weighted with."""
    from optinav.core.distributions import chi2_cdf

    return bool(chi2_cdf(chi2 * dof, dof) < MIN_CHI2_PROBABILITY)


def _quality_gates(method, out, x, r, rank: int, sigma_from_data: bool, max_dr: float) -> tuple[list[dict], float]:
    """After the fit: converged, plausible installation errors (|dr| ≤ ``max_dr`` m, :func:`dr_limit`), residual
    consistent with the noise and redundant data to judge it by; raises on the first that fails, else returns
    their outcomes and the reduced χ²."""
    if out is not None and not out.success:
        raise OptinavError(
            f"the LM fit did not converge ({out.message})",
            "check the data against the configuration, or try --method closed-form",
        )
    e = InstallationErrors.from_vector(x)
    dr, da = float(np.max(np.abs(e.dr))), float(np.max(np.abs(np.r_[e.dalpha, e.dbeta])))
    # a common shift of every position is the array's centre off the table axis: the spacing limit
    # is on the sensors' errors about their mean
    rel = np.linalg.norm(e.dr - e.dr.mean(axis=0), axis=1)
    if dr > MAX_DR_M or float(rel.max()) > max_dr or da > MAX_DANGLE_RAD:
        i = int(np.argmax(rel))
        raise OptinavError(
            f"the fitted installation errors are implausible (|dr| up to {dr:.3g} m, {rel[i]:.3g} m about their "
            f"mean at accelerometer {i + 1}; direction errors up to {da:.3g} rad; limits {MAX_DR_M} m, "
            f"{max_dr:.3g} m, {MAX_DANGLE_RAD} rad): the data do not belong to this configuration, two output "
            "columns are swapped, the table rates are off, or a column is in the wrong unit",
            "check the output columns' order against the configuration, table_rate, the gravity column (the local "
            "gravity) and the units",
        )
    dof = r.size - rank
    if dof <= 0:
        raise OptinavError(
            f"the turntable cases give {r.size} equations for {rank} unknowns: no redundancy to check the fit "
            "against the noise (a wrong column or a bias would be fitted exactly)",
            "record all six cases (three mountings, two rates each)",
        )
    chi2 = float(r @ r) / dof
    if dof > 0 and chi2 > MAX_REDUCED_CHI2:
        why = "the noise measured within the cases" if sigma_from_data else "--noise"
        raise OptinavError(
            f"the fit leaves residuals of {np.sqrt(chi2):.3g}σ RMS (reduced χ² {chi2:.3g}) against "
            f"{why}: the model does not explain the data",
            "check --noise (accelerometer noise std in m/s^2), the configuration, --offset and the gravity column "
            "(the local gravity: it scales every output, so an error of 1e-5 shows; scale factors are not estimated)",
        )
    if not sigma_from_data and _chi2_too_small(chi2, dof):
        raise OptinavError(
            f"the fit leaves residuals of only {np.sqrt(chi2):.2g}σ RMS (reduced χ² {chi2:.2g}, below what "
            f"{dof} degrees of freedom give once in {1 / MIN_CHI2_PROBABILITY:.0e}) against --noise: --noise is "
            "larger than the noise of the outputs, and every std would be as much too large",
            "check --noise (accelerometer noise std in m/s^2), or leave it out to use the scatter within the cases",
        )
    gates = [gate("optimizer converged", out.success, None, kind="true")] if out is not None else []
    gates += [
        gate("largest |dr|", dr, MAX_DR_M, unit="m"),
        gate("largest |dr − mean dr|", float(rel.max()), max_dr, unit="m"),
        gate("largest |direction error|", da, MAX_DANGLE_RAD, unit="rad"),
        gate("reduced chi-square", chi2, MAX_REDUCED_CHI2),
    ]
    return gates, chi2


def scheme_identifiability(
    nominal: AccelerometerArray,
    *,
    rates=(0.5, 1.0),
    gamma: float = np.radians(30.0),
    mountings=(1, 2, 3),
    offset: bool = False,
    bias_scale: bool = False,
):
    """Observability report (core ``analyze``) of a turntable scheme at the nominal geometry, σ = 1 per mean.

    Parameters
    ----------
    nominal : AccelerometerArray
        The design array.
    rates : sequence of float
        Table rates [rad/s].
    gamma : float
        Wedge angle γ [rad].
    mountings : sequence of int
        Mountings in 1..3.
    offset : bool
        Also estimate per-mounting offsets.
    bias_scale : bool
        Also estimate a bias and a scale factor per sensor.

    Returns
    -------
    ObservabilityReport
        Rank, unobservable combinations and CRLB std per unit output σ [parameter units].
    """
    U = table_axes(gamma, mountings)
    K = len(U) * len(rates)
    cm = CaseMeans(
        np.repeat(np.asarray(mountings, int), len(rates)),
        np.tile(np.asarray(rates, float), len(U)),
        np.zeros((K, nominal.n)),
        np.ones(K),
        np.ones(nominal.n),
    )
    model = _Model(nominal, cm, gamma, G_STANDARD, np.ones(nominal.n), offset, bias_scale)
    x = np.zeros(model.n_params)
    units = _unit_names(nominal.n, model.n_off) + ["m/s^2", ""] * (nominal.n if bias_scale else 0)
    return analyze(model.jacobian(x), 1.0, names=model.names(), units=units)


def required_samples(
    nominal: AccelerometerArray,
    errors: InstallationErrors,
    *,
    rates,
    target_pct: float,
    gamma: float = np.radians(30.0),
    noise: float = MICRO_G,
    k: float = 3.5,
) -> int:
    """Samples per case for which k·CRLB std of every position coefficient is ≤ target_pct % of its true value
    (k = 3.5: the largest of 30 Gaussian errors stays below ~3.5σ in most runs)."""
    rep = scheme_identifiability(perturb(nominal, errors), rates=rates, gamma=gamma)
    std1 = np.asarray(rep.crlb_std).reshape(-1, 5)[:, :3] * noise  # one sample per case
    truth = np.abs(errors.dr)
    need = (k * std1 / (target_pct / 100.0 * truth)) ** 2
    return int(np.ceil(need.max()))


def _legacy_v1(data: dict) -> dict:
    """RESULT.json of an older optinav (version 1: the nested layout, timing as ``elapsed``)."""
    return nested_kwargs(TurntableCalibration, data, {"elapsed": "elapsed_s"})


register_legacy(TurntableCalibration, "optinav.gfimu.calibration", 1, _legacy_v1)


def turntable_truth(errors: InstallationErrors, info: dict | None = None) -> Truth:
    """Simulated installation errors in the parameterizations :func:`calibrate` estimates (names
    ``dr_x_1`` … ``dbeta_N``; m, rad): absolute (a known offset), and ``dr_x_1 - mean(dr_x)`` … with
    ``mean(dr_x)`` … (the default, offset unknown: :func:`gauge_name`).

    Parameters
    ----------
    errors : InstallationErrors
        The simulated errors; also written per kind (``dr_m``, ``dalpha_rad``, ``dbeta_rad``) and by name
        (``coefficients``) beside the parameters.
    info : dict, optional
        The simulation's settings to record with them (units in the key names).

    Returns
    -------
    Truth
        The ``optinav.gfimu.truth`` record.
    """
    n = errors.n
    units = _unit_names(n, 0)
    own = {
        "dr_m": errors.dr.tolist(),
        "dalpha_rad": errors.dalpha.tolist(),
        "dbeta_rad": errors.dbeta.tolist(),
        "coefficients": dict(zip(InstallationErrors.names(n), errors.vector().tolist())),
    }
    params = {nm: Parameter(float(v), u) for nm, v, u in zip(InstallationErrors.names(n), errors.vector(), units)}
    # as a result without a known centre offset reports them (gauge mean(dr) = 0, GAUGE_UNKNOWN_OFFSET)
    mean = errors.dr.mean(axis=0)
    params.update({f"mean(dr_{c})": Parameter(float(mean[k]), "m") for k, c in enumerate("xyz")})
    params.update(
        {
            gauge_name(f"dr_{c}_{i + 1}"): Parameter(float(errors.dr[i, k] - mean[k]), "m")
            for i in range(n)
            for k, c in enumerate("xyz")
        }
    )
    return Truth("gfimu", params, {**own, **(info or {})})


register_truth_legacy(
    "gfimu",
    "optinav.gfimu_truth",
    lambda d: {
        nm: Parameter(float(v), "rad" if nm.startswith(("dalpha", "dbeta")) else "m")
        for nm, v in d["coefficients"].items()
    },
)
