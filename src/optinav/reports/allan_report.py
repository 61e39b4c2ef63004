"""The ``--report DIR`` of ``optinav allan``: noise tables and the log-log Allan deviation with the fitted slopes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from optinav.core.allan import FLICKER_FLOOR, allan_deviation_model
from optinav.reports.report import Cell, Figure, StudyResult, Table, write_report

_TERMS = (
    ("white", "white noise N", "·√s", -0.5, 1.0),
    ("bias_instability", "bias instability B", "", 0.0, None),
    ("random_walk", "random walk K", "/√s", 0.5, 3.0),
    ("quantization", "quantization Q", "·s", -1.0, math.sqrt(3)),
    ("rate_ramp", "rate ramp R", "/s", 1.0, math.sqrt(2)),
)


def _text(cell: dict) -> str:
    """A value with its 68 % interval as the report writes it (``summary.json`` keeps the numbers)."""
    v, (lo, hi) = cell["value"], cell["interval"]
    return "not seen" if v is None else f"{v:.4g} [{lo:.3g}, {hi:.3g}]"


def _cell(v, iv) -> Cell:
    """A noise term of one axis: value and 68 % interval as numbers (None: the term was not seen)."""
    value = {"value": float(v) if np.isfinite(v) else None, "interval": [float(iv[0]), float(iv[1])]}
    return Cell(value, _text)


def _tables(name: str, d: dict) -> list[Table]:
    fit, ro = d["fit"], d["read_off"]
    unit = fit.unit or "unit"
    rows = []
    for key, label, suffix, _, _ in _TERMS:
        if getattr(fit, key) is None:
            continue  # a fit written before the rate ramp was a term
        v_f = np.atleast_1d(getattr(fit, key))
        i_f = np.asarray(getattr(fit, key + "_interval")).reshape(2, -1)
        v_r = np.atleast_1d(getattr(ro, key))
        i_r = np.asarray(getattr(ro, key + "_interval")).reshape(2, -1)
        for j in range(v_f.size):
            rows.append([f"{label} [{unit}{suffix}]", "xyz"[j], _cell(v_f[j], i_f[:, j]), _cell(v_r[j], i_r[:, j])])
    note = (
        "fit: weighted least squares of σ² = 3Q²/τ² + N²/τ + (2 ln2/π)B² + K²τ/3 + R²τ²/2 over the whole curve; "
        "read-off: IEEE Std 952 slopes (N at τ = 1 s on −1/2, B = flat minimum / 0.664, K at τ = 3 s on +1/2, "
        "Q on −1, R at τ = √2 s on +1). "
        "Brackets: 68 % interval (the read-off's covers sampling error only)."
    )
    return [
        Table(
            f"{name.capitalize()} noise terms",
            ["term", "axis", "fit [68 % interval]", "IEEE 952 read-off [68 % interval]"],
            rows,
            note,
        )
    ]


def _figure(name: str, d: dict) -> Figure:
    ad, fit, ro = d["deviation"], d["fit"], d["read_off"]
    unit = ad.unit or "unit"

    def draw(fig):
        ax = fig.add_subplot(111)
        tau = np.asarray(ad.tau, float)
        A = np.asarray(ad.adev, float).reshape(tau.size, -1)
        lo = np.asarray(ad.lower, float).reshape(tau.size, -1)
        hi = np.asarray(ad.upper, float).reshape(tau.size, -1)
        colors = ("tab:red", "tab:green", "tab:blue")
        ramp = np.zeros(A.shape[1]) if fit.rate_ramp is None else np.atleast_1d(fit.rate_ramp)
        for j in range(A.shape[1]):
            c = colors[j % 3]
            ax.loglog(tau, A[:, j], "o", ms=3.5, color=c, label=f"{'xyz'[j]}")
            ax.fill_between(tau, lo[:, j], hi[:, j], color=c, alpha=0.15, lw=0)
            model = allan_deviation_model(
                tau,
                white=np.atleast_1d(fit.white)[j],
                bias_instability=np.atleast_1d(fit.bias_instability)[j],
                random_walk=np.atleast_1d(fit.random_walk)[j],
                quantization=np.atleast_1d(fit.quantization)[j],
                rate_ramp=ramp[j],
            )
            ax.loglog(tau, model, "-", color=c, lw=1.2, alpha=0.8)
            # the IEEE 952 read-off: each slope through its coefficient, a decade either side of where it was read
            for key, _, _, slope, at in _TERMS:
                if getattr(ro, key) is None:
                    continue
                v = float(np.atleast_1d(getattr(ro, key))[j])
                t_read = float(np.atleast_1d(getattr(ro, key + "_tau"))[j])
                if not (np.isfinite(v) and np.isfinite(t_read)):
                    continue
                span = tau[(tau >= t_read / 10) & (tau <= t_read * 10)]
                if span.size < 2:
                    continue
                if slope == 0.0:
                    ax.loglog(span, np.full(span.shape, FLICKER_FLOOR * v), ":", color=c, lw=1.5)
                else:
                    # N·τ^(−1/2) is N at τ = 1 s, K·(τ/3)^(1/2) is K at 3 s, √3·Q/τ is Q at √3 s, R·τ/√2 is R at √2 s
                    ax.loglog(span, v * (span / at) ** slope, "--", color=c, lw=1.0)
        ax.set_xlabel("cluster time τ [s]")
        ax.set_ylabel(f"Allan deviation [{unit}]")
        ax.set_title(
            f"{name}: estimates with 68 % band, five-term fit (solid), IEEE 952 read-off slopes (dashed)\n"
            "and 0.664·B floor (dotted)"
        )
        ax.title.set_fontsize(9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(title="axis", fontsize=8)

    return Figure(f"allan_{name}.png", f"Allan deviation of the {name}", draw, size=(8.0, 5.5))


def write_allan_report(res, out_dir) -> Path:
    """Write index.md/index.html, summary.json and one log-log PNG per sensor for an AllanAnalysis."""
    tables, figures = [], []
    for name in ("accelerometer", "gyroscope"):
        d = res.sensor(name)
        if d is not None:
            tables += _tables(name, d)
            figures.append(_figure(name, d))
    if res.kalibr:
        tables.append(
            Table(
                "Kalibr continuous-time noise (largest axis)",
                ["key", "value"],
                [[k, Cell(v, "{:.6g}") if isinstance(v, float) else v] for k, v in res.kalibr.items()],
            )
        )
    study = StudyResult(
        name="allan",
        title=f"Allan deviation of {res.source or 'the log'}",
        description=f"{res.n_samples} samples at {res.rate_hz:.6g} Hz over {res.duration_s / 3600:.3g} h."
        + "".join(f"\n\nNote: {n}." for n in res.notes),
        tables=tables,
        figures=figures,
        summary={"kalibr": res.kalibr},
    )
    return write_report([study], out_dir, title="optinav allan")
