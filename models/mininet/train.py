"""Trains MiniNet for text segmentation, the paper's recipe scaled to 2 CPU cores (or a GPU).

  /usr/bin/python3 models/mininet/train.py --data PAIRS --work DIR [--steps N]
      [--icdar-train SHARED/icdar2015/train] [--icdar SHARED] [--packed DIR]
      [--device cuda --workers 6 --batch 32 --mix 12,16,4 --crop 512x256]

Sources (data.py): generated pairs from `keyfleet scenario training` (PAIRS: images/ + masks/);
with --icdar-train, the ICDAR 2015 training photos, legible quads as text and `###` quads left out
of the loss (ignore index 255), except every 10th image id (img_10, img_20, ..., img_1000: 100
photos), which never trains and is the validation set; with --icdar, ICDAR 2015 test_blurred
img_201..500 (img_101..200 are the evaluation's). --packed DIR reads the same sources as pack.py
wrote them (for a machine without the data). Each batch has a fixed number of each (--mix
generated,icdar-train,test_blurred; default 2,5,1 of 8: three quarters real photos).
--init MODEL.onnx starts from an exported model's weights (fine-tuning the shipped one); with
--generated-floor F, best.pt is kept among checkpoints whose generated IoU reaches F.
Adam (lr 1e-3), polynomial decay (power 0.9); cross-entropy with median-frequency class weights
raised to a power, w_c = (f_median / f_c) ** power, over the pixels that count, plus --iou-loss
times one minus the soft IoU of the text class over the batch's counted pixels (the measure Table
III reports; the weighted cross-entropy alone leans to recall); augmentation: see data.augment.
Batch 8 crops of 256x128 by default (--crop). --bf16 runs the forward pass under CPU autocast in
bfloat16 (float sums and weights; about 1.3x the steps per second on a CPU with AVX512-BF16).

Every --validate-every steps: the held-out real photos whole, at the agent's 320x256 input and at
512x256, as Table III scores them (argmax; IoU of the text class with `###` counted as text, and
with `###` left out), and the last 5 % of the generated pairs likewise; a row in
WORK/validation.csv; WORK/latest.pt (resume point: network, optimizer, schedule, step, torch's RNG,
best so far) and WORK/best.pt (highest mean real-photo IoU over the two sizes; generated IoU
without real photos). A rerun resumes.
Deterministic from --seed for a given device and machine: the crops of step k are drawn from a
generator seeded by (seed, k), whatever --workers prepares them, and torch's generator (alpha
dropout) is seeded and checkpointed; the remaining freedom is the float summation order of torch's
kernels (fixed for a fixed --threads on the same CPU build, not across thread counts, machines or
devices); a run stopped and resumed from latest.pt ends with the same weights as one straight
through on the CPU.
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

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
import torch.nn.functional as F  # noqa: E402

import data  # noqa: E402
from mininet import MiniNet, count_flops, count_parameters

SIZES = ["x".join(map(str, size)) for size in data.VIEW_SIZES]
CSV_FIELDS = (["step", "loss", "lr", "s_per_step"]
              + [f"real_{k}_{n}" for n in SIZES for k in ("iou", "recall", "precision")]
              + [f"real_iou_legible_{n}" for n in SIZES] + [f"generated_iou_{n}" for n in SIZES]
              + ["score", "best_score", "wall_s"])


def evaluate(net, views, device="cpu"):
    """Recall, precision, IoU of the text class over whole views (argmax). IGNORE pixels count as
    text (Table III); iou_legible leaves them out."""
    net.eval()
    counts = np.zeros((2, 3))  # [### as text, ### left out] x [tp, fp, fn]
    with torch.no_grad():
        for i in range(0, len(views), 4):
            x = torch.from_numpy(np.stack([v[0] for v in views[i:i + 4]])).to(device)
            pred = net(x).argmax(1).cpu().numpy() == 1
            truth = np.stack([v[1] for v in views[i:i + 4]])
            for k, (text, counted) in enumerate(((truth != 0, truth >= 0),
                                                 (truth == 1, truth != data.IGNORE))):
                counts[k] += [(pred & text & counted).sum(), (pred & ~text & counted).sum(),
                              (~pred & text & counted).sum()]
    net.train()

    def scores(tp, fp, fn):
        return {"recall": tp / max(1, tp + fn), "precision": tp / max(1, tp + fp),
                "iou": tp / max(1, tp + fp + fn)}
    out = scores(*counts[0])
    out["iou_legible"] = scores(*counts[1])["iou"]
    return out


class StepBatches(torch.utils.data.Dataset):
    """Item k: the batch of step k, drawn from a generator seeded by (seed, k) alone."""

    def __init__(self, sources, mix, seed, crop):
        self.sources, self.mix, self.seed, self.crop = sources, mix, seed, crop

    def __len__(self):
        return 1 << 30

    def __getitem__(self, step):
        rng = random.Random(f"{self.seed}:{step}")
        batch = [data.augment(*source[rng.randrange(len(source))], rng, *self.crop)
                 for source, count in zip(self.sources, self.mix) for _ in range(count)]
        return (torch.from_numpy(np.stack([b[0] for b in batch])),
                torch.from_numpy(np.stack([b[1] for b in batch])).long())


def soft_iou_loss(logits, target):
    """1 - soft IoU of the text class over the pixels that count, the whole batch as one set."""
    p = torch.softmax(logits, 1)[:, 1]
    counted = (target != data.IGNORE).float()
    text = (target == 1).float()
    inter = (p * text * counted).sum()
    union = ((p + text - p * text) * counted).sum()
    return 1 - inter / union.clamp_min(1.0)


def one_thread_worker(_):
    torch.set_num_threads(1)
    cv2.setNumThreads(1)


def validate(net, sources, device, generated_floor=0.0):
    """Per size: real and generated scores; the selection score is the mean real IoU, less one
    whole point (so never above a checkpoint that holds it) where the mean generated IoU is below
    generated_floor."""
    row, real_ious, gen_ious = {}, [], []
    for size, name in zip(data.VIEW_SIZES, SIZES):
        gen = evaluate(net, sources.generated_views[size], device)
        gen_ious.append(gen["iou"])
        row[f"generated_iou_{name}"] = round(gen["iou"], 5)
        if sources.real_val:
            real = evaluate(net, sources.real_views[size], device)
            real_ious.append(real["iou"])
            for k in ("iou", "recall", "precision", "iou_legible"):
                row[f"real_{k}_{name}"] = round(real[k], 5)
        else:
            real_ious.append(gen["iou"])
    score = float(np.mean(real_ious))
    return row, score - 1.0 if np.mean(gen_ious) < generated_floor else score


def load_onnx_weights(net, path):
    """The weights of an exported MiniNet (export.py keeps the state-dict names; its 3x3 depthwise
    kernels padded from 1x3 / 3x1 give back their middle row / column)."""
    import onnx
    from onnx import numpy_helper
    stored = {t.name: numpy_helper.to_array(t) for t in onnx.load(path).graph.initializer}
    state = net.state_dict()
    for name, tensor in state.items():
        if tensor.dim() == 0:  # BatchNorm's num_batches_tracked is not exported
            continue
        if name not in stored:
            raise SystemExit(f"train.py: --init {path} has no weight {name}")
        w = stored[name].astype(np.float32)
        if w.shape != tuple(tensor.shape) and w.shape[2:] == (3, 3):
            w = w[:, :, 1:2, :] if tensor.shape[2] == 1 else w[:, :, :, 1:2]
        if w.shape != tuple(tensor.shape):
            raise SystemExit(f"train.py: --init {path}: {name} is {w.shape}, not "
                             f"{tuple(tensor.shape)}")
        state[name] = torch.from_numpy(np.ascontiguousarray(w))
    net.load_state_dict(state)


def rng_states(device):
    states = {"torch_rng": torch.get_rng_state()}
    if device.startswith("cuda"):
        states["cuda_rng"] = torch.cuda.get_rng_state()
    return states


def save(path, state):
    torch.save(state, path + ".tmp")
    os.replace(path + ".tmp", path)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--data", default="", help="generated pairs (images/, masks/)")
    ap.add_argument("--work", required=True, help="checkpoints, validation.csv")
    ap.add_argument("--packed", default="", help="pack.py's folder instead of --data/--icdar*")
    ap.add_argument("--steps", type=int, default=12000)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--mix", default="2,5,1",
                    help="crops per batch from generated, ICDAR train, test_blurred (sum = batch); "
                         "a missing source's share goes to the generated pairs")
    ap.add_argument("--crop", default=f"{data.TRAIN_W}x{data.TRAIN_H}", help="training crop WxH")
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--weight-power", type=float, default=0.5)
    ap.add_argument("--iou-loss", type=float, default=0.0,
                    help="weight of the soft-IoU term beside the cross-entropy (0: none)")
    ap.add_argument("--bf16", action="store_true",
                    help="forward pass under CPU autocast in bfloat16 (CPU only)")
    ap.add_argument("--validation", type=float, default=0.05, help="held-out generated fraction")
    ap.add_argument("--validate-every", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--workers", type=int, default=0, help="processes preparing batches")
    ap.add_argument("--device", default="cpu", help="cpu, or cuda where torch sees a GPU")
    ap.add_argument("--stop-at", type=int, default=0,
                    help="leave after the checkpoint at this step (a rerun goes on); 0: at --steps")
    ap.add_argument("--init", default="",
                    help="start from an exported model's weights (models/mininet/mininet_text.onnx)")
    ap.add_argument("--generated-floor", type=float, default=0.0,
                    help="best.pt only among checkpoints whose mean generated IoU reaches this, "
                         "while any does")
    ap.add_argument("--icdar-train", default="", help="ICDAR 2015 training folder (images/, gt/)")
    ap.add_argument("--icdar", default="", help="the shared data folder: test_blurred img_201..500")
    ap.add_argument("--icdar-scale", type=float, default=data.ICDAR_SCALE,
                    help="ICDAR photos are loaded at this scale before the crops zoom 0.4..1 of "
                         "it (1.0: crops see text up to its full 1280x720 size)")
    args = ap.parse_args()
    if not args.data and not args.packed:
        raise SystemExit("train.py: --data PAIRS or --packed DIR is needed")
    if args.bf16 and args.device != "cpu":
        raise SystemExit("train.py: --bf16 is CPU autocast; on a GPU leave it out")
    if not 0 <= args.iou_loss < float("inf"):
        raise SystemExit(f"train.py: --iou-loss {args.iou_loss} must be a number >= 0")
    crop = tuple(int(v) for v in args.crop.split("x"))
    if len(crop) != 2 or crop[0] % 64 or crop[1] % 64:
        raise SystemExit(f"train.py: --crop {args.crop} must be WxH, multiples of 64")

    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    os.makedirs(args.work, exist_ok=True)
    if not 0.1 <= args.icdar_scale <= 1.0:
        raise SystemExit(f"train.py: --icdar-scale {args.icdar_scale} must be in 0.1..1")
    sources = data.Sources(args.data, args.validation, args.icdar_train, args.icdar, args.packed,
                           args.icdar_scale)
    mix = [int(v) for v in args.mix.split(",")]
    if len(mix) != 3 or sum(mix) != args.batch:
        raise SystemExit(f"train.py: --mix {args.mix} must be three counts summing to --batch")
    pools = [sources.generated, sources.icdar_train, sources.blurred]
    for k in (1, 2):
        if not pools[k]:
            mix[0], mix[k] = mix[0] + mix[k], 0
    weights, freq = data.class_weights(list(zip(pools, mix)), args.weight_power)
    weights = torch.tensor(weights, dtype=torch.float32).to(args.device)
    print(f"training: {len(pools[0])} generated, {len(pools[1])} ICDAR train, {len(pools[2])} "
          f"test_blurred; batch mix {mix}, crops {crop[0]}x{crop[1]}; validation: "
          f"{len(sources.real_val)} ICDAR photos, {len(sources.generated_val)} generated; text "
          f"fraction {freq[1]:.4f}; class weights {weights.cpu().numpy().round(3).tolist()}; "
          f"device {args.device}", flush=True)

    net = MiniNet(2)
    print(f"MiniNet: {count_parameters(net) / 1e6:.3f} M parameters, "
          f"{count_flops(net, 256, 512) / 1e9:.3f} GFLOPs at 512x256", flush=True)
    if args.init:
        load_onnx_weights(net, args.init)
        print(f"starting from the weights of {args.init}", flush=True)
    net.to(args.device)
    optimizer = torch.optim.Adam(net.parameters(), lr=args.lr)
    schedule = torch.optim.lr_scheduler.LambdaLR(
        optimizer, lambda step: (1 - min(step, args.steps - 1) / args.steps) ** 0.9)
    step, best = 0, -2.0
    latest, best_path = os.path.join(args.work, "latest.pt"), os.path.join(args.work, "best.pt")
    csv_path = os.path.join(args.work, "validation.csv")
    if os.path.exists(latest):
        state = torch.load(latest, map_location=args.device)
        net.load_state_dict(state["net"])
        optimizer.load_state_dict(state["optimizer"])
        schedule.load_state_dict(state["schedule"])
        torch.set_rng_state(state["torch_rng"].cpu())
        if "cuda_rng" in state and args.device.startswith("cuda"):
            torch.cuda.set_rng_state(state["cuda_rng"].cpu())
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

    loader_options = {"prefetch_factor": 4, "worker_init_fn": one_thread_worker,
                      "persistent_workers": True} if args.workers else {}
    loader = torch.utils.data.DataLoader(
        StepBatches(pools, mix, args.seed, crop), batch_size=None,
        sampler=range(step + 1, args.steps + 1), num_workers=args.workers,
        pin_memory=args.device.startswith("cuda"), **loader_options)
    started = interval_start = time.time()
    losses = []
    net.train()
    for x, y in loader:
        x, y = x.to(args.device, non_blocking=True), y.to(args.device, non_blocking=True)
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=args.bf16):
            logits = net(x)
        logits = logits.float()
        loss = F.cross_entropy(logits, y, weight=weights, ignore_index=data.IGNORE)
        if args.iou_loss:
            loss = loss + args.iou_loss * soft_iou_loss(logits, y)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        schedule.step()
        step += 1
        losses.append(loss.item())
        if step % 50 == 0:
            print(f"step {step}/{args.steps} loss {np.mean(losses[-50:]):.4f} "
                  f"lr {schedule.get_last_lr()[0]:.2e} "
                  f"{(time.time() - interval_start) / len(losses):.3f} s/step", flush=True)
        if step % args.validate_every == 0 or step == args.steps:
            s_per_step = (time.time() - interval_start) / max(1, len(losses))
            row, score = validate(net, sources, args.device, args.generated_floor)
            improved = score > best
            best = max(best, score)
            row.update({"step": step, "loss": round(float(np.mean(losses)), 5),
                        "lr": f"{schedule.get_last_lr()[0]:.3e}", "s_per_step": round(s_per_step, 4),
                        "score": round(score, 5), "best_score": round(best, 5),
                        "wall_s": round(time.time() - started, 1)})
            print(f"validation at step {step}: {row}{' (best)' if improved else ''}", flush=True)
            state = {"net": {k: v.cpu() for k, v in net.state_dict().items()},
                     "optimizer": optimizer.state_dict(), "schedule": schedule.state_dict(),
                     "step": step, "best": best, "validation": row,
                     "class_weights": weights.tolist(), "args": vars(args),
                     **rng_states(args.device)}
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
