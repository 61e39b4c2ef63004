"""Compile the attitude estimators' numba kernels into their cache once, before the test workers start (conftest.py).

On a fresh install (CI's) the cache is empty: each worker, and the quick report beside them, compiled the same
kernels at once (about 30 s of CPU each for the attitude estimators). Run as a script; it exercises the public API
on a short simulated flight, so what it compiles is what the tests call."""

import warnings

import numpy as np


def main() -> None:
    from optinav.attitude import AttitudeFilter, estimate
    from optinav.attitude.simulate import simulate
    from optinav.core.rotations import quat_conjugate, quat_rotate
    from optinav.errors import OptinavError

    fl = simulate("dynamic", duration_s=60.0, rate_hz=100.0, rng=0)
    mag = quat_rotate(quat_conjugate(fl.q_b_n), np.broadcast_to([0.0, 20.0, -40.0], fl.gyr.shape))
    runs = [dict(), dict(offline=True), dict(mag=mag), dict(mag=mag, offline=True)]
    runs += [dict(method=m) for m in ("mekf", "qn", "gd", "cg")]
    pol = fl.polarization()
    runs += [dict(method=m, pol=pol, q0=fl.q_b_n[0]) for m in ("iframe", "mekf", "qn", "gd")]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for kw in runs:
            try:
                estimate(fl.gyr, fl.acc, fl.dt, frame=fl.frame, **kw)
            except OptinavError:  # a refusal compiles no more; the tests judge it
                pass
        for m in (None, mag):  # the streaming filter, sample by sample and by chunks
            f = AttitudeFilter(dt=fl.dt, frame=fl.frame, checks=False)
            for k in range(100):
                f.update(fl.gyr[k], fl.acc[k], None if m is None else m[k])
            f.update_batch(fl.gyr[100:], fl.acc[100:], None if m is None else m[100:])


if __name__ == "__main__":
    main()
