#!/usr/bin/python3
"""report.md and its plots for a `keyfleet experiment bandwidth` folder (reads results.json).

Run with Debian's python3-matplotlib: /usr/bin/python3 tools/report/bandwidth_report.py DIR
"""
import json
import statistics
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402


def fleet(mission):
    robots = mission["robots"]
    total = lambda key: sum(r[key] or 0 for r in robots)
    payload = total("payload_bytes")
    wire = None if any(r["wire_tx_bytes"] is None for r in robots) or not robots \
        else total("wire_tx_bytes")
    medians = [r["latency_median_ms"] for r in robots
               if r["latency_median_ms"] is not None and r["delivered"]]
    p95s = [r["latency_p95_ms"] for r in robots
            if r["latency_p95_ms"] is not None and r["delivered"]]
    return {
        "delivered": total("delivered"),
        "dropped": total("dropped"),
        "resent": total("resent"),
        "refused": total("refused_writes"),
        "payload": payload,
        "wire": wire,
        "lat_med": statistics.median(medians) if medians else None,
        "lat_p95": max(p95s) if p95s else None,
        "rate": statistics.median([r["throughput_bytes_per_s"] for r in robots]) if robots else 0,
        "x_stream": total("stream_all_bytes") / payload if payload else 0,
        "x_vslam": total("vslam_keyframe_bytes") / payload if payload else 0,
        "stream_est": any(r["stream_all_estimated"] for r in robots),
    }


def plot_bandwidth(results, link, out):
    missions = [m for m in results["missions"] if m["link"] == link]
    drones = sorted({m["drones"] for m in missions})
    profiles = list(dict.fromkeys(m["profile"]["name"] for m in missions))
    fig, axes = plt.subplots(len(drones), len(profiles), squeeze=False, sharex=True,
                             figsize=(4.2 * len(profiles), 2.6 * len(drones)))
    bin_s = results["bin_s"]
    for m in missions:
        ax = axes[drones.index(m["drones"])][profiles.index(m["profile"]["name"])]
        for r in m["robots"]:
            bins = r["bytes_per_bin"]
            ax.plot([i * bin_s for i in range(len(bins))], [b / bin_s / 1e3 for b in bins],
                    linewidth=1, label=r["robot_id"])
        rate = m["profile"]["rate_kbit_s"]
        if rate:
            ax.axhline(rate / 8, color="black", linestyle="--", linewidth=1, label="link rate")
        ax.set_title(f'{m["drones"]} drones, {m["profile"]["name"]}', fontsize=9)
        ax.grid(alpha=0.3)
    for row in axes:
        row[0].set_ylabel("kB/s received")
    for ax in axes[-1]:
        ax.set_xlabel("s since the first keyframe")
    axes[0][0].legend(fontsize=6, ncol=2)
    fig.suptitle(f"Bandwidth over time per robot ({link} links; {bin_s:g} s bins)")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def plot_savings(results, out):
    missions = results["missions"]
    names = [m["name"] for m in missions]
    figures = [fleet(m) for m in missions]
    x = range(len(names))
    fig, ax = plt.subplots(figsize=(max(6, 0.55 * len(names)), 4))
    ax.bar([i - 0.2 for i in x], [f["x_stream"] for f in figures], 0.4,
           label="vs streaming every frame (est.)")
    ax.bar([i + 0.2 for i in x], [f["x_vslam"] for f in figures], 0.4,
           label="vs every V-SLAM keyframe")
    if any(f["x_stream"] > 0 or f["x_vslam"] > 0 for f in figures):
        ax.set_yscale("log")  # not with nothing delivered: a log axis needs a positive value
    ax.set_ylabel("baseline bytes / delivered bytes")
    ax.set_xticks(list(x))
    ax.set_xticklabels(names, rotation=60, ha="right", fontsize=7)
    ax.grid(axis="y", alpha=0.3)
    ax.legend()
    ax.set_title("Savings against both baselines (fleet, per mission)")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def group_of(m):
    """A mission's series: fleet size, DDS-Security, link adaptation."""
    return (m["drones"], m.get("security", True), m.get("link_adaptation", False))


