"""MiniNet's training data: generated street pairs, ICDAR 2015 photos, augmentation, validation.

Masks hold 0 (background), 1 (text) and IGNORE (255: ICDAR's `###` don't-care quads, left out of
the loss and of the class frequencies).

Scales. The agent resizes its 640x480 frames to 320x256 (x 0.5, y 0.53). ICDAR photos are 1280x720
(legible word heights: median 23 px, 10-90 % 14-47 px); they are loaded at ICDAR_SCALE = 0.5
(640x360, the agent camera's width) and training crops zoom 0.4..1 of that, so a median word is
4.6..11.5 px tall in training, bracketing the full-frame evaluation (1280x720 squeezed to 320x256:
x 0.25, y 0.36, median word 8 px tall). Generated pairs are 640x480 and get the same crop zoom
(eval at x 0.5, y 0.53). The whole-frame resizes change the aspect: x/y 0.70 (ICDAR) and 0.94
(generated) at 320x256, 1.12 and 1.5 at 512x256; ASPECT (0.7..1.5) covers all four.
"""
import glob
import os

import cv2
import numpy as np

TRAIN_W, TRAIN_H = 256, 128
IGNORE = 255
ICDAR_SCALE = 0.5
VAL_EVERY = 10  # ICDAR train photos whose id is a multiple of 10 (img_10..img_1000) validate
BLURRED_HELD_OUT = 100  # test_blurred img_101..200 are the evaluation's; training uses img_201..500
VIEW_W, VIEW_H = 320, 256  # validation: the whole frame at the agent's input size (Table III)
VIEW_SIZES = ((320, 256), (512, 256))  # the agent's input and Table III's headline size

ASPECT = (0.7, 1.5)        # horizontal / vertical scale of a crop
JITTER = 0.1               # the paper: shifts and scales up to 10 %
CONTRAST = (0.9, 1.2)
GREY_P = 0.2
BLUR_P, BLUR_LEN, BLUR_HORIZONTAL_P = 0.5, (3, 15), 0.5
JPEG_P, JPEG_QUALITY = 0.5, (30, 90)


def load_pairs(data_dir, scale=1.0):
    """`keyfleet scenario training` output: images/NNNNNN.jpg + masks/NNNNNN.png (255: word box)"""
    images = sorted(glob.glob(os.path.join(data_dir, "images", "*.jpg")))
    if not images:
        raise SystemExit(f"train.py: no images in {data_dir}/images (keyfleet scenario training)")
    pairs = []
    for path in images:
        name = os.path.splitext(os.path.basename(path))[0]
        mask_path = os.path.join(data_dir, "masks", name + ".png")
        image = cv2.imread(path, cv2.IMREAD_COLOR)
        mask = cv2.imread(mask_path, cv2.IMREAD_GRAYSCALE)
        if image is None or mask is None:
            raise SystemExit(f"train.py: unreadable pair {path} / {mask_path}")
        if scale != 1.0:
            image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
            mask = cv2.resize(mask, image.shape[1::-1], interpolation=cv2.INTER_NEAREST)
        pairs.append((image, (mask > 127).astype(np.uint8)))
    return pairs


def read_quads(gt_path):
    """ICDAR 2015 ground truth: [(4x2 int32 quad, legible)], `###` = not legible (byte-order mark
    skipped; transcriptions may hold commas)."""
    quads = []
    with open(gt_path, encoding="utf-8-sig") as gt:
        for line in gt:
            fields = line.rstrip("\r\n").split(",")
            if len(fields) < 9:
                continue
            quad = np.array([int(round(float(v))) for v in fields[:8]], np.int32).reshape(4, 2)
            quads.append((quad, ",".join(fields[8:]).strip() != "###"))
    return quads


def icdar_mask(shape, quads, dont_care=IGNORE):
    """Legible quads -> 1, `###` quads -> dont_care (legible ones win where they overlap)."""
    mask = np.zeros(shape[:2], np.uint8)
    for quad, legible in quads:
        if not legible:
            cv2.fillPoly(mask, [quad], dont_care)
    for quad, legible in quads:
        if legible:
            cv2.fillPoly(mask, [quad], 1)
    return mask


def icdar_ids(folder):
    names = glob.glob(os.path.join(folder, "images", "img_*.jpg"))
    return sorted(int(os.path.basename(n)[4:-4]) for n in names)


def icdar_split(ids):
    """The fixed validation rule: id % VAL_EVERY == 0 validates, the rest trains."""
    return [i for i in ids if i % VAL_EVERY], [i for i in ids if i % VAL_EVERY == 0]


def load_icdar(folder, ids, scale=ICDAR_SCALE):
    """(image, mask) per id, the mask drawn at full resolution, both scaled by `scale`."""
    pairs = []
    for i in ids:
        path = os.path.join(folder, "images", f"img_{i}.jpg")
        image = cv2.imread(path, cv2.IMREAD_COLOR)
        if image is None:
            raise SystemExit(f"train.py: unreadable photo {path}")
        mask = icdar_mask(image.shape, read_quads(os.path.join(folder, "gt", f"gt_img_{i}.txt")))
        size = (int(round(image.shape[1] * scale)), int(round(image.shape[0] * scale)))
        pairs.append((cv2.resize(image, size, interpolation=cv2.INTER_AREA),
                      cv2.resize(mask, size, interpolation=cv2.INTER_NEAREST)))
    return pairs


