"""The public API has one shape across the four systems: ``optinav.<system>.simulate`` and ``calibrate`` (or
``estimate`` for attitude), returning the system's data / result types."""

import importlib
import inspect

import pytest

from optinav.core.results import Result

SYSTEMS = {"multipos": "calibrate", "rins": "calibrate", "gfimu": "calibrate", "attitude": "estimate"}


@pytest.mark.parametrize("system", sorted(SYSTEMS))
def test_each_system_has_simulate_and_its_fit(system):
    mod = importlib.import_module(f"optinav.{system}")
    for name in ("simulate", SYSTEMS[system]):
        assert name in mod.__all__, f"optinav.{system}.{name} not exported"
        assert inspect.isfunction(getattr(mod, name)), f"optinav.{system}.{name} is not a function"
    fit = getattr(mod, SYSTEMS[system])
    ret = inspect.signature(fit).return_annotation
    ret = eval(ret, vars(inspect.getmodule(fit))) if isinstance(ret, str) else ret
    assert isinstance(ret, type) and issubclass(ret, Result), f"optinav.{system}.{fit.__name__} returns {ret}"


def test_module_constants_stay_importable():
    """The package attribute ``simulate`` is the function; the module's names still import by their path."""
    from optinav.attitude.simulate import PAPER_SITE
    from optinav.multipos.simulate import SCHEMES
    from optinav.rins.simulate import PAPER_TABLE3

    assert PAPER_SITE and SCHEMES and len(PAPER_TABLE3) == 6


# --- one vocabulary (docs/conventions.md, "Names") -----------------------------------------------------------

#: parameter name → the name the conventions page uses instead
BANNED = {
    "rate": "rate_hz",
    "sample_rate": "rate_hz",
    "h": "height_m",
    "height": "height_m",
    "gyro": "gyr",
    "omega_ib_b": "gyr",
    "omega_b": "gyr",
    "accel": "acc",
    "f_b": "acc",
    "f": "acc",
    "dcm_b_n": "C_b_n",
    "c_b_n": "C_b_n",
    "q_true": "q_b_n",
    "h0": "height0_m",
}
#: in the systems (not in core.rotations, where a quaternion is any quaternion) an attitude is q_b_n
BANNED_IN_SYSTEMS = {"q": "q_b_n", "dcm": "C_b_n"}
#: library functions that take degrees on purpose, and why
DEGREE_BOUNDARY = {
    "optinav.sky.sun.solar_position_deg": "the NREL SPA report's own units, to check against it (CLI `optinav sun`)",
}
#: parameters named after the motion's acceleration, not the accelerometer (whose compound stem is acc_)
MOTION_ACCELERATION = {"accel_time", "accel_level"}
#: modules that are the I/O boundary (file formats may name degrees)
IO_MODULES = ("optinav.io", "optinav.rins.io", "optinav.cli")


def _public_modules():
    import pkgutil

    import optinav.core

    names = [
        f"optinav.core.{m.name}"
        for m in pkgutil.walk_packages(optinav.core.__path__, "")
        if not m.name.split(".")[-1].startswith("_")
    ]
    for system in ("multipos", "rins", "gfimu", "attitude", "sky"):
        pkg = importlib.import_module(f"optinav.{system}")
        names.append(f"optinav.{system}")
        names += [
            f"optinav.{system}.{m.name}" for m in pkgutil.iter_modules(pkg.__path__) if not m.name.startswith("_")
        ]
    return names


def _public_callables():
    """(qualified name, function) of every public function and public method of every public class, defined in
    optinav; a dataclass's generated ``__init__`` is left out (its fields are the serialized layout)."""
    import dataclasses

    seen, out = set(), []
    for mod_name in _public_modules():
        mod = importlib.import_module(mod_name)
        names = getattr(mod, "__all__", None) or [n for n in vars(mod) if not n.startswith("_")]
        for n in names:
            obj = getattr(mod, n, None)
            if id(obj) in seen or not getattr(obj, "__module__", "").startswith("optinav"):
                continue
            seen.add(id(obj))
            if inspect.isfunction(obj):
                out.append((f"{obj.__module__}.{obj.__qualname__}", obj))
            elif inspect.isclass(obj):
                for k, v in vars(obj).items():
                    if k == "__init__" and dataclasses.is_dataclass(obj):
                        continue
                    if inspect.isfunction(v) and (not k.startswith("_") or k == "__init__"):
                        out.append((f"{obj.__module__}.{obj.__qualname__}.{k}", v))
    return out


