#!/usr/bin/python3
"""Fig. 6 (a) and (b) of Alonso et al. (ICRA 2019) from `keyfleet eval`'s results.json.

usage: plot_eval.py OUT_DIR   (reads OUT_DIR/results.json, writes fig6a_words.png and
fig6b_places.png there). Debian's python3-matplotlib; small PNGs for the docs' result pages.
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


def main(out_dir):
    results = json.loads((out_dir / "results.json").read_text())
    summary, strategies = results["summary"], results["strategies"]

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
