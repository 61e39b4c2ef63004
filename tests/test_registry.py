"""The system registry: the four systems are declared once, and a fifth registered from outside appears in
``optinav calibrate``, ``optinav simulate`` and ``optinav batch calibrate`` and runs through the common result
layout."""

import dataclasses

import numpy as np
import pytest

from optinav import registry
from optinav.batch import read_results
from optinav.cli.main import build_parser, main
from optinav.core.results import Estimate, Parameter, Result, convergence, gate

THIS = __name__


@dataclasses.dataclass
class ToyResult(Estimate):
    """The mean of a column of numbers (m) with its standard error."""

    SCHEMA = "optinav.toy.calibration"
    VERSION = 1
    SYSTEM = "toy"
    KIND = "calibration"

    mean: float = 0.0
    sem: float = 0.0
    method: str = "mean"
    elapsed_s: float = 0.0
    convergence: dict = dataclasses.field(default_factory=lambda: convergence(None, message="closed form"))
    gates: list = dataclasses.field(default_factory=list)

    def parameters(self):
        return {
            "mean": Parameter(self.mean, "m", std=self.sem, crlb_std=self.sem),
            "spin": Parameter(None, "rad", observable=False, reason="a column of numbers has no spin"),
        }


@dataclasses.dataclass
class ToyOptions:
    scale: float = 1.0


def check(options):
    if options.scale <= 0:
        from optinav.errors import OptinavError

        raise OptinavError("--scale must be > 0", "give a positive --scale")


def run_unit(path, options, reference=False):
    x = np.loadtxt(path, ndmin=1) * options.scale
    res = ToyResult(
        mean=float(x.mean()),
        sem=float(x.std(ddof=1) / np.sqrt(x.size)),
        elapsed_s=1e-6,
        gates=[gate("samples", x.size, 2, kind="min")],
    )
    return res, {"n_samples": int(x.size)}


def add_batch_options(p):
    p.add_argument("--scale", type=float, default=1.0)


@dataclasses.dataclass
class ToyApplyOptions:
    shift: float = 0.0


def apply_file(result_path, data_path, out, options):
    """The column minus the calibrated mean (plus ``shift``)."""
    res = ToyResult.from_json(result_path)
    x = np.loadtxt(data_path, ndmin=1) - res.mean + options.shift
    np.savetxt(out, x)
    return f"wrote {x.size} centred numbers to {out}"


def add_apply_options(g):
    g.add_argument("--shift", type=float, default=0.0)


def report(res, out_dir, data=None, options=None):
    from optinav.reports.report import StudyResult, Table, write_report

    return write_report(
        [
            StudyResult(
                "toy",
                "Toy",
                tables=[Table("Mean", ["mean [m]", "sem [m]"], [[res.mean, res.sem]], formats=["{:.5f}"] * 2)],
            )
        ],
        out_dir,
    )


def register_calibrate(kinds):
    p = kinds.add_parser("toy", help="the mean of a column of numbers")
    p.add_argument("data")
    p.set_defaults(func=lambda args: print(run_unit(args.data, ToyOptions())[0].to_json()) or 0)


def register_simulate(kinds):
    kinds.add_parser("toy", help="a column of numbers")


@pytest.fixture
def toy():
    registry.register(
        registry.System(
            name="toy",
            command="toy",
            kind="calibration",
            result=f"{THIS}:ToyResult",
            options=f"{THIS}:ToyOptions",
            run_unit=f"{THIS}:run_unit",
            check=f"{THIS}:check",
            cli=THIS,
            help="the mean of a column of numbers",
            apply=f"{THIS}:apply_file",
            apply_options=f"{THIS}:ToyApplyOptions",
            report=f"{THIS}:report",
        )
    )
    yield
    registry.unregister("toy")