def _violations(calls) -> list[str]:
    bad = []
    for name, fn in calls:
        in_system = not name.startswith("optinav.core.")
        boundary = name.startswith(IO_MODULES) or name in DEGREE_BOUNDARY
        for p in inspect.signature(fn).parameters:
            if p in BANNED:
                bad.append(f"{name}({p}) → {BANNED[p]}")
            elif p.startswith("accel_") and p not in MOTION_ACCELERATION:
                bad.append(f"{name}({p}) → acc_{p[len('accel_') :]}")
            elif in_system and p in BANNED_IN_SYSTEMS:
                bad.append(f"{name}({p}) → {BANNED_IN_SYSTEMS[p]}")
            elif p.endswith("_deg") and not boundary:
                bad.append(f"{name}({p}): radians inside the library, degrees only in CLI and file I/O")
    return bad


def test_public_api_uses_one_vocabulary():
    calls = _public_callables()
    assert len(calls) > 300  # the walk found the API, not an empty set
    bad = _violations(calls)
    assert not bad, "banned parameter names:\n" + "\n".join(bad)


def test_the_vocabulary_check_flags_synonyms_and_degrees():
    def f(t, gyro, rate, lat_deg, q, accel_bias, accel_time):  # noqa: ARG001
        pass

    bad = _violations([("optinav.multipos.x.f", f), ("optinav.core.x.f", f), ("optinav.rins.io.f", f)])
    assert len(bad) == 5 + 4 + 4  # q is an attitude only in the systems; degrees are fine in file I/O


#: the data classes whose serialized fields and public properties follow the vocabulary (older field names load
#: through their schema's earlier versions)
DATA_CLASSES = (
    "optinav.core.simulate.ImuTruth",
    "optinav.io.imu.ImuLog",
    "optinav.core.imu_model.ImuModel",
    "optinav.core.imu_model.ImuMeasurement",
    "optinav.core.imu_model.ImuCompensated",
    "optinav.core.imu_model.ImuSpec",
    "optinav.core.alignment.AlignmentResult",
    "optinav.attitude.simulate.FlightData",
    "optinav.rins.simulate.RinsData",
    "optinav.multipos.simulate.SimulatedSession",
    "optinav.multipos.ferraris.FerrarisCalibration",
    "optinav.sky.sun.SolarPosition",
    "optinav.gfimu.turntable.TurntableData",
    "optinav.multipos.calibrate.SessionData",
)
#: fields not yet renamed, and why
FIELD_EXCEPTIONS: dict[str, str] = {}
#: the attitude system's results, runs and filters: an attitude is ``q_b_n`` and the estimated gyro bias ``gyr_bias``
#: (a spec's or an option's ``gyro_bias`` elsewhere is a setting, named like its CLI flag)
ATTITUDE_CLASSES = (
    "optinav.attitude.estimators.AttitudeEstimate",
    "optinav.attitude.iframe.FilterRun",
    "optinav.attitude.iframe.AttitudeFilter",
    "optinav.attitude.estimators.GradientDescent",
    "optinav.attitude.estimators.MEKF",
    "optinav.attitude.stream.StreamEstimator",
)
ATTITUDE_BANNED = {**BANNED_IN_SYSTEMS, "gyro_bias": "gyr_bias", "bias": "gyr_bias"}


def _field_violations(classes, banned=BANNED) -> list[str]:
    import dataclasses

    bad = []
    for cls in classes:
        names = (
            list(cls._fields)
            if hasattr(cls, "_fields")
            else [f.name for f in dataclasses.fields(cls)]
            if dataclasses.is_dataclass(cls)
            else []
        )
        names += [
            k for c in cls.__mro__[:-1] for k, v in vars(c).items() if isinstance(v, property) and not k.startswith("_")
        ]
        for name in names:
            if f"{cls.__name__}.{name}" in FIELD_EXCEPTIONS:
                continue
            if name in banned:
                bad.append(f"{cls.__name__}.{name} → {banned[name]}")
            elif name.startswith("accel_"):  # the accelerometer's stem is acc, in compound names too
                bad.append(f"{cls.__name__}.{name} → acc_{name[len('accel_') :]}")
    return bad


