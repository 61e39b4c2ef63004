"""The attitude of a log file estimated block by block, so that memory does not grow with its length
(``optinav attitude``; issue 17).

Two passes over the blocks: the first gathers what the physics checks judge (:class:`StreamChecks`), the second
runs the filter with its state carried from block to block (:class:`StreamEstimator`, the magnetometer and
polarization columns of the block included), writes each block's rows and adds the block's squared errors to
the score against a reference (BROAD: ``opt_quat`` over ``movement``). The output is renamed into place only
after every check passed, so the file is the in-memory path's byte for byte, and the score its RMSE to rounding.
``--offline`` (iframe's forward–backward smoother) keeps the second pass's inputs in a scratch file beside the
output and runs its passes over that file in blocks (:func:`_offline_segment`), again byte for byte. For ``--report``
the run also keeps what the report's summary shows (:class:`StreamedEstimate`) and every k-th row of roll, pitch and
yaw for its figure (at most ``figure_points`` rows), so the report too is bounded in memory.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from optinav.attitude.checks import online_offset_changed, zero_rows_missing
from optinav.attitude.stream import StreamChecks, StreamEstimator
from optinav.attitude.unit import AttitudeOptions, nan_rows_error
from optinav.attitude.recording import CSV_FORMAT, CSV_HEADER, attitude_rows
from optinav.core.files import CHUNK_ROWS, csv_writer
from optinav.errors import OptinavError
from optinav.io.imu import mag_names, mag_triad

__all__ = ["PolColumns", "pol_columns", "StreamRun", "StreamedEstimate", "stream_attitude"]


@dataclass
class PolColumns:
    """The polarization columns of a log: ``aop`` (and ``dop``) column names, ``aop_unit`` "rad"/"deg",
    ``min_dop``, and ``sun(t, t_first)``: the unit sun vector in the navigation frame, (n, 3) or (3,), for the
    times ``t`` (s) of a block of a log that starts at ``t_first``."""

    aop: str
    dop: str | None
    sun: Callable[[np.ndarray, float], np.ndarray]
    aop_unit: str = "rad"
    min_dop: float = 0.05


def pol_columns(columns: str, frame: str, *, aop_unit: str = "rad", min_dop: float = 0.05, **sun) -> PolColumns:
    """The polarization columns of ``--pol-columns`` with the sun along the log.

    Parameters
    ----------
    columns : str
        ``"AOP"`` or ``"AOP,DOP"``: the column names.
    frame : str
        Navigation frame of the sun vectors (``"ned"``/``"enu"``, either case).
    aop_unit : str
        Unit of the angle column in the file, ``"rad"`` or ``"deg"``.
    min_dop : float
        Degree of polarization below which a sample is not used [-].
    **sun
        The place and time or the fixed sun, as :func:`optinav.attitude.recording.sun_along_log` takes them
        (``lat``, ``lon``, ``height_m``, ``start_time``, ``azimuth``, ``elevation``; angles in radians).

    Returns
    -------
    PolColumns
        The columns and the sun of a block, ``sun(t, t_first)``.
    """
    from optinav.attitude.recording import pol_column_names, sun_along_log

    aop, dop = pol_column_names(columns)
    return PolColumns(aop, dop, lambda t, t_first: sun_along_log(t, frame, t_first=t_first, **sun), aop_unit, min_dop)


@dataclass
class StreamedEstimate:
    """The fields of an :class:`~optinav.attitude.AttitudeEstimate` that its report's summary and a batch row show,
    of an estimate run block by block (:func:`optinav.reports.attitude_report.attitude_tables` and
    :func:`optinav.batch.result_columns` read them); the per-sample series are not kept. ``mag_used``: samples with
    the magnetometer used (None: none given); ``truth_comparison``: :meth:`optinav.core.results.Truth.compare` of
    a simulated truth, its per-sample series as their RMS error (``{"rmse", "z"}``), when one was given."""

    method: str
    frame: str
    line: str
    pol_used: int = 0
    pol_skipped: dict = field(default_factory=dict)
    acc_threshold_hits: int = 0
    gyr_bias: np.ndarray | None = None  # rad/s, the final estimate
    mag_used: int | None = None
    mag_rows: int | None = None  # rows holding a magnetometer sample (a slower magnetometer: NaN rows between)
    truth_comparison: dict | None = None
    gates: list = field(default_factory=list)
    input_stage: bool = True  # gd/cg/qn/mekf: behind iframe's input stage (False: as published)
    offline: bool = False
    #: the hard-iron offset subtracted from the magnetometer (its unit; given, fitted from the log or fitted online),
    #: and the row from which the field was used less the one fitted online (None: not fitted online)
    mag_hard_iron: np.ndarray | None = None
    mag_hard_iron_from: int | None = None
    mag_used_before_fit: bool = False  # the field as measured before mag_hard_iron_from (else unused)
    declination: float = 0.0  # rad, east positive: the magnetometer's heading turned by it to the true one
    #: rad, the AoP residual RMS of the heading branch the data chose and of the other (None: not decided)
    pol_branch_rms: np.ndarray | None = None

    @property
    def SCHEMA(self) -> str:  # noqa: N802 - the attribute every result has
        from optinav.attitude.estimators import AttitudeEstimate

        return AttitudeEstimate.SCHEMA

    @property
    def convergence(self) -> dict:
        from optinav.attitude.estimators import filter_convergence

        return filter_convergence()

    @property
    def heading(self) -> bool:
        """Whether the magnetometer or polarization fixed the heading (else q_b_n and the yaw are unobservable)."""
        return self.pol_used > 0 or bool(self.mag_used)

    def parameters(self) -> dict:
        """The parameters that are not per-sample series: ``gyr_bias`` (3,) rad/s where the method has one."""
        from optinav.core.results import Parameter

        return {} if self.gyr_bias is None else {"gyr_bias": Parameter(np.asarray(self.gyr_bias, float), "rad/s")}

    def unobservable(self) -> dict[str, str]:
        """As :meth:`AttitudeEstimate.unobservable`: q_b_n and the yaw without a heading measurement."""
        from optinav.attitude.estimators import NO_HEADING

        return {} if self.heading else {"q_b_n": NO_HEADING, "yaw": NO_HEADING}

    def summary(self) -> str:
        """The line :meth:`AttitudeEstimate.summary` prints for the same estimate."""
        return self.line


@dataclass
class StreamRun:
    """What :func:`stream_attitude` did: ``summary`` (the line of :meth:`AttitudeEstimate.summary`), ``n`` samples
    and ``score`` (inclination RMSE [rad], heading RMSE [rad], samples with a valid reference) or None, as
    :func:`optinav.attitude.recording.reference_rmse`; ``estimate`` the report's fields and ``figure`` every k-th
    row's (t [s], (m, 3) roll, pitch, yaw [deg]) when ``figure_points`` was given, else None; ``duration_s`` the
    last time stamp minus the first [s]; ``notes`` what the reader assumed or left out (the rate's source, a text
    column left out, an incomplete last line)."""

    summary: str
    n: int
    score: tuple[float, float, int] | None = None
    estimate: StreamedEstimate | None = None
    figure: tuple[np.ndarray, np.ndarray] | None = None
    duration_s: float = 0.0
    notes: list[str] = field(default_factory=list)
    #: with ``figure`` and a reference: the same rows' (m, 2) inclination and heading error [deg], NaN where the
    #: row is not scored (no movement or no valid reference)
    figure_errors: np.ndarray | None = None


class _Decimated:
    """Every ``stride``-th row (by row index in the log) of the attitude rows, at most about ``points`` of ``n``."""

    def __init__(self, n: int, points: int):
        self.stride = max(1, -(-int(n) // max(int(points), 1)))
        self.parts: list[np.ndarray] = []
        self.errs: list[np.ndarray] = []

    def add(self, row0: int, rows: np.ndarray, errors: np.ndarray | None = None) -> None:
        """A block's attitude rows and, when scored, their (n, 2) inclination and heading error [deg]."""
        first = (-row0) % self.stride
        self.parts.append(np.array(rows[first :: self.stride][:, [0, 5, 6, 7]]))
        if errors is not None:
            self.errs.append(np.array(errors[first :: self.stride]))

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        a = np.concatenate(self.parts) if self.parts else np.empty((0, 4))
        return a[:, 0], a[:, 1:]

    def errors(self) -> np.ndarray | None:
        return np.concatenate(self.errs) if self.errs and len(self.errs) == len(self.parts) else None


class _Score:
    """:func:`optinav.attitude.recording.reference_rmse` accumulated over blocks, from per-block sums of squares."""

    def __init__(self, frame: str | None = None):
        self.ss = np.zeros(3)  # inclination, heading, inclination with the reference read as [x, y, z, w]
        self.k = np.zeros(3, dtype=np.int64)
        self.n = 0
        self.seen = np.zeros(3, dtype=np.int64)  # rows, rows marked movement, rows with a finite reference
        from optinav.attitude.checks import ReferenceTurns

        self.turns = ReferenceTurns(frame)

    def add(self, q, q_ref, movement, gyr=None, dts=None, acc=None) -> np.ndarray:
        """One block; returns its (n, 2) inclination and heading error [deg], NaN where not scored."""
        from optinav.attitude.checks import XYZW
        from optinav.attitude.metrics import heading_error, inclination_error

        if gyr is not None:
            self.turns.add(q_ref, gyr, dts, acc)

        valid = np.all(np.isfinite(q_ref), axis=1)
        mask = movement & valid
        self.n += int(mask.sum())
        self.seen += (len(valid), int(np.count_nonzero(movement)), int(np.count_nonzero(valid)))
        out = np.full((len(mask), 2), np.nan)
        for j, (err, ref) in enumerate(
            ((inclination_error, q_ref), (heading_error, q_ref), (inclination_error, q_ref[:, XYZW]))
        ):
            e = err(q, ref)
            ok = np.isfinite(e) & mask
            self.ss[j] += float(np.sum(e[ok] ** 2))
            self.k[j] += int(np.count_nonzero(ok))
            if j < 2:
                out[ok, j] = np.degrees(e[ok])
        return out

    def result(self) -> tuple[float, float, int]:
        from optinav.attitude.checks import warn_reference_order

        from optinav.attitude.recording import nothing_to_score

        if not np.all(self.k[:2]):
            raise nothing_to_score(*(int(x) for x in self.seen))
        self.turns.check()
        r = np.sqrt(self.ss / np.maximum(self.k, 1))
        warn_reference_order(float(r[0]), float(r[2]))
        return float(r[0]), float(r[1]), self.n


