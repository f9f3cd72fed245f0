"""Trains MiniNet for text segmentation on the CPU, the paper's recipe scaled to 2 cores.

  /usr/bin/python3 models/mininet/train.py --data PAIRS --work DIR [--steps N]
      [--icdar-train SHARED/icdar2015/train] [--icdar SHARED]

Sources (data.py): generated pairs from `keyfleet scenario training` (PAIRS: images/ + masks/);
with --icdar-train, the ICDAR 2015 training photos, legible quads as text and `###` quads left out
of the loss (ignore index 255), except every 10th image id (img_10, img_20, ..., img_1000: 100
photos), which never trains and is the validation set; with --icdar, ICDAR 2015 test_blurred
img_201..500 (img_101..200 are the evaluation's). Each batch has a fixed number of each
(--mix generated,icdar-train,test_blurred; default 3,4,1 of 8: five eighths real photos).
Adam (lr 1e-3), polynomial decay (power 0.9); cross-entropy with median-frequency class weights
raised to a power, w_c = (f_median / f_c) ** power, over the pixels that count; augmentation:
see data.augment. Batch 8 crops of 256x128.

Every --validate-every steps: the held-out real photos whole, at the agent's 320x256 input, as
Table III scores them (argmax; IoU of the text class with `###` counted as text, and with `###`
left out), and the last 5 % of the generated pairs likewise; a row in WORK/validation.csv;
WORK/latest.pt (resume point: network, optimizer, schedule, step, RNG states, best so far) and
WORK/best.pt (highest real-photo IoU; generated IoU without real photos). A rerun resumes.
Deterministic from --seed for a given thread count and machine: Python's, NumPy's and torch's
generators are seeded and checkpointed, and the data order is drawn from one random.Random; the
remaining freedom is the float summation order of torch's CPU kernels (fixed for a fixed
--threads on the same build, not across thread counts or machines); a run stopped and resumed
from latest.pt ends with the same weights as one straight through (checked: max |diff| 0).
OpenMP threads sleep instead of spinning while waiting (OMP_WAIT_POLICY=PASSIVE unless set): on
the 2 shared cores, spinning made a step 2.56 s instead of 0.38 s whenever builds ran beside it.
CSV columns: loss (mean since the last row), s_per_step (same span, validation excluded),
wall_s (since this process started).
"""
import argparse
import csv
import os
import random
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before torch loads libgomp

import numpy as np  # noqa: E402
import torch  # noqa: E402
import torch.nn.functional as F  # noqa: E402

import data  # noqa: E402
from mininet import MiniNet, count_flops, count_parameters

CSV_FIELDS = ["step", "loss", "lr", "s_per_step", "real_iou", "real_recall", "real_precision",
              "real_iou_legible", "generated_iou", "best_real_iou", "wall_s"]


def evaluate(net, views, dont_care_as_text=True):
    """Recall, precision, IoU of the text class over whole views (argmax). IGNORE pixels count as
    text when dont_care_as_text (Table III), else they are left out."""
    net.eval()
    counts = np.zeros((2, 3))  # [### as text, ### left out] x [tp, fp, fn]
    with torch.no_grad():
        for i in range(0, len(views), 4):
            x = torch.from_numpy(np.stack([v[0] for v in views[i:i + 4]]))
            pred = net(x).argmax(1).numpy() == 1
            truth = np.stack([v[1] for v in views[i:i + 4]])
            for k, (text, counted) in enumerate(((truth != 0, truth >= 0),
                                                 (truth == 1, truth != data.IGNORE))):
                counts[k] += [(pred & text & counted).sum(), (pred & ~text & counted).sum(),
                              (~pred & text & counted).sum()]
    net.train()

    def scores(tp, fp, fn):
        return {"recall": tp / max(1, tp + fn), "precision": tp / max(1, tp + fp),
                "iou": tp / max(1, tp + fp + fn)}
    out = scores(*counts[0 if dont_care_as_text else 1])
    out["iou_legible"] = scores(*counts[1])["iou"]
    return out


def rng_states(rng):
    return {"rng": rng.getstate(), "numpy_rng": np.random.get_state(),
            "torch_rng": torch.get_rng_state()}


