#!/usr/bin/python3
"""Fig. 6 (a) and (b) of Alonso et al. (ICRA 2019) from `keyfleet eval`'s results.json.

usage: plot_eval.py OUT_DIR   (reads OUT_DIR/results.json, writes fig6a_words.png and
fig6b_places.png there; with encodings, Fig. 6 is the first (reference) encoding's, and
fig_encodings.png shows words read and top-1 against the mean kB per keyframe, one point per
encoding). Debian's python3-matplotlib; small PNGs for the docs' result pages.
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display on build machines
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = {"vslam": "#555555", "quality": "#1f77b4", "semantic": "#ff7f0e", "full": "#2ca02c"}


def series(summary, strategy, key):
    points = sorted((p["density"], p[key]) for p in summary if p["strategy"] == strategy)
    return [100 * d for d, _ in points], [v for _, v in points]


def axes(title, ylabel):
    fig, ax = plt.subplots(figsize=(4.8, 3.4), dpi=90)
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("% of V-SLAM keyframes kept")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.set_ylim(0, 1.02)
    return fig, ax


def save(fig, ax, path):
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_encodings(results, path):
    """Words read (% of the reference encoding's) and top-1 against kB per keyframe: one line
    per strategy and density, one point per encoding, the encodings named."""
    points = results.get("encoding_points", [])
    if not points:
        return
    reference = results["encodings"][0]["name"]
    modes = results.get("place_retrievals") or sorted(points[0]["top1"])
    fig, (left, right) = plt.subplots(1, 2, figsize=(9.6, 3.8), dpi=90)
    curves = sorted({(p["strategy"], p["density"]) for p in points}, key=lambda c: (c[0], -c[1]))
    markers = ["o", "s", "^", "D"]
    lowest = 1.0
    for n, (strategy, density) in enumerate(curves):
        mine = sorted((p for p in points if p["strategy"] == strategy and p["density"] == density),
                      key=lambda p: p["kb_per_keyframe"])
        x = [p["kb_per_keyframe"] for p in mine]
        tag = f"{strategy} {100 * density:.0f} %"
        left.plot(x, [100 * p["words_vs_reference"] for p in mine], markers[n % 4] + "-",
                  color=COLOURS.get(strategy), alpha=0.4 + 0.6 * density, label=tag)
        for p in mine if n == 0 else []:  # the names once, on the first curve
            left.annotate(p["encoding"], (p["kb_per_keyframe"], 100 * p["words_vs_reference"]),
                          fontsize=6, xytext=(3, 3), textcoords="offset points")
        for m, mode in enumerate(modes):
            lowest = min([lowest] + [p["top1"].get(mode, 0) for p in mine])
            right.plot(x, [p["top1"].get(mode, 0) for p in mine], markers[m % 4] + "-",
                       color=COLOURS.get(strategy), alpha=(0.4 + 0.6 * density) / (1 + m * 0.5),
                       label=f"{tag}: {mode}")
    left.axhline(95, color="#999999", linestyle=":", linewidth=1)
    left.axvline(20, color="#999999", linestyle=":", linewidth=1)
    right.axvline(20, color="#999999", linestyle=":", linewidth=1)
    left.set_title(f"words read, % of {reference}'s", fontsize=10)
    right.set_title("place recognition top-1", fontsize=10)
    right.set_ylim(max(0.0, min(0.8, lowest - 0.05)), 1.01)
    for ax in (left, right):
        ax.set_xlabel("mean kB per keyframe")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(out_dir):
    results = json.loads((out_dir / "results.json").read_text())
    summary, strategies = results["summary"], results["strategies"]
    if results.get("encodings"):
        # Fig. 6 of the reference encoding; the others are compared in fig_encodings.png.
        reference = results["encodings"][0]["name"]
        summary = [p for p in summary if p.get("encoding") == reference]
        plot_encodings(results, out_dir / "fig_encodings.png")

    fig, ax = axes("(a) words read by the station", "word recall")
    for s in strategies:
        x, y = series(summary, s, "word_recall")
        ax.plot(x, y, "o-", color=COLOURS.get(s), label=f"{s}: read")
        x, y = series(summary, s, "full_word_recall")
        ax.plot(x, y, ":", color=COLOURS.get(s), alpha=0.7, label=f"{s}: fully visible")
    save(fig, ax, out_dir / "fig6a_words.png")

    fig, ax = axes("(b) place recognition", "accuracy")
    for s in strategies:
        x, y = series(summary, s, "top1")
        ax.plot(x, y, "o-", color=COLOURS.get(s), label=f"{s}: top-1")
        x, y = series(summary, s, "top5")
        ax.plot(x, y, "s--", color=COLOURS.get(s), alpha=0.7, label=f"{s}: top-5")
    save(fig, ax, out_dir / "fig6b_places.png")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
