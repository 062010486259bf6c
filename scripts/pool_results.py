#!/usr/bin/env python3
"""Adds runs to a committed results page without rendering its old runs again.

    scripts/pool_results.py PAGE NEW_ROOT [BIN]
    scripts/pool_results.py --replace [--rendered-at COMMIT] PAGE NEW_ROOT [BIN]

With --replace, NEW_ROOT's comparisons are not pooled with the page's but
take their place, for a scene rendered again after a change to the renderer
(the page's runs of that scene would mix two builds). The new comparison
must have the page's budget, methods and path settings; the note under the
header says which scenes were replaced and at which commit they were
rendered (--rendered-at; by default the current one).

PAGE is a page written by scripts/results.sh (docs/results.md or
docs/results-240s.md), whose comparisons live in docs/<page>/<scene>/.
NEW_ROOT holds comparisons of some of those scenes, one folder per scene,
rendered with the page's settings and new seeds (--first-run K past the runs
the page's budget lines name), e.g. for the 240 s page:

    for scene in staircase veach-ajar; do
      ltcguide compare ../shared/scenes/$scene --reference ../shared/scenes/$scene/reference.exr \
        --time 240 --clock cpu --runs 2 --first-run 5 --methods pt,radiance,product \
        --nee paper --side-by-side --no-plan --out NEW_ROOT/$scene
    done

For each scene of NEW_ROOT, `ltcguide merge` pools the page's comparison and
the new one into the page's folder (it refuses different budgets, methods or
settings, and any seed twice); the page's body for that scene is replaced by
the pooled summary's, the ratio table is recomputed by scripts/ratios.py from
the pooled CSVs, and a note under the header says what was added, when and at
which commit. Every body must be found exactly once in the page before
anything is merged; nothing is edited by hand.
"""
import os
import re
import shutil
import subprocess
import sys
from datetime import datetime, timezone

from page_text import body, with_note, write_page

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
RATIOS_HEADING = "## Equal-time ratios"
MARK = "Runs added by `scripts/pool_results.py`"
REPLACED = "Runs replaced by `scripts/pool_results.py --replace`"


def without_pooled_runs_of(text, scenes):
    """The page with `scenes` taken out of the notes of earlier pooling and replacing (those runs
    are gone once the scenes are replaced again); a note left with no scene is removed."""
    out = []
    lines = text.splitlines(keepends=True)
    skip_blank = False
    for line in lines:
        if skip_blank:
            skip_blank = False
            if line == "\n":
                continue
        if line.startswith((MARK, REPLACED)):
            head, rest = line.split(": ", 1)
            listed, tail = rest.split(", rendered ", 1)
            kept = [item for item in re.findall(r"[^,]+ \(seeds [^)]*\)", listed)
                    if item.strip().split(" (")[0] not in scenes]
            if not kept:
                skip_blank = True
                continue
            line = f"{head}: {', '.join(k.strip() for k in kept)}, rendered {tail}"
        out.append(line)
    return "".join(out)


def settings_lines(summary_text):
    """The lines of a summary that must agree for two comparisons to stand for one another:
    the budget and layout (without the run count and seeds), and the path settings."""
    lines = summary_text.splitlines()
    budget = re.sub(r", \d+ runs? per method \([^)]*\)", "",
                    next(l for l in lines if l.startswith("Budget ")))
    path = next(l for l in lines if l.startswith("Path settings:"))
    rows = lines[lines.index(next(l for l in lines if l.startswith("| method |"))) + 2:]
    methods = [l.split("|")[1].strip() for l in rows[:rows.index("")] if l.startswith("| ")]
    return budget, path, methods


def reference_of(summary_text):
    """The reference fingerprint of a summary's hidden study line (summaries written
    before session 44 have none: None)."""
    m = re.search(r"<!-- ltcguide study:.*?reference=([^;>]*?)\s*(?:;|-->)", summary_text)
    return m.group(1).strip() if m else None


