"""The systems optinav knows, each declared once: its result type, how one recording is read and processed, its
batch options, truth and report, and the CLI module that adds its options.

A system is a package (``optinav.multipos``, ``optinav.rins``, ``optinav.gfimu``, ``optinav.attitude``) plus one
:func:`register` call here. References are ``"module:attribute"`` strings imported on first use, so that
``optinav --help`` does not import numerical code. What reads the registry:

* :mod:`optinav.batch` — ``run_unit`` and ``options`` of the system named by ``optinav batch calibrate SYSTEM`` /
  ``optinav batch attitude``;
* :mod:`optinav.cli.main` — every system's ``cli`` module may define ``register_simulate(kinds)``,
  ``register_calibrate(kinds)`` (or ``register_estimate(sub)`` for a top-level estimate command),
  ``add_batch_options(parser)`` and ``add_apply_options(group)``; the ``simulate``, ``calibrate``, ``apply`` and
  ``batch`` commands are built from them, ``optinav calibrate SYSTEM`` runs the system's ``run_unit`` and
  ``optinav apply`` / ``optinav report`` pick the system by the result file's schema (:func:`for_result`).

Adding a fifth system: write its package (result class deriving :class:`optinav.core.results.Estimate`, a
``unit`` module with an options dataclass and ``run_unit(path, options, reference) -> (result, extra columns)``,
a CLI module with the register hooks) and register it here or from a plugin (``register(System(...))``).
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import Any

from optinav.errors import OptinavError


@dataclasses.dataclass(frozen=True)
class System:
    """One system. ``name``: package and schema name (``optinav.<name>.<kind>``); ``command``: the word after
    ``optinav calibrate`` / ``optinav batch calibrate`` (or the top-level command of an estimate); ``kind``:
    "calibration" or "estimate". The other fields are ``"module:attribute"`` references (None: not offered):
    ``result`` the :class:`~optinav.core.results.Estimate` subclass; ``simulate`` the simulator; ``fit`` the
    calibrator or estimator returning ``result``; ``options`` the batch options dataclass and ``check(options)``
    its checks, run once before a batch; ``run_unit(path, options, reference)`` reads one recording and returns
    ``(result, extra table columns)``; ``truth`` builds a :class:`~optinav.core.results.Truth`; ``report`` writes
    its report section (the result plus what the system plots, then the folder); ``read``/``write`` its data
    files; ``cli`` the module with its command-line hooks."""

    name: str
    command: str
    kind: str
    result: str
    simulate: str | None = None
    fit: str | None = None
    options: str | None = None
    check: str | None = None
    run_unit: str | None = None
    truth: str | None = None
    report: str | None = None
    apply: str | None = None
    apply_options: str | None = None
    read: str | None = None
    write: str | None = None
    cli: str | None = None
    help: str = ""

    def load(self, what: str) -> Any:
        """The object a reference field names (``self.load("run_unit")``)."""
        ref = getattr(self, what)
        if ref is None:
            raise OptinavError(f"the {self.name} system has no {what}", "see `optinav --help` for what it offers")
        module, _, attr = ref.partition(":")
        obj = importlib.import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
        return obj


SYSTEMS: dict[str, System] = {}


def register(system: System) -> System:
    """Add (or replace) a system; its ``name`` and ``command`` must not collide with another system's."""
    for other in SYSTEMS.values():
        if other.name != system.name and other.command == system.command:
            raise OptinavError(
                f"system {system.name!r} uses the command {system.command!r} of {other.name!r}",
                "choose another command word",
            )
    SYSTEMS[system.name] = system
    return system


def unregister(name: str) -> None:
    SYSTEMS.pop(name, None)


def by_command(command: str, kind: str | None = None) -> System:
    """The system whose CLI word is ``command`` (or whose name is), optionally of ``kind``."""
    for s in SYSTEMS.values():
        if (s.command == command or s.name == command) and (kind is None or s.kind == kind):
            return s
    known = ", ".join(s.command for s in SYSTEMS.values() if kind is None or s.kind == kind)
    raise OptinavError(f"unknown system {command!r}", f"use one of {known}")


def systems(kind: str | None = None) -> list[System]:
    """The registered systems (of ``kind``), in registration order."""
    return [s for s in SYSTEMS.values() if kind is None or s.kind == kind]


#: the system whose results have no schema: imucal JSON exports and imu_tk parameter files are multi-position
#: calibrations (:func:`optinav.multipos.exchange.load_calibration` reads them)
EXCHANGE_SYSTEM = "multipos"


