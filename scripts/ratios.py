#!/usr/bin/env python3
"""Equal-time ratios from the compare runs: for every scene under docs/results,
the final relMSE and MAE of product relative to radiance (and to pt when pt ran);
with `--roulette CLASSIC_ROOT ADRRS_ROOT`, each guided method's error under ADRRS
relative to classic roulette, and pt's (the same settings in both parts) as the
control for the drift between the parts.

Two ratios per metric, because relMSE on these scenes is dominated by a few
firefly pixels and one unlucky run can move a mean by 2x:
- "means": ratio of the per-method means over runs (what an average user sees);
- "geo": ratio of geometric means (mean of log errors), robust to one outlier run;
  with its 1-sigma factor from the spread of the log errors of both methods,
  sqrt(var_p/n_p + var_r/n_r), shown as x/ f.
Where every run recorded it (curves.csv from 2026-11-30 on), relMSE without the worst
0.1 % of pixels is compared too: a relMSE ratio it does not share is a few fireflies.
Numbers come only from the CSV files (each run's final row). What each run's image
holds comes from the plan lines of the scene's summary.md: a guided run whose strategy
trial handed its budget to path tracing images path-tracing passes alone, and a ratio
between two such runs measures the trials' cost, not guiding. Every row says how many
runs did so. Prints markdown."""
import csv
import math
import os
import re
import sys

scenes = ["cornell-box", "veach-mis", "veach-ajar", "staircase", "living-room"]


def finals(path):
    last = {}
    for r in csv.DictReader(open(path)):
        last[(r["method"], r["run"])] = r  # rows are in time order per run
    out = {}
    for (m, _), r in last.items():
        trimmed = r.get("relmse_trimmed") or None
        out.setdefault(m, []).append(
            (float(r["relmse"]), float(r["mae"]), float(trimmed) if trimmed else None)
        )
    return out


# The plan-line phrases of src/guiding/trial.rs (FALLBACK_IMAGE, the
# product's switch to radiance weights, and GUIDING_KEPT).
PT_IMAGE = "the image holds path tracing's passes alone"
RADIANCE_WEIGHTS = "product weights do not pay here"
FALLBACK_DECLINED = "a fallback would discard more guided work than it saves"


def plan_outcomes(scene_dir):
    """Per method: (runs, runs imaged by path tracing alone, product runs that
    switched to radiance weights, runs that kept guiding although path
    tracing led their trial), from the plan lines of summary.md."""
    out = {}
    path = os.path.join(scene_dir, "summary.md")
    if not os.path.exists(path):
        return out
    for line in open(path):
        m = re.match(r"- (?:`[^`]*`: )?(\w+), seed \d+: plan: ", line)
        if not m:
            continue
        runs, pt, radiance, declined = out.get(m.group(1), (0, 0, 0, 0))
        out[m.group(1)] = (
            runs + 1,
            pt + (PT_IMAGE in line),
            radiance + (RADIANCE_WEIGHTS in line),
            declined + (FALLBACK_DECLINED in line),
        )
    return out


def trial_notes(outcomes, method):
    """Runs of the method whose trial the footnote explains: imaged by path
    tracing alone, or declining a fallback."""
    _, pt, _, declined = outcomes.get(method, (0, 0, 0, 0))
    return pt + declined


def imaged(outcomes, method):
    """'k/n' runs of the method imaged by path tracing alone, with the runs
    that declined a fallback ('—' without plan lines)."""
    runs, pt, _, declined = outcomes.get(method, (0, 0, 0, 0))
    if not runs:
        return "—"
    return f"{pt}/{runs}" + (f" ({declined} declined)" if declined else "")


FALLBACK_NOTE = (
    "*pt-imaged*: runs whose strategy trial measured that guiding does not pay and handed the rest "
    "of the budget to path tracing with NEE, so that their image holds path tracing's passes alone "
    "(their plan lines say so). Where every run of both methods did, the ratio compares path "
    "tracing with path tracing and measures what the trials cost, not guiding; `docs/results-240s.md` "
    "runs every method as such throughout. *declined*: runs whose trial measured path tracing the "
    "more efficient but kept guiding, because a fallback would discard more guided work than the rest "
    "of the budget recovers."
)