def load_icdar_full(folder, ids):
    """(photo, mask) per id at full resolution: validation views are made from these as Table III
    makes them, so `###` pixels keep IGNORE and both IoUs (### as text, ### left out) are known."""
    pairs = []
    for i in ids:
        image = cv2.imread(os.path.join(folder, "images", f"img_{i}.jpg"), cv2.IMREAD_COLOR)
        if image is None:
            raise SystemExit(f"train.py: unreadable photo {folder}/images/img_{i}.jpg")
        pairs.append((image, icdar_mask(image.shape,
                                        read_quads(os.path.join(folder, "gt", f"gt_img_{i}.txt")))))
    return pairs


def whole_view(image, mask, width=VIEW_W, height=VIEW_H):
    """The whole frame resized as cv::dnn::blobFromImages does, the truth resized (nearest)."""
    img = cv2.resize(image, (width, height), interpolation=cv2.INTER_LINEAR)
    msk = cv2.resize(mask, (width, height), interpolation=cv2.INTER_NEAREST)
    return (img.astype(np.float32).transpose(2, 0, 1) / 255.0 - 0.5), msk


def text_fraction(pairs):
    """Share of text among the pixels that count (IGNORE left out)."""
    text = sum(int((m == 1).sum()) for _, m in pairs)
    counted = sum(int((m != IGNORE).sum()) for _, m in pairs)
    return text / max(1, counted)


def class_weights(groups, power):
    """Median-frequency weights raised to `power`, w_c = (f_median / f_c) ** power, from the text
    fraction of each source weighted by its share of the batch: groups = [(pairs, share)]."""
    shares = sum(share for pairs, share in groups if pairs)
    text = sum(share * text_fraction(pairs) for pairs, share in groups if pairs) / shares
    freq = np.array([1 - text, text])
    return (np.median(freq) / freq) ** power, freq


def motion_kernel(length, angle_deg):
    """A normalised anti-aliased line of `length` px at `angle_deg` (0 = horizontal)."""
    size = length if length % 2 else length + 1
    canvas = np.zeros((size, size), np.uint8)
    c, r = (size - 1) / 2, (length - 1) / 2
    dx, dy = np.cos(np.radians(angle_deg)) * r, np.sin(np.radians(angle_deg)) * r
    ends = [(int(round((c + sx * dx) * 16)), int(round((c + sx * dy) * 16))) for sx in (-1, 1)]
    cv2.line(canvas, ends[0], ends[1], 255, 1, cv2.LINE_AA, 4)  # 4 fractional bits
    kernel = canvas.astype(np.float32)
    return kernel / kernel.sum()


def augment(image, mask, rng, out_w=TRAIN_W, out_h=TRAIN_H):
    """A crop of a frame to out_w x out_h (TRAIN_W x TRAIN_H by default): zoom 0.36..1 output px
    per frame px (TRAIN_H over a height drawn between TRAIN_H and the frame's height, or half its
    width; a larger crop keeps the zoom and sees more of the frame), centred on text half of the
    time; the paper's shifts and scales up to 10 %, horizontal flip, contrast 0.9..1.2, greyscale
    (p 0.2); a horizontal / vertical scale ratio in ASPECT;
    motion blur (p 0.5, 3..15 px at training scale, horizontal half the time, else any direction);
    JPEG re-encoding (p 0.5, quality 30..90). Returns (CHW float32 image, HW uint8 mask)."""
    h, w = image.shape[:2]
    zoom = TRAIN_H / rng.uniform(TRAIN_H, min(h, w / 2))  # output px per frame px, before jitter
    s = rng.uniform(1 - JITTER, 1 + JITTER)
    ky = zoom * s
    kx = max(ky * rng.uniform(*ASPECT), out_w / w)  # the window never wider than the frame
    win_w, win_h = out_w / kx, out_h / ky
    ys, xs = np.nonzero(mask == 1)
    if len(xs) and rng.random() < 0.5:
        k = rng.randrange(len(xs))
        cx, cy = float(xs[k]), float(ys[k])
    else:
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
    cx = float(np.clip(cx, win_w / 2, max(win_w / 2, w - win_w / 2)))
    cy = float(np.clip(cy, win_h / 2, max(win_h / 2, h - win_h / 2)))
    tx = rng.uniform(-JITTER, JITTER) * out_w
    ty = rng.uniform(-JITTER, JITTER) * out_h
    m = np.array([[kx, 0, out_w / 2 + tx - kx * cx],
                  [0, ky, out_h / 2 + ty - ky * cy]], dtype=np.float32)
    img = cv2.warpAffine(image, m, (out_w, out_h), flags=cv2.INTER_AREA,
                         borderMode=cv2.BORDER_REFLECT)
    msk = cv2.warpAffine(mask, m, (out_w, out_h), flags=cv2.INTER_NEAREST,
                         borderMode=cv2.BORDER_REFLECT)
    if rng.random() < 0.5:
        img, msk = img[:, ::-1], msk[:, ::-1]
    if rng.random() < BLUR_P:
        angle = 0.0 if rng.random() < BLUR_HORIZONTAL_P else rng.uniform(0, 180)
        img = cv2.filter2D(np.ascontiguousarray(img), -1,
                           motion_kernel(rng.randint(*BLUR_LEN), angle),
                           borderType=cv2.BORDER_REFLECT)
    img = img.astype(np.float32)
    contrast = rng.uniform(*CONTRAST)
    img = (img - img.mean()) * contrast + img.mean()
    if rng.random() < GREY_P:
        grey = img @ np.array([0.114, 0.587, 0.299], dtype=np.float32)
        img = np.repeat(grey[:, :, None], 3, axis=2)
    img = np.clip(img, 0, 255)
    if rng.random() < JPEG_P:
        ok, code = cv2.imencode(".jpg", img.round().astype(np.uint8),
                                [cv2.IMWRITE_JPEG_QUALITY, rng.randint(*JPEG_QUALITY)])
        img = cv2.imdecode(code, cv2.IMREAD_COLOR).astype(np.float32)
    img = img / 255.0 - 0.5
    return np.ascontiguousarray(img.transpose(2, 0, 1)), np.ascontiguousarray(msk)


