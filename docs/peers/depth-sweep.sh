#!/usr/bin/env bash
# Where Lucent's time per sample lies against Mitsuba 3's SIMD backend, by path depth: both
# render the same Cornell scene at max depth 0, 1, 2, 3, 5 and 7 (Mitsuba's max_depth one
# more, as speed.sh pairs them; Russian roulette from bounce 5 in both), alternating, and the
# script prints each one's time per sample and what each added depth adds to it. Lucent's
# samples/s are the ones it prints for its render (no loading), Mitsuba's its render call
# after a warm-up. Timing only; needs the Mitsuba environment of ../shared/peers (setup.sh).
#   bash docs/peers/depth-sweep.sh target/release/lucent [cornell-box|cornell-box-glass] [SPP]
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
bin=${1:?usage: depth-sweep.sh LUCENT_BINARY [scene] [spp]}; scene=${2:-cornell-box}; spp=${3:-128}
peers=${PEERS:-$repo/../shared/peers}
venv=${PEERS_VENV:-$(dirname "$(mktemp -u)")/peers-venv}
[ -x "$venv/bin/python" ] || { echo "depth-sweep: run bash $peers/setup.sh first" >&2; exit 1; }
out=$(mktemp -d); trap 'rm -rf "$out"' EXIT
depths=(0 1 2 3 5 7); rates=()
for d in "${depths[@]}"; do
  l=$("$bin" render "$peers/../scenes/$scene.gltf" --spp "$spp" --width 256 --height 256 --max-depth "$d" \
      --rr-depth 5 --out "$out/l.exr" 2>&1 | sed -n 's/.* \([0-9.]*\) Msamples\/s.*/\1/p')
  m=$("$venv/bin/python" "$peers/run_mitsuba.py" --scene "$scene" --variant llvm_ad_rgb --spp "$spp" \
      --spp-per-pass 64 --max-depth $((d + 1)) --warmup --out "$out/m.exr" | tail -1 |
      python3 -c "import json,sys; print(json.load(sys.stdin)['samples_per_sec']/1e6)")
  rates+=("$d:$l:$m")
done
python3 - "$scene" "${rates[@]}" <<'PY'
import sys
print(f"{sys.argv[1]}: ns of the machine's time per sample, and what each depth adds to the one before")
print(f"{'depth':>5} {'Lucent Ms/s':>12} {'Mitsuba Ms/s':>13} {'Lucent ns':>10} {'Mitsuba ns':>11} {'Lucent +ns':>11} {'Mitsuba +ns':>12} {'ratio':>6}")
pl = pm = 0.0
for row in sys.argv[2:]:
    d, l, m = row.split(":")
    nl, nm = 1e3 / float(l), 1e3 / float(m)
    print(f"{d:>5} {float(l):>12.3f} {float(m):>13.3f} {nl:>10.1f} {nm:>11.1f} {nl - pl:>11.1f} {nm - pm:>12.1f} {(nl - pl) / (nm - pm):>6.2f}")
    pl, pm = nl, nm
PY
