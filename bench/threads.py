#!/usr/bin/python3
"""Strong scaling: each case run with 1 thread and with N, alternating, side by side in one
invocation; wall times (the least of --repeat runs), the stages' split of the first run
(stats.csv's t_* columns, summed), and a check that both thread counts end in the same
final_state.csv, bit for bit. Then, per case and stage (and the whole step), the serial fraction
that Amdahl's law gives from the two times, f = (N / S - 1) / (N - 1) for a speed-up S on N
threads, and what it predicts on 16 threads, 1 / (f + (1 - f) / 16). On a machine whose cores
are shared the fraction is an upper bound: noise only lowers S.

  /usr/bin/python3 bench/threads.py [--threads 2] [--repeat 1] [--cases funnel_50,...]
      [--funnel-state F50K.csv] [--powder-state SETTLED.csv] [--wide-state SETTLED_X10.csv]
      [--pile-state PILE_X12.csv] [--pile-copies 12] [--set path=value ...]

The cases that start from a saved state need it (docs/benchmarks.md, "Threads", gives the
commands that make them); the others run as they are. On a machine with more cores, pass
--threads 4, 8, ... (one count per invocation, always against 1). Each --set goes to every run
(e.g. --set scheme.normal_stage.solver=mprgp --set scheme.friction_stage.solver=mprgp).
"""
import argparse
import csv
import filecmp
import json
import os
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FUNNEL = os.path.join(ROOT, "examples", "funnel", "funnel.yaml")
POWDER = os.path.join(ROOT, "examples", "powder_bed", "powder_bed.yaml")
FAST = os.path.join(ROOT, "examples", "powder_bed", "fast.yaml")
REDUCED = os.path.join(ROOT, "examples", "powder_bed", "powder_bed_reduced.yaml")
PILE_2D = os.path.join(ROOT, "bench", "scenes", "touching_pile_2d.yaml")
# the pile at 0.06 s holds a few overlaps deeper than a restart accepts (a step at the cap):
# the check is switched off, the state taken as it is
FUNNEL_50K = ["--set", "generators[0].count=50000", "--set", "generators[0].orifice=0.0803",
              "--set", "detection.max_initial_overlap=-1"]


def cases(args):
    out = {
        "funnel_50 moreau-jean": [FUNNEL, "--scheme", "moreau-jean"],
        "funnel_50 catching-up": [FUNNEL, "--scheme", "catching-up"],
    }
    if "pile_2d" in args.cases.split(","):
        # 80 000 touching disks at rest, 20 steps at tolerance 1e-6; Jean-Moreau 5 steps, each
        # at its 3 000-sweep cap
        out["pile_2d catching-up"] = [PILE_2D]
        out["pile_2d moreau-jean"] = [PILE_2D, "--scheme", "moreau-jean", "--t-end", "5e-4"]
    if args.funnel_state:
        for scheme in ("moreau-jean", "catching-up"):
            out[f"funnel_50000 {scheme}"] = [
                FUNNEL, "--scheme", scheme, *FUNNEL_50K, "--initial-state", args.funnel_state,
                "--t-end", str(args.funnel_t_end)]
    if args.powder_state:
        out["powder pass moreau-jean"] = [POWDER, "--initial-state", args.powder_state,
                                          "--set-file", FAST]
    if args.pile_state:
        for scheme in ("moreau-jean", "catching-up"):
            out[f"pile_{800 * args.pile_copies} {scheme}"] = [
                REDUCED, "--scheme", scheme, "--set",
                f"generators[0].copies_across={args.pile_copies}", "--initial-state",
                args.pile_state, "--t-end", "0.0122", "--set", "scheme.coulomb.tolerance=1e-6",
                "--set", "scheme.normal_stage.tolerance=1e-6",
                "--set", "scheme.friction_stage.tolerance=1e-6"]
    if args.wide_state:
        out["wide bed moreau-jean"] = [POWDER, "--initial-state", args.wide_state,
                                       "--set-file", FAST,
                                       "--set", "generators[0].copies_across=10"]
    return out


