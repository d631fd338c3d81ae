"""The studies' runs and snapshots: running knitflow, reading its frames, the scene a run read
(KEY=VALUE overrides as `run --set` applies them), CSV rows and the commit."""
import csv
import glob
import json
import os
import re
import subprocess
import time
import tomllib

import h5py

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def frames(run_dir):
    found = sorted(glob.glob(os.path.join(run_dir, "frame_*.h5")))
    if not found:
        raise SystemExit(f"{run_dir}: no snapshots")
    return found


def frame_time(path):
    with h5py.File(path, "r") as f:
        return float(f.attrs["time"])


def steps(run_dir):
    with h5py.File(frames(run_dir)[-1], "r") as f:
        return int(f.attrs["step"])


def particles(run_dir):
    """The fluid particles at the start, or the knit's points in a scene without fluid."""
    with h5py.File(frames(run_dir)[0], "r") as f:
        phase = "fluid" if "fluid" in f else "knit"
        return int(f[f"{phase}/position"].shape[0])


def knit_points(run_dir):
    with h5py.File(frames(run_dir)[0], "r") as f:
        return int(f["knit/position"].shape[0]) if "knit" in f else 0


# [solver] quality's spacing scales (src/domain/QualityPresets.cpp): the errors read the spacing.
QUALITY_SPACING = {"preview": 2.0, "production": 1.0, "reference": 0.5}


def applied(scene, overrides):
    """The scene's table with KEY=VALUE overrides (TOML values) set, as `run --set` does (a
    number in the path indexes an array of tables), and a quality preset's spacing scale."""
    scene = json.loads(json.dumps(scene))
    for o in overrides:
        key, value = o.split("=", 1)
        *path, last = key.split(".")
        t = scene
        for k in path:
            t = t[int(k)] if isinstance(t, list) else t.setdefault(k, {})
        t[last] = tomllib.loads(f"v = {value}")["v"]
    quality = scene.get("solver", {}).get("quality")
    if quality:
        scene["fluid"]["spacing"] *= QUALITY_SPACING[quality]
    return scene


def commit():
    """The tree's commit (KF_COMMIT where the runs' checkout is a copy without its history)."""
    if os.environ.get("KF_COMMIT"):
        return os.environ["KF_COMMIT"]
    done = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True)
    return done.stdout.strip() or "unknown"


def run(exe, scene_path, overrides, out, device):
    """Runs knitflow; its wall seconds, peak resident memory [MB] and, where the solver stopped
    the run as unstable (the watchdog, or a step that would not hold), why ("" otherwise): such
    a setting is a study's answer too. Any other failure ends the study."""
    cmd = [exe, "run", scene_path, "--device", device, "--quiet", "--output", out]
    for o in overrides:
        cmd += ["--set", o]
    t0 = time.monotonic()
    child = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    log = child.stdout.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.monotonic() - t0
    code = os.waitstatus_to_exitcode(status)
    unstable = re.search(r"knitflow: error: ((?:watchdog|instability) at step \d+, t = \S+ s)",
                         log)
    if code != 0 and not (unstable and glob.glob(os.path.join(out, "frame_*.h5"))):
        raise SystemExit(f"{' '.join(cmd)}: exit {code}\n{log}")
    return wall, usage.ru_maxrss / 1024.0, unstable.group(1) if code != 0 else ""


def read_rows(paths):
    rows = []
    for path in paths:
        with open(path) as f:
            for r in csv.DictReader(f):
                for k, v in r.items():
                    try:
                        r[k] = float(v)
                    except (TypeError, ValueError):
                        pass
                rows.append(r)
    return rows


def write_csv(rows, path):
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
