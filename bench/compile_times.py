#!/usr/bin/env python3
"""Compile time of translation units under other optimisation / debug flags (README.md, "How long the test command
takes"): each unit's own command line from BUILD/compile_commands.json with its -O/-g flags replaced by each variant in
turn, compiled to a scratch object, wall seconds printed.

Usage: python3 bench/compile_times.py BUILD UNIT... [--variants "-O2 -g|-O2|-O1 -g|-O1 -g1"]
UNIT: a path ending as in compile_commands.json (e.g. src/cli/cmd_render.cpp). BUILD: any configured build (only its
compile_commands.json is read; its own -O and -g flags are taken out before each variant's go in).
"""
import json
import re
import subprocess
import sys
import tempfile
import time


def main():
    args = sys.argv[1:]
    variants = ["-O2 -g", "-O2", "-O1 -g", "-O1 -g1"]
    if "--variants" in args:
        i = args.index("--variants")
        variants = args[i + 1].split("|")
        del args[i:i + 2]
    if len(args) < 2:
        sys.exit(__doc__)
    build, units = args[0], args[1:]
    commands = json.load(open(f"{build}/compile_commands.json"))
    totals = [0.0] * len(variants)
    print("unit | " + " | ".join(variants))
    with tempfile.TemporaryDirectory() as scratch:
        for unit in units:
            entry = next((c for c in commands if c["file"].endswith(unit)), None)
            if entry is None:
                sys.exit(f"{unit}: not in {build}/compile_commands.json")
            base = re.sub(r" -o \S+", f" -o {scratch}/unit.o", entry["command"]).replace(" -Werror", "")
            base = re.sub(r" -O\d| -g\d?(?=\s)", "", base)
            row = []
            for k, flags in enumerate(variants):
                t = time.time()
                subprocess.run(base + " " + flags, shell=True, cwd=entry["directory"], check=True)
                row.append(time.time() - t)
                totals[k] += row[-1]
            print(unit + " | " + " | ".join(f"{s:.1f} s" for s in row), flush=True)
    print("sum | " + " | ".join(f"{s:.1f} s" for s in totals))


if __name__ == "__main__":
    main()