def save(path, state):
    torch.save(state, path + ".tmp")
    os.replace(path + ".tmp", path)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--data", required=True, help="generated pairs (images/, masks/)")
    ap.add_argument("--work", required=True, help="checkpoints, validation.csv")
    ap.add_argument("--steps", type=int, default=16000)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--mix", default="3,4,1",
                    help="crops per batch from generated, ICDAR train, test_blurred (sum = batch); "
                         "a missing source's share goes to the generated pairs")
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--weight-power", type=float, default=0.5)
    ap.add_argument("--validation", type=float, default=0.05, help="held-out generated fraction")
    ap.add_argument("--validate-every", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--stop-at", type=int, default=0,
                    help="leave after the checkpoint at this step (a rerun goes on); 0: at --steps")
    ap.add_argument("--icdar-train", default="", help="ICDAR 2015 training folder (images/, gt/)")
    ap.add_argument("--icdar", default="", help="the shared data folder: test_blurred img_201..500")
    args = ap.parse_args()

    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    np.random.seed(args.seed)
    rng = random.Random(args.seed)
    os.makedirs(args.work, exist_ok=True)

    pairs = data.load_pairs(args.data)
    held = max(1, int(len(pairs) * args.validation))
    generated, generated_val = pairs[:-held], pairs[-held:]  # the last views: other streets
    generated_views = [data.whole_view(i, m) for i, m in generated_val]
    icdar_train, real_views = [], []
    if args.icdar_train:
        if os.path.isdir(os.path.join(args.icdar_train, "images")):
            train_ids, val_ids = data.icdar_split(data.icdar_ids(args.icdar_train))
            icdar_train = data.load_icdar(args.icdar_train, train_ids)
            real_views = data.load_icdar_views(args.icdar_train, val_ids)
        else:
            print(f"no ICDAR training photos in {args.icdar_train}", flush=True)
    blurred = []
    if args.icdar:
        folder = os.path.join(args.icdar, "icdar2015", "test_blurred")
        if os.path.isdir(folder):
            ids = [i for i in data.icdar_ids(folder) if i > 100 + data.BLURRED_HELD_OUT]
            blurred = data.load_icdar(folder, ids)
        else:
            print(f"no ICDAR test_blurred photos under {args.icdar}", flush=True)
    mix = [int(v) for v in args.mix.split(",")]
    if len(mix) != 3 or sum(mix) != args.batch:
        raise SystemExit(f"train.py: --mix {args.mix} must be three counts summing to --batch")
    sources = [generated, icdar_train, blurred]
    for k in (1, 2):
        if not sources[k]:
            mix[0], mix[k] = mix[0] + mix[k], 0
    weights, freq = data.class_weights(list(zip(sources, mix)), args.weight_power)
    weights = torch.tensor(weights, dtype=torch.float32)
    print(f"training: {len(generated)} generated, {len(icdar_train)} ICDAR train, {len(blurred)} "
          f"test_blurred; batch mix {mix}; validation: {len(real_views)} ICDAR photos, "
          f"{len(generated_views)} generated; text fraction {freq[1]:.4f}; class weights "
          f"{weights.numpy().round(3).tolist()}", flush=True)

    net = MiniNet(2)
    print(f"MiniNet: {count_parameters(net) / 1e6:.3f} M parameters, "
          f"{count_flops(net, 256, 512) / 1e9:.3f} GFLOPs at 512x256", flush=True)
    optimizer = torch.optim.Adam(net.parameters(), lr=args.lr)
    schedule = torch.optim.lr_scheduler.LambdaLR(
        optimizer, lambda step: (1 - min(step, args.steps - 1) / args.steps) ** 0.9)
    step, best = 0, -1.0
    latest, best_path = os.path.join(args.work, "latest.pt"), os.path.join(args.work, "best.pt")
    csv_path = os.path.join(args.work, "validation.csv")
    if os.path.exists(latest):
        state = torch.load(latest)
        net.load_state_dict(state["net"])
        optimizer.load_state_dict(state["optimizer"])
        schedule.load_state_dict(state["schedule"])
        rng.setstate(state["rng"])
        np.random.set_state(state["numpy_rng"])
        torch.set_rng_state(state["torch_rng"])
        step, best = state["step"], state["best"]
        print(f"resuming from step {step} (best validation IoU so far {best:.4f})", flush=True)
    rows = []
    if os.path.exists(csv_path):  # rows after the resume point are redone
        with open(csv_path) as f:
            rows = [r for r in csv.DictReader(f) if int(r["step"]) <= step]
    with open(csv_path, "w", newline="") as f:
        writer = csv.DictWriter(f, CSV_FIELDS)
        writer.writeheader()
        writer.writerows(rows)

    started = interval_start = time.time()
    losses = []
    net.train()
    while step < args.steps:
        batch = [data.augment(*source[rng.randrange(len(source))], rng)
                 for source, count in zip(sources, mix) for _ in range(count)]
        x = torch.from_numpy(np.stack([b[0] for b in batch]))
        y = torch.from_numpy(np.stack([b[1] for b in batch])).long()
        loss = F.cross_entropy(net(x), y, weight=weights, ignore_index=data.IGNORE)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        schedule.step()
        step += 1
        losses.append(loss.item())
        if step % 50 == 0:
            print(f"step {step}/{args.steps} loss {np.mean(losses[-50:]):.4f} "
                  f"lr {schedule.get_last_lr()[0]:.2e} "
                  f"{(time.time() - interval_start) / len(losses):.2f} s/step", flush=True)
        if step % args.validate_every == 0 or step == args.steps:
            s_per_step = (time.time() - interval_start) / max(1, len(losses))
            gen = evaluate(net, generated_views)
            real = evaluate(net, real_views) if real_views else None
            score = real["iou"] if real else gen["iou"]
            improved = score > best
            best = max(best, score)
            row = {"step": step, "loss": round(float(np.mean(losses)), 5),
                   "lr": f"{schedule.get_last_lr()[0]:.3e}", "s_per_step": round(s_per_step, 3),
                   "generated_iou": round(gen["iou"], 5), "best_real_iou": round(best, 5),
                   "wall_s": round(time.time() - started, 1)}
            if real:
                row.update({"real_iou": round(real["iou"], 5),
                            "real_recall": round(real["recall"], 5),
                            "real_precision": round(real["precision"], 5),
                            "real_iou_legible": round(real["iou_legible"], 5)})
            print(f"validation at step {step}: real {real} generated {gen}"
                  f"{' (best)' if improved else ''}", flush=True)
            state = {"net": net.state_dict(), "optimizer": optimizer.state_dict(),
                     "schedule": schedule.state_dict(), "step": step, "best": best,
                     "validation": real or gen, "validation_generated": gen,
                     "class_weights": weights.tolist(), "args": vars(args), **rng_states(rng)}
            if improved:
                save(best_path, state)
            save(latest, state)
            with open(csv_path, "a", newline="") as f:
                csv.DictWriter(f, CSV_FIELDS).writerow(row)
            losses, interval_start = [], time.time()
            if args.stop_at and step >= args.stop_at and step < args.steps:
                print(f"stopping at step {step} as asked; rerun to go on", flush=True)
                return
    print(f"training done: best validation IoU {best:.4f} in {best_path}", flush=True)


if __name__ == "__main__":
    main()
