#!/usr/bin/env python3
"""Layer studies of the powder-bed spreader (issue #8, docs/powder_bed.md): the reduced scene
examples/powder_bed/powder_bed_reduced.yaml run by `sweep run` for a list of variants
(gap 150 vs 100 um, blade speed 0.05 vs 0.1 m/s, rough vs flat plate, time steps, schemes)
and several seeds each. Writes OUT/study.csv (one row per run: variant, seed, layer metrics,
CPU time), OUT/study.md (mean and standard deviation per variant) and OUT/study.png.

  /usr/bin/python3 examples/powder_bed/study.py --out results/powder_study --seeds 1,2,3 \
      --variants base,gap150,slow,rough --jobs 2

Everything after `--` goes to every `sweep run`.
"""
import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# name: (label, --set overrides)
VARIANTS = {
    "base": ("blade, flat plate, gap 100 um, 0.1 m/s", []),
    "gap150": ("gap 150 um", ["generators[0].gap=150e-6", "output.layer.gap=150e-6"]),
    "slow": ("blade at 0.05 m/s", ["generators[0].speed=0.05", "time.end=0.052"]),
    "rough": ("rough plate", ["generators[0].plate=rough"]),
    "roller": ("counter-rotating roller", ["generators[0].spreader=roller"]),
    # the roller's spin (its default is counter-rotating at speed / radius = 400 rad/s): not
    # turning (1e-12: 0 picks the default), rolling forward, and counter-rotating 3x faster
    "roller-still": ("roller, not turning",
                     ["generators[0].spreader=roller", "generators[0].roller_spin=1e-12"]),
    "roller-forward": ("roller, rolling forward (-400 rad/s)",
                       ["generators[0].spreader=roller", "generators[0].roller_spin=-400"]),
    "roller-fast": ("roller, counter-rotating at 1200 rad/s",
                    ["generators[0].spreader=roller", "generators[0].roller_spin=1200"]),
    # is the roller denser on the full scene because its heap stands above the roller's
    # axis? The reduced scene's 800 grains on a 0.275 mm footprint stand as high as the full
    # heap (about 0.4 mm); a roller of radius 30 um has its axis below the reduced heap's top
    "tall": ("blade, tall heap", ["generators[0].heap_length=0.275e-3"]),
    "roller-tall": ("counter-rotating roller, tall heap",
                    ["generators[0].spreader=roller", "generators[0].heap_length=0.275e-3"]),
    "roller-small": ("counter-rotating roller, radius 30 um",
                     ["generators[0].spreader=roller", "generators[0].roller_radius=0.03e-3"]),
    # IQS at h = 1e-4 with and without candidate screening (scheme.screening), and screened
    # at looser tolerances: the whole-candidate residual counts the open candidates in its
    # scale, the screened one does not (docs/powder_bed.md, "Candidate screening")
    "iqs-h1e-4": ("IQS, h = 1e-4", ["scheme.normal_law=iqs", "time.step=1e-4"]),
    "screened": ("IQS, h = 1e-4, screened",
                 ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true"]),
    "screened-3e-3": ("IQS, h = 1e-4, screened, tolerance 3e-3",
                      ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true",
                       "scheme.coulomb.tolerance=3e-3"]),
    "screened-1e-2": ("IQS, h = 1e-4, screened, tolerance 1e-2",
                      ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true",
                       "scheme.coulomb.tolerance=1e-2"]),
    # the same with the detection margin at 1.25 times the fastest speed (detection.
    # verify_margin, on by default, detects again when the end speeds outrun it), and looser
    "fast": ("IQS, h = 1e-4, screened, tolerance 1e-2, margin 1.25 h v",
             ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true",
              "scheme.coulomb.tolerance=1e-2", "detection.speed_factor=1.25"]),
    # the faster setting of powder_bed.yaml's header: the same with the residual every 5
    # sweeps, and under-relaxed (docs/powder_bed.md, "Under-relaxation")
    "fast5": ("the same, residual every 5 sweeps",
              ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true",
               "scheme.coulomb.tolerance=1e-2", "detection.speed_factor=1.25",
               "scheme.coulomb.residual_check_interval=5"]),
    "fast5-0.9": ("the same, relaxation 0.9",
                  ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true",
                   "scheme.coulomb.tolerance=1e-2", "detection.speed_factor=1.25",
                   "scheme.coulomb.residual_check_interval=5", "scheme.coulomb.relaxation=0.9"]),
    # and with the balls' margin from their relative speeds (detection.margin_rule), on
    # body-form rows rather than the compact sphere rows of scheme A's default
    "fast5-rel": ("the same, relative ball margins, body-form rows",
                  ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true",
                   "scheme.coulomb.tolerance=1e-2", "detection.speed_factor=1.25",
                   "scheme.coulomb.residual_check_interval=5", "scheme.coulomb.relaxation=0.9",
                   "detection.margin_rule=relative", "--row-storage=body-form"]),
    # and with the contacts of free spheres in compact rows (--row-storage compact)
    "fast5-compact": ("the same, compact sphere rows",
                      ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true",
                       "scheme.coulomb.tolerance=1e-2", "detection.speed_factor=1.25",
                       "scheme.coulomb.residual_check_interval=5",
                       "scheme.coulomb.relaxation=0.9", "detection.margin_rule=relative",
                       "--row-storage=compact"]),
    "fast-3e-2": ("the same at tolerance 3e-2",
                  ["scheme.normal_law=iqs", "time.step=1e-4", "scheme.screening=true",
                   "scheme.coulomb.tolerance=3e-2", "detection.speed_factor=1.25"]),
    "h5e-6": ("h = 5e-6 s", ["time.step=5e-6"]),
    "h2e-5": ("h = 2e-5 s", ["time.step=2e-5"]),
    "h1e-6": ("h = 1e-6 s", ["time.step=1e-6"]),
    "catching-up": ("staggered scheme", ["scheme.name=catching-up"]),
    # the staggered scheme at the tolerance the Jean-Moreau studies use (1e-4), and with its
    # friction stage cut to 150 sweeps (it hits the 1500 cap on most steps either way)
    "catching-up-1e-4": ("staggered, tolerance 1e-4",
                         ["scheme.name=catching-up", "scheme.normal_stage.tolerance=1e-4",
                          "scheme.friction_stage.tolerance=1e-4"]),
    "catching-up-cap150": ("staggered, 5b cap 150",
                           ["scheme.name=catching-up", "scheme.normal_stage.tolerance=1e-4",
                            "scheme.friction_stage.tolerance=1e-4",
                            "scheme.friction_stage.max_iterations=150"]),
    # the staggered scheme as the powder notes run it (both stages NNCG at 1e-3), with the
    # contacts stage 5a leaves open guarded in stage 5b (the default) or free
    "catching-up-1e-3": ("staggered, tolerance 1e-3",
                         ["scheme.name=catching-up", "scheme.normal_stage.tolerance=1e-3",
                          "scheme.friction_stage.tolerance=1e-3",
                          "scheme.normal_stage.acceleration=nncg",
                          "scheme.friction_stage.acceleration=nncg"]),
    "catching-up-free": ("staggered, tolerance 1e-3, open contacts free",
                         ["scheme.name=catching-up", "scheme.normal_stage.tolerance=1e-3",
                          "scheme.friction_stage.tolerance=1e-3",
                          "scheme.normal_stage.acceleration=nncg",
                          "scheme.friction_stage.acceleration=nncg",
                          "scheme.open_contacts=free"]),
    "pos": ("Jean-Moreau with the POS law", ["scheme.normal_law=pos"]),
    # Jean's quasi-shock law: every candidate in the solve, the gap closed at most
    "iqs": ("Jean-Moreau with the IQS law", ["scheme.normal_law=iqs"]),
    "rough-iqs": ("rough plate, IQS law", ["generators[0].plate=rough", "scheme.normal_law=iqs"]),
    # Jean-Moreau's sweeps with and without the NNCG momentum (docs/powder_bed.md, "NNCG"; the
    # examples use it)
    "nncg": ("Jean-Moreau, NNCG sweeps", ["scheme.coulomb.acceleration=nncg"]),
    "plain": ("Jean-Moreau, plain sweeps", ["scheme.coulomb.acceleration=none"]),
    "rough-nncg": ("rough plate, NNCG sweeps",
                   ["generators[0].plate=rough", "scheme.coulomb.acceleration=nncg"]),
    # run time against error: the stopping tolerance of Jean-Moreau's solve (pass no other
    # tolerance after `--`, it would override these)
    "tol1e-2": ("tolerance 1e-2", ["scheme.coulomb.tolerance=1e-2"]),
    "tol3e-3": ("tolerance 3e-3", ["scheme.coulomb.tolerance=3e-3"]),
    "tol1e-3": ("tolerance 1e-3", ["scheme.coulomb.tolerance=1e-3"]),
    "tol3e-4": ("tolerance 3e-4", ["scheme.coulomb.tolerance=3e-4"]),
    "tol1e-4": ("tolerance 1e-4", ["scheme.coulomb.tolerance=1e-4"]),
    "tol1e-5": ("tolerance 1e-5", ["scheme.coulomb.tolerance=1e-5"]),
}
METRICS = ["packing_fraction", "effective_depth_over_gap", "solid_thickness", "coverage"]


