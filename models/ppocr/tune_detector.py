"""Tunes PP-OCRv4's detector to a smaller input: the converted detector at the small size is its
own student, started from the detector's weights, and learns the detector's own map at a larger
size (the same aspect) on the same views (no labels needed).

  /usr/bin/python3 models/ppocr/tune_detector.py --pack DIR --student ppocr_det_256x192.onnx \
      --teacher ppocr_det_384x288.onnx --work DIR [--batch 12] [--lr 1e-4] [--max-minutes 32]

Why: the agent's semantic score costs one detector pass per frame scored, in proportion to the
input's pixels; PP-OCRv4 was trained on large inputs, so at 256x192 it misses the small words it
finds at larger ones (ICDAR 2015 test_clean IoU 19.5 % against 24.8 % at 320x256, untuned). A
MiniNet distilled from scratch learnt too little in the GPU minutes sessions get
(docs/results/2026-11-27-distillation.md); a student that starts as the teacher starts where the
teacher already is and only has to adapt its filters to text two thirds the size, which two CPU
cores do in half an hour.

The pack is models/mininet/distill_pack.py's folder. Views: models/mininet/distill.py's (windows
of real and generated frames, a third of them whole frames or --whole-views of them, flips,
brightness, contrast, grey, motion blur) at the teacher's size; the student reads each view resized bilinearly to its own size (as the agent's blob resize
does), both with ImageNet's mean and std as the agent feeds the detector. Target: the teacher's
text kernels (its map over DB's binary threshold, 0.3), a student pixel text where the kernels
cover at least half of it: binary, as DB's own training targets are (a run on the averaged soft
map fared no better: with either, the students came to mark some windows of the generated
streets as text). The teacher's size is a choice: at 512x384 it finds more of ICDAR's small words
than at 384x288 but also much unlabelled text in the generated streets' textures, and its
students followed it there (docs/results/2026-11-27-tuned-detector.md). Loss: binary
cross-entropy plus the batch's soft Dice loss (the student starts calibrated, so the plain
cross-entropy does not collapse as it did from scratch). Trained: every convolution's weights and
biases and the head's batch-norm scales and shifts; the graph itself (and with it every C++
stand-in the agent runs it with) is the converted file's. Adam, cosine decay from --lr; bounded
by --steps or --max-minutes.

Every --validate-every steps: the student's filled DB boxes (the agent's post-processing) against
the truth on the packed ICDAR validation photos (ids divisible by 10, never trained on) and the
held-out generated views, at the student's size; WORK/validation.csv gets a row, WORK/last.pt and
WORK/best.pt (the best mean of the two IoUs: real photos and the product's own streets; with
--select icdar the best ICDAR IoU alone) the weights. export_tuned() writes an ONNX file: the student's converted file with its trained
initializers replaced, nothing else changed.
"""
import argparse
import csv
import json
import math
import os
import sys
import time

import cv2
import numpy as np
import onnx
import torch
import torch.nn.functional as F
from onnx import numpy_helper

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "mininet"))
import distill  # noqa: E402
from onnx_reference import Graph  # noqa: E402
from ppocr_reference import box_mask  # noqa: E402


DB_THRESHOLD = 0.3  # the detector's binary threshold (ppocr_meta.json, the .json's db)


def trainable_names(graph_module):
    """Initializers the tuning changes: convolution weights and biases, batch-norm scale/shift."""
    names = []
    for node in graph_module.order:
        inputs = list(node.input)
        if node.op_type in ("Conv", "ConvTranspose"):
            names += inputs[1:]
        elif node.op_type == "BatchNormalization":
            names += inputs[1:3]
    return [n for n in dict.fromkeys(names) if n in graph_module.buffer_names]


def input_size(model_path):
    shape = onnx.load(model_path, load_external_data=False).graph.input[0].type.tensor_type.shape
    return int(shape.dim[2].dim_value), int(shape.dim[3].dim_value)  # height, width


def validate(student, sets, size):
    student.eval()
    rows = {}
    for name, items in sets.items():
        tp = fp = fn = 0
        for k in range(0, len(items), 16):
            chunk = items[k:k + 16]
            views = np.stack([cv2.resize(i, (size[1], size[0]), interpolation=cv2.INTER_LINEAR)
                              for i, _ in chunk]).transpose(0, 3, 1, 2)
            x = torch.from_numpy(views.astype(np.float32))
            with torch.no_grad():
                maps = student(distill.teacher_input(x))[:, 0].numpy()
            for j, (_, mask) in enumerate(chunk):
                truth = cv2.resize(mask, (size[1], size[0]), interpolation=cv2.INTER_NEAREST) != 0
                found = box_mask(maps[j]) > 0
                tp += (found & truth).sum()
                fp += (found & ~truth).sum()
                fn += (~found & truth).sum()
        rows[f"{name}_iou"] = tp / max(1, tp + fp + fn)
    student.train()
    return rows