def plot_latency(results, out):
    links = list(dict.fromkeys(m["link"] for m in results["missions"]))
    fig, axes = plt.subplots(1, len(links), squeeze=False, figsize=(5.5 * len(links), 4))
    for col, link in enumerate(links):
        ax = axes[0][col]
        missions = [m for m in results["missions"] if m["link"] == link]
        profiles = list(dict.fromkeys(m["profile"]["name"] for m in missions))
        groups = sorted({group_of(m) for m in missions})
        any_latency = False
        for k, (n, secure, adapting) in enumerate(groups):
            xs, med, p95 = [], [], []
            for m in missions:
                if group_of(m) != (n, secure, adapting):
                    continue
                f = fleet(m)
                if f["lat_med"] is None:
                    continue
                xs.append(profiles.index(m["profile"]["name"]) + (k - len(groups) / 2) * 0.12)
                med.append(f["lat_med"] / 1e3)
                p95.append(f["lat_p95"] / 1e3)
                any_latency = any_latency or f["lat_med"] > 0
            label = (f"{n} drones" + ("" if secure else ", no security")
                     + (", adapting" if adapting else ""))
            ax.scatter(xs, med, label=f"{label}: median", marker="o")
            ax.scatter(xs, p95, marker="^", alpha=0.6, label=f"{label}: worst p95")
        ax.set_xticks(range(len(profiles)))
        ax.set_xticklabels(profiles, rotation=45, ha="right", fontsize=7)
        if any_latency:
            ax.set_yscale("log")
        ax.set_ylabel("capture -> stored (s)")
        ax.set_title(f"Latency per profile ({link})")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def plot_radio(results, out):
    """Goodput and worst p95 latency against the link's rate, a line per loss and security."""
    missions = [m for m in results["missions"]
                if m["profile"]["rate_kbit_s"] and any(r.get("wire_split") for r in m["robots"])]
    if not missions:
        return False
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    keys = sorted({group_of(m) + (m["profile"]["loss_percent"],) for m in missions})
    for drones, secure, adapting, loss in keys:
        rows = sorted(((m["profile"]["rate_kbit_s"], m) for m in missions
                       if group_of(m) + (m["profile"]["loss_percent"],)
                       == (drones, secure, adapting, loss)), key=lambda row: row[0])
        rates = [rate for rate, _ in rows]
        goodput = [statistics.median([r.get("goodput_fraction") or 0 for r in m["robots"]])
                   for _, m in rows]
        p95 = [(fleet(m)["lat_p95"] or float("nan")) / 1e3 for _, m in rows]
        style = ":" if adapting else ("-" if secure else "--")
        label = (f'{drones} drones, {loss:g} % loss{"" if secure else ", no security"}'
                 + (", adapting" if adapting else ""))
        left.plot(rates, goodput, style, marker="o", label=label)
        right.plot(rates, p95, style, marker="o", label=label)
    left.set_ylabel("goodput (stored payload / busy time / link rate)")
    right.set_ylabel("worst p95 latency (s)")
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_xlabel("link rate per drone (kbit/s)")
        ax.grid(alpha=0.3)
    left.set_ylim(0, 1)
    left.legend(fontsize=6)
    fig.suptitle("Radio links: goodput and latency")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return True


def kb_per_s_per_drone(results, mission):
    """Stored payload per drone per second of flight (kB/s), or None without a flight length."""
    flight = results.get("flight_s") or 0
    if not flight or not mission["drones"]:
        return None
    return fleet(mission)["payload"] / 1e3 / mission["drones"] / flight


def plot_words(results, out):
    """Words read at the station against kB/s per drone, over the whole flight and within
    words_in_time_s of capture: a point per mission, a line per fleet size, security and
    adaptation (the missions that replayed a scenario)."""
    missions = [m for m in results["missions"]
                if m.get("analysis") and "words_read" in m["analysis"]
                and kb_per_s_per_drone(results, m) is not None]
    if not missions:
        return False
    within = results.get("words_in_time_s", 5)
    panels = [("words_read", "in the end (whole flight, drained)"),
              ("words_read_in_time", f"in keyframes stored within {within:g} s of capture")]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    top = max(m["analysis"]["words_read"] for m in missions) * 1.15 + 1
    for ax, (key_name, title) in zip(axes, panels):
        labels = {}  # one label per point, naming every mission there
        for key in sorted({group_of(m) for m in missions}):
            drones, secure, adapting = key
            rows = sorted(((kb_per_s_per_drone(results, m), m) for m in missions
                           if group_of(m) == key), key=lambda row: row[0])
            x = [rate for rate, _ in rows]
            y = [m["analysis"].get(key_name) for _, m in rows]
            y = [float("nan") if v is None else v for v in y]  # not measured: no point
            # Fixed: large hollow squares, so that an adapting point on the same spot shows.
            ax.plot(x, y, ":" if adapting else ("-" if secure else "--"),
                    marker="o" if adapting else "s", markersize=5 if adapting else 11,
                    fillstyle="full" if adapting else "none",
                    label=f'{drones} drones{"" if secure else ", no security"}'
                    + (", adapting" if adapting else ", fixed"))
            for rate, words, (_, m) in zip(x, y, rows):
                if words != words:  # nan
                    continue
                name = m["profile"]["name"] + (" (adapting)" if adapting else "")
                labels.setdefault((round(rate, 1), words), []).append(name)
        for (rate, words), names in labels.items():
            ax.annotate("\n".join(names), (rate, words), fontsize=6, xytext=(6, -4),
                        textcoords="offset points", va="top")
        ax.set_xlabel("stored keyframe payload per drone (kB per second of flight)")
        ax.set_ylim(0, top)
        ax.set_xlim(left=0)
        ax.grid(alpha=0.3)
        ax.set_title(f"sign words read {title}", fontsize=9)
    axes[0].set_ylabel("distinct sign words read at the station")
    axes[0].legend(fontsize=7)
    fig.suptitle("Words read per byte")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return True


