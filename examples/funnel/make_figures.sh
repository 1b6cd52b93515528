#!/usr/bin/env bash
# The seed's Figures 1-3 for the Hall funnel (docs/funnel.md), from a built tree:
#   examples/funnel/make_figures.sh [OUT_DIR] [extra sweep options, e.g. --set scheme.normal_law=pos]
# Figure 1: snapshots of both schemes at h = 1e-4; Figure 2: CPU time and cumulative
# penetration against h, and CPU time against penetration with the speed-up at equal
# penetration; Figure 3: solver iterations per step at h = 1e-4. Each scheme's run also gets
# view.html, a page that plays it back (sweep view).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
out="${1:-results/funnel}"
shift || true
sweep="$root/build/sweep"
scene="$root/examples/funnel/funnel.yaml"
mkdir -p "$out"

for scheme in moreau-jean catching-up; do
  "$sweep" run "$scene" --scheme "$scheme" --dt 1e-4 --out "$out/$scheme" "$@"
  "$sweep" view "$out/$scheme"  # view.html: the run played back in a browser
done
"$sweep" bench "$scene" --dt 1e-3,5e-4,2e-4,1e-4,5e-5,2e-5,1e-5 --scheme moreau-jean,catching-up \
  --out "$out/bench" "$@"

/usr/bin/python3 "$root/scripts/plot_snapshots.py" "$out/figure1_snapshots.png" --times 0,0.03,0.06 \
  "$out/moreau-jean:Jean-Moreau" "$out/catching-up:staggered (catching-up)"
cp "$out/bench/cpu_and_penetration_vs_dt.png" "$out/figure2a_cpu_and_penetration_vs_dt.png"
cp "$out/bench/cpu_vs_penetration.png" "$out/figure2b_cpu_vs_penetration.png"
cp "$out/bench/iterations_per_step.png" "$out/figure3_iterations_per_step.png"
echo "figures in $out: figure1_snapshots.png figure2a_cpu_and_penetration_vs_dt.png" \
  "figure2b_cpu_vs_penetration.png figure3_iterations_per_step.png; table in $out/bench/bench.csv"