def mean(xs):
    return sum(xs) / len(xs)


def ratios(a, b):
    """(ratio of means, ratio of geometric means, 1-sigma factor of the latter)."""
    la, lb = [math.log(x) for x in a], [math.log(x) for x in b]

    def var(xs):
        m = mean(xs)
        return sum((x - m) ** 2 for x in xs) / (len(xs) - 1) if len(xs) > 1 else float("nan")

    sigma = math.sqrt(var(la) / len(la) + var(lb) / len(lb))
    return mean(a) / mean(b), math.exp(mean(la) - mean(lb)), math.exp(sigma)


def cell(a, b):
    if any(x is None for x in a + b):
        return "— | —"
    means, geo, f = ratios(a, b)
    spread = f"{geo:.2f} x/ {f:.2f}" if math.isfinite(f) else f"{geo:.2f}"
    return f"{means:.2f} | {spread}"


def product_vs_radiance(root):
    print("| scene | runs | pt-imaged: radiance; product | relMSE product/radiance: means | geo | relMSE w/o worst 0.1 % product/radiance: means | geo | MAE product/radiance: means | geo | relMSE product/pt: means | geo |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    any_fallback = False
    for s in scenes:
        p = os.path.join(root, s, "curves.csv")
        if not os.path.exists(p):
            continue
        f = finals(p)
        if not all(m in f for m in ("radiance", "product")):
            continue
        col = lambda m, i: [v[i] for v in f[m]]
        n = min(len(f["product"]), len(f["radiance"]))
        vs_pt = cell(col("product", 0), col("pt", 0)) if "pt" in f else "— | —"
        plans = plan_outcomes(os.path.join(root, s))
        any_fallback |= any(trial_notes(plans, m) for m in ("radiance", "product"))
        print(
            f"| {s} | {n} | {imaged(plans, 'radiance')}; {imaged(plans, 'product')} | "
            f"{cell(col('product', 0), col('radiance', 0))} | "
            f"{cell(col('product', 2), col('radiance', 2))} | "
            f"{cell(col('product', 1), col('radiance', 1))} | {vs_pt} |"
        )
    if any_fallback:
        print()
        print(FALLBACK_NOTE)


def roulette_vs_classic(classic_root, adrrs_root):
    """Per scene and guided method: ADRRS's final error over classic's."""
    print("| scene | method | runs | pt-imaged: classic; adrrs | relMSE adrrs/classic: means | geo | MAE adrrs/classic: means | geo |")
    print("|---|---|---|---|---|---|---|---|")
    any_fallback = False
    for s in scenes:
        a, c = (os.path.join(r, s, "curves.csv") for r in (adrrs_root, classic_root))
        if not (os.path.exists(a) and os.path.exists(c)):
            continue
        fa, fc = finals(a), finals(c)
        pa, pc = (plan_outcomes(os.path.dirname(x)) for x in (a, c))
        # pt has Mitsuba's roulette in both parts: the control row.
        for m, label in (("pt", "pt (control)"), ("radiance", "radiance"), ("product", "product")):
            if m in fa and m in fc:
                col = lambda f, i: [v[i] for v in f[m]]
                n = min(len(fa[m]), len(fc[m]))
                fallbacks = f"{imaged(pc, m)}; {imaged(pa, m)}" if m != "pt" else "—"
                any_fallback |= m != "pt" and trial_notes(pa, m) + trial_notes(pc, m) > 0
                print(
                    f"| {s} | {label} | {n} | {fallbacks} | {cell(col(fa, 0), col(fc, 0))} | "
                    f"{cell(col(fa, 1), col(fc, 1))} |"
                )
    if any_fallback:
        print()
        print(
            FALLBACK_NOTE
            + " A pt-imaged run renders its path-tracing passes with classic roulette in both parts, "
            "so its row says what the trial cost under each roulette, not what ADRRS does."
        )


if len(sys.argv) == 4 and sys.argv[1] == "--roulette":
    roulette_vs_classic(sys.argv[2], sys.argv[3])
else:
    product_vs_radiance(sys.argv[1] if len(sys.argv) > 1 else "docs/results")
