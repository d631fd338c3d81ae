#!/usr/bin/env python3
"""CI's CUDA compile-only check (scripts/test.sh): compiles, from a configured CUDA build's
compile_commands.json, what that build compiles otherwise than the CPU build does:

- every translation unit nvcc compiles (the kernels library, the tests test_*_K), through its
  host front end (cudafe++) and its device compiler (cicc, to PTX), with `-cuda` in place of
  `-c`: the host compiler's pass over cudafe++'s output is left out (32% of nvcc's time on CI's
  cores: 152 of 479 s), as the CPU build's g++ has just compiled the same host code (EDG's front
  end still parses all of it: a host-side error fails here);
- the transports (src/comm/, NCCL's code) and every other source or test naming KF_WITH_CUDA or
  __CUDACC__, by the C++ compiler as the CUDA build has them.

Nothing is linked (no GPU needed). Usage: cuda_check.py BUILD_DIR JOBS. Exits non-zero after
printing each failed unit's command and output.
"""
import json
import os
import re
import shlex
import subprocess
import sys
import shutil
from concurrent.futures import ThreadPoolExecutor


def names_cuda(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        text = f.read()
    return "KF_WITH_CUDA" in text or "__CUDACC__" in text


def without_dependency_file(args):
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
        elif a in ("-MT", "-MF"):
            skip = True
        elif a != "-MD":
            out.append(a)
    return out


def units(build):
    with open(os.path.join(build, "compile_commands.json"), encoding="utf-8") as f:
        entries = json.load(f)
    out = os.path.abspath(os.path.join(build, "compile-check"))  # what the units write, anew
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    for k, e in enumerate(entries):
        args = shlex.split(e["command"])
        src = e["file"]
        rel = os.path.relpath(src)
        if os.path.basename(args[0]) == "nvcc":
            args = ["-cuda" if a == "-c" else a for a in args]
            # The output: a translation unit (.ii), not an object; no dependency file.
            args = without_dependency_file(args)
            args[args.index("-o") + 1] = os.path.join(out, f"{k}.ii")
        elif "/src/comm/" in src or (not re.search(r"/src/kernels/", src) and names_cuda(src)):
            args = without_dependency_file(args)
            args[args.index("-o") + 1] = os.path.join(out, f"{k}.o")
        else:
            continue
        yield rel, e["directory"], args


def compile_one(unit):
    rel, directory, args = unit
    r = subprocess.run(args, cwd=directory, capture_output=True, text=True)
    return rel, args, r.returncode, r.stdout + r.stderr


def main():
    build, jobs = sys.argv[1], int(sys.argv[2])
    todo = list(units(build))
    failed = 0
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for rel, args, rc, text in pool.map(compile_one, todo):
            print(f"cuda-check: {rel}" + ("" if rc == 0 else f": FAILED ({rc})"), flush=True)
            if rc != 0 or text.strip():
                if rc != 0:
                    print(shlex.join(args))
                    failed += 1
                print(text, end="")
    print(f"cuda-check: {len(todo)} units, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
