"""Text helpers shared by the scripts that rewrite committed results pages
(replot_pages.py, pool_results.py)."""
import os


def body(summary_text):
    """What results.sh and roulette_study.sh copy of a summary: all but its first two lines."""
    return "".join(summary_text.splitlines(keepends=True)[2:])


def with_note(text, note, mark=None):
    """The page with `note` as a paragraph of its own at the end of the preamble (before the
    first section); earlier notes starting with `mark` are removed, with the blank line each
    brought."""
    lines = text.splitlines(keepends=True)
    if mark is not None:
        for i in reversed([i for i, l in enumerate(lines) if l.startswith(mark)]):
            del lines[i:i + 2 if i + 1 < len(lines) and lines[i + 1] == "\n" else i + 1]
    at = next((i for i, l in enumerate(lines) if l.startswith("## ")), len(lines))
    lines[at:at] = [note, "\n"]
    return "".join(lines)


def write_page(page, text):
    """Replaces the page in one step, so that an interrupted run leaves the old page."""
    tmp = page + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, page)
