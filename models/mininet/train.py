"""Trains MiniNet for text segmentation on the CPU, the paper's recipe scaled to 2 cores.

  /usr/bin/python3 models/mininet/train.py --data DIR --work DIR [--steps 4000] [--icdar DATA]

DIR holds images/NNNNNN.jpg + masks/NNNNNN.png (255 = inside a word box) from `keyfleet scenario
training`; with --icdar, a quarter of each batch comes from the real ICDAR 2015 test_blurred
photos that the evaluation does not use (their word quads as masks).
Adam (lr 1e-3) with polynomial decay (power 0.9); cross-entropy with median-frequency class
weights raised to a power, w_c = (f_median / f_c) ** power; augmentation: horizontal flips,
shifts and scales up to 10 %, contrast 0.9..1.2, random greyscale. Batch 8 at 256x128 (the
paper: batch 32; a CPU step costs about 0.3 s here). Deterministic from --seed; a checkpoint
every --checkpoint-every steps in --work, and a rerun resumes from the latest.
"""
import argparse
import glob
import json
import os
import random
import time

import cv2
import numpy as np
import torch
import torch.nn.functional as F

from mininet import MiniNet, count_flops, count_parameters

TRAIN_W, TRAIN_H = 256, 128


def load_pairs(data_dir, scale=1.0):
    images = sorted(glob.glob(os.path.join(data_dir, "images", "*.jpg")))
    if not images:
        raise SystemExit(f"train.py: no images in {data_dir}/images (run keyfleet scenario training)")
    pairs = []
    for path in images:
        name = os.path.splitext(os.path.basename(path))[0]
        mask_path = os.path.join(data_dir, "masks", name + ".png")
        image = cv2.imread(path, cv2.IMREAD_COLOR)
        mask = cv2.imread(mask_path, cv2.IMREAD_GRAYSCALE)
        if image is None or mask is None:
            raise SystemExit(f"train.py: unreadable pair {path} / {mask_path}")
        image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        mask = cv2.resize(mask, (image.shape[1], image.shape[0]), interpolation=cv2.INTER_NEAREST)
        pairs.append((image, (mask > 127).astype(np.uint8)))
    return pairs


BLURRED_HELD_OUT = 100  # test_blurred's first 100 photos (img_101..200) are the evaluation's


def load_icdar_blurred(data_root, scale=0.5):
    """ICDAR 2015 test_blurred photos after the evaluation's first 100, word quads (### too:
    illegible text is still text) filled as masks, scaled to the agent's frame size."""
    folder = os.path.join(data_root, "icdar2015", "test_blurred")
    images = sorted(glob.glob(os.path.join(folder, "images", "*.jpg")))[BLURRED_HELD_OUT:]
    pairs = []
    for path in images:
        image = cv2.imread(path, cv2.IMREAD_COLOR)
        if image is None:
            raise SystemExit(f"train.py: unreadable photo {path}")
        mask = np.zeros(image.shape[:2], np.uint8)
        name = os.path.splitext(os.path.basename(path))[0]
        with open(os.path.join(folder, "gt", f"gt_{name}.txt"), encoding="utf-8-sig") as gt:
            for line in gt:
                fields = line.strip().split(",")
                if len(fields) >= 8:
                    quad = np.array(fields[:8], dtype=np.int32).reshape(4, 2)
                    cv2.fillPoly(mask, [quad], 1)
        image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        mask = cv2.resize(mask, (image.shape[1], image.shape[0]), interpolation=cv2.INTER_NEAREST)
        pairs.append((image, mask))
    return pairs