def truth_frame(truth, default: str) -> str:
    """The navigation frame of a simulated truth (:class:`~optinav.core.results.Truth`): its ``frame`` entry, else
    ``default``."""
    from optinav.core.rotations import frame_name

    f = truth.info.get("frame") if isinstance(getattr(truth, "info", None), dict) else None
    return frame_name(f, "truth frame") if f else frame_name(default)


class _TruthSeries:
    """:meth:`optinav.core.results.Truth.compare` of a simulated truth's per-sample series (q_b_n, roll, pitch, yaw)
    accumulated over blocks as sums of squared errors; its other parameters are compared with the final estimate.
    ``truth``: a :class:`~optinav.core.results.Truth` or a
    :class:`~optinav.core.results.TruthSeriesReader` (long series read block by block beside the log)."""

    SERIES = ("q_b_n", "roll", "pitch", "yaw")

    def __init__(self, truth, frame: str):
        from optinav.core.results import TruthSeriesReader

        self.reader = truth if isinstance(truth, TruthSeriesReader) else None
        self.truth, self.frame = (truth.truth if self.reader is not None else truth), frame
        # the truth's q_b_n, roll, pitch, yaw are of its navigation frame (a NED flight estimated with --frame ENU
        # was compared as if both were ENU: 175° of inclination error, exit 0); the estimate is turned into it
        self.truth_frame = truth_frame(self.truth, frame)
        streamed = self.reader.rows if self.reader is not None else {}
        # the series held in memory, as arrays once (not per block)
        self.inline = {
            k: np.asarray(p.value, float)
            for k, p in self.truth.parameters.items()
            if k in self.SERIES and p.value is not None and k not in streamed
        }
        self.streamed = [k for k in self.SERIES if k in streamed]
        self.ss: dict[str, float] = {}
        self.k: dict[str, int] = {}

    def _mismatch(self, name: str, have: int, n: int) -> OptinavError:
        return OptinavError(
            f"the truth's {name} has {have} samples, the log {n}",
            "pass the truth written with this log by optinav simulate flight, or remove it",
        )

    def add(self, row0: int, q: np.ndarray) -> None:
        from optinav.attitude.estimators import AttitudeEstimate
        from optinav.core.results import Truth
        from optinav.core.rotations import attitude_in_frame

        n = len(q)
        values = {k: v[row0 : row0 + n] for k, v in self.inline.items()}
        for k in self.streamed:
            values[k] = self.reader.take(k, n)
        for k, v in values.items():
            if len(v) < n:
                have = self.reader.taken(k) if k in self.streamed else len(self.inline[k])
                raise self._mismatch(k, have, f"at least {row0 + n}")
        params = self.truth.parameters
        part = Truth(self.truth.system, {k: dataclasses.replace(params[k], value=v) for k, v in values.items()})
        q = attitude_in_frame(q, self.frame, self.truth_frame)
        for name, c in part.compare(_Observed(AttitudeEstimate(q_b_n=q, frame=self.truth_frame))).items():
            e = np.asarray(c["error"], float)
            self.ss[name] = self.ss.get(name, 0.0) + float(np.sum(e**2))
            self.k[name] = self.k.get(name, 0) + e.size

    def result(self, est: StreamedEstimate, n: int) -> dict:
        """The comparison as :meth:`Truth.compare` gives it for the whole estimate ``est`` of ``n`` samples (its
        series as ``{"rmse", "z"}``, only those the estimate observes)."""
        from optinav.core.results import Truth

        for name, v in self.inline.items():
            if len(v) != n:
                raise self._mismatch(name, len(v), n)
        for name in self.streamed:
            rest = self.reader.count_rest(name)
            if rest:
                raise self._mismatch(name, self.reader.taken(name), n)
        if self.reader is not None:
            self.reader.close()
        hidden = est.unobservable()
        out = {
            name: {"rmse": float(np.sqrt(self.ss[name] / self.k[name])), "z": float("nan")}
            for name in self.ss
            if name not in hidden and self.k[name]
        }
        rest = {k: p for k, p in self.truth.parameters.items() if k not in self.SERIES}
        out.update(Truth(self.truth.system, rest).compare(est))
        return out


class _Observed:
    """A result's parameters all taken as observable: a block is compared whatever the whole log observes."""

    def __init__(self, result):
        self.result = result

    def parameters(self) -> dict:
        return {k: dataclasses.replace(p, observable=True) for k, p in self.result.parameters().items()}


class _TruthRows:
    """The reference q (n, 4) of a simulator's ``STEM.truth.csv`` (t, qw, qx, qy, qz per log row) read block by
    block beside the log's blocks."""

    def __init__(self, path: Path, frame_from: str | None = None, frame_to: str | None = None):
        from optinav.io.readers import iter_table

        self.path, self.rows = Path(path), 0
        self.frames = (frame_from, frame_to) if frame_from and frame_to else None  # truth's, estimate's
        self._blocks = iter(iter_table(path))
        self._buf = np.empty((0, 5))

    def take(self, n: int, t: np.ndarray | None = None) -> np.ndarray:
        """The next ``n`` rows' q; ``t`` (n,) s: the log's times, which the truth's t must match (within half a
        step: a truth of another rate or start scored the wrong attitude against each sample)."""
        while self._buf.shape[0] < n:
            tab = next(self._blocks, None)
            if tab is None:
                raise self.mismatch(f"{self.rows + self._buf.shape[0]} rows for more log samples")
            cols = list(tab.data.values())
            if len(cols) != 5:
                raise self.mismatch(f"{len(cols)} columns")
            self._buf = np.vstack([self._buf, np.column_stack([np.asarray(c, float) for c in cols])])
        rows, self._buf = self._buf[:n], self._buf[n:]
        if t is not None and n:
            half = 0.5 * float(np.median(np.diff(t))) if n > 1 else np.inf
            off = np.abs(rows[:, 0] - t)
            bad = np.flatnonzero(~(off <= half))
            if bad.size and np.isfinite(half):
                i = int(bad[0])
                raise self.mismatch(
                    f"row {self.rows + i + 1}: t = {rows[i, 0]:.6g} s, the log's sample at {t[i]:.6g} s"
                )
        q = rows[:, 1:]
        self.rows += n
        if self.frames is not None:
            from optinav.core.rotations import attitude_in_frame

            q = attitude_in_frame(q, *self.frames)
        return q

    def finish(self) -> None:
        """Check that the truth ends with the log."""
        if self._buf.shape[0] or next(self._blocks, None) is not None:
            raise self.mismatch(f"more rows than the {self.rows} log samples")

    def mismatch(self, what: str) -> OptinavError:
        return OptinavError(
            f"{self.path.name} does not hold t,qw,qx,qy,qz for each log sample ({what})",
            "write it with optinav simulate flight, or remove it",
        )


def _finite_rows(blocks, notes: list[str], o: AttitudeOptions):
    """The ``blocks`` (see :class:`_Blocks`) without their rows that hold a NaN accelerometer or gyro value — lost
    samples (``--drop-nan``, implied by ``--skip-bad-lines``): rows numbered and steps taken over the rows kept; how many were left out is added to
    ``notes`` at the end."""
    from optinav.attitude.unit import nan_rows_note

    row, prev, lost = 0, None, 0
    for _, t, gyr, acc, dts, finite, extra in blocks:
        keep = np.flatnonzero(finite)
        lost += finite.size - keep.size
        if not keep.size:
            continue
        tk = t[keep]
        first = tk[0] - dts[keep[0]] if prev is None else prev
        prev = tk[-1]
        yield (row, tk, gyr[keep], acc[keep], np.diff(tk, prepend=first), finite[keep],
               {k: v[keep] for k, v in extra.items()})  # fmt: skip
        row += keep.size
    if lost and nan_rows_note(lost, o) not in notes:
        notes.append(nan_rows_note(lost, o))


