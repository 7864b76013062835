#!/usr/bin/env python3
"""Compare `mapvlm agree --json` with the Python reference on generated cases
that the golden file does not have: ties, missing values, constant columns,
one or two items, one annotator, unscored items, superseded and withdrawn
judgements.

usage: scripts/agree_cases.py PYTHON_WITH_SCIPY [MAPVLM] [--keep DIR]

PYTHON_WITH_SCIPY is an interpreter with numpy, scipy and krippendorff
(e.g. a venv made with `python3 -m venv /tmp/stats && /tmp/stats/bin/pip
install scipy krippendorff numpy`). MAPVLM defaults to target/release/mapvlm.
The reference is read from ../shared/reference/agree_ref.py beside the
repository. Point estimates must agree to 1e-9 and counts exactly; the
p-values of tau-b, rho and r (`metrics.M.p_values`) must equal scipy's to
1e-9 relative, with scipy pinned below, and so must Williams' test of each
pair of metrics (`williams.pairs.A_vs_B`: t, p_value and the Holm-adjusted
p_holm, by their definitions in scipy); the bootstrap intervals and the
permutation p-value are not in the reference.

usage: scripts/agree_cases.py PYTHON_WITH_SCIPY --golden-fixture OUT.json
writes the p-values of the golden set (../shared/golden/agree.dev.*) as
scipy gives them, and Williams' test of each pair of metrics with Holm's
correction, the fixture tests/fixtures/agree.golden.p_values.json.
"""
import json, os, random, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REFERENCE = os.path.join(ROOT, "..", "shared", "reference", "agree_ref.py")
GOLDEN = os.path.join(ROOT, "..", "shared", "golden", "agree.dev.")
# The scipy whose p-values are the reference.
SCIPY = "1.17.1"

# Run by PYTHON_WITH_SCIPY itself: the p-values of every metric's column.
P_VALUES = r"""
import json, math, sys, warnings
import numpy as np
from scipy import stats
sys.path.insert(0, sys.argv[1])
import agree_ref as ref
if __import__("scipy").__version__ != sys.argv[2]:
    sys.exit(f"scipy {__import__('scipy').__version__}, not the pinned {sys.argv[2]}")
items = {i["id"]: i for i in ref.jsonl(sys.argv[3])}
scores = {s["id"]: s for s in ref.jsonl(sys.argv[4])}
cur = ref.current_ratings([l for f in sys.argv[5:] for l in ref.jsonl(f)], items)
rated = sorted({i for i, _ in cur})
human = {i: float(np.mean([r for (j, _), r in cur.items() if j == i])) for i in rated}
out = {}
warnings.simplefilter("ignore")
def p(f, x, h):
    if len(x) < 2 or np.ptp(x) == 0 or np.ptp(h) == 0:
        return None
    with np.errstate(all="ignore"):
        v = float(f(x, h).pvalue)
    return None if math.isnan(v) else v
for m in ref.METRICS:
    ids = [i for i in rated if i in scores and scores[i].get(m) is not None]
    x = np.asarray([scores[i][m] for i in ids], float)
    h = np.asarray([human[i] for i in ids], float)
    out[m] = {"kendall_tau_b": p(stats.kendalltau, x, h), "spearman": p(stats.spearmanr, x, h),
              "pearson": p(stats.pearsonr, x, h)}
# Williams' t-test of each pair of metrics (Williams 1959; Steiger 1980,
# eq. 7) over the rated items that have both, by its definition.
def williams(a, b):
    ids = [i for i in rated if i in scores and scores[i].get(a) is not None
           and scores[i].get(b) is not None]
    n = len(ids)
    h = np.asarray([human[i] for i in ids], float)
    x = np.asarray([scores[i][a] for i in ids], float)
    y = np.asarray([scores[i][b] for i in ids], float)
    row = {"n": n, "t": None, "p_value": None}
    if n < 4 or min(np.ptp(h), np.ptp(x), np.ptp(y)) == 0:
        return row
    r12, r13, r23 = (float(stats.pearsonr(u, v).statistic) for u, v in ((x, h), (y, h), (x, y)))
    K = 1 - r12**2 - r13**2 - r23**2 + 2 * r12 * r13 * r23
    if max(abs(r12), abs(r13), abs(r23)) >= 1 or K <= 0:
        return row
    t = (r12 - r13) * math.sqrt((n - 1) * (1 + r23)) / math.sqrt(
        2 * K * (n - 1) / (n - 3) + ((r12 + r13) ** 2 / 4) * (1 - r23) ** 3)
    row.update(t=t, p_value=float(2 * stats.t.sf(abs(t), n - 3)))
    return row
tests = {f"{a}_vs_{b}": williams(a, b) for k, a in enumerate(ref.METRICS) for b in ref.METRICS[k + 1:]}
# Holm (1979): the sorted p-values times m, m - 1, ..., 1; each adjusted
# value the largest of those up to it, at most 1.
family = sorted((row["p_value"], name) for name, row in tests.items() if row["p_value"] is not None)
largest = 0.0
for k, (pv, name) in enumerate(family):
    largest = max(largest, min(1.0, (len(family) - k) * pv))
    tests[name]["p_holm"] = largest
for row in tests.values():
    row.setdefault("p_holm", None)
print(json.dumps({"p_values": out, "williams": {"holm_family": len(family), "pairs": tests}},
                 indent=1, sort_keys=True))
"""


