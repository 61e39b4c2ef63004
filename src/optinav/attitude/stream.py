"""Attitude of a log read in blocks, with memory that does not grow with the samples kept.

:class:`StreamChecks` gives the verdicts of :func:`~optinav.attitude.checks.check_imu`,
:func:`~optinav.attitude.checks.find_gaps` and :func:`~optinav.attitude.checks.check_frame` from two passes
over the blocks (the first keeps three floats per sample for the exact medians, the second the gyro-unit
window and the samples at the gyro's extremes); :class:`StreamEstimator` runs the online estimators over
consecutive blocks with their state carried, so the concatenated output equals
:func:`~optinav.attitude.estimate` on the whole log (same kernels, same order of operations).
"""

from __future__ import annotations

import numpy as np

from optinav.attitude import checks as _c
from optinav.attitude.methods import _options
from optinav.core.rotations import DEFAULT_FRAME, frame_name
from optinav.errors import OptinavError

__all__ = ["StreamChecks", "StreamEstimator", "STREAM_METHODS"]

#: methods that run online, sample after sample (iframe ``offline`` needs the whole recording)
STREAM_METHODS = ("iframe", "gd", "cg", "qn", "mekf")


class StreamChecks:
    """The physics checks of the attitude inputs over a log seen block by block: :meth:`add` every block
    (pass 1), :meth:`finish_first` (swapped triads, accelerometer unit, gyro peak, time gaps), :meth:`collect`
    every block again (pass 2), :meth:`finish_second` (gyro unit from how gravity turns, clipping, frame)."""

    def __init__(self, gyro_unit: str | None = None):
        #: the unit the gyro was declared in before its conversion to rad/s (the messages name it; None: not known)
        self.gyro_unit = gyro_unit
        self._dts: list[np.ndarray] = []
        self._na: list[np.ndarray] = []
        self._ng: list[np.ndarray] = []
        self._tilt: list[tuple[np.ndarray, np.ndarray]] = []  # specific-force sums per TILT_BIN samples
        # per triad (gyro, accelerometer) and axis, the largest of +x and of −x (clipping, a dead axis)
        self._max = np.full((2, 3, 2), -np.inf)
        self._noisy: tuple[np.ndarray, np.ndarray] | None = None
        self._held = _c.HeldRows()  # a whole sample repeated in a turn (a logger that stalled)
        self._wraps = _c.Wraps()  # gyro readings that wrap around at the range
        self._stuck = _c.StuckAxes()  # one axis holding its value in motion
        self._level = np.zeros(2, dtype=np.int64)  # samples lying level, body z up and down (frame check)
        # per triad, steps between samples spread over the blocks (each axis's quantum) and their count
        self._head: tuple[list[np.ndarray], list[np.ndarray]] = ([], [])
        self._head_n = 0
        self.n = 0
        self._mag: list[np.ndarray] = []  # magnetometer rows 0, s, 2s, … (the hard-iron check)
        self._mag_seen, self._mag_stride, self._mag_kept = 0, 1, 0
        self._mag_any = False  # a magnetometer row with three finite values seen
        self._mag_held = _c.MagHeld()  # the magnetometer (or an axis) holding its reading in a turn
        self._mag_sums: list[tuple] = []  # per TILT_BIN rows: gravity and field sums (the magnetometer-axes check)
        self._gyr_sums: list[tuple] = []  # per TILT_BIN rows: gyro sums (the field turning as the gyro says)
        self._scale_sums: list[tuple] = []  # field and gyro sums per _scale_rows rows (the gyro-scale check)
        self._scale_rows = 0
        self._witness: list[tuple] = []  # the same sums of a magnetometer the estimate does not use (add_witness)
        self._still: list[tuple] = []  # per TILT_BIN rows: gyro, accelerometer and their squares (the rest bias)
        self._lag_sums: list[tuple] = []  # specific force and gyro sums per _scale_rows rows (the gyro's clock)
        self._up: tuple[np.ndarray, np.ndarray] | None = None  # those joined after pass 1 (the field's lag)
        # rows whose turn across their step is uncertain beyond GAP_TURN (a gap where they lost samples), the
        # uncertainty, and the block's last gyro row
        self._turn_rows: list[np.ndarray] = []
        self._turns: list[np.ndarray] = []
        self._last_gyr: np.ndarray | None = None

    def add_mag(self, mag: np.ndarray, acc: np.ndarray | None = None, gyr: np.ndarray | None = None) -> None:
        """Pass 1, after :meth:`add` of the same block: its magnetometer rows (n, 3); evenly spaced rows are kept,
        at most twice :data:`~optinav.attitude.checks.MAG_FIT_ROWS` (the spacing doubles when full); with ``acc``
        the block's gravity and field sums per bin (:func:`~optinav.attitude.checks.mag_sums`)."""
        if gyr is not None:
            self._mag_held.add(gyr, mag, self._dts[-1])
        if acc is not None:
            self._mag_sums.append(_c.mag_sums(acc, mag, self.n - mag.shape[0]))
        if gyr is not None:
            self._gyr_sums.append(_c.gyro_sums(gyr, self.n - mag.shape[0]))
            self._scale_sums.append(_c.field_rate_sums(gyr, mag, self._scale_rows, self.n - mag.shape[0]))
        self._mag_any = self._mag_any or bool(np.isfinite(mag).all(axis=1).any())
        first = (-self._mag_seen) % self._mag_stride
        self._mag.append(mag[first :: self._mag_stride].copy())
        self._mag_kept += self._mag[-1].shape[0]
        self._mag_seen += mag.shape[0]
        if self._mag_kept > 2 * _c.MAG_FIT_ROWS:
            kept = np.concatenate(self._mag)[::2]
            self._mag, self._mag_kept, self._mag_stride = [kept], kept.shape[0], 2 * self._mag_stride

    def add_witness(self, mag: np.ndarray, gyr: np.ndarray) -> None:
        """Pass 1, after :meth:`add` of the same block: the rows (n, 3, any unit) of a magnetometer the file has but
        the estimate does not use, kept as 0.1-s field and gyro sums for the gyro's scale and sense only
        (:func:`~optinav.attitude.checks.witness_error`; nothing else is judged on it)."""
        self._witness.append(_c.field_rate_sums(gyr, mag, self._scale_rows, self.n - mag.shape[0]))

    def add(self, gyr: np.ndarray, acc: np.ndarray, dts: np.ndarray) -> None:
        """Pass 1: one block of gyr (n, 3) rad/s, acc (n, 3) m/s², dts (n,) s."""
        self._dts.append(np.array(dts, dtype=float))
        na = _c._norm(acc)
        self._na.append(na)
        self._level += _c.frame_counts(acc, na)
        self._ng.append(_c._norm(gyr))
        self._tilt.append(_c.tilt_sums(acc, self.n))
        self._still.append(_c.still_sums(gyr, acc, self.n))  # (the rest offset the unit checks take off, too)
        for t, x in enumerate((gyr, acc)):
            np.maximum(self._max[t], _c.axis_extremes(x), out=self._max[t])
        self._held.add(gyr, acc)
        if gyr.shape[0]:
            u = _c.lost_turns(gyr, dts, self._last_gyr)
            k = np.flatnonzero(u > _c.GAP_TURN)
            self._turn_rows.append(self.n + k)
            self._turns.append(u[k])
            self._last_gyr = gyr[-1].copy()
        self._wraps.add(gyr, dts)
        self._stuck.add(gyr, acc)
        if not self._scale_rows:  # the first block's step sets the 0.1-s bins (of this check and the field's)
            self._scale_rows = _c.scale_bin_rows(float(np.median(dts)))
        self._lag_sums.append(_c.field_rate_sums(gyr, acc, self._scale_rows, self.n))
        if self._noisy is None:  # the first block's rows: which axes carry a sensor's noise (a dead axis)
            head = slice(0, _c.DEAD_HEAD_ROWS)
            self._noisy = (_c.noisy_axes(gyr[head]), _c.noisy_axes(acc[head]))
        if self._head_n < _c.QUANTUM_ROWS:  # steps between samples spread over the blocks: each axis's quantum
            for head, x in zip(self._head, (gyr, acc)):
                head.append(_c.axis_steps(x, 256))
            self._head_n += self._head[0][-1].shape[0]
        self.n += gyr.shape[0]

    #: the gyro bias (rad/s) the estimate tracks (:func:`~optinav.attitude.estimators.bias_clip`; None: not judged)
    bias_clip: float | None = None
    #: the estimator (the bias message names iframe's option for another)
    method: str = "iframe"

    #: the hard-iron offset given (its unit; None: none): :meth:`finish_second` judges the field less it, and
    #: refuses one that shows an offset, unless ``offline`` (then :meth:`hard_iron` fitted it after pass 1)
    given_hard_iron: np.ndarray | None = None
    offline = False
    #: iframe online without an offset given: :meth:`hard_iron` judged the field after pass 1 and the estimate fits
    #: an offset found from past samples itself (:meth:`online_fit_failed` when it cannot): not judged again here
    #: (the filestream's local ``online_fit`` says whether the estimate fits one)
    hard_iron_judged = False

    def online_fit_failed(self) -> OptinavError:
        """The refusal of an online estimate whose offset fitted from past samples never passed its gates
        (:func:`checks.online_fit_failed` on the rows of pass 1), or, where the field's parts show that offset
        changes, that change (:func:`checks.one_offset_error`, as estimate())."""
        if self._scale_sums and self.fitted_hard_iron is not None:
            bins, raw, h = self._turn_sums()
            pieces = _c.offset_pieces(bins, raw, h)
            changed = _c.one_offset_error(pieces, bins, raw, h, self._scale_rows, self.fitted_hard_iron, _c.FITTED)
            if changed is not None:
                return changed
        return _c.online_fit_failed(np.concatenate(self._mag))

    def hard_iron(self, online: bool = False) -> np.ndarray | None:
        """The hard-iron offset fitted over the magnetometer rows of pass 1 (:func:`checks.check_mag` offline, else
        :func:`checks.check_turning_offset` from how the field turns), for an offline estimate to subtract in pass 2
        (``online``: for the checks, the estimate fits it from past samples; one only the turning shows is refused);
        None when the field shows none."""
        if not self._mag:
            return None
        mag = np.concatenate(self._mag)
        b = _c.check_mag(mag, offline=True, turned=self._turned())
        if online and b is not None and self._mag_sums:  # as estimate() decides how the field is used online
            tilt = self._tilt_sums()
            turn = _c.offset_heading(b, *tilt[:4])
            if self._scale_sums:
                self.hard_iron_tolerated = _c.offset_tolerated(turn, mag, self._turn_sums(), tilt)
            self.hard_iron_measured = _c.measured_before_fit(turn)
        if b is None and self._scale_sums:  # online refused: the fit from past samples needs every axis turned
            b = _c.check_turning_offset(*self._turn_sums(), offline=not online)
        if b is None and not online and self._scale_sums and self._mag_sums:  # as estimate() offline
            b = _c.small_offset(*self._turn_sums(), self._tilt_sums)
        self.fitted_hard_iron = b
        return b

    #: the offset :meth:`hard_iron` fitted (None: none, or not asked): the later checks judge the field less it
    fitted_hard_iron: np.ndarray | None = None
    #: online, the offset :meth:`hard_iron` fitted turns the heading so little that the estimate uses the field as
    #: measured, fitting none from past samples (:func:`checks.offset_tolerated`); the checks still take it off
    hard_iron_tolerated = False
    #: online, the field is used as measured until the fit from past samples passes (:func:`checks.measured_before_fit`)
    hard_iron_measured = False

    def _tilt_sums(self) -> list[np.ndarray]:
        """The tilt bins' sums (:func:`checks.mag_sums`: bins, specific force, field, counts, …) over the whole log."""
        return [np.concatenate(x) for x in zip(*self._mag_sums)]

    def _turned(self) -> float:
        """The body's turning (rad, :func:`checks.body_turned`); inf when the gyro-scale sums were not kept."""
        return _c.body_turned(*self._turn_sums()) if self._scale_sums else float("inf")

    def _turn_sums(self, offset=None) -> tuple[np.ndarray, np.ndarray, float]:
        """(bins, sums, h) of the gyro-scale bins (:func:`checks.field_rate_sums`), the field less ``offset``."""
        bins, sums = (np.concatenate(x) for x in zip(*self._scale_sums))
        return bins, _c.rate_sums_less_offset(sums, offset), self._scale_rows * self.median_dt

    def gaps_refused(self, allow_gaps: bool) -> bool:
        """Whether the log's gaps, or its steps that lost samples where the turn is uncertain, are refused."""
        return bool(self.gaps.size or self.lost.size) and not allow_gaps

    def gap_error(self, allow_gaps: bool = False) -> OptinavError | None:
        """The refusal of the log's time gaps, or of its steps that lost samples where the turn across them is
        uncertain (:func:`~optinav.attitude.checks.gap_error`, :func:`~optinav.attitude.checks.lost_error`); with
        ``allow_gaps`` None, those steps said bridged (:func:`~optinav.attitude.checks.lost_warning`)."""
        if allow_gaps:
            if self.lost.size:
                _c.lost_warning(self.lost_turns)
            return None
        if self.gaps.size:
            return _c.gap_error(float(self.gap_steps[0]), int(self.gaps[0]), self.gaps.size)
        if self.lost.size:
            return _c.lost_error(float(self.lost_steps[0]), int(self.lost[0]), self.lost_turns)
        return None

    def finish_first(self) -> None:
        """The checks that need only the first pass, in the order of check_imu; sets ``gaps`` (indices),
        ``median_dt`` (s) and the windows the second pass gathers."""
        if self._mag_seen and not self._mag_any:
            from optinav.attitude.estimators import no_mag_error

            raise no_mag_error()
        self._mag_held.check()
        dts = np.concatenate(self._dts)
        self._dts = []
        self.gaps = _c.find_gaps(dts)
        self.gap_steps = dts[self.gaps]
        self.median_dt = float(np.median(dts))
        # the steps that lost samples where the turn across them is uncertain (checks.uncertain_steps)
        rows, turns = np.concatenate(self._turn_rows), np.concatenate(self._turns)
        self._turn_rows, self._turns = [], []
        keep = rows < 0
        if dts.shape[0] >= 3:
            step = float(np.median(dts[1:]))
            keep = (rows > 0) & (dts[rows] > _c.LOST_STEPS * step) & (dts[rows] <= _c.gap_limit(step))
        #: rows, rad and s: the steps that lost samples where the gyro's turn across them is uncertain
        self.lost, self.lost_turns, self.lost_steps = rows[keep], turns[keep], dts[rows[keep]]
        del dts
        _c.check_rate(self.median_dt)
        if self._noisy is not None:
            _c.check_dead_axes(self._max, self.n, self._noisy)
            self._held.check(self.median_dt, self._noisy)
        self._wraps.check()
        if self._noisy is not None:
            self._stuck.check(self.median_dt, self._max, self._noisy)
        ng = np.concatenate(self._ng)
        self._ng = []
        self.peak = float(np.max(ng))
        rms_rate = float(np.sqrt(np.mean(ng * ng)))
        bins, sums = (np.concatenate(x) for x in zip(*self._tilt))
        self._tilt = []
        na = np.concatenate(self._na)
        self._na = []
        low = (float(np.percentile(na, _c.LOW_PERCENTILE)), float(np.percentile(ng, _c.LOW_PERCENTILE)))
        med_a = float(np.median(na, overwrite_input=True))
        del na
        self._acc_sum = sums.sum(axis=0)  # the whole log's mean specific force, for the frame warning
        self.windows = _c.unit_windows(ng, np.array([self.median_dt]), bins, sums)
        self.window_max = [float(np.max(ng[w])) for w in self.windows]
        share = self.gravity_share = _c.gravity_share(bins, sums, self.median_dt, med_a, ng)
        med_g = float(np.median(ng, overwrite_input=True))
        del ng
        _c.check_norms(med_a, med_g, self.peak, self.gyro_unit, share, low)
        lag = [np.concatenate(x) for x in zip(*self._lag_sums)]
        self._lag_sums = []
        self._up = tuple(lag) if lag else None  # kept: the field's lag judges the yaw rate about them (finish_second)
        _c.check_gyro_lag(*lag, self._scale_rows * self.median_dt)
        # pass 2 gathers the unit window and, per axis and sign reaching 1 rad/s, the samples at the extreme
        self._win: list[list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = [[] for _ in self.windows]
        # (and the accelerometer's from ACC_CLIP_MIN)
        self._clip = {
            (t, k, j): ([], [], [], [])
            for t, least in enumerate((1.0, _c.ACC_CLIP_MIN))
            for k in range(3)
            for j in range(2)
            if self._max[t, k, j] >= least
        }
        # and the whole log in bins (its time base judged over minutes), when long enough
        self._long_m = (
            _c.long_bin_rows(self.n, self.median_dt, rms_rate) if self.n * self.median_dt >= _c.LONG_MIN_S else 0
        )
        self._long: list[tuple[np.ndarray, np.ndarray]] = []
        # and in bins of AXES_BIN_S (the order of the gyro's axes judged axis by axis)
        self._axes_m = _c.axes_bin_rows(self.median_dt)
        self._axes: list[tuple[np.ndarray, np.ndarray]] = []
        # a bias beyond what the unit checks allow for, taken off the gyro they judge (as estimate()'s check_imu)
        self._reading = (
            _c.rest_reading(*(np.concatenate(x) for x in zip(*self._still)), self.median_dt) if self._still else None
        )
        self._still = []
        self._rest = _c.rest_offset(self._reading)

    def collect(self, row0: int, gyr: np.ndarray, acc: np.ndarray, dts: np.ndarray) -> None:
        """Pass 2: the block starting at row ``row0`` (the same blocks as pass 1)."""
        n = gyr.shape[0]
        gu = gyr if self._rest is None else gyr - self._rest
        for win, got in zip(self.windows, self._win):
            a, b = max(win.start - row0, 0), min(win.stop - row0, n)
            if a < b:
                got.append((gu[a:b].copy(), acc[a:b].copy(), np.array(dts[a:b], dtype=float)))
        if self._long_m:
            self._long.append(_c.time_bins(gu, acc, dts, self._long_m, row0))
        self._axes.append(_c.time_bins(gu, acc, dts, self._axes_m, row0))
        for (t, k, j), (idx, keys, vals, rows) in self._clip.items():
            x = (gyr, acc)[t][:, k]
            y = x if j == 0 else -x
            m = self._max[t, k, j]
            at = np.flatnonzero(y >= m - 1e-9 * max(m, 1.0))
            # the values at the extreme and beside it; a block's first and last value serve the runs that cross
            # from one block to the next
            near = np.unique(np.concatenate([at - 1, at, at + 1, [0, n - 1]]))
            near = near[(near >= 0) & (near < n)]
            idx.append(at + row0)
            keys.append(near + row0)
            vals.append(y[near])
            rows.append(np.hstack([gyr[at], acc[at]]))  # whole samples at the extreme: a held one repeats them all

    def _long_bins(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pass 2's whole-log bins, their sums and the bins holding a gap (as
        :func:`~optinav.attitude.checks.whole_log_bins`; empty for a log under LONG_MIN_S)."""
        if not self._long:
            return np.zeros(0, dtype=np.int64), np.zeros((0, 8)), np.zeros(0, dtype=np.int64)
        bins, sums = _c.merge_bins(*(np.concatenate(x) for x in zip(*self._long)))
        return bins, sums, np.unique(self.gaps // self._long_m)

    def _long_hint(self) -> _c.UnitHint | None:
        """The whole log's time-base hint (:func:`~optinav.attitude.checks.long_time_hint`) from pass 2's bins."""
        bins, sums, gap_bins = self._long_bins()
        return _c.long_time_hint(bins, sums, gap_bins, self.median_dt) if bins.shape[0] else None

    def _axes_hint(self) -> _c.UnitHint | None:
        """The order of the gyro's axes judged axis by axis (:func:`~optinav.attitude.checks.axes_turn_hint`)."""
        if not self._axes:
            return None
        bins, sums = _c.merge_bins(*(np.concatenate(x) for x in zip(*self._axes)))
        return _c.axes_turn_hint(bins, sums, self._axes_m, self.median_dt)

    def finish_second(self, frame: str) -> None:
        """The checks that need the second pass, in the order of check_imu, then the frame warning."""
        windows = (
            (*(np.concatenate(x) for x in zip(*got)), peak) for got, peak in zip(self._win, self.window_max) if got
        )
        _c.check_time_base(windows, self._long_hint, self.gyro_unit, self.gravity_share, self._axes_hint)
        acc_found = []
        for (t, k, j), (idx, keys, vals, rows) in self._clip.items():
            keys, first = np.unique(np.concatenate(keys), return_index=True)
            vals = np.concatenate(vals)[first]
            idx, rows = np.concatenate(idx), np.concatenate(rows)
            m = self._max[t, k, j]
            q = _c.quantum(np.concatenate(self._head[t])[:, k]) if self._head[t] else 0.0

            def held(s, e, idx=idx, rows=rows):
                r = rows[np.searchsorted(idx, s) : np.searchsorted(idx, e)]
                return bool(np.all(r == r[0]))

            steep = _c.steep_runs(idx, lambda i: vals[np.searchsorted(keys, i)], self.n, m, self.median_dt, q, held)
            if steep and t == 0:
                raise _c.clipped(k, m if j == 0 else -m, steep)
            if steep:
                acc_found.append((k, m if j == 0 else -m, idx.size, steep))
        _c.acc_clipped(acc_found, self.n)
        if self.bias_clip is not None:  # after the units and the clipping, as estimate() judges it after check_imu
            field = self._turn_sums if self._scale_sums else None
            _c.check_bias_range(self._reading, self.bias_clip, self.method, self._long_bins, field)
        else:
            _c.check_untracked_bias(self._reading, self.method)
        _c.check_frame(None, frame, self._acc_sum, self.median_dt, self._level)
        given = self.given_hard_iron
        if self._mag and ((not self.offline and not self.hard_iron_judged) or given is not None):
            _c.check_mag(np.concatenate(self._mag), given=given, turned=self._turned())
            if self._scale_sums:
                _c.check_turning_offset(*self._turn_sums(), given=given)
        # online with an offset fitted from past samples, the checks take off the whole recording's
        offset = (
            given if given is not None else self.fitted_hard_iron if self.offline or self.hard_iron_judged else None
        )
        err = None  # raised after the magnetometer-axes check (a mirrored frame turns the field about other points)
        raw_pieces = None  # the windows of the field as measured (offset_pieces), once if at all
        # the tilt bins' sums (bins, specific force, field, counts, …) over the whole log, joined once
        msums = self._tilt_sums() if self._mag_sums else None
        if self._mag and self._scale_sums:  # one offset for the whole recording, or none, must hold in every part
            bins, raw, h = self._turn_sums()
            sums = _c.rate_sums_less_offset(raw, offset)
            up = None
            if msums is not None:  # the specific force over the last second (as estimate() takes it)
                up = _c.end_up(msums[0], msums[1], msums[3], self.median_dt)
            pieces = _c.offset_pieces(bins, sums, h)
            err = _c.offset_change_error(
                pieces, self._scale_rows, h, offset, self.offline, _c.bin_fields(bins, sums), up,
                msums if self.offline else None,
            )  # fmt: skip
            # subtracted from every row (given, or fitted offline): it must be there at each
            subtracted = given if given is not None else self.fitted_hard_iron if self.offline else None
            raw_pieces = pieces if offset is None else None
            if err is None and subtracted is not None:
                err = _c.offset_held_error(bins, raw, h, self._scale_rows, subtracted, self.offline)
                if err is None:
                    raw_pieces = _c.offset_pieces(bins, raw, h) if raw_pieces is None else raw_pieces
                    how = _c.GIVEN if given is not None else _c.FITTED
                    err = _c.one_offset_error(raw_pieces, bins, raw, h, self._scale_rows, subtracted, how)
            if err is None and offset is None:  # no offset taken out: the field must turn about zero
                err = _c.offset_unseen_error(
                    pieces, bins, sums, h, self._scale_rows, np.concatenate(self._mag), self.offline,
                    (lambda: msums) if msums is not None else None,
                )  # fmt: skip
        if msums is not None:  # in the order of check_mag_axes, on the field less the offset the estimate subtracts
            sums = list(msums)
            sums[2] = _c.field_less_offset(sums[2], sums[3], offset)
            gyro = [np.concatenate(x) for x in zip(*self._gyr_sums)] if self._gyr_sums else None
            turn = self._turn_sums(offset) if self._scale_sums else (None, None, None)
            held = self._mag_held.hold_s(self.median_dt)
            try:
                _c.judge_mag_axes(sums, turn[0], turn[1], turn[2], gyro, self.median_dt, self.gyro_unit, self._up, held)
            except OptinavError as refused:
                if not self._scale_sums:
                    raise
                bins, raw, h = self._turn_sums()
                raw_pieces = _c.offset_pieces(bins, raw, h) if raw_pieces is None else raw_pieces
                raise _c.axes_or_change(refused, err, raw_pieces, self._scale_rows, h, bins, raw, msums, gyro,
                                        self.median_dt, self.gyro_unit, self._up, held) from None  # fmt: skip
        elif self._witness and err is None:
            err = _c.witness_error(*(np.concatenate(x) for x in zip(*self._witness)), self._scale_rows * self.median_dt,
                                   self.gyro_unit)  # fmt: skip
        if err is not None:
            raise err


class StreamEstimator:
    """An online estimator run over consecutive blocks: :meth:`run` (gyr, acc, dts of one block) returns its
    q_b^n (n, 4); :meth:`restart` starts a new segment (after a time gap: levelled from its first sample).
    ``method``/``options``/``frame``/``q0``/``input_stage`` as :func:`~optinav.attitude.estimate`; ``branches``
    per segment the polarization's heading branch the log decided (:class:`~optinav.attitude.branch.Branch`) or
    None, and ``branch_rms`` (2,) rad the residual RMS its summary names."""

    @staticmethod
    def check(method: str, options: dict) -> dict:
        """The options of ``method`` checked (and completed with the defaults) without loading the kernels."""
        if method not in STREAM_METHODS:
            raise OptinavError(f"method {method!r} does not run on a stream", f"use one of {STREAM_METHODS}")
        return _options(method, dict(options))

    def __init__(
        self,
        method: str,
        *,
        frame: str = DEFAULT_FRAME,
        q0=None,
        input_stage: bool = True,
        mag_hard_iron=None,
        mag_hard_iron_fitted: bool = False,
        mag_hard_iron_online: bool = False,
        mag_measured_before_fit: bool = False,
        branches=(),
        branch_rms=None,
        **options,
    ):
        from optinav.attitude.estimators import _as_q0

        self.opts = self.check(method, options)
        #: the hard-iron offset subtracted from every magnetometer row (its unit; fitted from the log or given)
        self.mag_hard_iron = None if mag_hard_iron is None else np.asarray(mag_hard_iron, float)
        self.mag_hard_iron_fitted = mag_hard_iron_fitted
        #: an uncalibrated magnetometer's offset fitted from past samples over every segment (iframe online, as
        #: :func:`~optinav.attitude.estimate` fits it): its state, or None
        self._fit = None
        if mag_hard_iron_online:
            from optinav.attitude.iframe import online_fit_state

            self._fit = online_fit_state(mag_measured_before_fit)
        self.method, self.frame, self.q0 = method, frame_name(frame), None if q0 is None else _as_q0(q0)
        self.input_stage = input_stage or method == "iframe"
        self.counts = np.zeros(3, dtype=np.int64)  # the kernels' counts over every segment
        self.n = self.rest = self.acc_hits = self.segments = 0
        self.mag_used: int | None = None  # samples with the magnetometer used (None: no magnetometer given)
        self.mag_rows = 0  # ... and those holding a magnetometer sample
        self.mag_offset_used = 0  # ... of them less a body-fixed offset fitted while disturbed (iframe)
        self._used_before_fit = 0  # ... of them before the online fit's offset was subtracted
        self.pol_skipped: dict[str, int] | None = None  # None: no polarization given
        self.gyr_bias = None
        self.branches, self.branch_rms = list(branches), branch_rms
        self.restart()

    def restart(self) -> None:
        self._filter = None

    def _new_filter(self):
        """The streaming filter of :func:`~optinav.attitude.make_filter` for a new segment (q0 for the first)."""
        from optinav.attitude.estimators import make_filter

        # the file's checks judged the whole log (StreamChecks): the filter's own, on its first seconds, are off
        kw = dict(self.opts, frame=self.frame, q0=self.q0 if self.segments == 0 else None, checks=False)
        f = make_filter(self.method, input_stage=self.input_stage, **kw)
        b = self.branches[self.segments] if self.segments < len(self.branches) else None
        if b is not None:
            f._decided(b.other_root)
        f._gap_check = False  # the file's gaps, judged on its whole median, are cut here (restart)
        if self._fit is not None:
            f._fit = self._fit  # one fit over every segment, which the filter continues
        return f

    def run(
        self, gyr: np.ndarray, acc: np.ndarray, dts: np.ndarray, *, mag: np.ndarray | None = None, pol=None
    ) -> np.ndarray:
        """q_b^n (n, 4) of the next block: gyr (n, 3) rad/s, acc (n, 3) m/s², dts (n,) s, ``mag`` (n, 3) any unit
        (iframe) and ``pol`` a :class:`~optinav.attitude.PolarizationMeasurement` of the block: the
        segment's filter's :meth:`update_batch`, its per-block outputs summed for :meth:`summary`."""
        if mag is not None and self.method != "iframe":
            raise OptinavError(f"method {self.method} takes no magnetometer", "use --method iframe with --mag-columns")
        if mag is not None and self.mag_hard_iron is not None:
            mag = mag - self.mag_hard_iron
        if self._filter is None:
            self._filter = self._new_filter()
            self.segments += 1
        f, dts = self._filter, np.ascontiguousarray(dts, dtype=float)
        self.n += dts.shape[0]
        if self.method == "iframe":
            before = self.n - dts.shape[0] if self._fit is not None and self.mag_hard_iron_from is None else None
            r = f.update_batch(gyr, acc, mag, dt=dts, pol=pol)
            self.acc_hits += int(np.count_nonzero(~r.acc_used))
            if pol is not None:  # counted as the other methods' kernels count them
                from optinav.attitude import _kernels

                skipped = dict(r.pol_skipped)
                self.counts[_kernels.C_POL_USED] += int(np.count_nonzero(r.pol_used))
                self.counts[_kernels.C_POL_NEAR_ZENITH] += skipped.pop("sun_near_sensor_zenith")
                self.pol_skipped = self.pol_skipped or {}
                for k, v in skipped.items():
                    self.pol_skipped[k] = self.pol_skipped.get(k, 0) + v
            if before is not None and r.mag_used is not None:  # its rows before the fit passed (all while it has not)
                k = self.mag_hard_iron_from
                self._used_before_fit += int(np.count_nonzero(r.mag_used[: None if k is None else k - before]))
            if mag is not None:
                self.mag_used = (self.mag_used or 0) + int(np.count_nonzero(r.mag_used))
                self.mag_rows += int(np.count_nonzero(np.isfinite(mag).all(axis=1)))
                self.mag_offset_used += int(np.count_nonzero(r.offset_used))
        else:
            counts, skipped = f.counts.copy(), dict(f._skipped)
            r = f.update_batch(gyr, acc, dts, pol=pol)
            self.counts += f.counts - counts
            if pol is not None:
                self.pol_skipped = self.pol_skipped or {}
                for k, v in f._skipped.items():
                    self.pol_skipped[k] = self.pol_skipped.get(k, 0) + v - skipped.get(k, 0)
        if r.rest is not None:
            self.rest += int(np.count_nonzero(r.rest))
        self.gyr_bias = f.gyr_bias
        return r.q_b_n

    @property
    def hard_iron_used(self) -> np.ndarray | None:
        """The hard-iron offset subtracted (given, fitted from the log, or fitted online so far), or None."""
        if self._fit is None:
            return self.mag_hard_iron
        from optinav.attitude.iframe import online_fit_result

        return online_fit_result(self._fit)[0]

    @property
    def mag_hard_iron_held(self) -> tuple[int, float] | None:
        """(row, s): the field left unused from that row on, as it no longer fits the offset fitted online
        (:func:`~optinav.attitude.iframe.online_fit_held`); None while it fits, and without an online fit."""
        if self._fit is None:
            return None
        from optinav.attitude.iframe import online_fit_held

        return online_fit_held(self._fit)

    @property
    def mag_hard_iron_from(self) -> int | None:
        """The row from which the field was used less the offset fitted online (None: not, or not yet)."""
        if self._fit is None:
            return None
        from optinav.attitude.iframe import online_fit_result

        return online_fit_result(self._fit)[1]

    @property
    def mag_used_before_fit(self) -> bool:
        """Whether the field was used as measured before :attr:`mag_hard_iron_from` (else unused there), as
        :attr:`AttitudeEstimate.mag_used_before_fit` tells it."""
        return self.mag_hard_iron_from is not None and self._used_before_fit > 0

    @property
    def acc_threshold_hits(self) -> int:
        from optinav.attitude import _kernels

        return self.acc_hits if self.method == "iframe" else int(self.counts[_kernels.C_ACC_SHRUNK])

    def summary(self) -> str:
        """The line :meth:`AttitudeEstimate.summary` prints for the same estimate."""
        from optinav.attitude.estimators import summary_line

        skipped = None
        if self.pol_skipped is not None:
            from optinav.attitude import _kernels

            skipped = {**self.pol_skipped, "sun_near_sensor_zenith": int(self.counts[_kernels.C_POL_NEAR_ZENITH])}
        return summary_line(
            self.method,
            self.frame,
            self.n,
            input_stage=self.input_stage,
            segments=self.segments,
            rest=self.rest / self.n if self.input_stage and self.n else None,
            mag_used=None if self.mag_used is None else self.mag_used / self.n,
            mag_rows=None if self.mag_used is None else self.mag_rows,
            pol_used=int(self.counts[0]) if skipped is not None else 0,
            pol_skipped=skipped,
            mag_offset_used=self.mag_offset_used / self.n if self.n else None,
            mag_hard_iron=self.hard_iron_used if self.mag_used is not None else None,
            mag_hard_iron_fitted=self.mag_hard_iron_fitted or self._fit is not None,
            mag_hard_iron_from=self.mag_hard_iron_from,
            mag_used_before_fit=self.mag_used_before_fit,
            declination=self.declination,
            pol_branch_rms=self.branch_rms,
        )

    @property
    def declination(self) -> float:
        """rad, east positive: the magnetic declination iframe turns the magnetometer's heading by (0 otherwise)."""
        return float(self.opts.get("declination", 0.0))