class _Blocks:
    """The blocks of a log: (first row, t, gyr, acc, dts, {"mag", "aop", "dop", "q_ref", "movement"}) with
    ``size``/``position`` for the progress bar. A BROAD trial is read whole (its HDF5/MAT library reads it so)
    and cut; text files are read block by block (:func:`optinav.io.iter_imu`), with the reference q of
    ``truth_csv`` (a simulator's ``STEM.truth.csv``) as "q_ref" when given (every sample scored)."""

    def __init__(
        self,
        path,
        o: AttitudeOptions,
        *,
        mag: bool,
        pol: PolColumns | None,
        reference: bool,
        chunk_rows: int,
        truth_csv=None,
        truth_frame: str | None = None,
    ):
        from optinav.attitude.data import has_reference, is_broad

        self.path, self.o, self.mag, self.pol, self.chunk_rows = Path(path), o, mag, pol, max(int(chunk_rows), 2)
        self.truth_csv, self.truth_frame, self.reference = truth_csv, truth_frame, reference
        self.gyro_unit = "rad/s"  # as the file declared it (the checks' messages name it), set by the first block
        self.broad = is_broad(path) and not o.columns and not o.datasets
        if not mag:
            from optinav.attitude.unit import refuse_unused_mag_topic

            refuse_unused_mag_topic(path, o)
        if reference and not (self.broad and has_reference(path)):
            raise OptinavError(
                f"{path} is not a BROAD file with opt_quat and movement", "drop --reference or pass a BROAD trial"
            )
        self.size = max(self.path.stat().st_size, 1) if self.path.is_file() else 1
        self.position = 0
        self.notes: list[str] = []  # the reader's notes (optinav.io.ImuLog.notes), each once
        self._whole: dict | None = None
        #: read the magnetometer the readers find unasked (mx, my, mz; BROAD's imu_mag) as the checks' "witness"
        #: when the estimate does not take one; None once it is absent or unreadable (then it stays absent)
        self.witness: dict | None = {} if not mag and o.gyro_path is None else None
        self._witness_whole: np.ndarray | None = None
        #: a magnetometer on its own time stamps (a file of its own, a phone export's, a multi record's rows)
        self.own_mag = None
        if self.broad and o.mag_path is not None:
            raise OptinavError(f"{self.path.name} is a BROAD trial, which holds its magnetometer", "drop --mag-file")
        if mag and not self.broad:
            from optinav.attitude.unit import separate_mag

            self.own_mag = separate_mag(self.path, o)
        if self.witness is not None:
            from optinav.io.phone import phone_export

            if phone_export(self.path) is not None:
                self.witness = None  # its magnetometer is not on the IMU's rows
        names = {}
        if mag and self.own_mag is None:
            m, self.mag_signs = mag_names(o.mag_columns)
            names = {"mag": m[0]} if len(m) == 1 else {f"m{k}": v for k, v in zip("xyz", m)}
        if pol is not None:
            names["aop"] = pol.aop
            if pol.dop:
                names["dop"] = pol.dop
        self.names = names
        if not self.broad and (names or self.witness is not None):
            from optinav.io.imu import MULTI_RECORD_BESIDE, multi_record, reader_options

            if multi_record(self.path, **reader_options(o, gyro_path=None, gyro_columns=None)):
                if names:
                    raise OptinavError(f"{self.path.name}: {MULTI_RECORD_BESIDE[0]}", MULTI_RECORD_BESIDE[1])
                self.witness = None  # its rows are not the samples': no magnetometer to check against

    def __iter__(self):
        blocks = self._broad() if self.broad else self._text()
        for block in _finite_rows(blocks, self.notes, self.o) if self.o.drops_nan else blocks:
            if "mag" in block[6]:  # a row of zeros is no sample (checks.zero_rows_missing), as estimate() reads it
                block[6]["mag"] = zero_rows_missing(block[6]["mag"])
            yield block

    def _text(self):
        blocks = self._text_blocks()
        yield from blocks if self.own_mag is None else self._with_own_mag(blocks)

    def _with_own_mag(self, blocks):
        """``blocks`` with the magnetometer on its own time stamps put on their rows (extra "mag",
        :meth:`optinav.io.imu.MagSamples.on_rows`), each block held until the next one's first time is known (a
        sample between two blocks goes on the nearer row); what was done is noted at the end."""
        ms, held, before, step, used, n = self.own_mag, None, -np.inf, None, 0, 0
        t0 = None
        for block in itertools.chain(blocks, [None]):
            if held is not None:
                t = held[1]
                if block is None:
                    ms.check_clock(t0, float(t[-1]), step)
                m = ms.on_rows(t, step, before, np.inf if block is None else float(block[1][0]))
                held[6]["mag"] = m
                used += int(np.count_nonzero(np.isfinite(m).all(axis=1)))
                n += t.size
                before = float(t[-1])
                yield held
            if block is not None and step is None:
                step = float(np.median(block[4]))  # the IMU's step: its first block's
                t0 = float(block[1][0])
            held = block
        note = ms.note(step, used, n)
        if note not in self.notes:
            self.notes.append(note)

    def _text_blocks(self):
        from optinav.io.imu import iter_imu, reader_options

        o = self.o
        chunks = iter_imu(self.path, chunk_rows=self.chunk_rows, **reader_options(o))
        self.size = chunks.size
        prev = None
        truth = None if self.truth_csv is None else _TruthRows(self.truth_csv, self.truth_frame, self.o.frame)
        for log in chunks:
            self.position = chunks.position
            self.notes += [n for n in log.notes if n not in self.notes]
            if log.acc is None or log.gyr is None:
                from optinav.io.imu import headphone_error

                err = headphone_error(chunks) if log.acc is None else None
                if err is not None:
                    raise err
                has = "only the accelerometer" if log.acc is not None else "only the gyroscope"
                raise OptinavError(
                    f"{self.path} has {has}: the attitude needs the accelerometer and the gyroscope in one file",
                    "pass the other sensor's file with --gyro GYRODATA (phone apps write a file per sensor; its "
                    "times are interpolated onto the accelerometer's), or name the columns with --columns "
                    "t,ax,ay,az,gx,gy,gz",
                )
            if log.acc_unit == "counts" or log.gyro_unit == "counts":
                from optinav.attitude.unit import RAW_COUNTS

                raise OptinavError(*RAW_COUNTS)
            self.gyro_unit = log.gyro_input_unit or log.gyro_unit
            row0 = chunks.rows - len(log)
            t = log.t
            # two rows at least in the first block: its first step comes from its first two times
            first = t[0] - (t[1] - t[0] if t.size > 1 else 0.01) if prev is None else prev
            prev = t[-1]
            extra = self._extra(chunks.table, row0, len(log))
            w = self._witness_rows(chunks.table, row0, len(log))
            if w is not None:
                extra["witness"] = w
            if truth is not None:
                extra.update(q_ref=truth.take(len(log), t), movement=np.ones(len(log), bool))
            yield (row0, t, log.gyr, log.acc, np.diff(t, prepend=first), log.finite, extra)
        if truth is not None:
            truth.finish()

    def _extra(self, table, row0: int, n: int) -> dict:
        if not self.names:
            return {}
        from optinav.io.readers import MissingColumn

        try:
            return self._extra_columns(table, row0, n)
        except MissingColumn as exc:
            if exc.name not in {self.names.get(k) for k in ("mx", "my", "mz", "mag")}:
                raise
            if self._resolve_mag(exc.found):
                return self._extra_columns(table, row0, n)
            # Xsens' Mag_X, a phone app's magneticField_x: --mag looked for mx,my,mz and named only the file's columns
            like = [c for c in exc.found if "mag" in c.lower()]
            if len(like) not in (1, 3):
                like = [c for c in exc.found if c.lower() in ("bx", "by", "bz")]  # Physics Toolbox: the field B
            raise OptinavError(
                exc.cause,
                "name the magnetometer's three columns (or its N×3 array) with --mag-columns"
                + (f" (e.g. --mag-columns {','.join(_short(like))})" if len(like) in (1, 3) else " X,Y,Z"),
            ) from None

    def _resolve_mag(self, found: list) -> bool:
        """Whether the magnetometer's names were found again among the file's columns ``found`` by their alias key
        (a unit in brackets, case, spaces: ``mx [G]`` for mx, ``Mag_X`` for mag_x); then ``names`` holds them."""
        keys = [k for k in ("mx", "my", "mz", "mag") if k in self.names]
        new = _by_alias_key({k: self.names[k] for k in keys}, found)
        if new is None and self.o.mag_columns is None:  # --mag alone: the magnetometer's usual names
            new = mag_triad(found)
            if new is not None:
                self.notes.append(f"magnetometer: columns {', '.join(new[k] for k in ('mx', 'my', 'mz'))}")
        if new is None or all(new[k] == self.names[k] for k in keys):
            return False
        self.names.update(new)
        return True

    def _witness_rows(self, table, row0: int, n: int) -> np.ndarray | None:
        """The (n, 3) rows of the magnetometer ``--mag`` would read by default (columns mx, my, mz, found as
        :meth:`_resolve_mag` finds them; a bag's MagneticField topic) when the estimate takes none, for the checks
        only; None when there is none or it cannot be read (then none is looked for again: no error, no note)."""
        from optinav.io.readers import read_table

        if self.witness is None:
            return None
        keys = ("mx", "my", "mz")
        try:
            if table is None:  # a format read whole by its library: the columns once, then cut
                if self._witness_whole is None:
                    tab = read_table(self.path, delimiter=self.o.delimiter, topic=self.o.topic,
                                     skip_bad_lines=self.o.skip_bad_lines)  # fmt: skip
                    names = _by_alias_key(dict(zip(keys, keys)), list(tab)) or mag_triad(list(tab))
                    self._witness_whole = np.column_stack([np.asarray(tab[names[k]], float) for k in keys])
                m = self._witness_whole[row0 : row0 + n]
            else:
                names = (
                    self.witness
                    or _by_alias_key(dict(zip(keys, keys)), list(table.data))
                    or mag_triad(list(table.data))
                )
                m = np.column_stack([np.asarray(table.data[names[k]], float) for k in keys])
                self.witness = names
            if m.shape != (n, 3):
                raise ValueError("not the IMU's rows")
            return m
        except (OptinavError, ValueError, TypeError, KeyError, IndexError, OSError):
            self.witness = None  # absent, not numbers or not the IMU's rows: no witness
            return None

    def _extra_columns(self, table, row0: int, n: int) -> dict:
        if table is None:  # a format read whole by its library: its columns once, then cut
            if self._whole is None:
                from optinav.io.readers import read_table

                tab = read_table(
                    self.path,
                    columns=",".join(f"{k}={v}" for k, v in self.names.items()),
                    delimiter=self.o.delimiter,
                    topic=self.o.topic,
                    skip_bad_lines=self.o.skip_bad_lines,
                )
                self._whole = {k: _column(k, v) for k, v in tab.items()}
            cols = {k: v[row0 : row0 + n] for k, v in self._whole.items()}
        else:
            from optinav.io.readers import with_lost_rows

            cols = {k: _column(k, with_lost_rows(table.get(v), table.bad_rows, n)) for k, v in self.names.items()}
        for k, v in cols.items():
            if v.shape[0] != n:
                what = "the magnetometer" if k.startswith("m") else f"{k.upper()} column"
                raise OptinavError(
                    f"{what} has {v.shape[0]} rows, the IMU {n} (block at row {row0})",
                    "check --mag-columns" if k.startswith("m") else "check --pol-columns",
                )
        out = {}
        if self.mag:
            out["mag"] = cols["mag"] if "mag" in cols else np.column_stack([cols["mx"], cols["my"], cols["mz"]])
            out["mag"] = out["mag"] * self.mag_signs if np.any(self.mag_signs < 0) else out["mag"]
        for k in ("aop", "dop"):
            if k in cols:
                out[k] = cols[k]
        return out

    def _broad(self):
        import contextlib

        from optinav.attitude.data import check_broad_shapes, load_broad, movement_mask
        from optinav.core.rotations import attitude_in_frame

        with contextlib.ExitStack() as stack:
            if self.path.suffix.lower() in (".h5", ".hdf5"):
                # HDF5: the datasets are read block by block (the file is validated as load_broad does)
                tr = _Hdf5Trial(stack, self.path, self.o)
                fa, fg = tr.acc_factor, tr.gyro_factor
            else:  # MAT: scipy reads it whole
                tr = load_broad(self.path, self.o)
                fa = fg = 1.0
            self.gyro_unit = tr.gyro_unit  # as declared: the checks' messages name it
            if self.reference:
                shapes = {"imu_gyr": tr.gyr.shape, "opt_quat": tr.q_ref.shape, "movement": tr.movement.shape}
                check_broad_shapes(self.path.name, shapes)
            n = tr.gyr.shape[0]
            h = 1.0 / tr.rate_hz
            prev = None
            for a in range(0, n, self.chunk_rows):
                s = slice(a, a + self.chunk_rows)
                self.position = int(self.size * min(a + self.chunk_rows, n) / max(n, 1))
                t = np.arange(a, min(a + self.chunk_rows, n)) / tr.rate_hz
                first = (t[0] - (t[1] - t[0] if t.size > 1 else h)) if prev is None else prev
                prev = t[-1]
                try:
                    gyr, acc = np.asarray(tr.gyr[s], float) * fg, np.asarray(tr.acc[s], float) * fa
                    extra = {
                        # body -> ENU; compared in the estimate's frame (--frame NED was refused)
                        "q_ref": attitude_in_frame(np.asarray(tr.q_ref[s], float), "enu", self.o.frame),
                        "movement": movement_mask(tr.movement[s]),
                    }
                    if self.mag:
                        m = tr.mag
                        extra["mag"] = np.asarray(m[s], float) if m is not None else np.full(gyr.shape, np.nan)
                    elif self.witness is not None and tr.mag is not None:
                        try:  # the magnetometer the estimate does not take: the checks' witness, if readable
                            w = np.asarray(tr.mag[s], float)
                            extra["witness"] = w if w.shape == gyr.shape else None
                        except (OSError, ValueError, TypeError, IndexError):
                            extra["witness"] = None
                        if extra["witness"] is None:
                            self.witness = extra.pop("witness")
                except OSError as exc:  # h5py: a damaged block (a chunk's filter fails) from this row on
                    from optinav.io.readers import h5_damaged

                    raise h5_damaged(self.path, exc) from None
                finite = np.isfinite(gyr).all(axis=1) & np.isfinite(acc).all(axis=1)
                yield a, t, gyr, acc, np.diff(t, prepend=first), finite, extra


