#!/usr/bin/env bash
# Confirms that the 16-wide child kernels compile to 512-bit (zmm) code for
# an AVX-512 CPU, on any x86-64 host: the library and every dependency are
# built for CPU (default znver4) with --emit asm, and the zmm and ymm
# operands of each kernel's functions are counted. `wide` picks its f32x16
# implementation from the target features it is compiled with, so the
# whole graph must be built for CPU, not the library alone; with --target,
# the flags reach the target's code only, so build scripts and proc macros
# still run on this host. Nothing is run, so the host needs no AVX-512.
#
# Usage: scripts/zmm_check.sh [CPU]
# Exits 1 when the kernel has no zmm operand although CPU has AVX-512F.
set -euo pipefail
cd "$(dirname "$0")/.."
CPU=${1:-znver4}
TARGET=x86_64-unknown-linux-gnu
DIR=target/zmm-check/$CPU
# Only this build's assembly may be counted.
rm -f "$DIR/$TARGET/release/deps/"ltcguide-*.s
cargo --config "build.rustflags=[\"-C\",\"target-cpu=$CPU\"]" rustc --release --lib --quiet \
  --target "$TARGET" --target-dir "$DIR" -- --emit asm
AVX512=$(rustc --print cfg -C target-cpu="$CPU" | grep -c 'target_feature="avx512f"' || true)
python3 - "$DIR/$TARGET/release/deps" "$CPU" "$AVX512" <<'EOF'
import collections, glob, os, sys
deps, cpu, avx512 = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
files = glob.glob(os.path.join(deps, "ltcguide-*.s"))
if not files:
    sys.exit(f"zmm_check: no assembly under {deps}")
zmm, ymm = collections.Counter(), collections.Counter()
for f in files:
    symbol = None
    for line in open(f):
        if line.startswith("_ZN") and line.rstrip().endswith(":"):
            symbol = line.strip()[:-1]
        elif symbol:
            zmm[symbol] += "%zmm" in line
            ymm[symbol] += "%ymm" in line
kernels = ["children_x16", "coarse_children_x16", "stokes_children_x16",
           "clipped_small_children", "edge_z_soa", "child_integrals"]
print(f"target-cpu={cpu} (AVX-512F: {'yes' if avx512 else 'no'}): lines with a zmm / ymm operand")
for k in kernels:
    z = sum(v for s, v in zmm.items() if k in s)
    y = sum(v for s, v in ymm.items() if k in s)
    print(f"  {k:24s} {z:6d} {y:6d}")
main = sum(v for s, v in zmm.items() if "children_x16" in s)
if avx512 and main == 0:
    sys.exit("zmm_check: the 16-wide kernel has no zmm operand on an AVX-512 target")
EOF
