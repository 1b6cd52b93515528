#!/usr/bin/python3
"""The spread layer against particle size and adhesion: the whole powder job (settle the heap,
spread it) of examples/powder_bed/powder_bed.yaml at its fast setting, with the size
distribution scaled by each factor s and the surface energy set, one run per pair.

  /usr/bin/python3 bench/layer_vs_size.py OUT_DIR [--sweep ./build/sweep] \
      [--scales 0.5,0.75,1] [--surface-energies 0,1e-4] [--threads 1] [--jobs 2]

Each scale multiplies the diameters (30/40/50 um by mass 0.3/0.4/0.3) by s and the grain count
(3 500) by 1 / s^3, so that every run spreads the same volume of powder through the same gap
(100 um) over the same plate; the step (1e-4 s) is multiplied by s, so that the blade moves
the same fraction of a grain per step. The layer's metrics come from each run's layer.json
(docs/powder_bed.md, "Layer metrics"): packing fraction, coverage, the surface height's mean
and standard deviation (its roughness) and the grains in the window.
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "examples/powder_bed/powder_bed.yaml")
FAST = os.path.join(ROOT, "examples/powder_bed/fast.yaml")


def run(sweep, out, scale, surface_energy, threads):
    diameters = ", ".join("%.6g" % (d * scale) for d in (30e-6, 40e-6, 50e-6))
    command = [sweep, "run", SCENE, "--set-file", FAST, "--out", out, "--quiet",
               "--threads", str(threads),
               "--set", "generators[0].sizes={kind: discrete, diameters: [%s], "
                        "mass_fractions: [0.3, 0.4, 0.3]}" % diameters,
               "--set", "generators[0].count=%d" % round(3500 / scale ** 3),
               "--set", "generators[0].surface_energy=%g" % surface_energy,
               "--set", "time.step=%g" % (1e-4 * scale),
               "--set", "output.vtk_interval=0"]
    start = time.time()
    subprocess.run(command, check=True, capture_output=True, text=True)
    wall = time.time() - start
    with open(os.path.join(out, "layer.json")) as f:
        layer = json.load(f)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return {"scale": scale, "surface_energy": surface_energy, "wall": wall,
            "cpu": summary.get("cpu_seconds", float("nan")), "layer": layer}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--sweep", default=os.path.join(ROOT, "build/sweep"))
    parser.add_argument("--scales", default="0.5,0.75,1")
    parser.add_argument("--surface-energies", default="0,1e-4")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2, help="runs at once")
    args = parser.parse_args()
    cases = [(float(s), float(g)) for s in args.scales.split(",")
             for g in args.surface_energies.split(",")]
    os.makedirs(args.out, exist_ok=True)
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(run, args.sweep, os.path.join(args.out, "s%g_g%g" % case),
                               case[0], case[1], args.threads) for case in cases]
        results = [f.result() for f in futures]
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    print("| mean diameter (um) | grains | surface energy (J/m^2) | packing fraction | coverage "
          "| surface height: mean / std (um) | grains in window | CPU (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in results:
        layer = r["layer"]
        print("| %.0f | %d | %g | %.3f | %.2f | %.1f / %.1f | %d | %.1f |" % (
            40 * r["scale"], round(3500 / r["scale"] ** 3), r["surface_energy"],
            layer["packing_fraction"], layer["coverage"], layer["height"]["mean"] * 1e6,
            layer["height"]["std"] * 1e6, layer["particles"], r["cpu"]))


if __name__ == "__main__":
    main()