def test_data_class_fields_use_the_vocabulary():
    classes = [getattr(importlib.import_module(p.rsplit(".", 1)[0]), p.rsplit(".", 1)[1]) for p in DATA_CLASSES]
    bad = _field_violations(classes)
    assert not bad, "banned field names:\n" + "\n".join(bad)
    # the check flags a field named by a synonym
    import dataclasses

    old = dataclasses.make_dataclass(
        "Old",
        [
            ("omega_ib_b", float),
            ("f_b", float),
            ("q_true", float),
            ("h", float),
            ("c_b_n", float),
            ("gyro", float),
            ("acc", float),
            ("accel_noise", float),
            ("acc_noise", float),
        ],
        namespace={
            "dcm_b_n": property(lambda self: None),
            "sample_rate": property(lambda self: None),
            "rate_hz": property(lambda self: None),
        },
    )
    assert len(_field_violations([old])) == 9


def _option_classes():
    """The options dataclasses every registered system declares (``options`` and ``apply_options``)."""
    from optinav import registry

    keys = ("options", "apply_options")
    return list({s.load(k) for s in registry.systems() for k in keys if getattr(s, k)})


def test_option_records_use_the_vocabulary():
    """The option records mirror the CLI flags' meaning, not their spelling: ``--rate`` is ``rate_hz``,
    ``--height`` ``height_m``, ``--gyro FILE`` ``gyro_path``, ``--latitude DEG`` ``lat_deg`` (degrees are the
    CLI's, so the unit is in the name); options keep the ``gyro_`` stem of the flags (``gyro_unit``)."""
    import dataclasses

    classes = _option_classes()
    names = {c.__name__ for c in classes}
    assert {"FileOptions", "ApplyOptions", "AttitudeOptions", "RinsOptions", "GfimuOptions"} <= names
    assert not (bad := _field_violations(classes)), "banned option names:\n" + "\n".join(bad)
    for cls in classes:
        fields = {f.name for f in dataclasses.fields(cls)}
        assert not {"latitude", "lat", "lon"} & fields, f"{cls.__name__}: a latitude option is lat_deg (CLI degrees)"
    from optinav.multipos.calibrate import FileOptions

    assert {"rate_hz", "height_m", "gyro_path", "lat_deg", "gyro_unit", "acc_unit"} <= {
        f.name for f in dataclasses.fields(FileOptions)
    }


def test_cli_flags_fill_the_renamed_options():
    """``--rate``/``--height``/``--gyro``/``--latitude`` keep their spelling and land in the renamed fields."""
    from optinav.attitude.unit import AttitudeOptions
    from optinav.cli.common import file_options, options_from_args
    from optinav.cli.main import build_parser
    from optinav.multipos.apply import ApplyOptions

    parser = build_parser()
    args = parser.parse_args(
        [
            "calibrate",
            "accel",
            "s.csv",
            "--rate",
            "204.8",
            "--latitude",
            "38.88",
            "--height",
            "35",
            "--gyro",
            "g.csv",
            "--out",
            "r.json",
        ]
    )
    o = file_options(args)
    assert (o.rate_hz, o.lat_deg, o.height_m, o.gyro_path) == (204.8, 38.88, 35.0, "g.csv")
    args = parser.parse_args(["attitude", "f.csv", "--rate", "50", "--out", "o.csv"])
    assert options_from_args(AttitudeOptions, args).rate_hz == 50.0
    args = parser.parse_args(["apply", "r.json", "raw.csv", "--rate", "25", "--out", "o.csv"])
    assert options_from_args(ApplyOptions, args).rate_hz == 25.0


def test_attitude_results_and_filters_name_the_attitude_q_b_n():
    classes = [getattr(importlib.import_module(p.rsplit(".", 1)[0]), p.rsplit(".", 1)[1]) for p in ATTITUDE_CLASSES]
    bad = _field_violations(classes, {**BANNED, **ATTITUDE_BANNED})
    assert not bad, "banned field names:\n" + "\n".join(bad)
    import dataclasses

    old = dataclasses.make_dataclass("Run", [("q", float), ("bias", float), ("gyro_bias", float), ("q_b_n", float)])
    assert len(_field_violations([old], ATTITUDE_BANNED)) == 3


