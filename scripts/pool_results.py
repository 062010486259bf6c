#!/usr/bin/env python3
"""Adds runs to a committed results page without rendering its old runs again.

    scripts/pool_results.py PAGE NEW_ROOT [BIN]

PAGE is a page written by scripts/results.sh (docs/results.md or
docs/results-240s.md), whose comparisons live in docs/<page>/<scene>/.
NEW_ROOT holds comparisons of some of those scenes, one folder per scene,
rendered with the page's settings and new seeds, e.g. for the 240 s page:

    for scene in staircase veach-ajar; do
      ltcguide compare ../shared/scenes/$scene --reference ../shared/scenes/$scene/reference.exr \
        --time 240 --runs 3 --first-run 3 --methods pt,radiance,product --nee paper \
        --side-by-side --no-plan --out NEW_ROOT/$scene
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
import subprocess
import sys
from datetime import datetime, timezone

from page_text import body, with_note, write_page

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
RATIOS_HEADING = "## Equal-time ratios"
MARK = "Runs added by `scripts/pool_results.py`"


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    os.chdir(ROOT)
    page, new_root = sys.argv[1], sys.argv[2]
    binary = sys.argv[3] if len(sys.argv) > 3 else "target/release/ltcguide"
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
    if text.count(RATIOS_HEADING) != 1:
        sys.exit(f"{page}: no single '{RATIOS_HEADING}' section; nothing written")
    added = []
    for scene in scenes:
        folder = os.path.join(page_dir, scene)
        new = os.path.join(new_root, scene)
        subprocess.run([binary, "merge", "--out", folder, folder, new], check=True,
                       stdout=subprocess.DEVNULL)
        text = text.replace(olds[scene], body(open(os.path.join(folder, "summary.md")).read()), 1)
        budget = next(l for l in open(os.path.join(new, "summary.md")) if l.startswith("Budget "))
        seeds = budget.split("runs per method (")[1].split(")")[0]
        added.append(f"{scene} ({seeds})")
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
    note = (f"{MARK} at ltcguide {commit} on {when}: {', '.join(added)}, rendered with this page's "
            f"settings by `compare --first-run` and pooled with the earlier runs by `ltcguide merge`; "
            f"those scenes' tables, curves and time-to-error figures, and the ratio table, are "
            f"computed from all their runs.\n")
    write_page(page, with_note(text, note))
    print(f"{page}: {', '.join(added)} pooled")


if __name__ == "__main__":
    main()