class _Hdf5Trial:
    """The datasets of a BROAD HDF5 trial, sliced on demand (``gyr``, ``acc``, ``mag`` or None, ``q_ref``,
    ``movement``, ``rate_hz``); the checks of :func:`optinav.attitude.data.load_broad`."""

    def __init__(self, stack, path: Path, options=None):
        import h5py

        from optinav.attitude.data import broad_declared, broad_units, check_broad_shapes

        try:
            f = stack.enter_context(h5py.File(path, "r"))
        except OSError as exc:
            raise OptinavError(f"cannot read {path} ({exc})", "pass a BROAD trial HDF5 file") from None
        missing = [k for k in ("imu_gyr", "imu_acc") if k not in f]
        if missing:
            raise OptinavError(f"{path.name} lacks BROAD dataset(s) {missing}", "pass a BROAD trial HDF5 or MAT file")
        try:
            rate = f.attrs.get("sampling_rate")
            if rate is None and "sampling_rate" in f:
                rate = f["sampling_rate"][()]
            attrs = dict(f.attrs)
            self.gyr, self.acc = f["imu_gyr"], f["imu_acc"]
            shapes = {k: f[k].shape for k in ("imu_gyr", "imu_acc", "imu_mag") if k in f}
            n = self.gyr.shape[0]
            self.q_ref = f["opt_quat"] if "opt_quat" in f else np.full((n, 4), np.nan)
            self.movement = f["movement"] if "movement" in f else np.zeros(n, bool)
            self.mag = f["imu_mag"] if "imu_mag" in f else None
        except (OSError, KeyError, ValueError, RuntimeError) as exc:  # h5py: a damaged object header or block
            from optinav.io.readers import h5_damaged

            raise h5_damaged(path, exc) from None
        check_broad_shapes(path.name, shapes)
        self.acc_factor, self.gyro_factor, self.rate_hz = broad_units(path.name, attrs, options, rate)
        self.gyro_unit = str(broad_declared("gyro_unit", attrs, options) or "rad/s")


class _Scratch:
    """Per-sample fields of a log in a scratch file (float64 rows; ``fields`` name → width), read and written by
    row ranges (pread/pwrite: the process holds one block; a memory map would count its pages as resident)."""

    def __init__(self, fh, fields: dict[str, int]):
        self.fd, self.cols, w = fh.fileno(), {}, 0
        for name, k in fields.items():
            self.cols[name] = slice(w, w + k)
            w += k
        self.width, self.n = w, 0

    def append(self, **values) -> None:
        k = len(values["t"])
        rows = np.zeros((k, self.width))
        for name, v in values.items():
            rows[:, self.cols[name]] = np.asarray(v, float).reshape(k, -1)
        self.write(self.n, rows)
        self.n += k

    def read(self, a: int, b: int) -> np.ndarray:
        size, at = (b - a) * self.width * 8, a * self.width * 8
        buf = bytearray()
        while len(buf) < size:
            got = os.pread(self.fd, size - len(buf), at + len(buf))
            if not got:
                raise OSError(f"scratch file ends at row {a + len(buf) // (self.width * 8)}")
            buf += got
        return np.frombuffer(buf, float).reshape(b - a, self.width)

    def write(self, a: int, rows: np.ndarray) -> None:
        data = memoryview(np.ascontiguousarray(rows, float)).cast("B")
        done = 0
        while done < len(data):
            done += os.pwrite(self.fd, data[done:], a * self.width * 8 + done)

    def col(self, rows: np.ndarray, name: str) -> np.ndarray:
        return np.ascontiguousarray(rows[:, self.cols[name]])


def _block_pol(pol: PolColumns | None, extra: dict, t: np.ndarray, t_first: float, frame: str):
    """The :class:`~optinav.attitude.PolarizationMeasurement` of a block's polarization columns (``extra``, times
    ``t`` s of a log starting at ``t_first``), or None without them."""
    if pol is None:
        return None
    from optinav.attitude.measurement import PolarizationMeasurement

    aop = np.radians(extra["aop"]) if pol.aop_unit == "deg" else extra["aop"]
    return PolarizationMeasurement(aop, pol.sun(t, t_first), dop=extra.get("dop"), frame=frame, min_dop=pol.min_dop)