def for_result(path) -> tuple[System, Any]:
    """The system of the result file at ``path``, selected by its schema ``optinav.<system>.<kind>`` (or an
    older layout a system reads), and the loaded result; a file without a schema (imucal, imu_tk) is a
    calibration of :data:`EXCHANGE_SYSTEM`, returned with ``None`` (its system's loader reads it)."""
    from optinav.core.files import is_hdf5, read_text
    from optinav.core.results import Result

    if is_hdf5(path):  # imucal's to_hdf5 export (optinav's results are JSON)
        return SYSTEMS[EXCHANGE_SYSTEM], None
    text = read_text(path, "result file")
    if not text.lstrip().startswith("{") or '"schema"' not in text:
        return SYSTEMS[EXCHANGE_SYSTEM], None
    try:
        res = Result.from_json(path)
    except OptinavError:
        _not_a_result(path, text)
        raise
    name = getattr(res, "SYSTEM", None)
    if name not in SYSTEMS:
        _not_a_result(path, text)
        raise OptinavError(
            f"{path} ({res.SCHEMA}) is not the result of a registered system", f"pass a result of {', '.join(SYSTEMS)}"
        )
    return SYSTEMS[name], res


def _not_a_result(path, text: str) -> None:
    """Raise where the file at ``path`` is one optinav writes that is no calibration or estimate result (a pose plan
    was told "unknown result schema … upgrade optinav", a simulation's truth "no 'schema'/'fields' keys")."""
    import json

    from optinav.core.results import PLAIN_ARRAYS_SINCE

    try:
        schema = json.loads(text).get("schema")
    except (ValueError, AttributeError):
        return
    if not isinstance(schema, str) or not (schema in PLAIN_ARRAYS_SINCE or schema.endswith(".truth")):
        return
    parts = schema.split(".")
    if len(parts) == 3 and parts[1] in SYSTEMS and parts[2] != "truth":
        return  # a system's result (damaged, or of another version): its own error says what
    what = (
        "a pose plan (optinav design; its report: optinav design ... --out plan.md)"
        if schema == "optinav.pose_plan"
        else "a simulation's truth (optinav simulate)"
        if schema.endswith(".truth")
        else f"optinav's {schema}"
    )
    raise OptinavError(
        f"{path} is {what}, not a calibration or estimate result",
        "pass RESULT.json written by optinav calibrate, attitude or allan",
    )


register(
    System(
        name="multipos",
        command="accel",
        kind="calibration",
        result="optinav.multipos.result:CalibrationResult",
        simulate="optinav.multipos.simulate:simulate",
        fit="optinav.multipos.calibrate:calibrate",
        options="optinav.multipos.calibrate:FileOptions",
        run_unit="optinav.multipos.unit:run_unit",
        check="optinav.multipos.unit:check",
        truth="optinav.multipos.result:session_truth",
        report="optinav.reports.result_report:multipos_report",
        apply="optinav.multipos.apply:apply_file",
        apply_options="optinav.multipos.apply:ApplyOptions",
        read="optinav.multipos.calibrate:read_session_file",
        write="optinav.io:write_imu",
        cli="optinav.cli.calibrate",
        help="multi-position accelerometer (and gyroscope) calibration",
    )
)
register(
    System(
        name="rins",
        command="rins",
        kind="calibration",
        result="optinav.rins.calibrate:RinsCalibration",
        simulate="optinav.rins.simulate:simulate",
        fit="optinav.rins.calibrate:calibrate",
        options="optinav.rins.unit:RinsOptions",
        run_unit="optinav.rins.unit:run_unit",
        check="optinav.rins.unit:check",
        truth="optinav.rins.calibrate:rins_truth",
        report="optinav.rins.report:rins_report",
        apply="optinav.rins.unit:apply_file",
        apply_options="optinav.rins.unit:RinsOptions",
        read="optinav.rins.io:read_rins",
        write="optinav.rins.io:write_rins",
        cli="optinav.cli.rins",
        help="gimbal non-orthogonality of a dual-axis rotational INS",
    )
)
register(
    System(
        name="gfimu",
        command="gfimu",
        kind="calibration",
        result="optinav.gfimu.turntable:TurntableCalibration",
        simulate="optinav.gfimu.turntable:simulate",
        fit="optinav.gfimu.turntable:calibrate",
        options="optinav.gfimu.unit:GfimuOptions",
        run_unit="optinav.gfimu.unit:run_unit",
        check="optinav.gfimu.unit:check",
        truth="optinav.gfimu.turntable:turntable_truth",
        report="optinav.gfimu.report:gfimu_report",
        apply="optinav.gfimu.unit:apply_file",
        apply_options="optinav.gfimu.unit:GfimuApplyOptions",
        read="optinav.gfimu.turntable:TurntableData.load",
        cli="optinav.cli.gfimu",
        help="installation errors of a gyro-free accelerometer array",
    )
)
register(
    System(
        name="attitude",
        command="attitude",
        kind="estimate",
        result="optinav.attitude.estimators:AttitudeEstimate",
        simulate="optinav.attitude.simulate:simulate",
        fit="optinav.attitude.estimators:estimate",
        options="optinav.attitude.unit:AttitudeOptions",
        run_unit="optinav.attitude.unit:run_unit",
        check="optinav.attitude.unit:check",
        truth="optinav.attitude.estimators:attitude_truth",
        report="optinav.reports.result_report:attitude_report",
        read="optinav.attitude.unit:read_log",
        cli="optinav.cli.attitude",
        help="attitude from gyroscope + accelerometer (+ magnetometer, polarization)",
    )
)
