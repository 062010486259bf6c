#!/usr/bin/env python3
"""Redraws the committed comparison pages' curves and time-to-error tables from
their runs' curves.csv, and their cost sections from runs.csv where a folder has
one, without rendering again.

For every compare folder of a page (docs/results/<scene>, docs/results-240s/<scene>,
docs/study/{classic,adrrs}/<scene>), runs `ltcguide replot` on it, which rewrites
curves.svg and the summary's time-to-error section from curves.csv. The page holds
each summary's body (all but its first two lines, as results.sh and
roulette_study.sh copy it), so the old body is replaced by the new one; a body
that is not found exactly once in its page stops the script before anything of
that page is written. Each page then says, under its header, that this was done
and at which commit. Nothing else of a page changes: replot rewrites the final-errors
table from the same last rows of curves.csv (so its numbers stay), and the ratios and
plan lines are left alone.

Usage: scripts/replot_pages.py [BIN]   (BIN defaults to target/release/ltcguide)
"""
import os
import subprocess
import sys
from datetime import datetime, timezone

from page_text import body, with_note, write_page

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
PAGES = {
    "docs/results.md": ["docs/results"],
    "docs/results-240s.md": ["docs/results-240s"],
    "docs/study.md": ["docs/study/classic", "docs/study/adrrs"],
}
MARK = "Curves and time-to-error tables redrawn from the runs' `curves.csv` by `scripts/replot_pages.py`"


def main():
    os.chdir(ROOT)
    binary = sys.argv[1] if len(sys.argv) > 1 else "target/release/ltcguide"
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip() or "unknown"
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    for page, roots in PAGES.items():
        if not os.path.exists(page):
            print(f"{page}: absent, skipped", file=sys.stderr)
            continue
        text = open(page).read()
        folders = sorted(os.path.join(r, d) for r in roots if os.path.isdir(r)
                         for d in os.listdir(r)
                         if os.path.exists(os.path.join(r, d, "curves.csv")))
        # Check every body is found once before any folder is rewritten.
        olds = {}
        for f in folders:
            old = body(open(os.path.join(f, "summary.md")).read())
            n = text.count(old)
            if n != 1:
                sys.exit(f"{page}: the summary of {f} occurs {n} times in the page; nothing written")
            olds[f] = old
        for f in folders:
            subprocess.run([binary, "replot", f], check=True)
            new = body(open(os.path.join(f, "summary.md")).read())
            text = text.replace(olds[f], new, 1)
        note = (f"{MARK} (and cost sections from `runs.csv`) at ltcguide {commit} on {when}: "
                f"the runs of a method are averaged at common times, a method reaches an error "
                f"when its curve stays at or below it (a speedup marked ≥ was reached by the "
                f"curve's first point, so it is a lower bound), and a cost section names the runs "
                f"whose image holds path tracing's passes alone, whose spp is not what they "
                f"traced.\n")
        write_page(page, with_note(text, note, MARK))
        print(f"{page}: {len(folders)} comparisons redrawn")


if __name__ == "__main__":
    main()
