"""Explicitly stop-aimed rays in optiland, vectorised: for every pupil point (px, py)
the ray of field F (direction (0, sin F, cos F)) whose stop intercept is
(px, py) * R_stop. Newton's method on the start point (plane z0) with a
finite-difference Jacobian from optiland's own real trace, started from the
paraxial entrance-pupil point and carried up from the axis in field steps
(continuation), so wide fields with strong pupil aberration converge.
Independent of unicac: only optiland traces here.
"""
from __future__ import annotations

import math

import numpy as np

import make_references as mr

TOLERANCE_MM = 1e-13   # stop-intercept residual at which a ray counts as aimed
MAX_ITERATIONS = 40
FIELD_STEPS = 10       # continuation steps from the axis to the field


def _directions(field_deg: float, n: int) -> np.ndarray:
    f = math.radians(field_deg)
    return np.tile([0.0, math.sin(f), math.cos(f)], (n, 1))


def _newton(model, stop: int, field_deg: float, targets: np.ndarray, z0: float,
            start_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start points (n, 2) on z0 and a converged mask, for one field."""
    n = len(targets)
    p = start_xy.astype(float).copy()
    h = 1e-7 * max(1.0, float(np.abs(targets).max()))
    d = _directions(field_deg, 3 * n)
    done = np.zeros(n, dtype=bool)
    for _ in range(MAX_ITERATIONS):
        trial = np.concatenate([
            np.column_stack([p[:, 0], p[:, 1], np.full(n, z0)]),
            np.column_stack([p[:, 0] + h, p[:, 1], np.full(n, z0)]),
            np.column_stack([p[:, 0], p[:, 1] + h, np.full(n, z0)])])
        pts, ok = model.trace(trial, d)
        xy = pts[:, stop, :2]
        base, dx, dy = xy[:n], xy[n:2 * n], xy[2 * n:]
        good = ok[:n] & ok[n:2 * n] & ok[2 * n:]
        err = base - targets
        done = good & (np.abs(err).max(axis=1) < TOLERANCE_MM)
        if done.all():
            break
        jac = np.stack([(dx - base) / h, (dy - base) / h], axis=-1)  # (n, 2, 2): d stop / d start
        step = np.zeros_like(p)
        todo = good & ~done
        if todo.any():
            step[todo] = np.linalg.solve(jac[todo], err[todo][..., None])[..., 0]
        p = p - step
    return p, done


def aim_rays(model, lens: dict, aim: dict, field_deg: float, pupil) -> dict:
    """Stop-aimed rays of one field at the model's wavelength, traced unclipped:
    start points, stop intercepts, per-surface intercepts and the converged mask."""
    stop = mr.stop_index(lens)
    pupil = np.asarray(pupil, dtype=float).reshape(-1, 2)
    targets = pupil * aim["stop_marginal_height_mm"]
    z0 = mr.start_plane(aim)
    starts, _ = mr.pupil_rays(0.0, pupil, aim["epd_mm"], aim["entrance_pupil_z_mm"], z0)
    p = starts[:, :2]
    steps = [field_deg * k / FIELD_STEPS for k in range(1, FIELD_STEPS + 1)] if field_deg else [0.0]
    for f in steps:
        p, done = _newton(model, stop, f, targets, z0, p)
    start = np.column_stack([p[:, 0], p[:, 1], np.full(len(p), z0)])
    pts, ok = model.trace(start, _directions(field_deg, len(p)))
    return {"start": start, "direction": _directions(field_deg, len(p)), "points": pts,
            "ok": ok & done, "stop": stop}
