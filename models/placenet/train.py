"""Trains PlaceNet, the holistic place descriptor, on generated two-day streets (metric learning).

  /usr/bin/python3 models/placenet/train.py --work DIR [--steps N] [--threads 2]

Reads WORK/streets/*.npz (streets.py). A batch holds STREETS_PER_BATCH streets x PLACES_PER_STREET
places x 2 views: a random frame of a random drone, and a frame of another drone (of the other day
with probability OTHER_DAY) whose camera looks within POSITIVE_M of the same street point. Pairs of
the batch are positives when they are on one street within POSITIVE_M, negatives when on other
streets or farther apart than NEGATIVE_M, ignored in between. Multi-similarity loss (Wang et al.,
CVPR 2019: alpha 2, beta 50, lambda 0.5, pairs mined with margin 0.1); Adam (lr 1e-3, cosine decay
to zero over --steps, weight decay 1e-4). Augmentation per view (augment()): a small affine
jitter, exposure gain and gamma, motion blur, sensor noise, JPEG artefacts: the conditions the
seed's CNN feature is claimed to withstand.

Every --validate-every steps: on each validation street (streets.VALIDATION_SEEDS, both kinds),
the day-1 views query a database of the day-0 views by cosine similarity; recall@1 and @5 count a
query right when a retrieved view looks within TOLERANCE_M of the query's street point (keyfleet
eval's place tolerance), over the queries that have such a view; once as rendered and once with
the queries blurred and darkened (fixed per query). A row in WORK/validation.csv; WORK/latest.pt
(resume point: network, optimizer, step, torch's RNG, best so far) and WORK/best.pt (highest mean
recall@1 over clean and degraded). A rerun resumes. Deterministic from --seed for a given
--threads on one CPU: the batch of step k is drawn from a generator seeded by (seed, k).
"""
import argparse
import csv
import glob
import math
import os
import random
import time

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # sleep, not spin, on shared cores

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

import streets  # noqa: E402
from placenet import PlaceNet, count_macs, count_parameters  # noqa: E402

STREETS_PER_BATCH = 4
PLACES_PER_STREET = 8
OTHER_DAY = 0.75
POSITIVE_M = 1.5
NEGATIVE_M = 10.0
TOLERANCE_M = 5.0
CSV_FIELDS = ["step", "loss", "lr", "s_per_step", "recall1", "recall5", "degraded_recall1",
              "degraded_recall5", "score", "best_score", "wall_s"]


class Street:
    def __init__(self, path):
        z = np.load(path)
        self.name = os.path.basename(path)[:-4]
        self.images, self.position = z["images"], z["position"].astype(np.float64)
        self.drone, self.day = z["drone"], z["day"]

    def __len__(self):
        return len(self.images)


def motion_blur(image, length, angle_deg):
    size = int(math.ceil(length)) | 1
    kernel = np.zeros((size, size), np.float32)
    c = size // 2
    dx, dy = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    for t in np.linspace(-length / 2, length / 2, 4 * size):
        kernel[int(round(c + t * dy)), int(round(c + t * dx))] = 1
    return cv2.filter2D(image, -1, kernel / kernel.sum(), borderType=cv2.BORDER_REFLECT)


def degrade(image, rng, blur_px, gain):
    """Motion blur of blur_px (at the 160 px input) and an exposure gain."""
    out = motion_blur(image, blur_px, rng.uniform(0, 180)) if blur_px >= 1 else image
    return np.clip(out.astype(np.float32) * gain, 0, 255).astype(np.uint8)


def augment(image, rng):
    h, w = image.shape[:2]
    angle, scale = rng.uniform(-3, 3), math.exp(rng.uniform(-0.1, 0.1))
    m = cv2.getRotationMatrix2D((w / 2, h / 2), angle, scale)
    m[:, 2] += (rng.uniform(-8, 8), rng.uniform(-6, 6))
    out = cv2.warpAffine(image, m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    if rng.random() < 0.5:
        out = motion_blur(out, rng.uniform(1, 7), rng.uniform(0, 180))
    gain, gamma = math.exp(rng.uniform(-0.7, 0.5)), math.exp(rng.uniform(-0.25, 0.25))
    f = np.clip((out.astype(np.float32) / 255.0) ** gamma * gain, 0, 1) * 255.0
    f += np.float32(rng.uniform(0, 6)) * np.random.default_rng(rng.getrandbits(32)).standard_normal(
        f.shape, dtype=np.float32)
    out = np.clip(f, 0, 255).astype(np.uint8)
    if rng.random() < 0.5:
        ok, jpeg = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, rng.randint(30, 95)])
        out = cv2.imdecode(jpeg, cv2.IMREAD_COLOR)
    return out