def run(args, variant, seed):
    run_dir = os.path.join(args.out, f"{variant}_s{seed}")
    if not (args.reuse and os.path.exists(os.path.join(run_dir, "layer.json"))):
        command = [args.sweep, "run", args.scene, "--out", run_dir, "--quiet",
                   "--set", f"generators[0].seed={seed}"]
        for override in VARIANTS[variant][1]:
            # a leading "--" is a command-line option (--row-storage), the rest scene fields
            command += override.split("=", 1) if override.startswith("--") else ["--set", override]
        command += args.extra
        print(" ".join(command), flush=True)
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    with open(os.path.join(run_dir, "layer.json")) as f:
        layer = json.load(f)
    with open(os.path.join(run_dir, "summary.json")) as f:
        summary = json.load(f)
    row = {"variant": variant, "seed": seed, "cpu_seconds": summary["cpu_seconds"],
           "cap_hit_steps": summary["iterations"]["cap_hit_steps"],
           "highest_top": layer["height"]["highest_top"],
           "height_std": layer["height"]["std"], "cell_std": layer["cell_packing"]["std"],
           "sweeps_mean": summary["iterations"]["mean"],
           "penetration_peak": summary["penetration"]["peak"]}
    for m in METRICS:
        row[m] = layer[m]
    # over the volume a rough plate's spheres leave free (runs older than the metric: blank)
    row["free_volume_packing_fraction"] = layer.get("free_volume_packing_fraction", "")
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="results/powder_study")
    parser.add_argument("--sweep", default=os.path.join(ROOT, "build", "sweep"))
    parser.add_argument("--scene", default=os.path.join(ROOT, "examples", "powder_bed",
                                                        "powder_bed_reduced.yaml"))
    parser.add_argument("--variants", default="base,gap150,slow,rough")
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--no-plot", action="store_true")
    parser.add_argument("--reuse", action="store_true", help="keep runs already in OUT")
    parser.add_argument("extra", nargs="*", help="options passed to every sweep run")
    args = parser.parse_args()
    variants = args.variants.split(",")
    for v in variants:
        if v not in VARIANTS:
            sys.exit(f"study.py: unknown variant '{v}' (one of {', '.join(VARIANTS)})")
    seeds = [int(s) for s in args.seeds.split(",")]
    os.makedirs(args.out, exist_ok=True)
    jobs = [(v, s) for v in variants for s in seeds]
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(lambda job: run(args, *job), jobs))

    fields = list(rows[0].keys())
    with open(os.path.join(args.out, "study.csv.partial"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    os.replace(os.path.join(args.out, "study.csv.partial"), os.path.join(args.out, "study.csv"))

    lines = ["| variant | runs | packing fraction | depth / gap | coverage | sweeps per step | "
             "peak penetration (um) | CPU s |",
             "|---|---|---|---|---|---|---|---|"]
    summary = {}
    for v in variants:
        mine = [r for r in rows if r["variant"] == v]
        def stat(key):
            values = [r[key] for r in mine]
            sd = statistics.stdev(values) if len(values) > 1 else 0.0
            return statistics.mean(values), sd
        summary[v] = {k: stat(k) for k in METRICS + ["cpu_seconds", "sweeps_mean"]}
        p, d, c, t, n = (summary[v][k] for k in ["packing_fraction", "effective_depth_over_gap",
                                                 "coverage", "cpu_seconds", "sweeps_mean"])
        pen = max(r["penetration_peak"] for r in mine) * 1e6
        lines.append(f"| {VARIANTS[v][0]} | {len(mine)} | {p[0]:.3f} +- {p[1]:.3f} | "
                     f"{d[0]:.2f} +- {d[1]:.2f} | {c[0]:.2f} +- {c[1]:.2f} | {n[0]:.0f} | "
                     f"{pen:.2f} | {t[0]:.1f} |")
    with open(os.path.join(args.out, "study.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))

    if args.no_plot:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for i, v in enumerate(variants):
        values = [r["packing_fraction"] for r in rows if r["variant"] == v]
        ax.scatter([i] * len(values), values, color="tab:blue", s=18)
        ax.errorbar([i + 0.15], [summary[v]["packing_fraction"][0]],
                    yerr=[summary[v]["packing_fraction"][1]], fmt="o", color="black")
    ax.set_xticks(range(len(variants)))
    ax.set_xticklabels([VARIANTS[v][0] for v in variants], rotation=20, ha="right", fontsize=8)
    ax.set_ylabel("packing fraction of the layer")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "study.png"), dpi=130)


if __name__ == "__main__":
    main()
