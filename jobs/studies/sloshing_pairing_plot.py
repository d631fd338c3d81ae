#!/usr/bin/python3
"""The sloshing's period against the kernel (P7, docs/VALIDATION.md): the signed error of the
period against the spacing for the cubic spline at supports 2 and 3 and Wendland C2 at 3 (the
studies' spacing rows), and against the support at 0.005 m for both kernels with the fraction of
particles paired (within half a spacing of a neighbour) after 2 s.

    jobs/studies/sloshing_pairing_plot.py OUT.png
"""
import os
import sys

from study_io import ROOT, read_rows
from study_plots import pyplot

DATA = os.path.join(ROOT, "docs", "data")
SPACING_SERIES = [  # (label, CSV of a study whose spacing rows are the series)
    ("cubic, support 2", "p7_h200_2026-12-01/sloshing_all_support2.csv"),
    ("cubic, support 3 (pairs)", "p7_h200_2026-12-01/sloshing_all_cubic_support3.csv"),
    ("Wendland C2, support 3", "p7_h200/sloshing_all.csv"),
]
PAIRING = "p7_h200_2026-12-01/sloshing_pairing.csv"


def rows(path):
    return read_rows([os.path.join(DATA, path)])


def signed(r):
    """The period's relative error in percent, + long."""
    return 100 * (r["period_s"] / r["period_linear_s"] - 1)


def main():
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for label, path in SPACING_SERIES:
        mine = sorted((r for r in rows(path) if r["axis"] == "spacing" and r["period_s"] != ""),
                      key=lambda r: r["value"])
        a.semilogx([r["value"] for r in mine], [signed(r) for r in mine], "o-", label=label)
    a.axhline(0, color="k", lw=0.6)
    ticks = [0.0025, 0.005, 0.01, 0.02]
    a.set_xticks(ticks, [str(t) for t in ticks])
    a.minorticks_off()
    a.set_xlabel("particle spacing [m]")
    a.set_ylabel("period against linear theory [%]")
    a.set_title("sloshing: the period against the spacing")
    a.legend(fontsize=8)
    pairing = [r for r in rows(PAIRING) if r["spacing"] == 0.005 and r["device"] == "cuda"]
    twin = b.twinx()
    for kernel, colour in (("cubic", "C0"), ("wendland", "C2")):
        mine = sorted((r for r in pairing if r["kernel"] == kernel), key=lambda r: r["support"])
        s = [r["support"] for r in mine]
        b.plot(s, [100 * r["period_error"] for r in mine], "o-", color=colour,
               label=f"{kernel}: period")
        twin.plot(s, [100 * r["paired"] for r in mine], "s--", color=colour, alpha=0.6,
                  label=f"{kernel}: paired")
    b.axhline(0, color="k", lw=0.6)
    b.set_xlabel("kernel support [spacings]")
    b.set_ylabel("period against linear theory [%]")
    twin.set_ylabel("particles paired after 2 s [%]")
    b.set_title("at 0.005 m: the support, and the cubic's pairing")
    lines = b.get_legend_handles_labels(), twin.get_legend_handles_labels()
    b.legend(lines[0][0] + lines[1][0], lines[0][1] + lines[1][1], fontsize=8, loc="center right")
    fig.tight_layout()
    fig.savefig(sys.argv[1], dpi=110)


if __name__ == "__main__":
    main()