# --- one frame spelling, one validator, documented defaults ------------------------------------------------


def test_frame_name_is_the_one_validator():
    from optinav.core.rotations import FRAMES, frame_name
    from optinav.errors import OptinavError

    assert [frame_name(f) for f in ("NED", "ned", " Enu ", "ENU")] == ["ned", "ned", "enu", "enu"]
    assert set(FRAMES) == {"enu", "ned"}
    for bad in ("nwu", "", None, "body"):
        with pytest.raises(OptinavError, match="unknown navigation frame"):
            frame_name(bad)


#: data-class fields named ``frame`` that are not a navigation frame: a turntable move's axis is fixed in the
#: "body" or the "nav" frame
NOT_NAVIGATION_FRAMES = {"optinav.core.simulate.Rotate.frame"}


def _frame_defaults():
    """(name, default) of every ``frame`` / Euler ``convention`` parameter of the public API that has a default,
    and of every ``frame`` field of a public data class that has one (``MISSING`` for a required field)."""
    import dataclasses

    out = []
    for name, fn in _public_callables():
        for key in ("frame", "convention"):
            p = inspect.signature(fn).parameters.get(key)
            if p is not None and p.default is not inspect.Parameter.empty:
                out.append((f"{name}({key}=)", p.default))
    seen = set()
    for mod_name in _public_modules():
        for obj in vars(importlib.import_module(mod_name)).values():
            if (
                inspect.isclass(obj)
                and dataclasses.is_dataclass(obj)
                and obj.__module__.startswith("optinav")
                and obj not in seen
            ):
                seen.add(obj)
                for f in dataclasses.fields(obj):
                    name = f"{obj.__module__}.{obj.__qualname__}.{f.name}"
                    if f.name == "frame" and name not in NOT_NAVIGATION_FRAMES:
                        out.append((name, f.default))
    return out


def _bad_frame_defaults(found) -> list[str]:
    import dataclasses

    from optinav.core.rotations import DEFAULT_FRAME

    return [f"{n}: {d!r}" for n, d in found if d is not dataclasses.MISSING and d != DEFAULT_FRAME]


def test_every_frame_default_is_the_one_default():
    """One default navigation frame, NED (docs/conventions.md, "Spelling and defaults"): every ``frame`` and Euler
    ``convention`` parameter and every ``frame`` field of the public API defaults to ``DEFAULT_FRAME`` or has no
    default; code that reproduces PSINS passes "enu" explicitly."""
    from optinav.core.rotations import DEFAULT_FRAME

    assert DEFAULT_FRAME == "ned"
    found = _frame_defaults()
    names = {n for n, _ in found}
    # the walk reaches the navigation core, the attitude system, the sky models and the results
    for must in (
        "optinav.core.earth.gravity_vector(frame=)",
        "optinav.core.alignment.fine_alignment(frame=)",
        "optinav.core.simulate.static_positions(frame=)",
        "optinav.core.strapdown.mechanize(frame=)",
        "optinav.core.rotations.euler_from_dcm(convention=)",
        "optinav.attitude.data.synthesize_polarization(frame=)",
        "optinav.attitude.estimators.estimate(frame=)",
        "optinav.sky.sun.sun_vector(frame=)",
        "optinav.core.strapdown.NavSolution.frame",
        "optinav.attitude.estimators.AttitudeEstimate.frame",
    ):
        assert must in names, must
    assert len(found) > 40
    bad = _bad_frame_defaults(found)
    assert not bad, "frame defaults other than DEFAULT_FRAME:\n" + "\n".join(bad)


def test_the_frame_default_check_flags_another_default():
    import dataclasses

    found = [("a(frame=)", "enu"), ("b(frame=)", "ned"), ("C.frame", dataclasses.MISSING), ("d(convention=)", "ENU")]
    assert _bad_frame_defaults(found) == ["a(frame=): 'enu'", "d(convention=): 'ENU'"]