def _choices(parser, *path):
    for word in path:
        parser = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction").choices[word]
    return set(next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction").choices)


def test_the_four_systems_are_declared_once():
    assert [s.name for s in registry.systems()] == ["multipos", "rins", "gfimu", "attitude"]
    for s in registry.systems():
        assert issubclass(s.load("result"), Estimate) and s.load("result").SCHEMA.startswith(f"optinav.{s.name}.")
        assert dataclasses.is_dataclass(s.load("options")) and callable(s.load("run_unit"))
        assert callable(s.load("truth")) and callable(s.load("report")) and callable(s.load("read"))
        assert callable(s.load("simulate")) and callable(s.load("fit"))
        # a calibration is applied to data; an attitude estimate is not
        assert (s.apply is not None) == (s.kind == "calibration")
        assert s.apply is None or (callable(s.load("apply")) and dataclasses.is_dataclass(s.load("apply_options")))
    parser = build_parser()
    assert _choices(parser, "batch", "calibrate") == {"accel", "rins", "gfimu"}
    assert {"attitude", "calibrate"} <= _choices(parser, "batch")
    assert {"rins", "gfimu"} <= _choices(parser, "calibrate")
    assert {"accel-multipos", "rins", "gfimu-turntable", "flight"} <= _choices(parser, "simulate")


def test_a_registered_fifth_system_appears_in_the_cli_and_runs_a_batch(toy, tmp_path, capsys):
    parser = build_parser()
    assert "toy" in _choices(parser, "batch", "calibrate") and "toy" in _choices(parser, "calibrate")
    assert "toy" in _choices(parser, "simulate")
    d = tmp_path / "units"
    d.mkdir()
    rng = np.random.default_rng(0)
    data = {f"u{k}": rng.normal(k, 1.0, 50) for k in range(3)}
    for name, x in data.items():
        np.savetxt(d / f"{name}.txt", x)
    out = tmp_path / "r.csv"
    assert (
        main(["--quiet", "batch", "calibrate", "toy", str(d), "--out", str(out), "--workers", "0", "--scale", "2"]) == 0
    )
    rows = {r["unit"]: r for r in read_results(out)}
    for name, x in data.items():
        r = rows[name]
        assert r["system"] == "toy" and r["schema"] == "optinav.toy.calibration" and r["gates_passed"] is True
        assert r["mean"] == pytest.approx(2 * x.mean(), rel=1e-12) and r["n_samples"] == 50
        assert r["mean_std"] == pytest.approx(2 * x.std(ddof=1) / np.sqrt(50), rel=1e-12)
        assert r["spin"] is None and r["unobservable"] == "spin"
    assert main(["--quiet", "batch", "calibrate", "toy", str(d), "--out", str(out), "--scale", "-1"]) == 2
    assert "--scale must be > 0" in capsys.readouterr().err
    capsys.readouterr()
    assert main(["calibrate", "toy", str(d / "u1.txt")]) == 0
    res = Result.from_json(capsys.readouterr().out)
    assert isinstance(res, ToyResult) and res.mean == pytest.approx(data["u1"].mean())


def test_a_command_word_is_owned_by_one_system():
    from optinav.errors import OptinavError

    with pytest.raises(OptinavError, match="uses the command"):
        registry.register(registry.System(name="other", command="rins", kind="calibration", result="x:y"))
    assert "other" not in registry.SYSTEMS


def test_a_registered_fifth_system_is_applied_and_reported(toy, tmp_path, capsys):
    """`optinav apply` and `optinav report` pick the toy system by its result's schema and run its references."""
    data = tmp_path / "x.txt"
    x = np.random.default_rng(1).normal(3.0, 1.0, 40)
    np.savetxt(data, x)
    res, _ = run_unit(data, ToyOptions())
    result = tmp_path / "r.json"
    res.to_json(result)
    out = tmp_path / "c.txt"
    assert main(["--quiet", "apply", str(result), str(data), "--shift", "0.5", "--out", str(out)]) == 0
    np.testing.assert_allclose(np.loadtxt(out), x - x.mean() + 0.5, rtol=0, atol=1e-12)
    assert main(["--quiet", "report", str(result), "--out", str(tmp_path / "rep")]) == 0
    assert f"| {x.mean():.5f} | {x.std(ddof=1) / np.sqrt(x.size):.5f} |" in (tmp_path / "rep" / "index.md").read_text()
