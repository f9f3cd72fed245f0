#!/usr/bin/python3
"""Markdown tables of a `keyfleet experiment bandwidth` folder's radio-link figures.

Reads DIR/results.json (of each DIR given); prints, per mission, delivery, goodput, wire/payload, latency, the time
to the station's match and to the first keyframe stored, idle chatter, and where the drones'
bytes went (share of each category, drone -> station). Medians over the mission's robots, the
worst robot's p95. Usage: /usr/bin/python3 tools/report/radio_table.py DIR...
"""
import json
import statistics
import sys
from pathlib import Path

CATEGORIES = ["keyframe_data", "keyframe_repair", "reliability_control", "discovery",
              "security", "other_topics", "unknown"]


def med(values, fmt):
    values = [v for v in values if v is not None]
    return fmt.format(statistics.median(values)) if values else "-"


def mission_row(m):
    robots = m["robots"]
    delivered = sum(r["delivered"] for r in robots)
    lost = sum(r.get("pending", 0) + r["dropped"] for r in robots)
    splits = [r["wire_split"] for r in robots if r.get("wire_split")]
    ratio = [s["tx"]["total"]["bytes"] / r["payload_bytes"]
             for r, s in ((r, r.get("wire_split")) for r in robots)
             if s and r["payload_bytes"]]
    idle_tx = [s["quiet_window"]["tx_bytes_per_s"] for s in splits if s.get("quiet_window")]
    idle_rx = [s["quiet_window"]["rx_bytes_per_s"] for s in splits if s.get("quiet_window")]
    p95 = [r["latency_p95_ms"] for r in robots if r["latency_p95_ms"] is not None and r["delivered"]]
    p = m["profile"]
    return [
        f'{m["drones"]}', "on" if m.get("security", True) else "off",
        f'{p["rate_kbit_s"]:g}', f'{p["loss_percent"]:g}',
        f"{delivered}", f"{lost}",
        med([r.get("goodput_fraction") for r in robots], "{:.2f}"),
        med(ratio, "{:.2f}"),
        med([r["latency_median_ms"] / 1e3 if r["latency_median_ms"] is not None else None
             for r in robots], "{:.1f}"),
        f"{max(p95) / 1e3:.1f}" if p95 else "-",
        med([r.get("matched_s") for r in robots], "{:.1f}"),
        med([r.get("first_keyframe_s") for r in robots], "{:.1f}"),
        med(idle_tx, "{:.0f}") + " / " + med(idle_rx, "{:.0f}"),
    ]


def split_row(m):
    cells = []
    for direction in ("tx", "rx"):
        totals = {c: 0 for c in CATEGORIES}
        for r in m["robots"]:
            s = r.get("wire_split")
            if not s:
                continue
            for c in CATEGORIES:
                totals[c] += s[direction].get(c, {}).get("bytes", 0)
        whole = sum(totals.values())
        cells.append(" ".join(f"{100 * totals[c] / whole:.0f}" if whole else "-"
                              for c in CATEGORIES[:6]) + (f" ({whole / 1e6:.2f} MB)" if whole else ""))
    return cells


def main(folders):
    # Several folders (runs of parts of a matrix) make one table, in the order given.
    results = {"missions": []}
    for folder in folders:
        results["missions"] += json.loads((Path(folder) / "results.json").read_text())["missions"]
    out = ["| drones | security | kbit/s | loss % | delivered | undelivered | goodput | wire/payload "
           "| latency p50 s | p95 s | matched s | 1st keyframe s | idle B/s tx / rx |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for m in results["missions"]:
        out.append("| " + " | ".join(mission_row(m)) + " |")
    out += ["", "Where the bytes went, % of each direction's wire bytes (data, repairs, control, "
            "discovery, security, other topics):", "",
            "| drones | security | kbit/s | loss % | drone -> station | station -> drone |",
            "|---|---|---|---|---|---|"]
    for m in results["missions"]:
        row = mission_row(m)[:4] + split_row(m)
        out.append("| " + " | ".join(row) + " |")
    print("\n".join(out))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("usage: radio_table.py EXPERIMENT_FOLDER...")
    main(sys.argv[1:])