def _cut(checks, row0: int, dts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows of a block (from ``row0``) where a time gap starts a new segment, and its steps ``dts`` (s) with
    each segment's first the median one."""
    gaps = checks.gaps
    cuts = gaps[(gaps >= row0) & (gaps < row0 + len(dts))] - row0
    dts = dts.copy()
    dts[cuts] = checks.median_dt
    return cuts, dts


class _BranchSegment:
    """One segment's runs of iframe online (options ``opts``) from either heading branch
    (:data:`~optinav.attitude.branch.BRANCHES`; :func:`~optinav.attitude.iframe.run_iframe`'s kernel with the
    states carried block by block): their AoP residuals, and the segment's first usable polarization row and first
    row with a field (relative to the segment). ``method``: (name, filter options) of gd/cg/qn/mekf, run from
    either start too (:class:`~optinav.attitude.branch.HeldBranch` over the segment's ``n`` rows), or None. From
    ``q0`` (4,) the runs start from it and from it turned 180° about up: the AoP must not contradict its branch."""

    def __init__(self, frame: str, opts: dict, method=None, n: int = 0, q0=None):
        from optinav.attitude import iframe as _if
        from optinav.attitude.branch import BRANCHES, HeldBranch, q0_starts
        from optinav.attitude.estimators import make_filter

        self.frame, self.par = frame, _if._params(frame, opts)
        if q0 is None:
            self.states = [_if._new_state(opts, None, other_root=b) for b in BRANCHES]
        else:
            self.states = [_if._new_state(opts, q) for q in q0_starts(q0, frame)]
        self.last = q0  # the run from q0: the attitude before the next block's first row
        self.res, self.n, self.pol_row, self.mag_row = None, 0, None, None
        self.method = None if method is None else method[0]
        # from q0 nothing is decided, so nothing for gd/cg/qn/mekf to hold
        self.tries = (
            []
            if method is None or q0 is not None
            else [make_filter(method[0], **method[1], checks=False) for _ in BRANCHES]
        )
        for f, b in zip(self.tries, BRANCHES):
            f._decided(b)
            f._gap_check = False  # the file's gaps are cut by the caller
        self.held = HeldBranch(n, refs=2)

    def add(self, gyr, acc, dts, pin, pm=None, mag=None) -> None:
        """A block: gyr, acc (n, 3), dts (n,) s, ``pin`` its polarization's kernel inputs (``pol_inputs``) and ``pm``
        the measurement (for gd/cg/qn/mekf), ``mag`` (n, 3) or None (only where its field starts)."""
        from optinav.attitude import iframe as _if
        from optinav.attitude.branch import BranchResiduals
        from optinav.attitude.measurement import up_vector

        out = [_if._run_pol(st, self.par, gyr, acc, np.zeros((0, 3)), dts, pin) for st in self.states]
        runs = [r.q_b_n for r in out]
        use, sn, cbm, aop, min_d2 = pin[:5]
        if self.res is None:
            self.res = BranchResiduals(cbm, min_d2, up_vector(self.frame))
        self.res.add(runs[0], runs[1], use, sn, aop)
        if self.last is not None and len(dts):
            self.res.add_turn(runs[0], out[0].pol_used, self.last)
            self.last = runs[0][-1]
        if self.tries:
            for j, f in enumerate(self.tries):
                self.held.add(j, f.update_batch(gyr, acc, dts, pol=pm).q_b_n, runs)
        if self.pol_row is None and use.any():
            self.pol_row = self.n + int(np.argmax(use))
        if mag is not None and self.mag_row is None and np.isfinite(mag).all(axis=1).any():
            self.mag_row = self.n + int(np.argmax(np.isfinite(mag).all(axis=1)))
        self.n += len(dts)

    def branch(self, fixed: bool, field: bool):
        """The :class:`~optinav.attitude.branch.Branch` its AoP takes (refused when alike, or when gd/cg/qn/mekf hold
        it from neither start), or None where ``fixed`` (q0: refused where the AoP contradicts it, when the runs
        started from it), where no polarization sample was usable, or where a field (``field``: the magnetometer's,
        not fitted online) came with or before the first."""
        from optinav.attitude.branch import BRANCHES, Branch

        if self.pol_row is None or field and self.mag_row is not None and self.mag_row <= self.pol_row:
            return None
        if fixed:
            if self.last is not None:
                self.res.verdict(fixed=True)
            return None
        k, rms = self.res.verdict()
        if self.tries and rms is not None:
            k = self.held.verdict(self.method, k, prefer=k)
        return Branch(BRANCHES[k], rms)


def _branch_pass(src, checks, frame: str, q0, pol, t_first: float, opts: dict, online_fit: bool, progress, method=None):
    """The heading branch of each segment of an online log with polarization (:mod:`optinav.attitude.branch`), by
    a pass of iframe (options ``opts``) from either branch over the blocks (and of gd/cg/qn/mekf, ``method``: (name,
    filter options), from either start), which is also the second pass of the ``checks`` (collected and finished
    here, so their errors come first as in the in-memory estimate). Returns the segments'
    :class:`~optinav.attitude.branch.Branch` (None where nothing was decided) and the residual RMS (2,) rad the
    summary names (:func:`~optinav.attitude.branch.weakest`)."""
    from optinav.attitude.branch import weakest
    from optinav.attitude.estimators import _as_q0
    from optinav.attitude.measurement import pol_inputs
    from optinav.core.progress import progress_blocks

    segs: list[_BranchSegment] = []
    rows = np.diff(np.r_[0, checks.gaps, checks.n])  # each segment's
    for row0, t, gyr, acc, dts, _, extra in progress_blocks(src, "attitude: heading branch", progress):
        checks.collect(row0, gyr, acc, dts)
        pm, mag = _block_pol(pol, extra, t, t_first, frame), extra.get("mag")
        cuts, dts = _cut(checks, row0, dts)
        for k, (a, b) in enumerate(zip(np.r_[0, cuts], np.r_[cuts, len(t)])):
            if k or not segs:
                start = None if segs or q0 is None else _as_q0(q0)  # the first segment's runs: from q0 when given
                segs.append(_BranchSegment(frame, opts, method, int(rows[len(segs)]), start))
            if b > a:
                p = pm.select(slice(a, b))
                pin = pol_inputs(p, b - a, frame, "the IMU")
                segs[-1].add(gyr[a:b], acc[a:b], dts[a:b], pin, p, None if mag is None else mag[a:b])
    checks.finish_second(frame)
    field = bool(src.mag) and not online_fit  # an offset fitted online leaves the field unused until it passes
    branches = [seg.branch(i == 0 and q0 is not None, field) for i, seg in enumerate(segs)]
    return branches, weakest(b.rms for b in branches if b is not None)


def _stream_offline(
    src, out, o, frame, q0, checks, score, chunk_rows, progress, figure_points=0, truth=None, hard_iron=(None, False),
    pol=None, t_first=0.0, branch_opts=None,
) -> StreamRun:  # fmt: skip
    """``--offline`` of a log read block by block: the second pass over the file keeps the inputs in a scratch
    file beside ``out`` (None: in the temporary folder), the magnetometer less ``hard_iron`` ((offset or None,
    whether it was fitted)) and the polarization's kernel inputs (``pol``, :class:`PolColumns` of a log starting at
    ``t_first`` s); each segment (between time gaps) then runs
    :func:`_offline_segment` over it, and a last forward pass writes the CSV (none when ``out`` is None). The
    output is the in-memory ``estimate(..., offline=True)``'s byte for byte."""
    from optinav.attitude.estimators import _as_q0, summary_line
    from optinav.attitude._iframe import POL_USED
    from optinav.attitude.iframe import pol_skipped
    from optinav.attitude.branch import weakest
    from optinav.attitude.measurement import pol_inputs
    from optinav.attitude.methods import IFRAME_DEFAULTS, _options
    from optinav.core.files import scratch_file
    from optinav.core.progress import progress_blocks

    opts = dict(IFRAME_DEFAULTS)
    opts.update(_options("iframe", dict(o.options)))
    blk = max(int(chunk_rows), 2)
    # bfw: the forward pass's bias (the 6D heading's blended bias; with a magnetometer the offline heading's rate
    # uncertainty)
    fields = {"t": 1, "gyr": 3, "acc": 3, "dts": 1, "q": 4, "bias": 3, "flags": 3, "qg": 4, "v": 3, "bfw": 3}
    if src.mag:
        # hx: the offline heading's Φ = ∫up_b dt and its filtered series (iframe._smoothed_offset)
        fields.update(mag=3, hx=6)
    if score is not None:
        fields.update(q_ref=4, movement=1)
    if pol is not None:
        # the polarization's kernel inputs (usable, sun, AoP), then its outcome (iframe.either_pass)
        fields.update(puse=1, sun=3, aop=1, pol=1)
    # without an output file (a batch unit) the scratch file goes to the temporary folder
    place = Path(out) if out is not None else Path(tempfile.gettempdir()) / src.path.name
    need, free = checks.n * sum(fields.values()) * 8, _free_bytes(place)
    if need > free:
        raise OptinavError(
            f"--offline needs {need / 2**30:.2f} GiB of scratch space in {place.parent} for {checks.n} "
            f"samples; {free / 2**30:.2f} GiB are free there",
            "write --out to a disk with more free space, or drop --offline"
            if out is not None
            else "set TMPDIR to a disk with more free space, or drop --offline",
        )
    pol_const, skipped = None, {}  # (C_b^m, min_d2) of the polarization sensor; its samples left out by the inputs
    with scratch_file(place) as fh:
        store = _Scratch(fh, fields)
        for row0, t, gyr, acc, dts, _, extra in progress_blocks(src, "attitude: iframe offline", progress):
            checks.collect(row0, gyr, acc, dts)
            if not checks.gaps_refused(o.allow_gaps):
                more = {k: extra[k] for k in ("mag", "q_ref", "movement") if k in store.cols}
                if "mag" in more and hard_iron[0] is not None:
                    more["mag"] = more["mag"] - hard_iron[0]
                if pol is not None:
                    pm = _block_pol(pol, extra, t, t_first, frame)
                    use, sn, cbm, a0, min_d2, sk = pol_inputs(pm, len(t), frame, "the IMU")
                    pol_const = cbm, min_d2
                    skipped = {k: skipped.get(k, 0) + v for k, v in sk.items()}
                    more.update(puse=use, sun=np.broadcast_to(sn, (len(t), 3)), aop=a0)
                store.append(t=t, gyr=gyr, acc=acc, dts=dts, **more)
        checks.finish_second(frame)
        gaps = checks.gaps
        if (err := checks.gap_error(o.allow_gaps)) is not None:
            raise err
        if gaps.size:  # each segment starts afresh: its first step is a normal one (as estimate)
            for i in gaps:
                row = store.read(int(i), int(i) + 1).copy()
                row[0, store.cols["dts"]] = checks.median_dt
                store.write(int(i), row)
        bounds = list(zip(np.r_[0, gaps], np.r_[gaps, store.n]))
        lat, rms = 0.0, []
        for k, (a, b) in enumerate(bounds):
            branch = None
            if branch_opts is not None and pol_const is not None:
                # the segment's heading branch, from the inputs kept (from q0: that the AoP does not contradict it)
                start = _as_q0(q0) if k == 0 and q0 is not None else None
                seg = _BranchSegment(frame, branch_opts, q0=start)
                for s in range(int(a), int(b), blk):
                    r = store.read(s, min(s + blk, int(b)))
                    mag = store.col(r, "mag") if src.mag else None
                    seg.add(
                        store.col(r, "gyr"),
                        store.col(r, "acc"),
                        store.col(r, "dts")[:, 0],
                        _store_pin(store, r, pol_const),
                        mag=mag,
                    )
                branch = seg.branch(start is not None, bool(src.mag))
                rms.append(None if branch is None else branch.rms)
            other = branch is not None and branch.other_root
            lat = _offline_segment(store, int(a), int(b), opts, frame, q0 if k == 0 else None, blk, pol_const, other)
        rest = mag_used = acc_hits = mag_rows = pol_used = 0
        left = {}  # the polarization samples neither pass used, by the forward pass's reason (iframe.pol_skipped)
        fig = _Decimated(store.n, figure_points) if figure_points else None
        with _rows_writer(out) as write:
            for a in range(0, store.n, blk):
                r = store.read(a, min(a + blk, store.n))
                q = store.col(r, "q")
                if lat != 0.0:
                    from optinav.core.rotations import quat_from_rotvec, quat_multiply

                    q = quat_multiply(q, quat_from_rotvec((store.col(r, "gyr") - store.col(r, "bias")) * lat))
                rows = attitude_rows(store.col(r, "t")[:, 0], q, frame)
                write(rows)
                errs = None
                if score is not None:
                    errs = score.add(
                        q,
                        store.col(r, "q_ref"),
                        store.col(r, "movement")[:, 0].astype(bool),
                        store.col(r, "gyr"),
                        store.col(r, "dts")[:, 0],
                        store.col(r, "acc"),
                    )
                if fig is not None:
                    fig.add(a, rows, errs)
                flags = store.col(r, "flags")
                rest += int(np.count_nonzero(flags[:, 0]))
                acc_hits += int(np.count_nonzero(flags[:, 1] == 0))
                mag_used += int(np.count_nonzero(flags[:, 2]))
                if src.mag:
                    mag_rows += int(np.count_nonzero(np.isfinite(store.col(r, "mag")).all(axis=1)))
                if pol is not None:
                    code = store.col(r, "pol")[:, 0]
                    for k, v in pol_skipped({}, code).items():
                        left[k] = left.get(k, 0) + v
                    pol_used += int(np.count_nonzero(code == POL_USED))
                if truth is not None:
                    truth.add(a, q)
            result = None if score is None else score.result()
        n = store.n
        bias = store.col(store.read(n - 1, n), "bias")[0].copy() if n else None
    skipped = {**skipped, **left}
    line = summary_line(
        "iframe",
        frame,
        n,
        offline=True,
        segments=len(bounds),
        rest=rest / n,
        mag_used=mag_used / n if src.mag else None,
        mag_rows=mag_rows if src.mag else None,
        mag_hard_iron=hard_iron[0] if src.mag else None,
        mag_hard_iron_fitted=hard_iron[1],
        declination=opts["declination"],
        pol_used=pol_used,
        pol_skipped=skipped,
        pol_branch_rms=weakest(rms),
    )
    est = StreamedEstimate(
        "iframe", frame, line, acc_threshold_hits=acc_hits, gyr_bias=bias, mag_used=mag_used if src.mag else None,
        mag_rows=mag_rows if src.mag else None, offline=True, pol_used=pol_used, pol_skipped=skipped,
        mag_hard_iron=None if hard_iron[0] is None or not src.mag else np.asarray(hard_iron[0], float),
        declination=opts["declination"], pol_branch_rms=weakest(rms),
    )  # fmt: skip
    if truth is not None:
        est.truth_comparison = truth.result(est, n)
    return StreamRun(
        line, n, result, est, None if fig is None else fig.arrays(), notes=src.notes,
        figure_errors=None if fig is None else fig.errors(),
    )  # fmt: skip


def _rows_writer(out):
    """The attitude CSV writer of ``out`` (:func:`optinav.core.files.csv_writer`), or one that keeps nothing when
    ``out`` is None (a batch unit keeps only its table row)."""
    if out is None:
        return contextlib.nullcontext(lambda rows: None)
    return csv_writer(out, CSV_HEADER, CSV_FORMAT)


def _free_bytes(path) -> float:
    """Free bytes on the disk of ``path``'s folder (inf when the OS cannot tell)."""
    import shutil

    try:
        return float(shutil.disk_usage(Path(path).parent or ".").free)
    except OSError:
        return float("inf")


def _store_pin(store: _Scratch, r: np.ndarray, pol) -> tuple:
    """The polarization's kernel inputs (:func:`~optinav.attitude.measurement.pol_inputs`) of the rows ``r`` of
    ``store``, ``pol`` (C_b^m, min_d2) the sensor's."""
    return store.col(r, "puse")[:, 0] != 0.0, store.col(r, "sun"), pol[0], store.col(r, "aop")[:, 0], pol[1], {}


def _offline_segment(
    store: _Scratch, a: int, b: int, opts: dict, frame: str, q0, blk: int, pol=None, other_root: bool = False
) -> float:
    """:func:`optinav.attitude.iframe.run_iframe` with ``offline=True`` on the rows [a, b) of ``store``, in
    blocks of ``blk`` rows with the states carried: the forward pass, the backward pass over the reversed rows
    (fused with the forward one), and the zero-phase tilt refinement (strapdown, then the forward–backward
    Butterworth filter as ``scipy.signal.filtfilt`` computes it, from the padded ends). Leaves the smoothed q,
    the bias and the flags (rest, acc used, mag used; the polarization's outcome in "pol") in ``store``; returns
    the latency still to apply (s). ``pol``: (C_b^m, min_d2) of the polarization sensor whose inputs ``store``
    holds, or None; ``other_root``: without ``q0``, start on the AoP's other heading branch (the one decided)."""
    from scipy.signal import lfilter, lfilter_zi

    from optinav.attitude import _iframe as _k
    from optinav.attitude import iframe as _if
    from optinav.attitude.estimators import _as_q0
    from optinav.core.rotations import quat_conjugate, quat_rotate

    c, col = store.cols, store.col
    par = _if._params(frame, opts)
    lat = float(par[_k.P_LATENCY])
    par[_k.P_LATENCY] = 0.0  # applied once, to the smoothed result
    no_mag = np.zeros((0, 3))
    mag = (lambda r: col(r, "mag")) if "mag" in c else (lambda r: no_mag)

    def pin(r, reverse=False):
        """The rows' polarization inputs (iframe.run_iframe's), reversed for the backward pass; None without."""
        if pol is None:
            return None
        p = _store_pin(store, r, pol)
        return _if.reversed_pol(p) if reverse else p

    st = _if._new_state(opts, None if q0 is None else _as_q0(q0), other_root=other_root)
    finite = True
    t_run, h_last = 0.0, 0.0  # the elapsed time at the last row and the last step (s): the fusion weights
    t_pol = None  # the elapsed time of the forward pass's first polarization sample used
    for s in range(a, b, blk):
        r = store.read(s, min(s + blk, b)).copy()
        h = col(r, "dts")[:, 0]
        # the elapsed time per row, summed in order as the in-memory cumsum does, kept in "v" (free until the
        # zero-phase pass) for the backward pass's fusion weights
        t = np.cumsum(np.r_[t_run, h])[1:]
        r[:, c["v"].start] = t
        t_run, h_last = float(t[-1]), float(h[-1])
        acc = col(r, "acc")
        finite &= bool(np.isfinite(acc).all())
        code = np.empty(r.shape[0], np.int8)
        f = _if._pass(st, par, col(r, "gyr"), acc, mag(r), col(r, "dts")[:, 0], pin(r), code)
        if pol is not None:
            r[:, c["pol"].start] = code
            if t_pol is None and f.pol_used.any():
                t_pol = _if.first_pol_time(t, f.pol_used)
        r[:, c["q"]] = f.q_b_n
        r[:, c["flags"]] = np.column_stack([f.rest, f.acc_used, _if.measured_used(f)])
        r[:, c["bfw"]] = f.gyr_bias
        store.write(s, r)
    # backward: reversed step j runs from sample i + 1 to i with −ω_{i+1} over dt_{i+1} (the last: 0 over dt_{b−1})
    st = _if.reversed_state(st)
    held = t_pol is not None  # polarization holds the heading (iframe.run_iframe): no gyro or field heading after
    for e in range(b, a, -blk):
        s = max(e - blk, a)
        r = store.read(s, min(e + 1, b)).copy()
        k = e - s
        g, d = np.zeros((k, 3)), np.empty(k)
        g[: r.shape[0] - 1] = -col(r, "gyr")[1:]
        d[: r.shape[0] - 1] = col(r, "dts")[1:, 0]
        if r.shape[0] == k:
            d[k - 1] = r[k - 1, c["dts"]][0]
        r = r[:k]
        rev = (g[::-1].copy(), col(r, "acc")[::-1].copy(), mag(r)[::-1].copy(), d[::-1].copy())
        w = _if._pass(st, par, *rev, pin(r, reverse=True))
        if pol is not None:
            held |= bool(w.pol_used.any())
            r[:, c["pol"].start] = _if.either_pass(col(r, "pol")[:, 0], w.pol_used[::-1])
        flags = col(r, "flags").astype(bool)
        share = _if.backward_share(col(r, "v")[:, 0], t_run, h_last, opts["tau_acc"], t_pol or 0.0)
        r[:, c["q"]] = _if._fuse(col(r, "q"), w.q_b_n[::-1], share)
        r[:, c["bias"]] = -w.gyr_bias[::-1]
        r[:, c["flags"]] = np.column_stack(
            [flags[:, 0] | w.rest[::-1], flags[:, 1], flags[:, 2] & _if.measured_used(w)[::-1]]
        )
        store.write(s, r)
    n = b - a
    p_bias = st[_k.S_P : _k.S_P + 9].copy()  # the smoothed bias's covariance (the offline heading's prior)
    if n < _if.MIN_REFINE_ROWS or not finite:  # iframe.refinable, the rows' finiteness gathered block by block
        if not held:
            _offline_heading(store, a, b, opts, frame, blk, False, p_bias)
        return lat
    # zero-phase refinement: strapdown with the smoothed bias, the specific force in its frame ("v")
    dts = np.concatenate([col(store.read(s, min(s + blk, b)), "dts")[:, 0] for s in range(a, b, blk)])
    bf, af, pad = _if.zero_phase_filter(dts, opts["tau_acc"], n)
    q = col(store.read(a, a + 1), "q")[0].copy()  # iframe.run_iframe: q_g starts at the first attitude
    for s in range(a, b, blk):
        r = store.read(s, min(s + blk, b)).copy()
        qg = np.empty((r.shape[0], 4))
        _k.strapdown(col(r, "gyr"), col(r, "bias"), col(r, "dts")[:, 0], qg, q)
        r[:, c["qg"]] = qg
        r[:, c["v"]] = quat_rotate(qg, col(r, "acc"))
        store.write(s, r)
    # iframe._zero_phase_tilt: filtfilt(bf, af, [left, v, right], axis=0, padtype=None) with constant extensions at
    # the mean of each end's first tau_acc s (edge_rows), forward then backward with the steady-state initial
    # conditions, in blocks with the filter state carried (the same arithmetic)
    k0 = _if.edge_rows(dts, opts["tau_acc"], pad)
    del dts
    head = col(store.read(a, a + k0), "v")
    tail = col(store.read(b - k0, b), "v")
    left = np.repeat(head.mean(axis=0)[None], pad, 0)
    right = np.repeat(tail.mean(axis=0)[None], pad, 0)
    zi = lfilter_zi(bf, af).reshape(-1, 1)
    _, z = lfilter(bf, af, left, axis=0, zi=zi * left[0:1])
    for s in range(a, b, blk):
        r = store.read(s, min(s + blk, b)).copy()
        r[:, c["v"]], z = lfilter(bf, af, col(r, "v"), axis=0, zi=z)
        store.write(s, r)
    yr, z = lfilter(bf, af, right, axis=0, zi=z)
    _, z = lfilter(bf, af, yr[::-1], axis=0, zi=zi * yr[-1:])
    ok = True
    for e in range(b, a, -blk):
        s = max(e - blk, a)
        r = store.read(s, e).copy()
        lp, z = lfilter(bf, af, col(r, "v")[::-1], axis=0, zi=z)
        r[:, c["v"]] = up = quat_rotate(quat_conjugate(col(r, "qg")), lp[::-1])
        ok &= bool(np.all(np.linalg.norm(up, axis=1) > 0.0))
        store.write(s, r)
    if ok:
        for s in range(a, b, blk):
            r = store.read(s, min(s + blk, b)).copy()
            r[:, c["q"]] = _if.tilt_halfway(col(r, "q"), col(r, "v"), frame)
            store.write(s, r)
    # 6D: iframe.blended_bias's heading, the elapsed times summed again as in the forward pass
    if "mag" not in c and not held:
        q, t0, psi0 = col(store.read(a, a + 1), "q")[0].copy(), 0.0, None
        for s in range(a, b, blk):
            r = store.read(s, min(s + blk, b)).copy()
            h = col(r, "dts")[:, 0]
            t = np.cumsum(np.r_[t0, h])[1:]
            t0 = float(t[-1])
            share = _if.backward_share(t, t_run, h_last, opts["tau_acc"])
            qg = np.empty((r.shape[0], 4))
            _k.strapdown(col(r, "gyr"), _if.blended_bias(col(r, "bfw"), col(r, "bias"), share), h, qg, q)
            psi = _if.gyro_heading(col(r, "q"), qg, frame)
            psi0 = psi[0] if psi0 is None else psi0
            r[:, c["q"]] = _if.heading_turned(col(r, "q"), psi - psi0, frame)
            store.write(s, r)
    if not held:
        _offline_heading(store, a, b, opts, frame, blk, True, p_bias)
    return lat


def _offline_heading(
    store: _Scratch, a: int, b: int, opts: dict, frame: str, blk: int, have_qg: bool, p_bias: np.ndarray
) -> None:
    """The offline heading of :func:`optinav.attitude.iframe.run_iframe` on the rows [a, b) of ``store`` (with a
    magnetometer), in blocks with the states carried, the same arithmetic: the attitude with the heading the gyro
    carries (its strapdown in "qg", made here unless ``have_qg``), the field's azimuth in it ("v": offset, its
    variance, azimuth) filtered forward and smoothed backward, the azimuth's scatter around that, and the two
    passes again with it and the gyro-bias error's regressors ("hx"; ``p_bias`` (9,) the backward pass's bias
    covariance at row a)."""
    from optinav.attitude import _iframe as _k
    from optinav.attitude import iframe as _if

    c, col = store.cols, store.col
    tau = opts["tau_mag_smooth"]
    if "mag" not in c or not tau > 0.0:
        return
    v, hx = c["v"].start, c["hx"].start
    seen, qg0, mom, none = False, col(store.read(a, a + 1), "q")[0].copy(), np.zeros(10), np.zeros((0, 3))

    def read(s, e):
        r = store.read(s, e).copy()
        return r, col(r, "flags")[:, 2].astype(bool), _if.norm_dip(col(r, "q"), col(r, "mag"), frame)

    # the Earth's field: the medians of the norm and dip over the rows both passes used (iframe.earth_like)
    norms, dips = [], []
    for s in range(a, b, blk):
        _, u, (n, d) = read(s, min(s + blk, b))
        norms.append(n[u])
        dips.append(d[u])
    norms, dips = np.concatenate(norms), np.concatenate(dips)
    ref = (np.median(norms), np.median(dips)) if norms.size else (np.nan, np.nan)

    def rows(s, e):
        r, used, (norm, dip) = read(s, e)
        db = np.ascontiguousarray(col(r, "bfw") - col(r, "bias"))
        used &= _if.earth_like(norm, dip, ref, opts)
        return r, db, _if.bias_gap(col(r, "q"), db, frame), used, col(r, "dts")[:, 0]

    def forward(sa2, first):
        nonlocal seen
        st, normal = np.zeros(9), np.zeros(12)
        for s in range(a, b, blk):
            r, db, sb, used, h = rows(s, min(s + blk, b))
            if first:
                if not have_qg:
                    qg = np.empty((r.shape[0], 4))
                    _k.strapdown(col(r, "gyr"), col(r, "bias"), h, qg, qg0)
                    r[:, c["qg"]] = qg
                seen |= bool(used.any())
                _k.outer_sum(db, mom)
                psi = _if.gyro_heading(col(r, "q"), col(r, "qg"), frame)
                r[:, v + 2] = _if.field_azimuth(col(r, "q"), col(r, "mag"), frame, opts["declination"]) - psi
            n = r.shape[0] * (not first)
            x, p, xr, phi = np.empty(r.shape[0]), np.empty(r.shape[0]), np.empty((n, 3)), np.empty((n, 3))
            u = none if first else np.ascontiguousarray(_if.body_up(col(r, "q"), frame))
            _k.heading_forward(r[:, v + 2].copy(), u, used, sb, h, tau, sa2, st, x, p, xr, phi, normal)
            r[:, v], r[:, v + 1] = x, p
            if not first:
                r[:, hx : hx + 3], r[:, hx + 3 : hx + 6] = xr, phi
            store.write(s, r)
        return normal

    def backward(sa2, db_err):
        st = np.zeros(6)
        for e in range(b, a, -blk):
            s = max(e - blk, a)
            r, _, sb, _, h = rows(s, e)
            n = r.shape[0] * (db_err is not None)
            out, outr = np.empty(r.shape[0]), np.empty((n, 3))
            xr = r[:, hx : hx + 3].copy() if n else none
            _k.heading_backward(r[:, v].copy(), r[:, v + 1].copy(), xr, sb, h, tau, sa2, st, out, outr)
            if db_err is not None:
                out += _if.bias_turn(r[:, hx + 3 : hx + 6] - outr, db_err)
                out += _if.gyro_heading(col(r, "q"), col(r, "qg"), frame)
                r[:, c["q"]] = _if.heading_turned(col(r, "q"), out, frame)
            else:
                r[:, v] = out
            store.write(s, r)

    forward(0.0, True)
    if not seen:  # no sample used: the attitude as the passes left it, as in memory
        return
    backward(0.0, None)
    acc = np.zeros(2)
    for s in range(a, b, blk):
        r, _, _, used, _ = rows(s, min(s + blk, b))
        _k.azimuth_scatter(r[:, v + 2].copy(), r[:, v].copy(), used, acc)
    sa2 = acc[0] / acc[1]
    normal = forward(sa2, False)
    backward(sa2, _if.bias_error(normal, _if.bias_prior(p_bias, mom), sa2, tau))


def _short(names: list) -> list:
    """Column names with a unit in brackets as their alias keys (``mag_x [uT]`` → ``mag_x``, which finds the column
    again, without the shell's quotes), where those are distinct; the others as they are."""
    from optinav.io.readers import normalize_name

    keys = [normalize_name(c)[0] if normalize_name(c)[1] else c for c in names]
    return keys if len(set(keys)) == len(keys) and all(keys) else list(names)


def _by_alias_key(names: dict, found: list) -> dict | None:
    """``names`` (key → column name) found again among the file's columns ``found`` by their alias key
    (:func:`optinav.io.readers.normalize_name`: a unit in brackets, case, spaces), one distinct column each;
    None when one is missing or ambiguous."""
    from optinav.io.readers import normalize_name

    by_key: dict = {}
    for c in found:
        by_key.setdefault(normalize_name(c)[0], []).append(c)
    hits = {k: by_key.get(normalize_name(v)[0], []) for k, v in names.items()}
    if not all(len(h) == 1 for h in hits.values()) or len({h[0] for h in hits.values()}) != len(names):
        return None
    return {k: h[0] for k, h in hits.items()}


def _column(key: str, values) -> np.ndarray:
    """A column of the extra columns as floats: the magnetometer's (N×3) array ``mag`` as (N, 3), checked, the
    others 1-D."""
    v = np.asarray(values, float)
    if key != "mag":
        return v.reshape(-1)
    if v.ndim != 2 or v.shape[1] != 3:
        raise OptinavError(
            f"the magnetometer array has shape {v.shape}, not (N, 3)", "name its three columns with --mag-columns"
        )
    return v


def stream_attitude(
    path,
    out,
    options: AttitudeOptions,
    *,
    q0=None,
    pol: PolColumns | None = None,
    reference: bool = False,
    chunk_rows: int = CHUNK_ROWS,
    announce: Callable[[int, str], None] | None = None,
    progress: bool | None = None,
    figure_points: int = 0,
    truth_csv=None,
    truth=None,
) -> StreamRun:
    """Estimate the attitude of the log ``path`` block by block (at most ``chunk_rows`` samples held) and write
    the attitude CSV (:data:`optinav.attitude.recording.CSV_HEADER`) to ``out`` atomically. ``options`` as :func:`optinav.attitude.unit.
    read_log` / :func:`~optinav.attitude.estimate` (``offline``: the inputs go to a scratch file beside ``out``,
    removed at the end, for the backward and zero-phase passes; about 200 B per sample on disk);
    ``pol`` the polarization columns; ``reference`` scores against a BROAD trial's optical reference (frame ENU).
    ``announce(n, method)`` is called between the two passes; ``figure_points`` > 0 keeps every k-th row's Euler
    angles, at most that many (:attr:`StreamRun.figure`, for ``--report``). ``out`` None writes no CSV (a batch
    unit: only the run's numbers are kept). ``truth_csv``: a simulator's ``STEM.truth.csv`` (t, qw, qx, qy, qz per
    sample, read block by block) scored as the reference of a log that is not a BROAD trial; ``truth``: a
    :class:`~optinav.core.results.Truth` compared with the estimate (:attr:`StreamedEstimate.truth_comparison`).
    Bad input raises :class:`OptinavError` before anything is written under ``out``."""
    from optinav.attitude.checks import aop_range
    from optinav.attitude.methods import _method, _options, bias_clip, declination_without_mag
    from optinav.core.progress import progress_blocks, step
    from optinav.core.rotations import frame_name

    o = options
    frame = frame_name(o.frame)
    method = _method(o.method, True if pol is not None else None, o.uses_mag, o.offline)
    if o.offline and method != "iframe":
        raise OptinavError(f"method {method} has no offline mode", "use --method iframe with --offline")
    want_mag = o.uses_mag
    if want_mag and method != "iframe":
        raise OptinavError(f"method {method} takes no magnetometer", "use --method iframe with --mag-columns")
    StreamEstimator.check(method, o.options)
    # iframe's options for the runs from either heading branch (the estimate's own where it is iframe)
    branch_opts = _options("iframe", dict(o.options) if method == "iframe" else {})
    # a simulator's truth CSV holds q_b_n of the frame its STEM.truth.json names (the CSV does not say it)
    tf = None if truth is None else truth_frame(getattr(truth, "truth", truth), frame)
    src = _Blocks(
        path, o, mag=want_mag, pol=pol, reference=reference, chunk_rows=chunk_rows, truth_csv=truth_csv, truth_frame=tf
    )
    if pol is not None:
        pol.sun(np.zeros(1), 0.0)  # a bad sun specification fails before the log is read
    if o.mag_hard_iron is not None and not src.mag:
        raise OptinavError(
            "--mag-hard-iron was given without a magnetometer", "add --mag (or --mag-columns, --mag-file)"
        )
    if not src.mag and StreamEstimator.check(method, o.options).get("declination"):
        raise declination_without_mag()

    step("checks")
    checks, bad, aop_lo, aop_hi, aop_n, t_first, t_last = StreamChecks(), 0, np.inf, -np.inf, 0, None, None
    pol_usable, pol_skipped = False, {}  # a polarization sample the estimate can use seen; the others by reason
    first = {}  # the first row with an AoP ("aop") and with a field ("mag"): whether the field sets the branch
    checks.bias_clip, checks.method = bias_clip(method, _options(method, dict(o.options)), o.input_stage), method
    for _, t, gyr, acc, dts, finite, extra in progress_blocks(src, "attitude: checks", progress):
        if t_first is None:
            t_first = float(t[0])
        t_last = float(t[-1])
        bad += int(np.count_nonzero(~finite))
        if not bad:
            checks.add(gyr, acc, dts)
            if "mag" in extra:
                checks.add_mag(extra["mag"], acc, gyr)
            elif "witness" in extra:
                checks.add_witness(extra["witness"], gyr)
        if pol is not None:
            a = extra["aop"][np.isfinite(extra["aop"])]
            if a.size:
                aop_lo, aop_hi, aop_n = min(aop_lo, float(a.min())), max(aop_hi, float(a.max())), aop_n + a.size
                aop_range(aop_lo, aop_hi, 0, pol.aop_unit)  # a value no angle has, before the block is taken as one
        if pol is not None and not pol_usable:
            # the sun along the log costs ~3.6 µs a sample and the estimate's pass computes it again: once a sample
            # is usable nothing more is needed, and every 64th row finds one in a block that has some
            sub = {k: extra[k][::64] for k in ("aop", "dop") if k in extra}
            if _block_pol(pol, sub, t[::64], t_first, frame).usable()[0].any():
                pol_usable = True
            else:
                use, skipped = _block_pol(pol, extra, t, t_first, frame).usable()
                pol_usable = bool(use.any())
                pol_skipped = {k: pol_skipped.get(k, 0) + v for k, v in skipped.items()}
        if pol is not None:
            for key, rows in (("aop", np.isfinite(extra["aop"])), ("mag", np.isfinite(extra.get("mag", [])))):
                if key not in first and rows.size and rows.reshape(len(t), -1).all(axis=1).any():
                    first[key] = checks.n - len(t) + int(np.argmax(rows.reshape(len(t), -1).all(axis=1)))
    if bad:
        raise OptinavError(*nan_rows_error(path, bad))
    if pol is not None and aop_n:
        aop_range(aop_lo, aop_hi, aop_n, pol.aop_unit)
    if pol is not None and checks.n and not pol_usable:
        from optinav.attitude.measurement import unusable_pol_error

        raise unusable_pol_error(pol_skipped, checks.n)
    checks.gyro_unit = src.gyro_unit
    src.witness = None  # the checks have its sums: the second pass reads no magnetometer the estimate does not take
    checks.finish_first()
    hard_iron, fitted, online_fit = o.mag_hard_iron, False, False
    if src.mag and hard_iron is None and (o.offline or method == "iframe"):
        hard_iron = checks.hard_iron(online=not o.offline)
        fitted = hard_iron is not None
        # online the offset the whole log shows is fitted from past samples instead, or, turning the heading
        # little, the field used as measured (as estimate() does)
        online_fit, hard_iron = (
            (fitted and not checks.hard_iron_tolerated, None) if not o.offline else (False, hard_iron)
        )
    checks.offline = o.offline
    checks.hard_iron_judged = bool(src.mag) and o.mag_hard_iron is None and not o.offline and method == "iframe"
    checks.given_hard_iron = None if o.mag_hard_iron is None else np.asarray(o.mag_hard_iron, float)
    gaps = checks.gaps
    if announce is not None:
        announce(checks.n, method)
    score = _Score(frame) if reference or truth_csv is not None else None
    tcmp = None if truth is None else _TruthSeries(truth, frame)
    duration = 0.0 if t_first is None else t_last - t_first
    # polarization without q0 (or after a time gap) and without a field that starts with it: runs of iframe from
    # either heading branch decide each segment's (optinav.attitude.branch); online a pass of its own, which is
    # the checks' second too, offline over the inputs kept
    late_field = "mag" in first and first["mag"] > first.get("aop", np.inf)
    fixed = q0 is not None and not gaps.size or src.mag and not (online_fit or gaps.size or late_field)
    decide = pol is not None and "aop" in first and not fixed
    # from q0 without a field its branch is taken: the same runs, from it, refuse an AoP that contradicts it
    decide = decide or pol is not None and "aop" in first and q0 is not None and not src.mag
    # the estimators (numba kernels) load only from here, so that a bad file is reported within a second of start
    if o.offline:
        step("estimate (iframe offline), write")
        run = _stream_offline(
            src, out, o, frame, q0, checks, score, chunk_rows, progress, figure_points, tcmp, (hard_iron, fitted),
            pol, t_first, branch_opts if decide else None,
        )  # fmt: skip
        return dataclasses.replace(run, duration_s=duration)
    branches, branch_rms, collected = [], None, False
    if decide and not checks.gaps_refused(o.allow_gaps):
        step("heading branch")
        # gd/cg/qn/mekf from either start: the one that holds the branch (their filters as the estimate's)
        tries = None if method == "iframe" else (method, dict(o.options, frame=frame, input_stage=o.input_stage))
        branches, branch_rms = _branch_pass(
            src, checks, frame, q0, pol, t_first, branch_opts, online_fit, progress, tries
        )
        collected = True
    estimator = StreamEstimator(
        method,
        frame=frame,
        q0=q0,
        input_stage=o.input_stage,
        mag_hard_iron=hard_iron,
        mag_hard_iron_online=online_fit,
        mag_measured_before_fit=online_fit and checks.hard_iron_measured,
        branches=branches,
        branch_rms=branch_rms,
        **dict(o.options),
    )
    step(f"estimate ({method}), write")  # one pass does both
    fig = _Decimated(checks.n, figure_points) if figure_points else None
    with _rows_writer(out) as write:
        for row0, t, gyr, acc, dts, _, extra in progress_blocks(src, f"attitude: {method}", progress):
            if not collected:
                checks.collect(row0, gyr, acc, dts)
            if checks.gaps_refused(o.allow_gaps):
                continue  # refused below, after the checks that come first
            pm = _block_pol(pol, extra, t, t_first, frame)
            mag = extra.get("mag")
            cuts, dts = _cut(checks, row0, dts)
            qs = []
            for k, (a, b) in enumerate(zip(np.r_[0, cuts], np.r_[cuts, len(t)])):
                if k:
                    estimator.restart()
                if b > a:
                    qs.append(
                        estimator.run(
                            gyr[a:b],
                            acc[a:b],
                            dts[a:b],
                            mag=None if mag is None else mag[a:b],
                            pol=None if pm is None else pm.select(slice(a, b)),
                        )
                    )
            q = np.concatenate(qs)
            rows = attitude_rows(t, q, frame)
            write(rows)
            errs = None if score is None else score.add(q, extra["q_ref"], extra["movement"], gyr, dts, acc)
            if fig is not None:
                fig.add(row0, rows, errs)
            if tcmp is not None:
                tcmp.add(row0, q)
        if not collected:
            checks.finish_second(frame)
        if online_fit and estimator.mag_hard_iron_from is None and not checks.gaps_refused(o.allow_gaps):
            raise checks.online_fit_failed()
        held = estimator.mag_hard_iron_held
        if online_fit and held is not None and held[1] >= estimator.opts["mag_new_time"]:
            raise online_offset_changed(*held)
        if (err := checks.gap_error(o.allow_gaps)) is not None:
            raise err
        result = None if score is None else score.result()
    est = _estimate(estimator)
    if tcmp is not None:
        est.truth_comparison = tcmp.result(est, checks.n)
    return StreamRun(
        estimator.summary(),
        checks.n,
        result,
        est,
        None if fig is None else fig.arrays(),
        duration_s=duration,
        notes=src.notes,
        figure_errors=None if fig is None else fig.errors(),
    )


def _estimate(e: StreamEstimator) -> StreamedEstimate:
    """The report's fields of an online estimate run block by block (as :func:`~optinav.attitude.estimate` sets
    them for the whole log)."""
    from optinav.attitude import _kernels

    skipped = {}
    if e.pol_skipped is not None:
        skipped = {**e.pol_skipped, "sun_near_sensor_zenith": int(e.counts[_kernels.C_POL_NEAR_ZENITH])}
    return StreamedEstimate(
        e.method,
        e.frame,
        e.summary(),
        pol_used=int(e.counts[0]),
        pol_skipped=skipped,
        acc_threshold_hits=e.acc_threshold_hits,
        gyr_bias=None if e.gyr_bias is None else np.array(e.gyr_bias),
        mag_used=e.mag_used,
        mag_rows=None if e.mag_used is None else e.mag_rows,
        input_stage=bool(e.input_stage),
        mag_hard_iron=e.hard_iron_used if e.mag_used is not None else None,
        mag_hard_iron_from=e.mag_hard_iron_from,
        mag_used_before_fit=e.mag_used_before_fit,
        declination=e.declination,
        pol_branch_rms=e.branch_rms,
    )
