"""Distils PP-OCRv4's detector into MiniNet students: the teacher's text-probability map is each
student's soft target, on augmented views of real and generated frames (no labels needed).

  python3 models/mininet/distill.py --pack DIR --teacher ppocr_det_320x256.onnx --work DIR \
      [--students 1.0,0.5] [--init models/mininet/mininet_text.onnx] [--steps 6000]
      [--batch 48] [--device cuda] [--max-minutes 8]

The pack is distill_pack.py's folder. Every step draws --batch views: a source by --mix (weights
of icdar_train, blurred, generated, frames), an image, and a window of it (the whole frame a third
of the time, else 45..100 % of its width and, independently, 45..100 % of its height, anywhere),
resized bilinearly to the agent's 320x256 (so the aspect changes as the agent's own whole-frame
resize changes it), flipped half the time, with brightness, contrast and greyscale
(p 0.2) jitter and horizontal or oblique motion blur (p 0.3, 3..15 px). The teacher (models/ppocr/
onnx_reference.py's Graph, frozen, float32) reads each view as the agent feeds it (ImageNet mean and std) and gives its
probability map; each student (MiniNet, one logit, `width` scaling every layer's channels) reads
the same view as MiniNet does (BGR / 255 - 0.5) and learns that map: binary cross-entropy against
the soft target, its text and background halves balanced, plus the soft Dice loss of the text
probability over the batch (text is a few per cent of the pixels: without the balance the
students learn to paint it out, and their sigmoids saturate where nothing moves them back). Adam, cosine decay from
--lr (a student started from --init, the shipped 2-class MiniNet, uses lr / 2, its text logit
initialised to logit_text - logit_background so it starts as the shipped model), bfloat16
autocast on CUDA.

Every --validate-every steps and at the end, on the packed validation images (never trained on)
at 320x256: per student, the IoU of its filled DB boxes (PP-OCR's post-processing, as the agent
runs it) against the truth (`###` counted as text, as Table III scores) and against the
teacher's own boxes; WORK/validation.csv gets a row, WORK/student_W_last.pt the weights, and
WORK/student_W_best.pt those with the best ICDAR validation IoU. A run stops at --steps or
--max-minutes, whichever comes first: the cosine schedule follows whichever of the two is further
along, so a run limited by time still ends at a rate of zero (and is then no longer deterministic
from --seed: how many steps fit depends on the machine). export.py --distilled turns a .pt into the agent's ONNX.
"""
import argparse
import csv
import glob
import math
import os
import sys
import time

import cv2
import numpy as np
import torch
import torch.nn.functional as F

import data
from mininet import MiniNet, count_parameters
from ppocr_reference import box_mask

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "ppocr"))
from onnx_reference import Graph  # noqa: E402

VIEW_H, VIEW_W = 256, 320
TEACHER_MEAN = [0.485, 0.456, 0.406]  # applied to B, G, R in that order, as the agent does
TEACHER_STD = [0.229, 0.224, 0.225]
SOURCES = ("icdar_train", "blurred", "generated", "frames")


def load_folder(folder, with_masks=False):
    """The folder's images (and truth masks), decoded by a pool of threads (OpenCV lets go of
    Python's lock while it decodes)."""
    from concurrent.futures import ThreadPoolExecutor

    def load(path):
        image = cv2.imread(path, cv2.IMREAD_COLOR)
        if image is None:
            raise SystemExit(f"distill.py: unreadable image {path}")
        if not with_masks:
            return image
        mask = cv2.imread(path[:-5] + ".png", cv2.IMREAD_GRAYSCALE)
        if mask is None:
            raise SystemExit(f"distill.py: no truth mask beside {path}")
        return image, mask

    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        return list(pool.map(load, sorted(glob.glob(os.path.join(folder, "*.webp")))))


def text_logit_init(student, path):
    """The shipped 2-class MiniNet's weights; the one output logit = text - background."""
    from train import load_onnx_weights
    two = MiniNet(2)
    load_onnx_weights(two, path)
    state = two.state_dict()
    state["output.weight"] = state["output.weight"][:, 1:2] - state["output.weight"][:, 0:1]
    state["output.bias"] = state["output.bias"][1:2] - state["output.bias"][0:1]
    student.load_state_dict(state)


