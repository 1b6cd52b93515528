#!/usr/bin/python3
"""Tiles a saved state (final_state.csv) of a periodic bed of free bodies across the periodic
axis, for a scene built with `copies_across: N` (docs/powder_bed.md, "The wide bed").

A state that is periodic with period W is also periodic with period N W, so N copies of a
settled heap side by side are a settled heap N times as wide, without settling it again. The
copies start identical and part through the seams between them (the solve visits the copies
in turn), so they are not N independent realisations.

Every moving body must be a free body (q: 3 position + 4 quaternion, v: 6), as in the
powder_bed generator, and the scene's bodies must be the saved ones repeated N times.

    /usr/bin/python3 scripts/tile_state.py settled/final_state.csv --copies 10 \
        --width 0.4e-3 --out settled_wide.csv
"""
import argparse
import math
import os
import sys
import tempfile

AXES = {"x": 0, "y": 1, "z": 2}


def fail(message):
    print("tile_state.py: " + message, file=sys.stderr)
    sys.exit(2)


def read_state(path):
    try:
        with open(path) as f:
            lines = f.read().splitlines()
    except OSError as error:
        fail(f"{path}: cannot read the saved state ({error.strerror})")
    if not lines or lines[0] != "vector,index,value":
        fail(f"{path}:1: expected the header 'vector,index,value' of a final_state.csv")
    vectors = {"t": {}, "q": {}, "v": {}}
    for number, line in enumerate(lines[1:], start=2):
        if not line:
            continue
        parts = line.split(",")
        if len(parts) != 3 or parts[0] not in vectors:
            fail(f"{path}:{number}: expected 't|q|v,index,value', got '{line[:80]}'")
        try:
            index, value = int(parts[1]), float(parts[2])
        except ValueError:
            fail(f"{path}:{number}: '{line[:80]}' is not 'vector,index,number'")
        if not math.isfinite(value):
            fail(f"{path}:{number}: {parts[0]}[{index}] = {parts[2]} is not finite")
        if index in vectors[parts[0]]:
            fail(f"{path}:{number}: {parts[0]}[{index}] is given twice")
        # keep the text: the copies carry the saved digits, not a reprinted value
        vectors[parts[0]][index] = (value, parts[2])
    for name in ("q", "v"):
        if sorted(vectors[name]) != list(range(len(vectors[name]))):
            fail(f"{path}: the {name} indices are not 0..{len(vectors[name]) - 1}")
    if 0 not in vectors["t"]:
        fail(f"{path}: no 't' row (the time of the state)")
    return vectors


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("state", help="final_state.csv of the one-copy scene")
    parser.add_argument("--copies", type=int, required=True, help="copies_across of the scene")
    parser.add_argument("--width", type=float, required=True,
                        help="the one-copy period (the generator's width), m")
    parser.add_argument("--axis", default="z", choices=sorted(AXES), help="the periodic axis")
    parser.add_argument("--out", required=True, help="the tiled state to write")
    args = parser.parse_args()
    if args.copies < 1:
        fail(f"--copies {args.copies} must be >= 1")
    if not (math.isfinite(args.width) and args.width > 0.0):
        fail(f"--width {args.width} must be > 0")

    state = read_state(args.state)
    nq, nv = len(state["q"]), len(state["v"])
    bodies = nq // 7
    if nq % 7 != 0 or nv != 6 * bodies or bodies == 0:
        fail(f"{args.state}: nq = {nq}, nv = {nv} are not those of free bodies only "
             "(7 and 6 per body)")
    axis = AXES[args.axis]
    rows = ["vector,index,value", "t,0," + state["t"][0][1]]
    for copy in range(args.copies):
        for index in range(nq):
            value, text = state["q"][index]
            if index % 7 == axis and copy > 0:
                text = repr(value + copy * args.width)
            rows.append(f"q,{copy * nq + index},{text}")
    for copy in range(args.copies):
        for index in range(nv):
            rows.append(f"v,{copy * nv + index},{state['v'][index][1]}")

    # written completely or not at all
    folder = os.path.dirname(os.path.abspath(args.out))
    partial = None
    try:
        with tempfile.NamedTemporaryFile("w", dir=folder, delete=False, suffix=".part") as f:
            partial = f.name
            f.write("\n".join(rows) + "\n")
        os.replace(partial, args.out)
    except OSError as error:
        if partial is not None and os.path.exists(partial):
            os.remove(partial)
        fail(f"{args.out}: cannot write the tiled state ({error.strerror})")
    print(f"{args.out}: {args.copies} copies of {bodies} bodies, {args.axis} shifted by "
          f"{args.width:g} m per copy")


if __name__ == "__main__":
    main()
