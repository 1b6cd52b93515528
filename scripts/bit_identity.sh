#!/usr/bin/env bash
# Runs a fixed set of scenes that between them take every solver path of both schemes (packed
# 2D rows, 3D rows in entry, body and sphere form, rolling rows, bilateral constraints, every
# stage solver, NNCG, the friction stage's modes) and prints one line per run: the SHA-256 of
# its final_state.csv and of its stats.csv (timings off). A change that must not move a bit
# (a refactor) is checked by running this with the build before and after and diffing:
#   scripts/bit_identity.sh ./build-before/sweep > before.txt
#   scripts/bit_identity.sh ./build/sweep > after.txt && diff before.txt after.txt
set -euo pipefail
cd "$(dirname "$0")/.."
sweep="$(realpath "${1:-./build/sweep}")"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

run() {  # NAME SCENE [ARGS...]
  local name="$1" scene="$2"
  shift 2
  local out="$work/$name"
  "$sweep" run "$scene" --out "$out" --quiet --threads "${THREADS:-1}" \
    --set output.vtk_interval=0 --set output.timings=false "$@" > /dev/null
  printf '%-44s %s %s\n' "$name" "$(sha256sum < "$out/final_state.csv" | cut -c1-16)" \
    "$(sha256sum < "$out/stats.csv" | cut -c1-16)"
}

for scheme in moreau-jean catching-up; do
  for scene in examples/archetypes/*.yaml examples/tutorial/hopper.yaml; do
    run "$(basename "$scene" .yaml)-$scheme" "$scene" --scheme "$scheme"
  done
  run "funnel-$scheme" examples/funnel/funnel.yaml --scheme "$scheme"
  run "arm_and_spheres-$scheme" tests/data/scenes/arm_and_spheres.yaml --scheme "$scheme"
  run "loads_3d-$scheme" tests/data/scenes/loads_3d.yaml --scheme "$scheme"
  run "powder-$scheme" examples/powder_bed/powder_bed_reduced.yaml --scheme "$scheme" \
    --t-end 0.004
  run "powder_fast-$scheme" examples/powder_bed/powder_bed_reduced.yaml --scheme "$scheme" \
    --set-file examples/powder_bed/fast.yaml --t-end 0.01
done
run funnel-nncg examples/funnel/funnel.yaml --scheme moreau-jean \
  --set scheme.coulomb.acceleration=nncg
run funnel-unpacked examples/funnel/funnel.yaml --scheme moreau-jean --row-storage generic
run funnel-relaxed examples/funnel/funnel.yaml --scheme moreau-jean \
  --set scheme.coulomb.relaxation=0.8
run powder-nncg examples/powder_bed/powder_bed_reduced.yaml --scheme moreau-jean --t-end 0.004 \
  --set scheme.coulomb.acceleration=nncg --set scheme.coulomb.local_solver=enumeration
run powder-bodyform examples/powder_bed/powder_bed_reduced.yaml --scheme moreau-jean \
  --t-end 0.004 --row-storage body-form
for solver in nlgs mprgp newton; do
  run "funnel-stages-$solver" examples/funnel/funnel.yaml --scheme catching-up \
    --set "scheme.normal_stage.solver=$solver" --set "scheme.friction_stage.solver=$solver"
  run "powder-stages-$solver" examples/powder_bed/powder_bed_reduced.yaml --scheme catching-up \
    --t-end 0.004 --set "scheme.normal_stage.solver=$solver" \
    --set "scheme.friction_stage.solver=$solver"
  run "arm-stages-$solver" examples/archetypes/arm_on_table.yaml --scheme catching-up \
    --set "scheme.normal_stage.solver=$solver" --set "scheme.friction_stage.solver=$solver"
  run "slider_crank-stages-$solver" examples/archetypes/slider_crank.yaml --scheme catching-up \
    --set "scheme.normal_stage.solver=$solver" --set "scheme.friction_stage.solver=$solver"
done
for tangents in local none; do
  run "funnel-tangents-$tangents" examples/funnel/funnel.yaml --scheme catching-up \
    --set "scheme.tangents=$tangents" --set scheme.friction_stage.solver=nlgs
done
run funnel-metric examples/funnel/funnel.yaml --scheme catching-up --set scheme.threshold=metric \
  --set scheme.friction_stage.solver=nlgs
run funnel-open-free examples/funnel/funnel.yaml --scheme catching-up \
  --set scheme.open_contacts=free --set scheme.friction_stage.solver=nlgs
run funnel-threshold-updates examples/funnel/funnel.yaml --scheme catching-up \
  --set scheme.threshold_updates=2
run funnel-nncg-stages examples/funnel/funnel.yaml --scheme catching-up \
  --set scheme.normal_stage.solver=nlgs --set scheme.friction_stage.solver=nlgs \
  --set scheme.normal_stage.acceleration=nncg --set scheme.friction_stage.acceleration=nncg
run funnel-unpacked-stages examples/funnel/funnel.yaml --scheme catching-up \
  --row-storage generic --set scheme.normal_stage.solver=nlgs \
  --set scheme.friction_stage.solver=nlgs
# rolling resistance: 2D rows (entry form), 3D rows in every form
for scheme in moreau-jean catching-up; do
  run "hopper-rolling-$scheme" examples/tutorial/hopper.yaml --scheme "$scheme" \
    --set contact.rolling_resistance=0.05
  run "arm_and_spheres-rolling-$scheme" tests/data/scenes/arm_and_spheres.yaml \
    --scheme "$scheme" --set contact.rolling_resistance=0.05
done
for solver in nlgs mprgp; do
  run "hopper-rolling-stages-$solver" examples/tutorial/hopper.yaml --scheme catching-up \
    --set contact.rolling_resistance=0.05 --set "scheme.friction_stage.solver=$solver"
  run "arm_and_spheres-rolling-stages-$solver" tests/data/scenes/arm_and_spheres.yaml \
    --scheme catching-up --set contact.rolling_resistance=0.05 \
    --set "scheme.friction_stage.solver=$solver"
done
run powder-rolling-bodyform examples/powder_bed/powder_bed_reduced.yaml --scheme moreau-jean \
  --t-end 0.012 --set generators[0].rolling_resistance=0.1 --row-storage body-form
run powder-rolling-unpacked examples/powder_bed/powder_bed_reduced.yaml --scheme moreau-jean \
  --t-end 0.012 --set generators[0].rolling_resistance=0.1 --row-storage generic
run powder-rolling-spheres examples/powder_bed/powder_bed_reduced.yaml --scheme moreau-jean \
  --t-end 0.012 --set generators[0].rolling_resistance=0.1
for solver in nlgs mprgp; do
  run "powder-rolling-stages-$solver" examples/powder_bed/powder_bed_reduced.yaml \
    --scheme catching-up --t-end 0.012 --set generators[0].rolling_resistance=0.1 \
    --set "scheme.normal_stage.solver=$solver" --set "scheme.friction_stage.solver=$solver"
done
