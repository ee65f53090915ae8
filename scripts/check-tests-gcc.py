#!/usr/bin/env python3
"""Compiles the unit tests' sources with GCC, front end only (-fsyntax-only -Wall -Wextra -Werror), using the
compile commands of a clang build (default build-asan/, the sanitizer build of scripts/test-all.sh, the only build
that compiles the tests in CI). CI builds the tests with clang alone, so a warning only GCC gives (GCC 12's
-Wunused-result on a (void) cast of a warn_unused_result call broke the developers' default build once) would go
unseen; this finds it in about 150 s on 2 cores without building anything.

Usage: scripts/check-tests-gcc.py [BUILD_DIR]   (exit status 1 and the first errors when a file fails)
"""
import concurrent.futures
import json
import os
import shlex
import subprocess
import sys
import time


def gcc_args(entry):
    args = shlex.split(entry["command"])
    compiler = next(i for i, a in enumerate(args) if a.endswith("clang++"))
    args = ["g++"] + [a for a in args[compiler + 1:] if not a.startswith("-fsanitize")]
    out = args.index("-o")
    del args[out:out + 2]
    if "-c" in args:
        args.remove("-c")
    return args + ["-Wall", "-Wextra", "-Werror", "-fsyntax-only"]


def check(entry):
    r = subprocess.run(gcc_args(entry), cwd=entry["directory"], capture_output=True, text=True)
    return entry["file"], r.returncode, r.stderr


def main():
    build = sys.argv[1] if len(sys.argv) > 1 else "build-asan"
    commands = json.load(open(os.path.join(build, "compile_commands.json")))
    tests = [c for c in commands if "/tests/" in c["file"] and c["file"].endswith(".cpp")]
    if not tests:
        sys.exit(f"{build}/compile_commands.json names no test sources (configure it with -DUGVR_UNIT_TESTS=ON)")
    start = time.time()
    with concurrent.futures.ThreadPoolExecutor(os.cpu_count() or 2) as pool:
        results = list(pool.map(check, tests))
    failed = [r for r in results if r[1] != 0]
    for name, _, err in failed:
        print(f"{name}:\n{err[-2000:]}")
    print(f"{len(tests)} test sources, {len(failed)} failing with GCC, {time.time() - start:.0f} s")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
