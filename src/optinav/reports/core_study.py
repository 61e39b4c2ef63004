"""Study ``core``: checks of the shared core against published values and analytic truth.

Each section is a function ``(quick, rng) -> (tables, checks, figures, summary)`` so the study grows as
the core does; the numbers come from references (NIMA TR8350.2, PSINS glv) or exact identities.
"""

from __future__ import annotations

import numpy as np

from optinav.core import earth, rotations
from optinav.reports.report import Check, Figure, StudyResult, Table, register_study


def _earth_section(quick, rng):
    lats = np.radians(np.arange(0, 91, 15.0))
    g_w = earth.gravity(lats)
    g_p = earth.gravity(lats, earth="psins")
    rows = [[float(np.degrees(la)), f"{a:.10f}", f"{b:.10f}", float((b - a) / 9.80665e-6)] for la, a, b in zip(lats, g_w, g_p)]
    table = Table("Normal gravity at sea level: WGS-84 (Somigliana) vs PSINS formula",
                  ["latitude [deg]", "WGS-84 [m/s²]", "PSINS [m/s²]", "PSINS − WGS-84 [μg]"], rows,
                  "Reference: NIMA TR8350.2 γ_e = 9.7803253359, γ_p = 9.8321849378 m/s².")
    checks = [Check("WGS-84 γ at equator − TR8350.2", abs(earth.gravity(0.0) - 9.7803253359), 1e-9, "m/s²"),
              Check("WGS-84 γ at pole − TR8350.2", abs(earth.gravity(np.pi / 2) - 9.8321849378), 1e-8, "m/s²"),
              Check("max |PSINS − WGS-84| gravity", float(np.max(np.abs(g_p - g_w)) / 9.80665e-6), 10.0, "μg")]

    def draw(fig):
        ax = fig.add_subplot(111)
        la = np.linspace(0, 90, 181)
        ax.plot(la, (earth.gravity(np.radians(la), earth="psins") - earth.gravity(np.radians(la))) / 9.80665e-6)
        ax.set_xlabel("latitude [deg]")
        ax.set_ylabel("PSINS − WGS-84 gravity [μg]")
        ax.grid(True)

    fig = Figure("core_gravity_models.png", "Difference of the PSINS gravity formula from WGS-84 normal gravity", draw)
    return [table], checks, [fig], {"gravity_wgs84": g_w, "gravity_psins": g_p}


def _rotation_section(quick, rng):
    n = 20_000 if quick else 200_000
    e = np.column_stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-np.pi, np.pi, n)])
    rows, checks = [], []
    for conv in ("ned", "enu"):
        c = rotations.dcm_from_euler(e, conv)
        err_e = np.max(np.abs(rotations.euler_from_quat(rotations.quat_from_dcm(c), conv) - e))
        err_o = np.max(np.abs(c @ np.swapaxes(c, -1, -2) - np.eye(3)))
        rows.append([conv, n, float(err_e), float(err_o)])
        checks.append(Check(f"Euler→DCM→quat→Euler round trip ({conv})", float(err_e), 1e-9, "rad"))
    table = Table("Rotation conversions on random attitudes", ["convention", "samples", "max round-trip error [rad]",
                                                                "max |CCᵀ − I|"], rows)
    return [table], checks, [], {}


SECTIONS = [_earth_section, _rotation_section]


@register_study("core", "shared core: Earth model and rotations against references")
def core_study(quick: bool = True, rng=None) -> StudyResult:
    rng = np.random.default_rng(rng)
    res = StudyResult("core", "Shared core checks",
                      "Earth model against NIMA TR8350.2 and the PSINS formula; rotation conversions against exact "
                      "identities; strapdown, alignment and optimizers as they are added.")
    for section in SECTIONS:
        tables, checks, figures, summary = section(quick, rng)
        res.tables += tables
        res.checks += checks
        res.figures += figures
        res.summary.update(summary)
    return res