def to_tensor(images):
    x = np.stack(images).astype(np.float32)
    return torch.from_numpy((x - 127.5) / 127.5).permute(0, 3, 1, 2).contiguous()


def draw_batch(train, seed, step):
    rng = random.Random(f"{seed}:{step}")
    images, street_ids, positions = [], [], []
    for s in rng.sample(range(len(train)), STREETS_PER_BATCH):
        street = train[s]
        placed = 0
        while placed < PLACES_PER_STREET:
            i = rng.randrange(len(street))
            other_day = rng.random() < OTHER_DAY
            near = np.abs(street.position - street.position[i]) < POSITIVE_M
            ok = near & (street.drone != street.drone[i])
            ok &= (street.day != street.day[i]) if other_day else (street.day == street.day[i])
            candidates = np.flatnonzero(ok)
            if len(candidates) == 0:
                continue
            j = int(candidates[rng.randrange(len(candidates))])
            for k in (i, j):
                images.append(augment(street.images[k], rng))
                street_ids.append(s)
                positions.append(street.position[k])
            placed += 1
    return to_tensor(images), np.array(street_ids), np.array(positions)


def multi_similarity_loss(embeddings, street_ids, positions, alpha=2.0, beta=50.0, lam=0.5,
                          margin=0.1):
    sim = embeddings @ embeddings.t()
    same_street = street_ids[:, None] == street_ids[None, :]
    distance = np.abs(positions[:, None] - positions[None, :])
    n = len(street_ids)
    positive = torch.from_numpy(same_street & (distance < POSITIVE_M) & ~np.eye(n, dtype=bool))
    negative = torch.from_numpy(~same_street | (distance > NEGATIVE_M))
    losses = []
    for a in range(n):
        pos, neg = sim[a][positive[a]], sim[a][negative[a]]
        if len(pos) == 0 or len(neg) == 0:
            continue
        hard_neg = neg[neg + margin > pos.min()]
        hard_pos = pos[pos - margin < neg.max()]
        loss = sim[a, a] * 0  # keeps the graph when nothing is mined
        if len(hard_pos):
            loss = loss + torch.log1p(torch.exp(-alpha * (hard_pos - lam)).sum()) / alpha
        if len(hard_neg):
            loss = loss + torch.log1p(torch.exp(beta * (hard_neg - lam)).sum()) / beta
        losses.append(loss)
    if not losses:
        return (sim * 0).sum()
    return torch.stack(losses).mean()


def describe(net, images, batch=128):
    net.eval()
    out = []
    with torch.no_grad():
        for i in range(0, len(images), batch):
            out.append(net(to_tensor(images[i:i + batch])).numpy())
    net.train()
    return np.concatenate(out)


def recall(query_desc, query_pos, db_desc, db_pos):
    """Recall@1, @5 over the answerable queries (a database view within TOLERANCE_M)."""
    answerable = np.abs(query_pos[:, None] - db_pos[None, :]).min(1) <= TOLERANCE_M
    top = np.argsort(-(query_desc @ db_desc.T), axis=1)[:, :5]
    right = np.abs(db_pos[top] - query_pos[:, None]) <= TOLERANCE_M
    n = max(1, answerable.sum())
    return (right[:, 0] & answerable).sum() / n, (right.any(1) & answerable).sum() / n