def reference_p_values(python, paths):
    """scipy's p-values of each metric's column, as `agree` forms them, and
    Williams' test of each pair of metrics: {p_values, williams}."""
    run = subprocess.run([python, "-c", P_VALUES, os.path.dirname(REFERENCE), SCIPY, *paths],
                         capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"the p-value reference failed: {run.stderr.strip()}")
    return json.loads(run.stdout)


def close_relative(ref, ours, path, problems):
    """p-values: null where scipy has none, else within 1e-9 relative."""
    for m, row in ref["p_values"].items():
        for k, v in row.items():
            got = ours.get("metrics", {}).get(m, {}).get("p_values", {}).get(k, "<missing>")
            relative(v, got, f"{path}.{m}.p_values.{k}", problems)
    williams = ours.get("williams", {})
    if williams.get("holm_family") != ref["williams"]["holm_family"]:
        problems.append(f"{path}.williams.holm_family: {williams.get('holm_family')!r} "
                        f"!= {ref['williams']['holm_family']!r}")
    for pair, row in ref["williams"]["pairs"].items():
        got = williams.get("pairs", {}).get(pair, {})
        if got.get("n") != row["n"]:
            problems.append(f"{path}.williams.{pair}.n: {got.get('n')!r} != {row['n']!r}")
        for k in ("t", "p_value", "p_holm"):
            relative(row[k], got.get(k, "<missing>"), f"{path}.williams.{pair}.{k}", problems)


def relative(v, got, path, problems):
    """One value: null where the reference has none, else within 1e-9 relative."""
    if v is None:
        if got is not None:
            problems.append(f"{path}: {got!r}, the reference has none")
    elif not isinstance(got, (int, float)) or abs(got - v) > 1e-9 * abs(v):
        problems.append(f"{path}: {got!r} != {v!r}")
METRICS = ["pg2s", "s_plan", "s_goal", "kas"]
KINDS = ["drop", "reorder", "object-swap"]


def case(rng, n, annotators, *, grid=10, kas_missing=0.2, constant=None,
         constant_human=False, unscored=0.0, share=0.7):
    items, scores, lines = [], [], []
    sources = [f"t{i}" for i in range(n)]
    for i, sid in enumerate(sources):
        items.append({"id": sid, "gt": ["A."], "pred": ["B."]})
        if rng.random() < 0.5 and n > 1:
            kind = rng.choice(KINDS)
            items.append({"id": f"{sid}~{kind}", "gt": ["A."], "pred": ["C."],
                          "source": sid, "corruption": {"kind": kind, "seed": 0, "edits": []}})
    t = 1700000000
    for it in items:
        if rng.random() < unscored:
            continue
        s = {"id": it["id"]}
        for m in METRICS:
            v = round(rng.randrange(grid + 1) / grid, 6)
            if m == constant:
                v = 0.5
            if m == "kas" and rng.random() < kas_missing:
                v = None
            s[m] = v
        scores.append(s)
        for a in annotators:
            if rng.random() > share:
                continue
            t += 1
            # constant_human: every item's mean is 3, the ratings are not all 3
            level = lambda: (2 if annotators.index(a) % 2 == 0 else 4) if constant_human else rng.randint(1, 5)
            r = level()
            lines.append({"item": it["id"], "annotator": a, "rating": r, "at": t})
            if rng.random() < 0.15:  # superseded
                t += 1
                lines.append({"item": it["id"], "annotator": a,
                              "rating": level(), "at": t})
            if rng.random() < 0.05 and not constant_human:  # withdrawn
                t += 1
                lines.append({"item": it["id"], "annotator": a, "withdrawn": True, "at": t})
    if annotators:
        lines.append({"item": "no-such-item", "annotator": annotators[0], "rating": 2, "at": t + 1})
    return items, scores, lines