def analysis_lines(results):
    missions = [m for m in results["missions"] if m.get("analysis")]
    if not missions:
        return []
    lines = ["## The station's analysis against the scenario's truth", "",
             "| mission | keyframes | analysed | sign words read | read in time | vs unlimited | "
             "junk | place matches (right) | kB/s per drone |", "|" + "---|" * 9]
    for m in missions:
        a = m["analysis"]
        if "error" in a:
            lines.append(f'| {m["name"]} | {a["error"]} |' + " |" * 7)
            continue
        versus = m.get("words_read_vs_unlimited")
        lines.append(
            f'| {m["name"]} | {a["keyframes"]} | {a["analysed"]} | '
            f'{a["words_read"]} of {a["visible_words"]} | {fmt(a.get("words_read_in_time"), "d")} | '
            f'{fmt(None if versus is None else 100 * versus, ".0f")}{"" if versus is None else " %"} | {a["junk"]} | '
            f'{a["place_matches"]} ({a["place_matches_right"]}) | '
            f'{fmt(kb_per_s_per_drone(results, m), ".1f")} |')
    lines += ["", "Sign words read: distinct words of the street's signs fully visible in a stored "
              "keyframe and read there; in time: read in keyframes the station stored within "
              f'{results.get("words_in_time_s", 5):g} s of their capture; '
              "vs unlimited: against the same flight over the unlimited "
              "profile (same link kind, security and fleet). Place matches: stored matches "
              "between two robots' keyframes, right when both look within 5 m on the street.", ""]
    return lines


def fmt(value, spec, missing="-"):
    return missing if value is None else format(value, spec)


def write_report(results, folder, pictures):
    machine = results["machine"]
    lines = [f'# Bandwidth experiment `{results["experiment"]}`', "",
             f'{machine["date"]} on {machine["hostname"]} ({machine["cpus"]} CPUs, '
             f'{machine.get("kernel", "?")}). Figures from one run on a shared, noisy machine.', ""]
    if results["interrupted"]:
        lines += ["**Interrupted**: the missions below are the ones that ran.", ""]
    for skipped in results["skipped"]:
        lines += [f"- {skipped}"]
    lines += ["", "| mission | ok | delivered | latency median | worst p95 | dropped | resent | "
              "refused writes | payload MB | wire MB | kB/s per robot (median) | x stream-all | "
              "x V-SLAM |", "|" + "---|" * 13]
    for m in results["missions"]:
        f = fleet(m)
        lines.append(
            f'| {m["name"]} | {"yes" if m["ok"] else "**NO**"} | {f["delivered"]} | '
            f'{fmt(f["lat_med"], ".0f")} ms | {fmt(f["lat_p95"], ".0f")} ms | {f["dropped"]} | '
            f'{f["resent"]} | {f["refused"]} | {f["payload"] / 1e6:.2f} | '
            f'{fmt(None if f["wire"] is None else f["wire"] / 1e6, ".2f", "not measured")} | '
            f'{f["rate"] / 1e3:.1f} | {f["x_stream"]:.1f} | {f["x_vslam"]:.1f} |')
    lines += ["", "Latency: capture time of the keyframe's frame to its commit at the station "
              "(one machine clock). Payload: serialized DDS samples stored (first copies). Wire: "
              "bytes the drone's veth sent (IP + UDP + RTPS, resends and discovery included), "
              "only on netns links. Stream-all is estimated from one frame in N (est.).", ""]
    lines += analysis_lines(results)
    for title, picture in pictures:
        lines += [f"## {title}", "", f"![{title}]({picture})", ""]
    lines += ["## What each link applied", ""]
    for m in results["missions"]:
        lines.append(f'- **{m["name"]}**: ' + "; ".join(m["notes"]))
        for failure in m["failures"]:
            lines.append(f"  - failure: {failure.splitlines()[0]}")
    (folder / "report.md").write_text("\n".join(lines) + "\n")


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: bandwidth_report.py EXPERIMENT_FOLDER")
    folder = Path(sys.argv[1])
    results = json.loads((folder / "results.json").read_text())
    pictures = []
    for link in dict.fromkeys(m["link"] for m in results["missions"]):
        name = f"bandwidth_{link}.png"
        plot_bandwidth(results, link, folder / name)
        pictures.append((f"Bandwidth over time ({link})", name))
    if results["missions"]:
        plot_savings(results, folder / "savings.png")
        plot_latency(results, folder / "latency.png")
        pictures += [("Savings against both baselines", "savings.png"),
                     ("Latency per profile", "latency.png")]
        if plot_radio(results, folder / "radio.png"):
            pictures.append(("Radio links: goodput and latency", "radio.png"))
        if plot_words(results, folder / "words.png"):
            pictures.append(("Words read per byte", "words.png"))
    write_report(results, folder, pictures)


if __name__ == "__main__":
    main()
