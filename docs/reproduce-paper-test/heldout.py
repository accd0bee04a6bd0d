"""Claim 1 (which lens metric predicts per-lens O.P.) and paired model comparisons over the test lenses a
bench's models never saw, next to the same over every test lens. Lenses whose lens_sha256 appears in the
train/val splits of the models' training dataset (EXCLUDE) count as seen.
Usage: heldout.py REPORT_DIR DATASET_LENSES_JSONL[.gz] EXCLUDE_LENSES_JSONL[.gz] [A B ...]
Needs numpy. Bootstrap: 2,000 resamples of lenses, seed 1; RMS radii negated so that every predictor
grows with sharpness."""
import csv, gzip, json, sys, random
from collections import defaultdict
import numpy as np

report, ds, exclude = sys.argv[1:4]
pairs_ab = list(zip(sys.argv[4::2], sys.argv[5::2]))
rows = lambda p: [json.loads(l) for l in (gzip.open(p, "rt") if p.endswith(".gz") else open(p))]
seen = {r["lens_sha256"] for r in rows(exclude) if r["split"] in ("train", "val")}
lens = {r["lens_id"]: r for r in rows(ds) if r["split"] == "test"}
unseen = {i for i, r in lens.items() if r["lens_sha256"] not in seen}
op = defaultdict(dict)
for r in csv.DictReader(open(f"{report}/lens_op.csv")):
    op[r["model"]][r["lens_id"]] = float(r["op"])
results = f"{report}/results.json"
results = gzip.open(results + ".gz", "rt") if not __import__("os").path.exists(results) else open(results)
kinds = {m["name"]: m["kind"] for m in json.load(results)["models"]}
learned = [m for m in op if kinds.get(m) == "onnx"]
print(f"test lenses {len(lens)}, unseen by the models {len(unseen)}; methods {sorted(op)}")

def ranks(x):
    order = np.argsort(x, kind="stable"); r = np.empty(len(x)); r[order] = np.arange(len(x))
    # average ties
    for v in np.unique(x):
        idx = np.where(x == v)[0]
        if len(idx) > 1: r[idx] = r[idx].mean()
    return r

def stats(y, x):
    r = np.corrcoef(x, y)[0, 1]
    rho = np.corrcoef(ranks(x), ranks(y))[0, 1]
    n = len(x); s = 0
    for i in range(n):
        s += np.sum(np.sign(x[i] - x[i+1:]) * np.sign(y[i] - y[i+1:]))
    tau = s / (n * (n - 1) / 2)
    return r * r, r, rho, tau

def analyse(name, methods, subset):
    ids = sorted(i for i in subset if all(i in op[m] for m in methods))
    y = np.array([np.mean([op[m][i] for m in methods]) for i in ids])
    ode = np.array([lens[i]["ode"] for i in ids]); rms = np.array([lens[i]["rms_radius_um"] for i in ids])
    # RMS negated: every predictor then grows with sharpness, so correlations compare by value.
    preds = {"ode": ode, "rms": -rms, "log_rms": -np.log(rms)}
    point = {k: stats(y, v) for k, v in preds.items()}
    rng = np.random.default_rng(1); boots = defaultdict(list)
    for _ in range(2000):
        s = rng.integers(0, len(ids), len(ids))
        b = {k: stats(y[s], v[s]) for k, v in preds.items()}
        for k in preds:
            for j, what in enumerate(("r2", "r", "rho", "tau")):
                boots[(k, what)].append(b[k][j])
        for base in ("rms", "log_rms"):
            boots[("diff", base)].append(b["ode"][0] - b[base][0])
            boots[("diff_rho", base)].append(b["ode"][2] - b[base][2])
    ci = lambda v: (np.percentile(v, 2.5), np.percentile(v, 97.5))
    print(f"\n{name}: {len(ids)} lenses, per-lens O.P. = mean over {len(methods)} methods")
    for k in preds:
        r2, r, rho, tau = point[k]
        print(f"  {k:8} R^2 {r2:.3f} [{ci(boots[(k,'r2')])[0]:.3f}, {ci(boots[(k,'r2')])[1]:.3f}]  r {r:+.3f}"
              f"  Spearman {rho:+.3f} [{ci(boots[(k,'rho')])[0]:+.3f}, {ci(boots[(k,'rho')])[1]:+.3f}]  Kendall {tau:+.3f}"
              f" [{ci(boots[(k,'tau')])[0]:+.3f}, {ci(boots[(k,'tau')])[1]:+.3f}]")
    for base in ("rms", "log_rms"):
        d = point["ode"][0] - point[base][0]; lo, hi = ci(boots[("diff", base)])
        dr = point["ode"][2] - point[base][2]; rlo, rhi = ci(boots[("diff_rho", base)])
        print(f"  R^2(ODE) - R^2({base}) = {d:+.3f} [{lo:+.3f}, {hi:+.3f}];  Spearman diff {dr:+.3f} [{rlo:+.3f}, {rhi:+.3f}]")

for label, subset in (("unseen lenses", unseen), ("all test lenses", set(lens))):
    analyse(f"{label}, all methods", list(op), subset)
    analyse(f"{label}, learned models only", learned, subset)

def interval(d, rounds=2000, seed=1):
    rng = random.Random(seed); n = len(d)
    means = sorted(sum(d[rng.randrange(n)] for _ in range(n)) / n for _ in range(rounds))
    return sum(d) / n, means[int(0.025 * rounds)], means[int(0.975 * rounds) - 1]

for a, b in pairs_ab:
    print(f"\n{a} minus {b}, O.P. per lens, unseen lenses")
    for lv in [None, 1, 2, 3, 4, 5]:
        ids = [i for i in unseen if i in op[a] and i in op[b] and (lv is None or lens[i]["level"] == lv)]
        if len(ids) < 2: continue
        m, lo, hi = interval([op[a][i] - op[b][i] for i in ids])
        print(f"  {'all' if lv is None else 'L%d' % lv:4} n={len(ids):3} {m:+.4f} [{lo:+.4f}, {hi:+.4f}]")