def main():
    args = sys.argv[1:]
    replace = "--replace" in args
    args = [a for a in args if a != "--replace"]
    rendered_at = None
    if "--rendered-at" in args:
        i = args.index("--rendered-at")
        if not replace or i + 1 >= len(args):
            sys.exit(__doc__)
        rendered_at = args[i + 1]
        del args[i:i + 2]
    if len(args) not in (2, 3):
        sys.exit(__doc__)
    os.chdir(ROOT)
    page, new_root = args[0], args[1]
    binary = args[2] if len(args) > 2 else "target/release/ltcguide"
    page_dir = os.path.splitext(page)[0]
    text = open(page).read()
    scenes = sorted(d for d in os.listdir(new_root)
                    if os.path.exists(os.path.join(new_root, d, "curves.csv")))
    if not scenes:
        sys.exit(f"{new_root}: no comparison folders")
    olds = {}
    for scene in scenes:
        folder = os.path.join(page_dir, scene)
        if not os.path.exists(os.path.join(folder, "summary.md")):
            sys.exit(f"{folder}: the page has no comparison of {scene}; nothing written")
        old = body(open(os.path.join(folder, "summary.md")).read())
        if text.count(old) != 1:
            sys.exit(f"{page}: the summary of {folder} occurs {text.count(old)} times; nothing written")
        olds[scene] = old
        if replace:
            mine = settings_lines(open(os.path.join(folder, "summary.md")).read())
            theirs = settings_lines(open(os.path.join(new_root, scene, "summary.md")).read())
            if mine != theirs:
                sys.exit(f"{scene}: the new comparison's settings differ from the page's "
                         f"({theirs} against {mine}); nothing written")
            # `merge` checks this when pooling; a replacement must be measured
            # against the same reference too, where both summaries recorded it.
            refs = [reference_of(open(os.path.join(d, "summary.md")).read())
                    for d in (folder, os.path.join(new_root, scene))]
            if None not in refs and refs[0] != refs[1]:
                sys.exit(f"{scene}: the new comparison's reference ({refs[1]}) is not the page's "
                         f"({refs[0]}); nothing written")
    if text.count(RATIOS_HEADING) != 1:
        sys.exit(f"{page}: no single '{RATIOS_HEADING}' section; nothing written")
    added = []
    for scene in scenes:
        folder = os.path.join(page_dir, scene)
        new = os.path.join(new_root, scene)
        if replace:
            shutil.rmtree(folder)
            shutil.copytree(new, folder)
        else:
            subprocess.run([binary, "merge", "--out", folder, folder, new], check=True,
                           stdout=subprocess.DEVNULL)
        text = text.replace(olds[scene], body(open(os.path.join(folder, "summary.md")).read()), 1)
        budget = next(l for l in open(os.path.join(new, "summary.md")) if l.startswith("Budget "))
        seeds = budget.split("runs per method (")[1].split(")")[0]
        added.append(f"{scene} ({seeds})")
    if replace:
        text = without_pooled_runs_of(text, scenes)
    # The ratio table: from its heading to the next section.
    start = text.index(RATIOS_HEADING)
    end = text.find("\n## ", start + 1)
    end = len(text) if end < 0 else end + 1
    heading = text[start:text.index("\n", start) + 1]
    ratios = subprocess.run([sys.executable, "scripts/ratios.py", page_dir], check=True,
                            capture_output=True, text=True).stdout
    text = text[:start] + heading + "\n" + ratios + "\n" + text[end:]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip() or "unknown"
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    if replace:
        note = (f"{REPLACED} at ltcguide {commit} on {when}: {', '.join(added)}, rendered again "
                f"with this page's settings at ltcguide {rendered_at or commit}; their earlier runs "
                f"were left out, and the ratio table is recomputed.\n")
    else:
        note = (f"{MARK} at ltcguide {commit} on {when}: {', '.join(added)}, rendered with this "
                f"page's settings by `compare --first-run` and pooled with the earlier runs by "
                f"`ltcguide merge`; those scenes' tables, curves and time-to-error figures, and the "
                f"ratio table, are computed from all their runs.\n")
    write_page(page, with_note(text, note))
    print(f"{page}: {', '.join(added)} {'replaced' if replace else 'pooled'}")


if __name__ == "__main__":
    main()