def export_tuned(student_path, state, out_path, note):
    """The student's converted file with its trained initializers replaced."""
    model = onnx.load(student_path)
    replaced = 0
    for init in model.graph.initializer:
        if init.name in state:
            value = state[init.name].detach().cpu().numpy().astype(np.float32)
            if value.shape != tuple(init.dims):
                raise SystemExit(f"tune_detector.py: {init.name} has shape {value.shape}, "
                                 f"the graph's {tuple(init.dims)}")
            init.CopyFrom(numpy_helper.from_array(value, init.name))
            replaced += 1
    if replaced != len(state):
        raise SystemExit(f"tune_detector.py: {len(state) - replaced} tuned tensors not in "
                         f"{student_path}")
    model.doc_string = note
    onnx.save(model, out_path)
    return replaced


def export(args):
    if not (args.out and args.describe):
        raise SystemExit("tune_detector.py: --export needs --out and --describe")
    saved = torch.load(args.export)
    recipe, row = saved["recipe"], saved["validation"]
    note = (f"PP-OCRv4's detector tuned to its input size by models/ppocr/tune_detector.py: step "
            f"{saved['step']}, teacher {os.path.basename(recipe['teacher'])}, lr {recipe['lr']}, "
            f"batch {recipe['batch']}, seed {recipe['seed']}; packed ICDAR validation IoU "
            f"{row.get('icdar_val_iou')}, generated {row.get('generated_val_iou')}")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    n = export_tuned(args.student, saved["tensors"], args.out, note)
    with open(args.describe) as f:
        info = json.load(f)
    info["description"] = note
    with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
        json.dump(info, f, indent=1)
        f.write("\n")
    print(f"wrote {args.out} ({n} tensors tuned) and its .json", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--pack")
    ap.add_argument("--student", required=True, help="the converted detector at the small size")
    ap.add_argument("--teacher", help="the converted detector at a larger size, same aspect")
    ap.add_argument("--work")
    ap.add_argument("--export", default="", help="a WORK/best.pt or last.pt: write it as ONNX "
                    "(--out, with a .json beside it from --describe) and stop")
    ap.add_argument("--out", default="")
    ap.add_argument("--describe", default="", help="the student's keyfleet-segmenter .json")
    ap.add_argument("--mix", default="9,2,6,3", help="weights of " + ",".join(distill.SOURCES))
    ap.add_argument("--whole-views", type=float, default=1 / 3,
                    help="share of views that show a whole frame at the teacher's size (the "
                         "rest: windows of 45..100 %% of its sides, enlarged)")
    ap.add_argument("--select", choices=("mean", "icdar"), default="mean",
                    help="best.pt by the mean of the ICDAR and generated validation IoUs, or by "
                         "ICDAR's alone (a station detector, whose teacher marks generated "
                         "textures the labels do not call text)")
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--batch", type=int, default=12)
    ap.add_argument("--lr", type=float, default=1e-4)
    ap.add_argument("--validate-every", type=int, default=100)
    ap.add_argument("--max-minutes", type=float, default=0, help="0: no limit")
    ap.add_argument("--threads", type=int, default=0, help="torch threads (0: torch's choice)")
    ap.add_argument("--resume", default="", help="a WORK/last.pt to continue from")
    ap.add_argument("--keep", action="store_true", help="also keep WORK/step_N.pt at each validation")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    if args.export:
        export(args)
        return
    if not (args.pack and args.teacher and args.work):
        ap.error("training needs --pack, --teacher and --work")
    start = time.time()
    os.makedirs(args.work, exist_ok=True)
    torch.manual_seed(args.seed)
    if args.threads:
        torch.set_num_threads(args.threads)

    small, big = input_size(args.student), input_size(args.teacher)
    if (big[0] < small[0] or big[1] < small[1]
            or abs(big[1] * small[0] / (big[0] * small[1]) - 1) > 0.01):
        raise SystemExit(f"tune_detector.py: the teacher's input {big[1]}x{big[0]} is not a "
                         f"larger view of the student's {small[1]}x{small[0]} (the same aspect)")
    distill.VIEW_H, distill.VIEW_W = big  # the views are made at the teacher's size
    teacher = Graph(args.teacher).eval()
    student = Graph(args.student)
    names = trainable_names(student)
    params = [getattr(student, student.buffer_names[n]) for n in names]
    for p in params:
        p.requires_grad_(True)
    step0 = 0
    if args.resume:
        saved = torch.load(args.resume)
        with torch.no_grad():
            for n, p in zip(names, params):
                p.copy_(saved["tensors"][n])
        step0 = saved["step"]
        print(f"resumed {args.resume} at step {step0}", flush=True)
    print(f"student {small[1]}x{small[0]}: {len(params)} tensors, "
          f"{sum(p.numel() for p in params) / 1e6:.3f} M values tuned; teacher {big[1]}x{big[0]}",
          flush=True)
    views = distill.Views(args.pack, [float(v) for v in args.mix.split(",")], torch.device("cpu"),
                          args.seed + step0, whole=args.whole_views)
    sets = {"icdar_val": distill.load_folder(os.path.join(args.pack, "icdar_val"), True),
            "generated_val": distill.load_folder(os.path.join(args.pack, "generated_val"), True)}
    optimizer = torch.optim.Adam(params, lr=args.lr)
    log = open(os.path.join(args.work, "validation.csv"), "a", newline="")
    writer, best, losses = None, -1.0, []

    def save(path, step, row):
        torch.save({"tensors": {n: p.detach().clone() for n, p in zip(names, params)},
                    "step": step, "validation": row, "recipe": vars(args)}, path)

    def checkpoint(step):
        nonlocal writer, best
        row = {"step": step, "wall_s": round(time.time() - start, 1),
               "loss": round(float(np.mean(losses)), 5) if losses else None}
        losses.clear()
        row.update({k: round(float(v), 4) for k, v in validate(student, sets, small).items()})
        if writer is None:
            writer = csv.DictWriter(log, fieldnames=list(row))
            if log.tell() == 0:
                writer.writeheader()
        writer.writerow(row)
        log.flush()
        print(" ".join(f"{k}={v}" for k, v in row.items()), flush=True)
        save(os.path.join(args.work, "last.pt"), step, row)
        if args.keep:
            save(os.path.join(args.work, f"step_{step}.pt"), step, row)
        score = row["icdar_val_iou"]
        if args.select == "mean":
            score = (score + row["generated_val_iou"]) / 2
        if score > best:
            best = score
            save(os.path.join(args.work, "best.pt"), step, row)

    if step0 == 0:
        checkpoint(0)  # the untuned detector at the small size: the floor to beat
    step = step0
    for step in range(step0 + 1, args.steps + 1):
        x = views.batch(args.batch)
        with torch.no_grad():
            kernels = (teacher(distill.teacher_input(x)) > DB_THRESHOLD).float()
            target = (F.adaptive_avg_pool2d(kernels, small) >= 0.5).float()
        small_x = F.interpolate(x, size=small, mode="bilinear", align_corners=False)
        progress = step / args.steps
        if args.max_minutes:
            progress = max(progress, (time.time() - start) / (args.max_minutes * 60))
        for group in optimizer.param_groups:
            group["lr"] = args.lr * 0.5 * (1 + math.cos(math.pi * min(1.0, progress)))
        p = student(distill.teacher_input(small_x)).float().clamp(1e-6, 1 - 1e-6)
        bce = F.binary_cross_entropy(p, target)
        dice = 1 - (2 * (p * target).sum() + 1) / (p.sum() + target.sum() + 1)
        loss = bce + dice
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        losses.append(float(loss.detach()))
        if step % 20 == 0:
            print(f"step {step} {time.time() - start:.0f} s loss {np.mean(losses[-20:]):.4f}",
                  flush=True)
        out_of_time = progress >= 1 and step < args.steps
        if step % args.validate_every == 0 or out_of_time:
            checkpoint(step)
        if out_of_time:
            print(f"stopped by --max-minutes at step {step}", flush=True)
            break
    else:
        if step % args.validate_every:  # the last steps are validated and saved too
            checkpoint(step)
    print(f"done: step {step}, {time.time() - start:.0f} s; best mean validation IoU {best:.4f}",
          flush=True)


if __name__ == "__main__":
    main()
