#!/usr/bin/python3
"""The spread layer against particle size and adhesion: the whole powder job (settle the heap,
spread it) of examples/powder_bed/powder_bed.yaml at its fast setting, with the size
distribution scaled by each factor s and the surface energy set, one run per pair.

  /usr/bin/python3 bench/layer_vs_size.py OUT_DIR [--sweep ./build/sweep] \
      [--scales 0.5,0.75,1] [--surface-energies 0,1e-4] [--seeds 1] [--gap-ratio R] \
      [--threads 1] [--jobs 2]

Each scale multiplies the diameters (30/40/50 um by mass 0.3/0.4/0.3) by s and the grain count
(3 500) by 1 / s^3, so that every run spreads the same volume of powder through the same gap
(100 um) over the same plate; the step (1e-4 s) is multiplied by s, so that the blade moves
the same fraction of a grain per step. The layer's metrics come from each run's layer.json
(docs/powder_bed.md, "Layer metrics"): packing fraction, coverage, the surface height's mean
and standard deviation (its roughness) and the grains in the window. With several seeds (the
generator's `seed`: the sizes drawn and the heap's packing) each row is the mean and the sample
standard deviation over them. --gap-ratio R sets the gap to R mean diameters (40 um times s)
instead of the fixed 100 um, so that every size spreads a layer of the same depth in grains.
"""
import argparse
import concurrent.futures
import json
import os
import statistics
import subprocess
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "examples/powder_bed/powder_bed.yaml")
FAST = os.path.join(ROOT, "examples/powder_bed/fast.yaml")


def run(sweep, out, scale, surface_energy, threads, seed, gap_ratio):
    diameters = ", ".join("%.6g" % (d * scale) for d in (30e-6, 40e-6, 50e-6))
    command = [sweep, "run", SCENE, "--set-file", FAST, "--out", out, "--quiet",
               "--threads", str(threads),
               "--set", "generators[0].sizes={kind: discrete, diameters: [%s], "
                        "mass_fractions: [0.3, 0.4, 0.3]}" % diameters,
               "--set", "generators[0].count=%d" % round(3500 / scale ** 3),
               "--set", "generators[0].surface_energy=%g" % surface_energy,
               "--set", "time.step=%g" % (1e-4 * scale),
               "--set", "output.vtk_interval=0",
               "--set", "generators[0].seed=%d" % seed]
    if gap_ratio is not None:
        command += ["--set", "generators[0].gap=%g" % (gap_ratio * 40e-6 * scale)]
    start = time.time()
    subprocess.run(command, check=True, capture_output=True, text=True)
    wall = time.time() - start
    with open(os.path.join(out, "layer.json")) as f:
        layer = json.load(f)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return {"scale": scale, "surface_energy": surface_energy, "seed": seed, "wall": wall,
            "cpu": summary.get("cpu_seconds", float("nan")), "layer": layer}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--sweep", default=os.path.join(ROOT, "build/sweep"))
    parser.add_argument("--scales", default="0.5,0.75,1")
    parser.add_argument("--surface-energies", default="0,1e-4")
    parser.add_argument("--seeds", default="1")
    parser.add_argument("--gap-ratio", type=float, default=None,
                        help="gap in mean diameters (default: the scene's 100 um)")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2, help="runs at once")
    args = parser.parse_args()
    cases = [(float(s), float(g)) for s in args.scales.split(",")
             for g in args.surface_energies.split(",")]
    seeds = [int(k) for k in args.seeds.split(",")]
    os.makedirs(args.out, exist_ok=True)
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(run, args.sweep,
                               os.path.join(args.out, "s%g_g%g_seed%d" % (case + (seed,))),
                               case[0], case[1], args.threads, seed, args.gap_ratio)
                   for case in cases for seed in seeds]
        results = [f.result() for f in futures]
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1)

    def spread(values, digits, scale=1.0):
        mean = statistics.mean(values) * scale
        if len(values) < 2:
            return "%.*f" % (digits, mean)
        return "%.*f +- %.*f" % (digits, mean, digits, statistics.stdev(values) * scale)

    print("| mean diameter (um) | gap (um) | grains | surface energy (J/m^2) | seeds "
          "| packing fraction | coverage | surface height: mean / std (um) | grains in window "
          "| CPU per run (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for scale, energy in cases:
        rows = [r for r in results if r["scale"] == scale and r["surface_energy"] == energy]
        layers = [r["layer"] for r in rows]
        gap = 100.0 if args.gap_ratio is None else args.gap_ratio * 40 * scale
        print("| %.0f | %.0f | %d | %g | %d | %s | %s | %s / %s | %s | %.1f |" % (
            40 * scale, gap, round(3500 / scale ** 3), energy, len(rows),
            spread([l["packing_fraction"] for l in layers], 3),
            spread([l["coverage"] for l in layers], 2),
            spread([l["height"]["mean"] for l in layers], 1, 1e6),
            spread([l["height"]["std"] for l in layers], 1, 1e6),
            spread([l["particles"] for l in layers], 0),
            statistics.mean([r["cpu"] for r in rows])))


if __name__ == "__main__":
    main()
