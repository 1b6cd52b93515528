#!/usr/bin/python3
"""The normal laws and the position projection side by side (issue #47, item 5): overlap at
the end and at its peak, energy above its start, CPU, for each scene, scheme and law.

    /usr/bin/python3 bench/normal_laws.py [--sweep build/sweep] [--cases bin,funnel,...]

Each configuration runs once with --threads 1; runs of one case alternate between laws, so
the CPU ratios within a case are side by side. Prints a Markdown table."""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CASES = {
    # name: (scene, extra settings, t_end)
    "bin": ("tests/data/scenes/bin.yaml", [], 2.0),
    "funnel": ("examples/funnel/funnel.yaml", [], 0.2),
    "powder": ("examples/powder_bed/powder_bed_reduced.yaml",
               ["--set-file", "examples/powder_bed/fast.yaml"], None),
    "arm": ("examples/archetypes/arm_on_table.yaml", [], None),
}
OFF = ["--set", "scheme.projection.max_rounds=0"]  # the 3D scenes' default projects
LAWS = {
    "vel": ["--set", "scheme.normal_law=vel"] + OFF,
    "iqs": ["--set", "scheme.normal_law=iqs"] + OFF,
    "pos": ["--set", "scheme.normal_law=pos"] + OFF,
    "vel + projection": ["--set", "scheme.normal_law=vel", "--set",
                         "scheme.projection.max_rounds=3"],
}


def run(sweep, scene, extra, t_end, scheme, law, out):
    cmd = [sweep, "run", os.path.join(ROOT, scene), "--scheme", scheme, "--threads", "1",
           "--quiet", "--out", out] + extra + LAWS[law]
    if t_end is not None:
        cmd += ["--t-end", str(t_end)]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        return None
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    with open(os.path.join(out, "stats.csv")) as f:
        rows = list(csv.DictReader(f))
    energy = [float(r["kinetic"]) + float(r["potential"]) for r in rows]
    start = summary["energy"]["initial"]
    return {
        "cpu": summary["cpu_seconds"],
        "peak": summary["penetration"]["peak_of_smallest_size"],
        "end": float(rows[-1]["penetration_max"]) / summary["penetration"]["smallest_size"],
        "above": max(energy) - start,
        "cap": summary["iterations"]["cap_hit_steps"],
        "projected": summary["contacts"].get("projection_steps", 0),
        "steps": summary["steps"],
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sweep", default=os.path.join(ROOT, "build", "sweep"))
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--schemes", default="moreau-jean,catching-up")
    parser.add_argument("--laws", default=",".join(LAWS))
    args = parser.parse_args()
    print("| case | scheme | law | overlap at the end (% of smallest size) | peak (%) "
          "| energy above its start (J) | cap-hit steps | projected steps | CPU (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for case in args.cases.split(","):
            scene, extra, t_end = CASES[case]
            for scheme in args.schemes.split(","):
                for law in args.laws.split(","):
                    out = os.path.join(tmp, f"{case}-{scheme}-{law}".replace(" ", "_"))
                    r = run(args.sweep, scene, extra, t_end, scheme, law, out)
                    if r is None:
                        print(f"| {case} | {scheme} | {law} | failed | | | | | |")
                    else:
                        print(f"| {case} | {scheme} | {law} | {100 * r['end']:.3g} | "
                              f"{100 * r['peak']:.3g} | {r['above']:.2g} | {r['cap']} | "
                              f"{r['projected']} of {r['steps']} | {r['cpu']:.3g} |")
                    sys.stdout.flush()


if __name__ == "__main__":
    main()