def save_pairs(folder, pairs, quality):
    """images/NNNNNN.jpg (JPEG `quality`) + masks/NNNNNN.png, mask values kept (0, 1, IGNORE)."""
    os.makedirs(os.path.join(folder, "images"), exist_ok=True)
    os.makedirs(os.path.join(folder, "masks"), exist_ok=True)
    for n, (image, mask) in enumerate(pairs):
        cv2.imwrite(os.path.join(folder, "images", f"{n:06d}.jpg"), image,
                    [cv2.IMWRITE_JPEG_QUALITY, quality])
        cv2.imwrite(os.path.join(folder, "masks", f"{n:06d}.png"), mask)


def load_saved_pairs(folder):
    """What save_pairs wrote, masks as they were."""
    pairs = []
    for path in sorted(glob.glob(os.path.join(folder, "images", "*.jpg"))):
        name = os.path.splitext(os.path.basename(path))[0]
        mask = cv2.imread(os.path.join(folder, "masks", name + ".png"), cv2.IMREAD_GRAYSCALE)
        pairs.append((cv2.imread(path, cv2.IMREAD_COLOR), mask))
    return pairs


class Sources:
    """Everything one training run reads: training pairs per source, validation views per size.

    From the original folders (generated pairs, ICDAR 2015 train and test_blurred) or from a
    packed folder (pack.py: the same training pairs at their training scale, for a machine that
    has no copy of the data; validation views are made from the original photos in both cases).
    """

    def __init__(self, pairs_dir, validation, icdar_train="", shared="", packed="",
                 icdar_scale=ICDAR_SCALE):
        self.generated, self.icdar_train, self.blurred = [], [], []
        generated_val, real_val = [], []
        if packed:
            for part in sorted(glob.glob(os.path.join(packed, "part*"))):
                self.generated += load_saved_pairs(os.path.join(part, "generated"))
                self.icdar_train += load_saved_pairs(os.path.join(part, "icdar_train"))
                self.blurred += load_saved_pairs(os.path.join(part, "blurred"))
            generated_val = load_saved_pairs(os.path.join(packed, "generated_val"))
            icdar_train = os.path.join(packed, "icdar_val")
            if os.path.isdir(os.path.join(icdar_train, "images")):
                real_val = load_icdar_full(icdar_train, icdar_ids(icdar_train))
        else:
            pairs = load_pairs(pairs_dir)
            held = max(1, int(len(pairs) * validation))
            self.generated, generated_val = pairs[:-held], pairs[-held:]  # the last: other streets
            if icdar_train and os.path.isdir(os.path.join(icdar_train, "images")):
                train_ids, val_ids = icdar_split(icdar_ids(icdar_train))
                self.icdar_train = load_icdar(icdar_train, train_ids, icdar_scale)
                real_val = load_icdar_full(icdar_train, val_ids)
            elif icdar_train:
                print(f"no ICDAR training photos in {icdar_train}", flush=True)
            folder = os.path.join(shared, "icdar2015", "test_blurred") if shared else ""
            if folder and os.path.isdir(folder):
                ids = [i for i in icdar_ids(folder) if i > 100 + BLURRED_HELD_OUT]
                self.blurred = load_icdar(folder, ids, icdar_scale)
            elif shared:
                print(f"no ICDAR test_blurred photos under {shared}", flush=True)
        self.generated_val = generated_val
        self.real_val = real_val
        self.generated_views = {size: [whole_view(i, m, *size) for i, m in generated_val]
                                for size in VIEW_SIZES}
        self.real_views = {size: [whole_view(i, m, *size) for i, m in real_val]
                           for size in VIEW_SIZES}
