"""Equal-time optiland run: optiland's scipy global optimiser (differential evolution or dual annealing,
optiland 0.6.3 wrappers, scipy defaults) on the spec's problem (common.make_problem) from a flat start,
until GLOBAL_FRACTION of the budget, then optiland's LeastSquares (scipy least_squares 'trf', bounded) from
the best design found until the budget ends. The time limit is a guard around optiland's objective: once
the deadline passes, the next evaluation raises and the best design evaluated so far is kept.

usage: run_optiland.py SPEC {de,da} BUDGET_S OUTDIR [SEED]
"""
import time

T0 = time.time()
import json  # noqa: E402
import math  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402

from common import SPECS, be, export_unicac, make_problem, np  # noqa: E402
from optiland.optimization import (  # noqa: E402
    DifferentialEvolution, DualAnnealing, LeastSquares)

GLOBAL_FRACTION = 0.7


class TimeUp(Exception):
    pass


def main():
    key, method, budget, out = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
    seed = int(sys.argv[5]) if len(sys.argv) > 5 else 1
    os.makedirs(out, exist_ok=True)
    np.random.seed(seed)  # scipy's DE / DA draw from numpy's global RandomState (the wrappers pass no seed)
    spec = SPECS[key]
    op, prob = make_problem(spec, rings=3)
    best = {"f": math.inf, "x": None}
    trace = []
    counts = {"global": 0, "local": 0}
    state = {"phase": "global", "deadline": T0 + GLOBAL_FRACTION * budget}

    def note(f, x):
        if f < best["f"]:
            best["f"], best["x"] = float(f), np.array(x, dtype=float).copy()
            trace.append({"t_s": round(time.time() - T0, 2), "phase": state["phase"], "merit": float(f),
                          "evals": counts["global"] + counts["local"]})

    if method.startswith("de") and method != "de":
        # "deN": optiland's DifferentialEvolution wrapper with scipy's popsize set to N (the wrapper does not
        # expose it; default 15) so that DE gets through generations within the budget
        import functools
        import types

        import scipy.optimize

        import optiland.optimization.optimizer.scipy.differential_evolution as de_mod
        de_mod.optimize = types.SimpleNamespace(differential_evolution=functools.partial(
            scipy.optimize.differential_evolution, popsize=int(method[2:])))
    opt = DifferentialEvolution(prob) if method.startswith("de") else DualAnnealing(prob)
    raw_fun = opt._fun

    def guarded_fun(x):
        if time.time() > state["deadline"]:
            raise TimeUp
        f = raw_fun(x)
        counts["global"] += 1
        note(f, x)
        return f

    opt._fun = guarded_fun
    t_global0 = time.time()
    status = "finished"
    try:
        if method.startswith("de"):
            opt.optimize(maxiter=100000, disp=False, workers=1)
        else:
            opt.optimize(maxiter=100000, disp=False)
    except TimeUp:
        status = "time limit"
    t_global = time.time() - t_global0
    global_best = best["f"]
    print(f"[{key} {method}] global {status} after {t_global:.0f} s, {counts['global']} evals, "
          f"merit {best['f']:.4g}", flush=True)

    # local: optiland's LeastSquares from the best global design
    for v, xv in zip(prob.variables, best["x"]):
        v.update(xv)
    prob.update_optics()
    state["phase"], state["deadline"] = "local", T0 + budget
    ls = LeastSquares(prob)
    raw_res = ls._compute_residuals_vector

    def guarded_res(x):
        if time.time() > state["deadline"]:
            raise TimeUp
        r = raw_res(x)
        counts["local"] += 1
        note(float(np.sum(np.asarray(r) ** 2)), x)
        return r

    ls._compute_residuals_vector = guarded_res
    t_local0 = time.time()
    lstatus = "finished"
    try:
        ls.optimize(maxiter=None, method_choice="trf", tol=1e-10, disp=False)
    except TimeUp:
        lstatus = "time limit"
    t_local = time.time() - t_local0
    wall = time.time() - T0
    for v, xv in zip(prob.variables, best["x"]):
        v.update(xv)
    prob.update_optics()
    merit = float(be.to_numpy(prob.sum_squared()))
    print(f"[{key} {method}] local {lstatus} after {t_local:.0f} s, {counts['local']} evals, "
          f"merit {merit:.4g}; wall {wall:.1f} s", flush=True)
    name = f"optiland-{method}-{key}"
    export_unicac(op, spec, name, os.path.join(out, name + ".json"))
    rms = [float(be.to_numpy(o.value)) * 1000 for o in prob.operands if o.operand_type == "rms_spot_size"]
    summary = {
        "spec": key, "method": method, "seed": seed, "budget_s": budget, "wall_s": wall,
        "global_status": status, "global_s": t_global, "global_evals": counts["global"],
        "global_best_merit": global_best,
        "local_status": lstatus, "local_s": t_local, "local_evals": counts["local"],
        "final_merit": merit, "optiland_rms_um_d_centroid": rms,
        "efl_mm": float(op.paraxial.f2()), "total_track_mm": float(op.total_track),
        "x": best["x"].tolist(), "trace": trace,
    }
    with open(os.path.join(out, name + ".summary.json"), "w") as fh:
        json.dump(summary, fh, indent=1)


if __name__ == "__main__":
    main()
