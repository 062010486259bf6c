#!/usr/bin/env bash
# Lists the functions of a built binary that execute 512-bit floating-point
# instructions (arithmetic, comparisons, conversions; not moves, broadcasts,
# shuffles or integer work), and checks that none of them is on the
# per-vertex path of a render.
#
# Why: on Intel cores any such instruction lowers the core's clock for a
# while after it, and one per shading point keeps a whole render at the
# lower clock (docs/results-reading.md, session 63). A build with the
# `ymm-kernels` feature is meant to have none on that path; the default
# build has them in the wide LTC kernels by design.
#
# Usage: scripts/zmm_fp_ops.sh [BINARY]   (default target/release/ltcguide)
# Exits 1 when a per-vertex function has one.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${1:-target/release/ltcguide}
LISTING=$(mktemp)
trap 'rm -f "$LISTING"' EXIT
objdump -d --no-show-raw-insn -C "$BIN" >"$LISTING"
python3 - "$LISTING" <<'EOF'
import collections, re, sys
fp = re.compile(r"^v(fn?m(add|sub)|mul|add|sub|div|sqrt|cmp|max|min|rcp|rsqrt|round|rndscale|cvt|getexp|getmant|scalef|range|reduce)\w*$")
# Functions a render runs at every path vertex (or every kernel call).
per_vertex = re.compile(r"ltcguide::(ltc::(children|coarse|quad|parallel|level1|quarter_sphere|form_factor|simd|fast_math|lobe|sphere_clip)"
                        r"|guiding::(descent|product|guide|defensive|adrrs)|integrator::|accel::|bsdf::|texture::|emitter::)")
counts = collections.Counter()
function = None
for line in open(sys.argv[1]):
    m = re.match(r"^[0-9a-f]+ <(.*)>:$", line)
    if m:
        function = m.group(1)
        continue
    if function is None or "%zmm" not in line:
        continue
    parts = line.split("\t")
    if len(parts) < 2:
        continue
    mnemonic = parts[1].split()[0] if parts[1].split() else ""
    if fp.match(mnemonic):
        counts[function] += 1
hot = []
print("functions with 512-bit floating-point instructions (count, name):")
for name, n in counts.most_common():
    mark = per_vertex.search(name) is not None
    hot += [name] if mark else []
    print(f"  {n:5d} {'PER-VERTEX ' if mark else ''}{name[:110]}")
if hot:
    print(f"{len(hot)} per-vertex function(s) use 512-bit floating point")
    sys.exit(1)
print("no per-vertex function uses 512-bit floating point")
EOF