class Views:
    """Augmented 320x256 views, made on the device a batch at a time: each source is one uint8
    tensor (images padded to the source's largest), a batch's windows one affine grid sample per
    source (bilinear, as the agent's own resize), its blur one grouped convolution."""

    def __init__(self, pack, mix, device, seed, bank=256, whole=1 / 3):
        self.device = device
        self.whole = whole  # the share of views that are a whole frame
        self.sources, self.sizes, weights = [], [], []
        for name, weight in zip(SOURCES, mix):
            images = load_folder(os.path.join(pack, name))
            if not images or weight <= 0:
                print(f"source {name}: {len(images)} images, weight {weight}: not used", flush=True)
                continue
            h = max(i.shape[0] for i in images)
            w = max(i.shape[1] for i in images)
            stack = np.zeros((len(images), 3, h, w), np.uint8)
            for k, image in enumerate(images):
                stack[k, :, :image.shape[0], :image.shape[1]] = image.transpose(2, 0, 1)
            self.sources.append(torch.from_numpy(stack).to(device))
            self.sizes.append(np.array([i.shape[:2] for i in images], np.float64))
            weights.append(weight)
            print(f"source {name}: {len(images)} images, weight {weight}", flush=True)
        self.weights = np.array(weights) / sum(weights)
        self.rng = np.random.default_rng(seed)
        # A bank of motion-blur kernels, 3..15 px, horizontal half the time; index 0: none.
        kernels = np.zeros((bank, 15, 15), np.float32)
        kernels[0, 7, 7] = 1
        for k in range(1, bank):
            angle = 0.0 if k % 2 else float(self.rng.uniform(0, 180))
            m = data.motion_kernel(int(self.rng.integers(3, 16)), angle)
            o = (15 - m.shape[0]) // 2
            kernels[k, o:o + m.shape[0], o:o + m.shape[1]] = m
        self.kernels = torch.from_numpy(kernels).to(device)
        self.grey = torch.tensor([0.114, 0.587, 0.299], device=device).view(1, 3, 1, 1)

    def windows(self, sizes, padded):
        """Affine parameters (n x 2 x 3) of random windows: the whole frame `whole` of the time,
        else 45..100 % of its width and, independently, of its height; flipped half the time."""
        rng, n = self.rng, len(sizes)
        h, w = sizes[:, 0], sizes[:, 1]
        whole = rng.random(n) < self.whole
        ww = np.where(whole, w, np.maximum(32, w * rng.uniform(0.45, 1.0, n)))
        wh = np.where(whole, h, np.maximum(32, h * rng.uniform(0.45, 1.0, n)))
        x0 = rng.random(n) * (w - ww)
        y0 = rng.random(n) * (h - wh)
        flip = np.where(rng.random(n) < 0.5, -1.0, 1.0)
        theta = np.zeros((n, 2, 3), np.float32)
        theta[:, 0, 0] = ww / padded[1] * flip
        theta[:, 0, 2] = (x0 + ww / 2) / padded[1] * 2 - 1
        theta[:, 1, 1] = wh / padded[0]
        theta[:, 1, 2] = (y0 + wh / 2) / padded[0] * 2 - 1
        return torch.from_numpy(theta).to(self.device)

    def batch(self, n):
        rng = self.rng
        counts = rng.multinomial(n, self.weights)
        views = []
        for source, sizes, count in zip(self.sources, self.sizes, counts):
            if count == 0:
                continue
            index = rng.integers(0, len(source), count)
            theta = self.windows(sizes[index], source.shape[2:])
            grid = F.affine_grid(theta, (int(count), 3, VIEW_H, VIEW_W), align_corners=False)
            views.append(F.grid_sample(source[torch.from_numpy(index).to(self.device)].float(),
                                       grid, mode="bilinear", padding_mode="border",
                                       align_corners=False))
        x = torch.cat(views)[torch.from_numpy(rng.permutation(n)).to(self.device)]
        contrast = torch.from_numpy(rng.uniform(0.7, 1.3, (n, 1, 1, 1)).astype(np.float32))
        brightness = torch.from_numpy(rng.uniform(-25, 25, (n, 1, 1, 1)).astype(np.float32))
        mean = x.mean(dim=(1, 2, 3), keepdim=True)
        x = (x - mean) * contrast.to(self.device) + mean + brightness.to(self.device)
        grey = torch.from_numpy(rng.random((n, 1, 1, 1)) < 0.2).to(self.device)
        x = torch.where(grey, (x * self.grey).sum(1, keepdim=True).expand(-1, 3, -1, -1), x)
        blur = np.where(rng.random(n) < 0.3, rng.integers(1, len(self.kernels), n), 0)
        k = self.kernels[torch.from_numpy(blur).to(self.device)][:, None].repeat_interleave(3, 0)
        x = F.conv2d(F.pad(x.reshape(1, n * 3, VIEW_H, VIEW_W), (7, 7, 7, 7), mode="reflect"),
                     k, groups=n * 3).reshape(n, 3, VIEW_H, VIEW_W)
        return x.clamp(0, 255).round()


