"""The studies' plots: a sweep's error against wall time and against its axis, and a case's
every run against its time with the Pareto front. Rows without an error (a case's reference
run) are left out."""
import math


def measured(rows):
    """The rows with an error to plot on a log scale."""
    return [r for r in rows if isinstance(r["error"], (int, float)) and math.isfinite(r["error"])
            and r["error"] > 0]


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot(rows, case, axis, path):
    rows = measured(rows)
    if not rows:
        return
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    wall = [r["wall_s"] for r in rows]
    err = [r["error"] for r in rows]
    a.loglog(wall, err, "o-")
    for r in rows:
        a.annotate(f"{r['value']}", (r["wall_s"], r["error"]), fontsize=8)
    a.set_xlabel("wall time [s]")
    a.set_ylabel("error")
    a.set_title(f"{case}: error against time ({axis})")
    numeric = all(isinstance(r["value"], (int, float)) for r in rows)
    if numeric:
        b.loglog([r["value"] for r in rows], err, "o-")
    else:
        b.bar([str(r["value"]) for r in rows], err)
        b.set_yscale("log")
    b.set_xlabel(axis)
    b.set_ylabel("error")
    b.set_title(f"{case}: error against {axis}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def pareto_front(rows):
    """The runs no other run beats on both wall time and error, by wall time."""
    rows = measured(rows)
    front = [r for r in rows if not any(
        o["wall_s"] <= r["wall_s"] and o["error"] <= r["error"]
        and (o["wall_s"] < r["wall_s"] or o["error"] < r["error"]) for o in rows)]
    return sorted(front, key=lambda r: r["wall_s"])


def plot_pareto(rows, case, path):
    rows = measured(rows)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for axis in dict.fromkeys(r["axis"] for r in rows):
        mine = [r for r in rows if r["axis"] == axis]
        ax.loglog([r["wall_s"] for r in mine], [r["error"] for r in mine], "o", label=axis)
        for r in mine:
            ax.annotate(f"{r['value']}", (r["wall_s"], r["error"]), fontsize=7)
    front = pareto_front(rows)
    ax.loglog([r["wall_s"] for r in front], [r["error"] for r in front], "k--", lw=1,
              label="Pareto front")
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("error")
    ax.set_title(f"{case}: every run's error against its time")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
