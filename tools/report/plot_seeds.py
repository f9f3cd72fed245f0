#!/usr/bin/python3
"""Fig. 6 over several streets from `keyfleet eval --seeds`'s seeds.json: per density, the mean
over the seeds and its 95 % interval, for each strategy.

usage: plot_seeds.py OUT_DIR [TITLE]   (reads OUT_DIR/seeds.json, writes OUT_DIR/seeds_fig6.png:
words read and place recognition top-1 on top, both as differences to `vslam` on the same street
below, where the street's own difficulty cancels and the claims are judged).
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display on build machines
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = {"vslam": "#555555", "quality": "#1f77b4", "semantic": "#ff7f0e", "full": "#2ca02c"}
PANELS = (("words_read", 1, "distinct signs read"),
          ("top1", 100, "place recognition top-1 (%)"),
          ("words_read_vs_vslam", 1, "signs read - vslam's"),
          ("top1_vs_vslam", 100, "top-1 - vslam's (points)"))


def main():
    out = Path(sys.argv[1])
    doc = json.loads((out / "seeds.json").read_text())
    title = sys.argv[2] if len(sys.argv) > 2 else ""
    strategies = list(dict.fromkeys(p["strategy"] for p in doc["points"]))
    fig, axes = plt.subplots(2, 2, figsize=(9.6, 6.4), dpi=90)
    offsets = {s: (i - (len(strategies) - 1) / 2) * 0.8 for i, s in enumerate(strategies)}
    for ax, (key, scale, label) in zip(axes.flat, PANELS):
        for strategy in strategies:
            if key.endswith("_vs_vslam") and strategy == "vslam":
                continue
            points = sorted((p["density"], p[key]) for p in doc["points"]
                            if p["strategy"] == strategy)
            x = [100 * d + offsets[strategy] for d, _ in points]
            mean = [scale * i["mean"] for _, i in points]
            below = [scale * (i["mean"] - i["low"]) for _, i in points]
            above = [scale * (i["high"] - i["mean"]) for _, i in points]
            ax.errorbar(x, mean, yerr=[below, above], marker="o", markersize=3, capsize=2,
                        linewidth=1, color=COLOURS.get(strategy), label=strategy)
        if key.endswith("_vs_vslam"):
            ax.axhline(0, color="#555555", linewidth=0.8)
        ax.set_xlabel("% of V-SLAM keyframes kept")
        ax.set_ylabel(label, fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"{title} mean and 95 % interval over seeds {doc['seeds']}".strip(), fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "seeds_fig6.png")
    plt.close(fig)


if __name__ == "__main__":
    main()