class Validation:
    def __init__(self, paths):
        self.sets = []
        for path in paths:
            street = Street(path)
            db = np.flatnonzero(street.day == 0)
            queries = np.flatnonzero(street.day == 1)[::3]
            rng = random.Random(street.name)
            degraded = [degrade(street.images[q], rng, rng.uniform(2, 6), math.exp(rng.uniform(
                -0.9, -0.4))) for q in queries]
            self.sets.append((street, db, queries, degraded))

    def run(self, net):
        r1, r5, d1, d5 = [], [], [], []
        for street, db, queries, degraded in self.sets:
            db_desc = describe(net, list(street.images[db]))
            q_desc = describe(net, list(street.images[queries]))
            deg_desc = describe(net, degraded)
            a, b = recall(q_desc, street.position[queries], db_desc, street.position[db])
            c, d = recall(deg_desc, street.position[queries], db_desc, street.position[db])
            r1.append(a)
            r5.append(b)
            d1.append(c)
            d5.append(d)
        return {"recall1": float(np.mean(r1)), "recall5": float(np.mean(r5)),
                "degraded_recall1": float(np.mean(d1)), "degraded_recall5": float(np.mean(d5))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", required=True)
    ap.add_argument("--steps", type=int, default=12000)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--validate-every", type=int, default=500)
    ap.add_argument("--checkpoint-every", type=int, default=100)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    cv2.setNumThreads(1)
    torch.manual_seed(args.seed)

    train_paths = sorted(streets.street_files(args.work, streets.TRAIN_SEEDS))
    val_paths = sorted(streets.street_files(args.work, streets.VALIDATION_SEEDS))
    missing = [p for p in train_paths + val_paths if not os.path.exists(p)]
    if missing:
        raise SystemExit(f"train.py: {len(missing)} street(s) not cached, e.g. {missing[0]}: "
                         "run streets.py first")
    train = [Street(p) for p in train_paths]
    validation = Validation(val_paths)
    print(f"{len(train)} training streets ({sum(map(len, train))} views), "
          f"{len(val_paths)} validation streets", flush=True)

    net = PlaceNet()
    print(f"PlaceNet: {count_parameters(net)} parameters, {count_macs(net) / 1e6:.1f} M "
          "multiply-adds a view", flush=True)
    opt = torch.optim.Adam(net.parameters(), lr=args.lr, weight_decay=1e-4)
    step, best = 0, -1.0
    latest = os.path.join(args.work, "latest.pt")
    if os.path.exists(latest):
        state = torch.load(latest)
        net.load_state_dict(state["net"])
        opt.load_state_dict(state["optimizer"])
        step, best = state["step"], state["best"]
        torch.set_rng_state(state["torch_rng"])
        print(f"resumed at step {step} (best {best:.4f})", flush=True)
    csv_path = os.path.join(args.work, "validation.csv")
    if not os.path.exists(csv_path):
        with open(csv_path, "w", newline="") as f:
            csv.writer(f).writerow(CSV_FIELDS)

    start, span_start, span_losses = time.time(), time.time(), []
    net.train()
    while step < args.steps:
        lr = args.lr * 0.5 * (1 + math.cos(math.pi * step / args.steps))
        for g in opt.param_groups:
            g["lr"] = lr
        x, street_ids, positions = draw_batch(train, args.seed, step)
        loss = multi_similarity_loss(net(x), street_ids, positions)
        opt.zero_grad()
        loss.backward()
        opt.step()
        span_losses.append(loss.item())
        step += 1
        if step % args.validate_every == 0 or step == args.steps:
            s_per_step = (time.time() - span_start) / len(span_losses)
            scores = validation.run(net)
            score = (scores["recall1"] + scores["degraded_recall1"]) / 2
            if score > best:
                best = score
                torch.save({"net": net.state_dict(), "step": step, "scores": scores},
                           os.path.join(args.work, "best.pt.part"))
                os.replace(os.path.join(args.work, "best.pt.part"),
                           os.path.join(args.work, "best.pt"))
            row = {"step": step, "loss": round(float(np.mean(span_losses)), 5),
                   "lr": round(lr, 7), "s_per_step": round(s_per_step, 3),
                   **{k: round(v, 4) for k, v in scores.items()}, "score": round(score, 4),
                   "best_score": round(best, 4), "wall_s": round(time.time() - start, 1)}
            with open(csv_path, "a", newline="") as f:
                csv.DictWriter(f, CSV_FIELDS).writerow(row)
            print(row, flush=True)
            span_start, span_losses = time.time(), []
        if step % args.checkpoint_every == 0 or step == args.steps:
            torch.save({"net": net.state_dict(), "optimizer": opt.state_dict(), "step": step,
                        "best": best, "torch_rng": torch.get_rng_state()}, latest + ".part")
            os.replace(latest + ".part", latest)


if __name__ == "__main__":
    main()
