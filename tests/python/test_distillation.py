#!/usr/bin/python3
"""The distillation recipe (models/mininet/distill.py), checked on the CPU: the teacher as a torch
module against OpenCV DNN, the loss, the augmented views, the shipped MiniNet as a one-logit
student, and a short run from a packed folder to an exported text-probability model.

  test_distillation.py [DATA_DIR]

$KEYFLEET_PPOCR_MODELS holds the converted PP-OCR files (build tree: share/keyfleet/models/ppocr);
without them the teacher's checks and the short run skip, saying so. DATA_DIR (else
$KEYFLEET_DATA, else ../shared/data) may hold a real photo for the teacher's check.
"""
import json
import os
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
MININET = os.path.join(HERE, "..", "..", "models", "mininet")
sys.path.insert(0, MININET)
sys.path.insert(0, os.path.join(HERE, "..", "..", "models", "ppocr"))

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

import distill  # noqa: E402
from mininet import MiniNet  # noqa: E402
from onnx_reference import Graph  # noqa: E402

MODELS = os.environ.get("KEYFLEET_PPOCR_MODELS", "")
TEACHER = os.path.join(MODELS, "ppocr_det_320x256.onnx")
HAVE_TEACHER = bool(MODELS) and os.path.isfile(TEACHER)
DATA = sys.argv[1] if len(sys.argv) > 1 else os.environ.get(
    "KEYFLEET_DATA", os.path.join(HERE, "..", "..", "..", "shared", "data"))
PHOTO = os.path.join(DATA, "icdar2015", "train", "images", "img_7.jpg")
SHIPPED = os.path.join(MININET, "mininet_text.onnx")


def street_like(seed, h=240, w=320):
    """A frame with dark words on light signs over texture, for views and a short run."""
    rng = np.random.default_rng(seed)
    image = rng.integers(60, 200, (h, w, 3), dtype=np.uint8)
    for k in range(3):
        x, y = int(rng.integers(0, w - 120)), int(rng.integers(0, h - 40))
        cv2.rectangle(image, (x, y), (x + 110, y + 34), (235, 235, 235), -1)
        cv2.putText(image, "OPEN %d" % k, (x + 6, y + 25), cv2.FONT_HERSHEY_SIMPLEX, 0.8,
                    (20, 20, 20), 2)
    return image


def make_pack(folder):
    for name in distill.SOURCES + ("icdar_val", "generated_val"):
        os.makedirs(os.path.join(folder, name))
        for k in range(3):
            image = street_like(hash((name, k)) % 1000)
            cv2.imwrite(os.path.join(folder, name, "%d.webp" % k), image)
            if name.endswith("_val"):
                mask = np.zeros(image.shape[:2], np.uint8)
                mask[20:60, 30:150] = 1
                cv2.imwrite(os.path.join(folder, name, "%d.png" % k), mask)