def augment(image, mask, rng):
    """A random 2:1 crop (zoom 0.4..1 of the frame width, centred on text half of the time)
    with shift and scale jitter up to 10 %, horizontal flip, contrast and greyscale."""
    h, w = image.shape[:2]
    crop_w = int(rng.uniform(TRAIN_W, min(w, 2 * h)))
    crop_h = crop_w // 2
    ys, xs = np.nonzero(mask)
    if len(xs) and rng.random() < 0.5:
        k = rng.randrange(len(xs))
        x0 = int(np.clip(xs[k] - crop_w // 2, 0, w - crop_w))
        y0 = int(np.clip(ys[k] - crop_h // 2, 0, h - crop_h))
    else:
        x0 = rng.randint(0, w - crop_w)
        y0 = rng.randint(0, h - crop_h)
    s = rng.uniform(0.9, 1.1)
    tx = rng.uniform(-0.1, 0.1) * TRAIN_W
    ty = rng.uniform(-0.1, 0.1) * TRAIN_H
    k = TRAIN_W / crop_w * s
    m = np.array([[k, 0, -x0 * k + tx + (1 - s) * TRAIN_W / 2],
                  [0, k, -y0 * k + ty + (1 - s) * TRAIN_H / 2]], dtype=np.float32)
    img = cv2.warpAffine(image, m, (TRAIN_W, TRAIN_H), flags=cv2.INTER_AREA,
                         borderMode=cv2.BORDER_REFLECT)
    msk = cv2.warpAffine(mask, m, (TRAIN_W, TRAIN_H), flags=cv2.INTER_NEAREST,
                         borderMode=cv2.BORDER_REFLECT)
    if rng.random() < 0.5:
        img, msk = img[:, ::-1], msk[:, ::-1]
    img = img.astype(np.float32)
    contrast = rng.uniform(0.9, 1.2)
    img = (img - img.mean()) * contrast + img.mean()
    if rng.random() < 0.2:
        grey = img @ np.array([0.114, 0.587, 0.299], dtype=np.float32)
        img = np.repeat(grey[:, :, None], 3, axis=2)
    img = np.clip(img, 0, 255) / 255.0 - 0.5
    return np.ascontiguousarray(img.transpose(2, 0, 1)), np.ascontiguousarray(msk)


def whole_view(image, mask, width=512, height=384):
    """Validation: the whole frame at the agent's input size, no augmentation."""
    img = cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)
    msk = cv2.resize(mask, (width, height), interpolation=cv2.INTER_NEAREST)
    return (img.astype(np.float32).transpose(2, 0, 1) / 255.0 - 0.5), msk


def pick(generated, real, real_fraction, rng):
    if real and rng.random() < real_fraction:
        return real[rng.randrange(len(real))]
    return generated[rng.randrange(len(generated))]


def class_weights(pairs, power):
    text = sum(int(m.sum()) for _, m in pairs)
    total = sum(m.size for _, m in pairs)
    freq = np.array([1 - text / total, text / total])
    weights = (np.median(freq) / freq) ** power
    return torch.tensor(weights, dtype=torch.float32), freq


def evaluate(net, batch_images, batch_masks):
    net.eval()
    tp = fp = fn = 0
    with torch.no_grad():
        for i in range(0, len(batch_images), 4):
            x = torch.from_numpy(np.stack(batch_images[i:i + 4]))
            pred = net(x).argmax(1).numpy()
            truth = np.stack(batch_masks[i:i + 4])
            tp += int(((pred == 1) & (truth == 1)).sum())
            fp += int(((pred == 1) & (truth == 0)).sum())
            fn += int(((pred == 0) & (truth == 1)).sum())
    net.train()
    recall = tp / max(1, tp + fn)
    precision = tp / max(1, tp + fp)
    iou = tp / max(1, tp + fp + fn)
    return {"recall": recall, "precision": precision, "iou": iou}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--data", required=True)
    ap.add_argument("--work", required=True, help="checkpoints and the training log")
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--weight-power", type=float, default=0.5)
    ap.add_argument("--validation", type=float, default=0.05, help="held-out fraction")
    ap.add_argument("--checkpoint-every", type=int, default=250)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--icdar", default="",
                    help="the shared data folder: ICDAR test_blurred photos join the training")
    ap.add_argument("--real-fraction", type=float, default=0.25,
                    help="share of each batch drawn from the real photos")
    args = ap.parse_args()

    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    rng = random.Random(args.seed)
    os.makedirs(args.work, exist_ok=True)

    pairs = load_pairs(args.data)
    held = max(1, int(len(pairs) * args.validation))
    train, val = pairs[:-held], pairs[-held:]  # the last views: other streets than most
    real = []
    if args.icdar:
        if os.path.isdir(os.path.join(args.icdar, "icdar2015", "test_blurred")):
            real = load_icdar_blurred(args.icdar)
        else:
            print(f"no ICDAR photos under {args.icdar}: generated views only", flush=True)
    weights, freq = class_weights(train + real, args.weight_power)
    val_images, val_masks = zip(*[whole_view(i, m) for i, m in val])
    print(f"{len(train)} generated + {len(real)} real training / {len(val)} validation pairs; "
          f"text fraction {freq[1]:.4f}; "
          f"class weights {weights.numpy().round(3).tolist()}", flush=True)

    net = MiniNet(2)
    print(f"MiniNet: {count_parameters(net) / 1e6:.3f} M parameters, "
          f"{count_flops(net, 256, 512) / 1e9:.3f} GFLOPs at 512x256", flush=True)
    optimizer = torch.optim.Adam(net.parameters(), lr=args.lr)
    schedule = torch.optim.lr_scheduler.LambdaLR(
        optimizer, lambda step: (1 - min(step, args.steps - 1) / args.steps) ** 0.9)
    step = 0
    latest = os.path.join(args.work, "latest.pt")
    if os.path.exists(latest):
        state = torch.load(latest)
        net.load_state_dict(state["net"])
        optimizer.load_state_dict(state["optimizer"])
        schedule.load_state_dict(state["schedule"])
        rng.setstate(state["rng"])
        torch.set_rng_state(state["torch_rng"])
        step = state["step"]
        print(f"resuming from step {step}", flush=True)

    log = open(os.path.join(args.work, "training_log.jsonl"), "a")
    started = time.time()
    net.train()
    while step < args.steps:
        batch = [augment(*pick(train, real, args.real_fraction, rng), rng) for _ in range(args.batch)]
        x = torch.from_numpy(np.stack([b[0] for b in batch]))
        y = torch.from_numpy(np.stack([b[1] for b in batch])).long()
        loss = F.cross_entropy(net(x), y, weight=weights)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        schedule.step()
        step += 1
        if step % 50 == 0:
            rate = (time.time() - started) / 50
            started = time.time()
            print(f"step {step}/{args.steps} loss {loss.item():.4f} lr {schedule.get_last_lr()[0]:.2e} "
                  f"{rate:.2f} s/step", flush=True)
            log.write(json.dumps({"step": step, "loss": loss.item(), "s_per_step": rate}) + "\n")
        if step % args.checkpoint_every == 0 or step == args.steps:
            metrics = evaluate(net, val_images, val_masks)
            print(f"validation at step {step}: {metrics}", flush=True)
            log.write(json.dumps({"step": step, "validation": metrics}) + "\n")
            log.flush()
            torch.save({"net": net.state_dict(), "optimizer": optimizer.state_dict(),
                        "schedule": schedule.state_dict(), "rng": rng.getstate(),
                        "torch_rng": torch.get_rng_state(), "step": step,
                        "validation": metrics, "class_weights": weights.tolist()}, latest + ".tmp")
            os.replace(latest + ".tmp", latest)
    print("training done", flush=True)


if __name__ == "__main__":
    main()