def teacher_input(x):
    mean = torch.tensor(TEACHER_MEAN, device=x.device).view(1, 3, 1, 1)
    std = torch.tensor(TEACHER_STD, device=x.device).view(1, 3, 1, 1)
    return (x / 255.0 - mean) / std


def student_input(x):
    return x / 255.0 - 0.5


def distill_loss(logits, target):
    """Balanced soft binary cross-entropy (text and background halves each averaged over their
    own soft mass, as DB balances its few text pixels) plus the batch's soft Dice loss."""
    text_mass, background_mass = target.sum() + 1.0, (1 - target).sum() + 1.0
    pos = F.binary_cross_entropy_with_logits(logits, torch.ones_like(target), reduction="none")
    neg = F.binary_cross_entropy_with_logits(logits, torch.zeros_like(target), reduction="none")
    bce = 0.5 * ((target * pos).sum() / text_mass + ((1 - target) * neg).sum() / background_mass)
    p = torch.sigmoid(logits)
    dice = 1 - (2 * (p * target).sum() + 1) / (p.sum() + target.sum() + 1)
    return bce + dice


def validate(students, teacher, sets, device):
    """Per student and set: IoU of filled DB boxes against the truth and against the teacher's."""
    for s in students.values():
        s.eval()  # alpha dropout off
    rows = {}
    for name, items in sets.items():
        counts = {w: np.zeros(6) for w in students}  # truth tp fp fn, teacher tp fp fn
        for k in range(0, len(items), 16):
            chunk = items[k:k + 16]
            views = np.stack([cv2.resize(i, (VIEW_W, VIEW_H), interpolation=cv2.INTER_LINEAR)
                              for i, _ in chunk]).transpose(0, 3, 1, 2)
            truths = [cv2.resize(m, (VIEW_W, VIEW_H), interpolation=cv2.INTER_NEAREST)
                      for _, m in chunk]
            x = torch.from_numpy(views.astype(np.float32)).to(device)
            with torch.no_grad():
                t = teacher(teacher_input(x))[:, 0].float().cpu().numpy()
                outs = {w: torch.sigmoid(s(student_input(x)))[:, 0].float().cpu().numpy()
                        for w, s in students.items()}
            for j, truth in enumerate(truths):
                text = truth != 0
                tmask = box_mask(t[j]) > 0
                for w, out in outs.items():
                    smask = box_mask(out[j]) > 0
                    counts[w] += [(smask & text).sum(), (smask & ~text).sum(), (~smask & text).sum(),
                                  (smask & tmask).sum(), (smask & ~tmask).sum(), (~smask & tmask).sum()]
        for w, c in counts.items():
            rows[f"{name}_iou_truth_w{w}"] = c[0] / max(1, c[0] + c[1] + c[2])
            rows[f"{name}_iou_teacher_w{w}"] = c[3] / max(1, c[3] + c[4] + c[5])
    for s in students.values():
        s.train()
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--pack", required=True)
    ap.add_argument("--teacher", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--students", default="1.0,0.5", help="width multipliers, comma-separated")
    ap.add_argument("--init", default="", help="shipped 2-class MiniNet for the width-1.0 student")
    ap.add_argument("--resume", default="",
                    help="WIDTH=CHECKPOINT,...: students that start from an earlier run's weights")
    ap.add_argument("--mix", default="9,2,6,3", help="weights of " + ",".join(SOURCES))
    ap.add_argument("--steps", type=int, default=6000)
    ap.add_argument("--batch", type=int, default=48)
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--validate-every", type=int, default=1000)
    ap.add_argument("--validate-at-start", action="store_true")
    ap.add_argument("--save-every", type=int, default=0,
                    help="also save each student_W_last.pt every N steps, unvalidated (0: never)")
    ap.add_argument("--max-minutes", type=float, default=0, help="0: no limit")
    ap.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    start = time.time()
    os.makedirs(args.work, exist_ok=True)
    torch.manual_seed(args.seed)
    device = torch.device(args.device)
    if device.type == "cuda":
        torch.backends.cudnn.benchmark = True
        torch.backends.cuda.matmul.allow_tf32 = True
        torch.backends.cudnn.allow_tf32 = True

    teacher = Graph(args.teacher).to(device).eval()
    views = Views(args.pack, [float(v) for v in args.mix.split(",")], device, args.seed)
    sets = {"icdar_val": load_folder(os.path.join(args.pack, "icdar_val"), True),
            "generated_val": load_folder(os.path.join(args.pack, "generated_val"), True)}
    resume = {float(w): path for w, path in
              (item.split("=", 1) for item in args.resume.split(",") if item)}
    students, optimizers = {}, {}
    for width in [float(w) for w in args.students.split(",")]:
        net = MiniNet(1, width)
        lr = args.lr
        if width in resume:
            state = torch.load(resume[width], map_location="cpu")
            if state.get("width") != width or state.get("classes") != 1:
                raise SystemExit(f"distill.py: {resume[width]} is no width-{width} student")
            net.load_state_dict(state["net"])
            print(f"student w{width} resumes {resume[width]} (its step {state['step']})", flush=True)
        elif width == 1.0 and args.init:
            text_logit_init(net, args.init)
            lr = args.lr / 2
            print(f"student w1.0 starts from {args.init}", flush=True)
        students[width] = net.to(device).train()
        optimizers[width] = (torch.optim.Adam(net.parameters(), lr=lr), lr)
        print(f"student w{width}: {count_parameters(net) / 1e6:.3f} M parameters", flush=True)

    log_path = os.path.join(args.work, "validation.csv")
    best = {w: -1.0 for w in students}
    losses = {w: [] for w in students}
    writer, log = None, open(log_path, "a", newline="")
    autocast = (torch.autocast("cuda", dtype=torch.bfloat16) if device.type == "cuda"
                else torch.autocast("cpu", enabled=False))

    def checkpoint(step, final=False):
        nonlocal writer
        rows = validate(students, teacher, sets, device)
        row = {"step": step, "wall_s": round(time.time() - start, 1)}
        for w in students:
            row[f"loss_w{w}"] = round(float(np.mean(losses[w])), 5) if losses[w] else None
            losses[w].clear()
        row.update({k: round(float(v), 4) for k, v in rows.items()})
        if writer is None:
            writer = csv.DictWriter(log, fieldnames=list(row))
            writer.writeheader()
        writer.writerow(row)
        log.flush()
        print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
        for w, net in students.items():
            state = {"net": net.state_dict(), "width": w, "step": step, "classes": 1,
                     "validation": {k: v for k, v in row.items() if k.endswith(f"w{w}")},
                     "recipe": vars(args)}
            torch.save(state, os.path.join(args.work, f"student_w{w}_last.pt"))
            score = row[f"icdar_val_iou_truth_w{w}"]
            if score > best[w]:
                best[w] = score
                torch.save(state, os.path.join(args.work, f"student_w{w}_best.pt"))

    if args.validate_at_start:
        checkpoint(0)
    step, out_of_time = 0, False
    for step in range(1, args.steps + 1):
        x = views.batch(args.batch)
        with torch.no_grad():
            target = teacher(teacher_input(x)).float().clamp(0, 1)
        progress = step / args.steps
        if args.max_minutes:
            progress = max(progress, (time.time() - start) / (args.max_minutes * 60))
        decay = 0.5 * (1 + math.cos(math.pi * min(1.0, progress)))
        for w, net in students.items():
            optimizer, lr = optimizers[w]
            for group in optimizer.param_groups:
                group["lr"] = lr * decay
            with autocast:
                logits = net(student_input(x))
            loss = distill_loss(logits.float(), target)
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            optimizer.step()
            losses[w].append(float(loss.detach()))
        if step % 200 == 0:
            print(f"step {step} {time.time() - start:.0f} s "
                  + " ".join(f"w{w} {np.mean(l[-100:]):.4f}" for w, l in losses.items()), flush=True)
        if args.save_every and step % args.save_every == 0:
            for w, net in students.items():
                torch.save({"net": net.state_dict(), "width": w, "step": step, "classes": 1,
                            "validation": {}, "recipe": vars(args)},
                           os.path.join(args.work, f"student_w{w}_last.pt"))
        out_of_time = progress >= 1 and step < args.steps
        if step % args.validate_every == 0 or out_of_time:
            checkpoint(step)
        if out_of_time:
            print(f"stopped by --max-minutes at step {step} of {args.steps}", flush=True)
            break
    if step % args.validate_every and not out_of_time:
        checkpoint(step)
    print(f"done: {step} steps in {time.time() - start:.0f} s; best ICDAR validation IoU "
          + ", ".join(f"w{w} {b:.4f}" for w, b in best.items()), flush=True)


if __name__ == "__main__":
    main()
