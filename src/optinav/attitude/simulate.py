"""UAV flight simulator for polarization-aided attitude: MPU6000-class IMU + zenith-viewing point-source
polarization sensor, at the place and times of Jin et al. (2021).

Truth from :mod:`optinav.core.simulate` (``static_positions`` for the static test, ``trajectory`` for the
dynamic flight), IMU errors from :func:`optinav.core.imu_model.preset`, the sun from the NREL SPA
(:mod:`optinav.sky.sun`) at every sample, the sky from :mod:`optinav.sky.polarization` (Rayleigh by default)
and the sensor from :class:`optinav.sky.polarization.PointSensor`.

Frames: ``frame="NED"`` (the paper's; body forward-right-down) or ``"ENU"`` (body right-forward-up). The sensor
frame m is related to the body by ``C_b_m`` (default: zenith viewing, reference axis forward — the mounting of
:func:`optinav.attitude.measurement.default_c_b_m`). AoP convention: α = atan2(E·Y_m, E·X_m) in [−π/2, π/2),
E ∝ s_m × Z_m for Rayleigh; see docs/methods/sky.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optinav.attitude.measurement import default_c_b_m, up_vector
from optinav.core.imu_model import ImuSpec, preset
from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.rotations import DEFAULT_FRAME, dcm_from_euler, dcm_from_quat, frame_name, ned_to_enu
from optinav.core.units import DEG
from optinav.core.validate import as_float_array, as_rng, check_positive
from optinav.errors import OptinavError

__all__ = ["FlightData", "FlightStream", "simulate", "PAPER_SITE", "PAPER_TIMES"]

#: the paper's site: roof of the mechanical east building, Dalian University of Technology (38.8814192° N,
#: 121.528255° E, 35 m): ``lat``, ``lon`` in rad, ``height_m`` in m
PAPER_SITE = {"lat": float(np.radians(38.8814192)), "lon": float(np.radians(121.528255)), "height_m": 35.0}
#: the paper's experiment times (local China time, UTC+08:00)
PAPER_TIMES = {"static": "2021-01-17T10:34:00+08:00", "dynamic": "2021-01-16T16:33:00+08:00"}


def _f(unit):
    return field(metadata={"unit": unit})


@dataclass
class FlightData(Result):
    """A simulated flight: IMU samples, true attitude, the polarization sensor's output and the sun.

    Samples k = 0..N−1 at ``t`` (s from ``start_time``). ``gyr`` (N, 3) rad/s and ``acc`` (N, 3) m/s² (specific
    force) in the body frame; ``q_b_n`` (N, 4) [w, x, y, z] body → navigation (``frame``); ``aop`` (N,) rad
    measured angle of polarization in frame m (NaN between polarization samples), ``dop`` (N,) measured degree;
    ``aop_true``/``dop_true`` the sky model's values; ``sun_n`` (N, 3) unit sun vector in the navigation frame;
    ``sun_elevation``/``sun_azimuth`` (N,) rad (apparent; azimuth from north towards east); ``C_b_m`` mounting.
    Feed the estimators with ``gyr, acc, dt`` and :meth:`polarization`. Version 2 renamed the version-1 fields
    ``q_true``/``height`` to ``q_b_n``/``height_m`` (version-1 files still load).
    """

    SCHEMA = "optinav.flight_data"
    VERSION = 3

    t: np.ndarray = _f("s")
    dt: float = _f("s")
    gyr: np.ndarray = _f("rad/s")
    acc: np.ndarray = _f("m/s^2")
    q_b_n: np.ndarray = _f("")
    aop: np.ndarray = _f("rad")
    dop: np.ndarray = _f("")
    aop_true: np.ndarray = _f("rad")
    dop_true: np.ndarray = _f("")
    sun_n: np.ndarray = _f("")
    sun_elevation: np.ndarray = _f("rad")
    sun_azimuth: np.ndarray = _f("rad")
    C_b_m: np.ndarray = _f("")
    frame: str = _f("-")
    kind: str = _f("-")
    start_time: str = _f("-")
    lat: float = _f("rad")
    lon: float = _f("rad")
    height_m: float = _f("m")
    gyr_true: np.ndarray = _f("rad/s")
    acc_true: np.ndarray = _f("m/s^2")
    metadata: dict = field(default_factory=dict, metadata={"unit": "-"})

    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def C_b_n(self) -> np.ndarray:
        """True attitude C_b^n (N, 3, 3)."""
        return dcm_from_quat(self.q_b_n)

    @property
    def euler(self) -> np.ndarray:
        """True [roll, pitch, yaw] (N, 3) rad in the convention of ``frame``."""
        from optinav.core.rotations import euler_from_quat

        return euler_from_quat(self.q_b_n, frame_name(self.frame))

    def polarization(self, **options):
        """The polarization samples as :class:`optinav.attitude.measurement.PolarizationMeasurement`
        (``options``: its skip thresholds, e.g. ``min_dop``)."""
        from optinav.attitude.measurement import PolarizationMeasurement

        return PolarizationMeasurement(
            aop=self.aop, sun_n=self.sun_n, dop=self.dop, C_b_m=self.C_b_m, frame=self.frame, **options
        )


register_legacy(
    FlightData, FlightData.SCHEMA, 1, lambda d: nested_kwargs(FlightData, d, {"q_true": "q_b_n", "height": "height_m"})
)


def _smooth_params(rng, f_lo, f_hi, n_terms=3):
    # a sum of sinusoids with random frequencies [Hz], phases and amplitudes
    f = rng.uniform(f_lo, f_hi, n_terms)
    ph = rng.uniform(0, 2 * np.pi, n_terms)
    amp = rng.uniform(0.5, 1.0, n_terms)
    return f, ph, amp


def _smooth_eval(par, t):
    f, ph, amp = par
    return np.sum(amp[:, None] * np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None]), axis=0)


def _envelope(t, duration, rest, ramp):
    # 0 during the initial rest, a smooth (C¹) ramp to 1, 1, a ramp down to 0 over the last ``ramp`` s
    def smooth(x):
        x = np.clip(x, 0.0, 1.0)
        return x * x * (3 - 2 * x)

    return smooth((t - rest) / ramp) * smooth((duration - t) / ramp)


#: the dynamic flight's manoeuvres are integrated on a 0.01 s grid, this many points at a time
FINE_CHUNK = 1 << 17
#: samples per block of a flight generated block by block (:class:`FlightStream`)
BLOCK_ROWS = 1 << 16


def _dynamic_knots(duration, frame, rng, accel_level, tilt, knot_spacing):
    """Knot times, C_b^n and positions (axes of ``frame``) of the dynamic flight and its end velocities: random
    smooth accelerations and attitude integrated on a 0.01 s grid, :data:`FINE_CHUNK` points at a time (with the
    integrals carried), sampled at knots ``knot_spacing`` apart."""
    from scipy.integrate import cumulative_trapezoid

    rest = min(5.0, 0.1 * duration)  # still on the ground first: the estimators initialize from gravity
    ramp = min(3.0, 0.15 * duration)
    # horizontal accelerations up to ~accel_level (m/s²), vertical a fifth of it; 0.05–0.3 Hz manoeuvres;
    # roll/pitch within ±tilt (0.1–0.4 Hz), heading turning at up to 45 °/s
    bands = [(0.05, 0.3)] * 3 + [(0.1, 0.4)] * 2 + [(0.03, 0.15)]
    pars = [_smooth_params(rng, lo, hi) for lo, hi in bands]
    yaw0 = rng.uniform(-np.pi, np.pi)
    nf = int(np.ceil(duration / 0.01)) + 1
    h = duration / (nf - 1)

    def grid(i0, i1):  # points i0 … i1 − 1 of np.linspace(0, duration, nf)
        x = np.arange(i0, i1) * h
        if i1 == nf:
            x[-1] = duration
        return x

    # consecutive chunks share their end point, so the integrals join
    edges = list(range(0, nf - 1, FINE_CHUNK)) + [nf - 1]
    peak = np.zeros(len(pars))
    for i0, i1 in zip(edges[:-1], edges[1:]):
        x = grid(i0, i1 + 1)
        peak = np.maximum(peak, [np.max(np.abs(_smooth_eval(p, x))) for p in pars])
    n_k = max(int(np.ceil(duration / knot_spacing - 1e-9)), 3)
    tk = np.linspace(0.0, duration, n_k + 1)
    eul, pos = np.empty((tk.size, 3)), np.empty((tk.size, 3))
    v0, p0, y0 = np.zeros(3), np.zeros(3), 0.0
    for i0, i1 in zip(edges[:-1], edges[1:]):
        fine = grid(i0, i1 + 1)
        env = _envelope(fine, duration, rest, ramp)
        sig = [_smooth_eval(p, fine) / m for p, m in zip(pars, peak)]
        acc = accel_level * np.stack([sig[0], sig[1], 0.2 * sig[2]], axis=1) * env[:, None]
        vel = cumulative_trapezoid(acc, fine, axis=0, initial=0.0) + v0
        p = cumulative_trapezoid(vel, fine, axis=0, initial=0.0) + p0
        roll, pitch = tilt * sig[3] * env, tilt * sig[4] * env
        yaw = yaw0 + (cumulative_trapezoid(45 * DEG * sig[5] * env, fine, initial=0.0) + y0)
        v0, p0, y0 = vel[-1], p[-1], yaw[-1] - yaw0
        last = i1 == nf - 1
        k = np.flatnonzero((tk >= fine[0]) & ((tk <= fine[-1]) if last else (tk < fine[-1])))
        for j, x in enumerate((roll, pitch, yaw)):
            eul[k, j] = np.interp(tk[k], fine, x)
        for j in range(3):
            pos[k, j] = np.interp(tk[k], fine, p[:, j])
    eul[:, 2] = (eul[:, 2] + np.pi) % (2 * np.pi) - np.pi
    vel_end = v0
    if frame == "enu":
        eul[:, 2] = -eul[:, 2]  # the same heading in the ENU (counter-clockwise yaw) convention
        pos, vel_end = ned_to_enu(pos), ned_to_enu(vel_end)
    return tk, dcm_from_euler(eul, frame), pos, vel_end


class FlightStream:
    """A simulated flight generated block by block, so that memory does not grow with its length (``optinav
    simulate flight``); :func:`simulate` gathers the same blocks.

    From ``rng``, in order: the trajectory (dynamic), the unit's errors, then one key from which the IMU noise and
    the polarization sensor's noise of every sample are drawn by sample index
    (:class:`~optinav.core.imu_model.SampleDraws`, noise states carried by
    :class:`~optinav.core.imu_model.MeasurementStream`): the same seed gives the same flight whatever the block
    length. The dynamic trajectory is splined window by window (:class:`optinav.core.simulate.TrajectorySampler`).

    Parameters
    ----------
    kind : str
        ``"static"`` (``attitude`` held for ``duration_s``) or ``"dynamic"`` (smooth random manoeuvres: still for
        the first min(5 s, 10 %), smooth ramps in and out, heading turning at up to 45 °/s).
    duration_s : float
        Length [s].
    rate_hz : float
        IMU sample rate [Hz].
    time : str or None
        ISO-8601 start with UTC offset; None: the paper's time for ``kind``.
    lat, lon : float
        Site [rad].
    height_m : float
        Height above the ellipsoid [m].
    frame : str
        ``"ned"`` (body FRD) or ``"enu"`` (body RFU).
    imu : str or ImuSpec
        Preset name or :class:`ImuSpec` (default MPU6000: noise, in-run bias instability, range, LSB).
    imu_errors : bool
        Also draw the spec's turn-on errors (±20 °/s gyro bias for an uncalibrated MPU6000).
    gyro_bias : (3,) array or None
        A constant residual gyro bias [rad/s].
    attitude : (3,) array_like
        Static attitude [roll, pitch, yaw] [rad] (Euler convention of ``frame``).
    accel_level : float
        Dynamic: largest horizontal acceleration [m/s^2] (vertical a fifth).
    tilt : float
        Dynamic: roll/pitch within ±tilt [rad], at 0.1–0.4 Hz.
    knot_spacing_s : float
        Dynamic: attitude/position splined through knots this far apart [s].
    sky_model : str
        ``"rayleigh"`` or ``"berry"``.
    d_max : float or None
        Largest degree of polarization of the sky model [-].
    neutral_distance : float or None
        Berry model: separation δ of the neutral points around the sun [rad].
    sensor : PointSensor or None
        The polarization sensor (default 3 channels, extinction ratio 100).
    pol_noise : float or None
        Relative intensity noise of the sensor [-] (default 0.002).
    pol_rate_hz : float or None
        Polarization sample rate [Hz] (default every IMU sample; NaN between).
    C_b_m : (3, 3) array or None
        Sensor mounting C_b^m [-]; None: zenith-viewing :func:`default_c_b_m`.
    pressure_mbar : float or None
        Air pressure for refraction [mbar]; None: geometric sun.
    temperature_c : float
        Air temperature for refraction [°C].
    delta_t : float or None
        TT − UT1 [s]; None: :func:`optinav.sky.sun.delta_t_espenak`.
    rng : int, Generator or None
        Seed or generator (trajectory, IMU and sensor noise).

    Attributes
    ----------
    n : int
        Samples of the flight.
    """

    def __init__(
        self,
        kind: str = "static",
        duration_s: float = 60.0,
        rate_hz: float = 100.0,
        *,
        time=None,
        lat: float = PAPER_SITE["lat"],
        lon: float = PAPER_SITE["lon"],
        height_m: float = PAPER_SITE["height_m"],
        frame: str = DEFAULT_FRAME,
        imu: str | ImuSpec = "mpu6000",
        imu_errors: bool = False,
        gyro_bias=None,
        attitude=tuple(np.radians((1.0, -2.0, 30.0)).tolist()),
        accel_level: float = 4.0,
        tilt: float = float(np.radians(30.0)),
        knot_spacing_s: float = 0.1,
        sky_model: str = "rayleigh",
        d_max: float | None = None,
        neutral_distance: float | None = None,
        sensor=None,
        pol_noise: float | None = None,
        pol_rate_hz: float | None = None,
        C_b_m=None,
        pressure_mbar: float | None = 1013.25,
        temperature_c: float = 5.0,
        delta_t: float | None = None,
        rng=None,
    ):
        from optinav.core.imu_model import MeasurementStream, SampleDraws, draw_key
        from optinav.core.simulate import TrajectorySampler, static_positions_sampler
        from optinav.sky import polarization as P
        from optinav.sky.sun import utc_seconds

        kind = str(kind).lower()
        if kind not in ("static", "dynamic"):
            raise OptinavError(f"unknown flight kind {kind!r}", "use 'static' or 'dynamic'")
        frame = frame_name(frame)
        duration = check_positive(duration_s, "duration_s")
        rate = check_positive(rate_hz, "rate_hz")
        if duration * rate < 2:
            raise OptinavError("the flight has fewer than 2 samples", "increase duration_s or rate_hz")
        lat, lon, height = float(lat), float(lon), float(height_m)
        if not -np.pi / 2 <= lat <= np.pi / 2:
            raise OptinavError(f"lat = {lat:g} rad is outside [-π/2, π/2]", "pass the latitude in rad")
        rng = as_rng(rng)
        self.start_time = PAPER_TIMES[kind] if time is None else time
        self._t0 = float(utc_seconds(self.start_time))  # raises for a time without UTC offset
        spec = preset(imu) if isinstance(imu, str) else imu
        if not isinstance(spec, ImuSpec):
            raise OptinavError("imu must be a preset name or an ImuSpec", "pass e.g. imu='mpu6000'")
        spec = spec.replace(rate_hz=rate)
        c_b_m = default_c_b_m(frame) if C_b_m is None else as_float_array(C_b_m, "C_b_m", last_dims=(3, 3))
        if c_b_m.shape != (3, 3) or not np.allclose(c_b_m @ c_b_m.T, np.eye(3), atol=1e-9) or np.linalg.det(c_b_m) < 0:
            raise OptinavError("C_b_m is not a rotation matrix", "pass the sensor mounting C_b^m (orthonormal, det +1)")
        if sensor is None:
            sensor = P.PointSensor(noise=0.002 if pol_noise is None else float(pol_noise))
        elif pol_noise is not None:
            raise OptinavError("pass either sensor or pol_noise", "set the noise in the PointSensor")
        self._pol_step = None
        if pol_rate_hz is not None:
            self._pol_step = max(int(round(rate / check_positive(pol_rate_hz, "pol_rate_hz"))), 1)

        if kind == "static":
            att = as_float_array(attitude, "attitude", last_dims=(3,))
            c = dcm_from_euler(att, "ned")
            if frame == "enu":
                from optinav.core.rotations import attitude_ned_to_enu

                c = attitude_ned_to_enu(c)
            self._truth = static_positions_sampler(c[None], duration, lat, height_m=height, lon=lon, frame=frame)
        else:
            tk, c, pk, v_end = _dynamic_knots(
                duration, frame, rng, float(accel_level), float(tilt), check_positive(knot_spacing_s, "knot_spacing_s")
            )
            self._truth = TrajectorySampler(
                tk, c, pk, frame, lat0=lat, lon0=lon, height0_m=height, bc_type=((1, np.zeros(3)), (1, v_end))
            )
        self.model = spec.draw(rng, errors=bool(imu_errors))
        self._imu = (spec.name, bool(imu_errors))
        key = draw_key(rng)
        self._measure = MeasurementStream(self.model, key)
        self._pol_draws = SampleDraws(key, 7, sensor.psi.size)
        self._bias = None if gyro_bias is None else as_float_array(gyro_bias, "gyro_bias", last_dims=(3,))
        self.n = int(np.floor(duration * rate + 1e-9)) + 1
        self.rate_hz, self.frame, self.kind, self.C_b_m, self.sensor = rate, frame, kind, c_b_m, sensor
        self.lat, self.lon, self.height_m = lat, lon, height
        self._sun = dict(
            pressure=None if pressure_mbar is None else 100.0 * pressure_mbar,
            temperature=temperature_c + 273.15,
            delta_t=delta_t,
        )
        self._sky = (sky_model, d_max, neutral_distance)
        self._stats = {"rate": 0.0, "force": 0.0, "elevation": 0.0, "azimuth": 0.0, "refraction": False}
        self._done = 0

    def n_blocks(self, block_rows: int = BLOCK_ROWS) -> int:
        """Number of blocks :meth:`blocks` yields for ``block_rows``."""
        return -(-self.n // int(block_rows))

    def blocks(self, block_rows: int = BLOCK_ROWS):
        """Generate the flight's samples in order, ``block_rows`` at a time (once per stream).

        Parameters
        ----------
        block_rows : int
            Samples per block (memory grows with it, not with the flight; the samples do not depend on it).

        Yields
        ------
        dict
            The block's arrays under :class:`FlightData`'s names: ``t``, ``gyr``, ``acc``, ``q_b_n``, ``aop``,
            ``dop``, ``aop_true``, ``dop_true``, ``sun_n``, ``sun_elevation``, ``sun_azimuth``, ``gyr_true``,
            ``acc_true`` (units as there).
        """
        from optinav.sky import polarization as P
        from optinav.sky.sun import solar_position

        if self._done:
            raise OptinavError("this flight was already generated", "make a new FlightStream")
        step = int(check_positive(block_rows, "block_rows"))
        sky_model, d_max, neutral_distance = self._sky
        st = self._stats
        for i0 in range(0, self.n, step):
            i1 = min(i0 + step, self.n)
            t = np.arange(i0, i1) / self.rate_hz
            w_true, f_true, q = self._truth.states(t)
            gyr, acc = self._measure(w_true, f_true, np.full(t.size, 1.0 / self.rate_hz))
            if self._bias is not None:
                gyr = gyr + self._bias
            # the sun at every sample (the vehicle moves < 1 km: the site's position is used)
            times = (np.round((self._t0 + t) * 1e9)).astype("datetime64[ns]")
            sp = solar_position(times, self.lat, self.lon, self.height_m, **self._sun)
            sun_n = sp.sun_vector(self.frame)
            c_n_m = self.C_b_m @ np.swapaxes(dcm_from_quat(q), -1, -2)
            sun_m = np.einsum("nij,nj->ni", c_n_m, sun_n)
            kw = {} if d_max is None else {"d_max": d_max}
            if sky_model.lower() == "berry":
                kw["up"] = np.einsum("nij,j->ni", c_n_m, up_vector(self.frame))
                if neutral_distance is not None:
                    kw["neutral_distance"] = neutral_distance
            sky = P.sky_polarization(sun_m, np.broadcast_to([0.0, 0.0, 1.0], sun_m.shape), model=sky_model, **kw)
            aop_true = P.aop_in_sensor(sky.e)
            reading = self.sensor.measure(aop_true, sky.dop, draws=self._pol_draws.take(i0, i1))
            aop, dop = reading.aop.copy(), reading.dop.copy()
            aop[~np.isfinite(aop_true)] = np.nan  # sun on the viewing axis: no usable angle
            if self._pol_step is not None:
                skip = np.arange(i0, i1) % self._pol_step != 0
                aop[skip], dop[skip] = np.nan, np.nan
            st["rate"] = max(st["rate"], float(np.max(np.linalg.norm(w_true, axis=1))))
            st["force"] = max(st["force"], float(np.max(np.linalg.norm(f_true, axis=1))))
            st["elevation"] += float(np.sum(sp.elevation))
            st["azimuth"] += float(np.sum(sp.azimuth))
            st["refraction"] = sp.refraction
            self._done = i1
            yield {
                "t": t,
                "gyr": gyr,
                "acc": acc,
                "q_b_n": q,
                "aop": aop,
                "dop": dop,
                "aop_true": aop_true,
                "dop_true": sky.dop,
                "sun_n": sun_n,
                "sun_elevation": sp.elevation,
                "sun_azimuth": sp.azimuth,
                "gyr_true": w_true,
                "acc_true": f_true,
            }

    @property
    def metadata(self) -> dict:
        """What the simulation recorded (after :meth:`blocks` ran to the end): the unit, the sensor, saturated
        samples, the largest rate and specific force, the mean sun position."""
        if self._done < self.n:
            raise OptinavError("the flight's blocks were not all generated", "run blocks() to the end first")
        sensor, st = self.sensor, self._stats
        return {
            "imu": self._imu[0],
            "imu_errors": self._imu[1],
            "sky_model": self._sky[0],
            "sensor_channels_deg": [float(x) for x in np.degrees(sensor.psi)],
            "sensor_noise": float(sensor.noise),
            "extinction_ratio": float(sensor.extinction_ratio),
            "gyro_saturated": self._measure.gyro_saturated,
            "acc_saturated": self._measure.acc_saturated,
            "max_rate_deg_s": float(np.degrees(st["rate"])),
            "max_specific_force_m_s2": st["force"],
            "sun_elevation_deg_mean": float(np.degrees(st["elevation"] / self.n)),
            "sun_azimuth_deg_mean": float(np.degrees(st["azimuth"] / self.n)),
            "refraction": st["refraction"],
        }

    def flight(self, **arrays) -> FlightData:
        """The :class:`FlightData` of the gathered blocks (after :meth:`blocks` ran to the end)."""
        meta = self.metadata
        return FlightData(
            dt=1.0 / self.rate_hz,
            C_b_m=self.C_b_m,
            frame=self.frame,
            kind=self.kind,
            start_time=str(self.start_time),
            lat=self.lat,
            lon=self.lon,
            height_m=self.height_m,
            metadata=meta,
            **arrays,
        )


def simulate(kind: str = "static", duration_s: float = 60.0, rate_hz: float = 100.0, **options) -> FlightData:
    """Simulate a static test or a dynamic UAV flight with IMU and skylight-polarization outputs: the blocks of
    :class:`FlightStream` gathered.

    The sun: SPA at every sample with refraction. Defaults reproduce the paper's site and times
    (:data:`PAPER_SITE`).

    Parameters
    ----------
    kind : str
        ``"static"`` or ``"dynamic"`` (as :class:`FlightStream`).
    duration_s : float
        Length [s].
    rate_hz : float
        IMU sample rate [Hz].
    **options
        The other keywords of :class:`FlightStream`: ``time``, ``lat``, ``lon`` [rad], ``height_m`` [m], ``frame``,
        ``imu``, ``imu_errors``, ``gyro_bias`` [rad/s], ``attitude`` [rad], ``accel_level`` [m/s^2], ``tilt``
        [rad], ``knot_spacing_s`` [s], ``sky_model``, ``d_max``, ``neutral_distance`` [rad], ``sensor``,
        ``pol_noise``, ``pol_rate_hz`` [Hz], ``C_b_m``, ``pressure_mbar``, ``temperature_c``, ``delta_t`` [s],
        ``rng``.

    Returns
    -------
    FlightData
        IMU samples ``gyr`` [rad/s], ``acc`` [m/s^2], true ``q_b_n``, AoP [rad], DoP and the sun.
    """
    stream = FlightStream(kind, duration_s, rate_hz, **options)
    parts = list(stream.blocks())
    return stream.flight(**{k: np.concatenate([p[k] for p in parts]) for k in parts[0]})