class Distillation(unittest.TestCase):
    @unittest.skipUnless(HAVE_TEACHER, "no converted PP-OCR detector in $KEYFLEET_PPOCR_MODELS "
                                       "(scripts/fetch_ppocr.sh)")
    def test_teacher_module_matches_opencv(self):
        image = cv2.imread(PHOTO) if os.path.isfile(PHOTO) else street_like(1, 480, 640)
        x = torch.from_numpy(cv2.resize(image, (320, 256)).transpose(2, 0, 1)[None].astype(np.float32))
        blob = distill.teacher_input(x).numpy()
        net = cv2.dnn.readNetFromONNX(TEACHER)
        net.setInput(blob)
        expected = net.forward()
        with torch.no_grad():
            got = Graph(TEACHER)(torch.from_numpy(blob)).numpy()
        self.assertEqual(got.shape, (1, 1, 256, 320))
        self.assertLess(float(np.abs(got - expected).max()), 1e-4)

    def test_loss_prefers_the_teacher_map_and_does_not_reward_painting_text_out(self):
        target = torch.zeros(2, 1, 32, 32)
        target[:, :, 10:14, 4:28] = 1.0  # a thin word: 6 % of the pixels
        match = torch.where(target > 0.5, torch.tensor(6.0), torch.tensor(-6.0))
        nothing = torch.full_like(target, -6.0)
        everything = torch.full_like(target, 6.0)
        loss = {k: float(distill.distill_loss(v, target))
                for k, v in (("match", match), ("nothing", nothing), ("everything", everything))}
        self.assertLess(loss["match"], 0.05)
        self.assertGreater(loss["nothing"], 1.0)  # text missed costs as much as text invented
        self.assertGreater(loss["everything"], 1.0)
        z = nothing.clone().requires_grad_(True)
        distill.distill_loss(z, target).backward()
        self.assertLess(float(z.grad[target > 0.5].max()), 0.0)  # pushes text pixels up

    def test_views_are_agent_sized_seeded_and_whole_frames_map_exactly(self):
        with tempfile.TemporaryDirectory() as tmp:
            make_pack(tmp)
            one = distill.Views(tmp, [1, 1, 1, 1], torch.device("cpu"), 5)
            two = distill.Views(tmp, [1, 1, 1, 1], torch.device("cpu"), 5)
            a, b = one.batch(6), two.batch(6)
            self.assertEqual(tuple(a.shape), (6, 3, 256, 320))
            self.assertTrue(torch.equal(a, b))
            self.assertGreaterEqual(float(a.min()), 0.0)
            self.assertLessEqual(float(a.max()), 255.0)
            self.assertFalse(torch.equal(a, one.batch(6)))
        sizes = np.array([[240.0, 320.0]] * 200)
        theta = distill.Views.windows(one, sizes, (240, 320)).numpy()
        whole = np.isclose(np.abs(theta[:, 0, 0]), 1) & np.isclose(theta[:, 1, 1], 1)
        self.assertGreater(whole.sum(), 30)  # about a third
        self.assertTrue(np.allclose(theta[whole][:, :, 2], 0, atol=1e-6))
        self.assertTrue((np.abs(theta[:, 0, 0]) >= 0.45 - 1e-6).all())
        self.assertTrue((np.abs(theta[:, :, 2]) <= 1 - np.abs(theta[:, [0, 1], [0, 1]]) + 1e-6).all())

    def test_one_logit_student_starts_as_the_shipped_model(self):
        student, two = MiniNet(1), MiniNet(2)
        distill.text_logit_init(student, SHIPPED)
        from train import load_onnx_weights
        load_onnx_weights(two, SHIPPED)
        student.eval()
        two.eval()
        x = torch.rand(1, 3, 128, 192) - 0.5
        with torch.no_grad():
            p_student = torch.sigmoid(student(x))[:, 0]
            p_two = torch.softmax(two(x), 1)[:, 1]
        self.assertLess(float((p_student - p_two).abs().max()), 1e-5)

    @unittest.skipUnless(HAVE_TEACHER, "no converted PP-OCR detector in $KEYFLEET_PPOCR_MODELS "
                                       "(scripts/fetch_ppocr.sh)")
    def test_short_run_exports_a_text_probability_model_opencv_reads(self):
        with tempfile.TemporaryDirectory() as tmp:
            pack, work = os.path.join(tmp, "pack"), os.path.join(tmp, "work")
            make_pack(pack)
            sys.argv = ["distill.py", "--pack", pack, "--teacher", TEACHER, "--work", work,
                        "--students", "0.25", "--steps", "3", "--batch", "2",
                        "--validate-every", "2", "--device", "cpu"]
            distill.main()
            rows = open(os.path.join(work, "validation.csv")).read().splitlines()
            self.assertEqual([r.split(",")[0] for r in rows], ["step", "2", "3"])
            checkpoint = os.path.join(work, "student_w0.25_last.pt")
            self.assertEqual(torch.load(checkpoint)["step"], 3)
            out = os.path.join(tmp, "student.onnx")
            sys.argv = ["export.py", "--checkpoint", checkpoint, "--out", out,
                        "--input-width", "320", "--input-height", "256"]
            import export
            export.main()
            meta = json.load(open(os.path.join(tmp, "student.json")))
            self.assertEqual(meta["output"], "text_probability")
            self.assertEqual(meta["classes"], ["text"])
            self.assertEqual(meta["db"]["box_threshold"], 0.6)
            net = cv2.dnn.readNetFromONNX(out)
            net.setInput(np.zeros((1, 3, 256, 320), np.float32))
            prob = net.forward()
            self.assertEqual(prob.shape, (1, 1, 256, 320))
            self.assertTrue(((prob >= 0) & (prob <= 1)).all())


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