def close(ref, ours, path, problems):
    if isinstance(ref, dict):
        if not isinstance(ours, dict):
            problems.append(f"{path}: {ours!r} is not an object")
            return
        for k, v in ref.items():
            close(v, ours.get(k, "<missing>"), f"{path}.{k}", problems)
    elif isinstance(ref, list):
        if ref != ours:
            problems.append(f"{path}: {ours!r} != {ref!r}")
    elif ref is None:
        if ours is not None:
            problems.append(f"{path}: {ours!r}, the reference has null")
    elif isinstance(ref, int):  # counts: exactly
        if type(ours) is not int or ref != ours:
            problems.append(f"{path}: {ours!r} != {ref!r}")
    else:
        if not isinstance(ours, (int, float)) or abs(float(ours) - float(ref)) > 1e-9:
            problems.append(f"{path}: {ours!r} != {ref!r}")


def main():
    python = sys.argv[1]
    if len(sys.argv) > 3 and sys.argv[2] == "--golden-fixture":
        parts = [GOLDEN + p for p in ("items.jsonl", "scores.jsonl", "annotations.jsonl")]
        with open(sys.argv[3], "w") as f:
            ref = reference_p_values(python, parts)
            f.write(json.dumps({"scipy": SCIPY, "metrics": ref["p_values"], "williams": ref["williams"]},
                               indent=1, sort_keys=True) + "\n")
        return
    mapvlm = sys.argv[2] if len(sys.argv) > 2 and not sys.argv[2].startswith("--") else os.path.join(ROOT, "target", "release", "mapvlm")
    rng = random.Random(20261201)
    three = ["ana", "bo", "chen"]
    five = three + ["dee", "eli"]
    cases = {
        "ties": dict(n=40, annotators=three, grid=4),
        "fine": dict(n=120, annotators=three, grid=1000, share=0.5),
        "one_item": dict(n=1, annotators=three),
        "two_items": dict(n=2, annotators=["ana", "bo"], share=1.0),
        "constant_metric": dict(n=25, annotators=three, constant="s_goal"),
        "constant_human": dict(n=25, annotators=["ana", "bo"], constant_human=True, share=1.0),
        "one_annotator": dict(n=30, annotators=["ana"]),
        "unscored": dict(n=30, annotators=three, unscored=0.3, kas_missing=0.6),
        "large": dict(n=600, annotators=three, grid=20, share=0.6),
        # Metric values without ties; few items can also have human means
        # without ties (tau-b's exact p-value), more cannot (asymptotic).
        "distinct_small": dict(n=4, annotators=five, grid=10**9, share=1.0),
        "distinct_large": dict(n=60, annotators=five, grid=10**9, share=0.8),
        "three_items": dict(n=3, annotators=three, share=1.0),
    }
    failed = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name, spec in cases.items():
            items, scores, lines = case(rng, **spec)
            paths = {}
            for part, rows in (("items", items), ("scores", scores), ("annotations", lines)):
                paths[part] = os.path.join(tmp, f"{name}.{part}.jsonl")
                with open(paths[part], "w") as f:
                    f.writelines(json.dumps(r) + "\n" for r in rows)
            ref = subprocess.run([python, REFERENCE, paths["items"], paths["scores"], paths["annotations"]],
                                 capture_output=True, text=True)
            if ref.returncode != 0:
                print(f"{name}: the reference failed ({ref.stderr.strip().splitlines()[-1]}); skipped")
                continue
            ours = subprocess.run([mapvlm, "agree", "--items", paths["items"], "--scores", paths["scores"],
                                   "--annotations", paths["annotations"], "--json", "--bootstrap", "200",
                                   "--permutations", "200"], capture_output=True, text=True)
            problems = []
            try:
                doc = json.loads(ours.stdout)
                close(json.loads(ref.stdout), doc, name, problems)
                p_ref = reference_p_values(python, [paths["items"], paths["scores"], paths["annotations"]])
                close_relative(p_ref, doc, name, problems)
            except json.JSONDecodeError:
                problems.append(f"{name}: not JSON: {ours.stderr.strip()}")
            failed += bool(problems)
            print(f"{name}: {'ok' if not problems else 'DIFFERS'}")
            for p in problems:
                print("  " + p)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