def run(sweep, argv, out, threads, settings):
    subprocess.run([sweep, "run", argv[0], "--out", out, "--quiet", "--threads", str(threads),
                    "--set", "output.vtk_interval=0", *argv[1:],
                    *[item for setting in settings for item in ("--set", setting)]], check=True,
                   stdout=subprocess.DEVNULL)
    with open(os.path.join(out, "summary.json")) as f:
        wall = json.load(f)["wall_seconds"]
    with open(os.path.join(out, "stats.csv")) as f:
        rows = list(csv.DictReader(f))
    split = [sum(float(r[k]) for r in rows) for k in ("t_detect", "t_assemble", "t_solve",
                                                      "t_update")]
    return wall, split


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sweep", default=os.path.join(ROOT, "build", "sweep"))
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--cases", default="")
    parser.add_argument("--funnel-state")
    parser.add_argument("--funnel-t-end", type=float, default=0.065)
    parser.add_argument("--powder-state")
    parser.add_argument("--wide-state")
    parser.add_argument("--pile-state")
    parser.add_argument("--pile-copies", type=int, default=12,
                        help="copies of the reduced bed's heap in --pile-state (12: 9 600 spheres)")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        help="a scene setting for every run")
    args = parser.parse_args()
    chosen = cases(args)
    if args.cases:
        chosen = {k: v for k, v in chosen.items() if k.split()[0] in args.cases.split(",")}
    scratch = tempfile.mkdtemp(prefix="sweep_threads_bench_")
    n = args.threads
    print(f"| case | 1 thread: wall (s) | {n} threads: wall (s) | speed-up | "
          f"detect / assemble / solve / update (s), 1 thread | same bits |")
    print("|---|---|---|---|---|---|")
    fractions = []
    for name, argv in chosen.items():
        best = {1: float("inf"), n: float("inf")}
        split, least = {}, {}
        for k in range(args.repeat):
            for threads in (1, n):
                out = os.path.join(scratch, f"{name.replace(' ', '_')}_{threads}")
                wall, parts = run(args.sweep, argv, out, threads, args.set)
                best[threads] = min(best[threads], wall)
                split.setdefault(threads, parts)
                least[threads] = [min(a, b) for a, b in zip(least.get(threads, parts), parts)]
        fractions.append((name, least, best))
        same = filecmp.cmp(os.path.join(scratch, f"{name.replace(' ', '_')}_1", "final_state.csv"),
                           os.path.join(scratch, f"{name.replace(' ', '_')}_{n}",
                                        "final_state.csv"), shallow=False)
        parts = " / ".join(f"{x:.2f}" for x in split[1])
        print(f"| {name} | {best[1]:.3f} | {best[n]:.3f} | {best[1] / best[n]:.2f} | {parts} | "
              f"{'yes' if same else 'NO'} |", flush=True)
    print(f"\n| case | stage | 1 thread (s) | {n} threads (s) | speed-up | serial fraction | "
          "predicted on 16 threads |")
    print("|---|---|---|---|---|---|---|")
    for name, least, best in fractions:
        stages = ["detect", "assemble", "solve", "update"]
        rows = list(zip(stages, least[1], least[n])) + [("step (wall)", best[1], best[n])]
        for stage, one, many in rows:
            if one <= 0.0 or many <= 0.0:
                continue
            speedup = one / many
            serial = min(max((n / speedup - 1.0) / (n - 1.0), 0.0), 1.0)
            predicted = 1.0 / (serial + (1.0 - serial) / 16.0)
            print(f"| {name} | {stage} | {one:.3f} | {many:.3f} | {speedup:.2f} | {serial:.3f} | "
                  f"{predicted:.1f} |")


if __name__ == "__main__":
    main()
