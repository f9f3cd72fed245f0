#!/usr/bin/python3
"""A small reference executor for ONNX graphs, written from the ONNX operator
specification, used to check the OpenCV-ready PP-OCR files (convert_ppocr.py)
against the UNMODIFIED PaddleOCR models: ONNX Runtime is not packaged by Debian
and onnx 1.12 has no reference evaluator.

    outputs = run("model.onnx", {"x": array})   # {output name: np.ndarray}
    net = Graph("model.onnx").to("cuda")       # a frozen torch module: net(x) -> first output

Float32 on the CPU with torch; shape arithmetic (Shape/Slice/Concat/...) runs on
int64 tensors, so dynamic input shapes work.  It implements exactly the op types
of PP-OCRv4's det (opset 11) and rec (opset 9) models, plus Gather/Unsqueeze and
the HardSwish of convert_ppocr.py's files,
with the semantics of the model's opset where they differ (Clip, Slice,
Squeeze, Unsqueeze, Softmax).  Any other op, or an attribute value that the
models do not use and this file does not implement, raises NotImplementedError
naming it -- never a silently different result.
"""
import math

import numpy as np
import onnx
import torch
import torch.nn.functional as F
from onnx import helper, numpy_helper

ONNX_TO_TORCH = {1: torch.float32, 2: torch.uint8, 3: torch.int8, 6: torch.int32, 7: torch.int64,
                 9: torch.bool, 10: torch.float16, 11: torch.float64}


def _attrs(node):
    return {a.name: helper.get_attribute_value(a) for a in node.attribute}


def _text(value):
    return value.decode() if isinstance(value, bytes) else value


def _unsupported(node, what):
    raise NotImplementedError("onnx_reference: %s node '%s': %s is not implemented"
                              % (node.op_type, node.name, what))


def _ints(t):
    return [int(v) for v in t.reshape(-1).tolist()]


def _spatial_pads(node, a, rank):
    """ONNX pads [x1_begin, x2_begin, ..., x1_end, x2_end, ...] (zeros if absent)."""
    if _text(a.get("auto_pad", "NOTSET")) not in ("NOTSET", "VALID"):
        _unsupported(node, "auto_pad=%s" % _text(a["auto_pad"]))
    pads = list(a.get("pads", [0] * (2 * rank)))
    return pads[:rank], pads[rank:]


def _pad_input(x, begin, end, value=0.0):
    """Zero-pad the spatial dims of x (F.pad lists the last dim first)."""
    spec = []
    for b, e in reversed(list(zip(begin, end))):
        spec += [b, e]
    return F.pad(x, spec, value=value) if any(spec) else x


def _conv(node, a, x, w, b=None):
    rank = x.dim() - 2
    begin, end = _spatial_pads(node, a, rank)
    conv = {1: F.conv1d, 2: F.conv2d, 3: F.conv3d}[rank]
    return conv(_pad_input(x, begin, end), w, b, stride=a.get("strides", [1] * rank),
                padding=0, dilation=a.get("dilations", [1] * rank), groups=a.get("group", 1))


def _conv_transpose(node, a, x, w, b=None):
    rank = x.dim() - 2
    if "output_shape" in a:
        _unsupported(node, "output_shape")
    begin, end = _spatial_pads(node, a, rank)
    conv = {1: F.conv_transpose1d, 2: F.conv_transpose2d, 3: F.conv_transpose3d}[rank]
    # Full output, then crop the pads: out = s*(in-1) + op + (k-1)*d + 1 - begin - end.
    y = conv(x, w, b, stride=a.get("strides", [1] * rank), padding=0,
             output_padding=a.get("output_padding", [0] * rank), groups=a.get("group", 1),
             dilation=a.get("dilations", [1] * rank))
    crop = [slice(None), slice(None)] + [slice(bb, y.shape[2 + i] - ee)
                                         for i, (bb, ee) in enumerate(zip(begin, end))]
    return y[tuple(crop)]


def _average_pool(node, a, x):
    rank = x.dim() - 2
    begin, end = _spatial_pads(node, a, rank)
    kernel = a["kernel_shape"]
    if begin != end or any(2 * p > k for p, k in zip(begin, kernel)):
        _unsupported(node, "pads %s" % a.get("pads"))
    if a.get("ceil_mode", 0) and any(begin):
        _unsupported(node, "ceil_mode with padding")
    pool = {1: F.avg_pool1d, 2: F.avg_pool2d, 3: F.avg_pool3d}[rank]
    return pool(x, kernel, stride=a.get("strides", [1] * rank), padding=begin,
                ceil_mode=bool(a.get("ceil_mode", 0)),
                count_include_pad=bool(a.get("count_include_pad", 0)))


def _resize(node, a, opset, x, roi=None, scales=None, sizes=None):
    """Resize (opset 11+): mode nearest, every coordinate transform but tf_crop_and_resize."""
    if opset < 11:
        _unsupported(node, "Resize/Upsample before opset 11")
    mode, ctm = _text(a.get("mode", "nearest")), _text(a.get("coordinate_transformation_mode", "half_pixel"))
    nearest = _text(a.get("nearest_mode", "round_prefer_floor"))
    if mode != "nearest" or ctm == "tf_crop_and_resize":
        _unsupported(node, "mode=%s coordinate_transformation_mode=%s" % (mode, ctm))
    if sizes is not None and sizes.numel():
        out_sizes = _ints(sizes)
        scale = [o / i for o, i in zip(out_sizes, x.shape)]
    else:
        scale = [float(s) for s in scales.reshape(-1).tolist()]
        out_sizes = [int(math.floor(i * s)) for i, s in zip(x.shape, scale)]
    y = x
    for axis, (n_in, n_out, s) in enumerate(zip(x.shape, out_sizes, scale)):
        if n_in == n_out and s == 1.0:
            continue
        o = torch.arange(n_out, dtype=torch.float64)
        if ctm == "asymmetric":
            src = o / s
        elif ctm == "align_corners":
            src = o * (n_in - 1) / (n_out - 1) if n_out > 1 else torch.zeros_like(o)
        elif ctm == "pytorch_half_pixel" and n_out == 1:
            src = torch.zeros_like(o)
        else:  # half_pixel, pytorch_half_pixel
            src = (o + 0.5) / s - 0.5
        if nearest == "floor":
            idx = torch.floor(src)
        elif nearest == "ceil":
            idx = torch.ceil(src)
        elif nearest == "round_prefer_ceil":
            idx = torch.floor(src + 0.5)
        else:  # round_prefer_floor
            idx = torch.ceil(src - 0.5)
        y = y.index_select(axis, idx.clamp(0, n_in - 1).long().to(x.device))
    return y


def _slice(node, a, opset, x, starts=None, ends=None, axes=None, steps=None):
    if opset < 10:
        starts, ends, axes, steps = a["starts"], a["ends"], a.get("axes"), None
    else:
        starts, ends = _ints(starts), _ints(ends)
        axes = _ints(axes) if axes is not None else None
        steps = _ints(steps) if steps is not None else None
    axes = axes if axes is not None else list(range(len(starts)))
    steps = steps if steps is not None else [1] * len(starts)
    index = [slice(None)] * x.dim()
    for start, end, axis, step in zip(starts, ends, axes, steps):
        if step <= 0:
            _unsupported(node, "step %d" % step)
        dim = x.shape[axis]
        start = min(max(start + dim if start < 0 else start, 0), dim)
        end = min(max(end + dim if end < 0 else end, 0), dim)
        index[axis] = slice(start, max(start, end), step)
    return x[tuple(index)]


def _reshape(x, shape):
    target = _ints(shape)
    target = [x.shape[i] if v == 0 else v for i, v in enumerate(target)]  # 0 = copy (no allowzero)
    return x.reshape(target)


def _softmax(a, opset, x):
    axis = a.get("axis", -1 if opset >= 13 else 1)
    if opset >= 13:
        return torch.softmax(x, dim=axis)
    axis = axis % x.dim()  # before opset 13: softmax of the input coerced to 2-D at `axis`
    rows = int(np.prod(x.shape[:axis], dtype=np.int64))
    return torch.softmax(x.reshape(rows, -1), dim=1).reshape(x.shape)


def _gather(a, data, indices):
    axis = a.get("axis", 0) % data.dim()
    idx = indices.long()
    idx = torch.where(idx < 0, idx + data.shape[axis], idx)
    out = data.index_select(axis, idx.reshape(-1))
    return out.reshape(list(data.shape[:axis]) + list(idx.shape) + list(data.shape[axis + 1:]))


def _squeeze(opset, a, x, axes=None):
    axes = a.get("axes") if opset < 13 else (_ints(axes) if axes is not None else None)
    if axes is None:
        return x.reshape([d for d in x.shape if d != 1])
    axes = {v % x.dim() for v in axes}
    return x.reshape([d for i, d in enumerate(x.shape) if i not in axes])


def _unsqueeze(opset, a, x, axes=None):
    axes = a["axes"] if opset < 13 else _ints(axes)
    rank = x.dim() + len(axes)
    shape = list(x.shape)
    for axis in sorted(v % rank for v in axes):
        shape.insert(axis, 1)
    return x.reshape(shape)


def _div(x, y):
    if x.dtype.is_floating_point:
        return x / y
    return torch.div(x, y, rounding_mode="trunc")  # integer Div truncates (C semantics)


def _clip(a, opset, x, lo=None, hi=None):
    if opset < 11:
        lo, hi = a.get("min"), a.get("max")
    else:
        lo = None if lo is None else lo.item()
        hi = None if hi is None else hi.item()
    return torch.clamp(x, min=lo, max=hi) if lo is not None or hi is not None else x


def _reduce_mean(a, x):
    axes = a.get("axes", list(range(x.dim())))
    return x.mean(dim=[v % x.dim() for v in axes], keepdim=bool(a.get("keepdims", 1)))


def _batch_norm(node, a, x, scale, bias, mean, var):
    if a.get("training_mode", 0) or a.get("spatial", 1) != 1:
        _unsupported(node, "training_mode/spatial")
    return F.batch_norm(x, mean, var, scale, bias, training=False, eps=a.get("epsilon", 1e-5))


def _constant(node, a):
    if "value" in a:
        return torch.from_numpy(numpy_helper.to_array(a["value"]).copy())
    for key, dtype in (("value_float", torch.float32), ("value_floats", torch.float32),
                       ("value_int", torch.int64), ("value_ints", torch.int64)):
        if key in a:
            return torch.tensor(a[key], dtype=dtype)
    _unsupported(node, "attributes %s" % sorted(a))


def _cast(node, a, x):
    if a["to"] not in ONNX_TO_TORCH:
        _unsupported(node, "to=%d" % a["to"])
    return x.to(ONNX_TO_TORCH[a["to"]])


OPS = {  # op type -> f(node, attributes, opset, *inputs); a missing optional input is None
    "Add": lambda n, a, o, x, y: x + y,
    "Sub": lambda n, a, o, x, y: x - y,
    "Mul": lambda n, a, o, x, y: x * y,
    "Div": lambda n, a, o, x, y: _div(x, y),
    "Pow": lambda n, a, o, x, y: torch.pow(x, y.to(x.dtype)),
    "Sqrt": lambda n, a, o, x: torch.sqrt(x),
    "Relu": lambda n, a, o, x: torch.relu(x),
    "Sigmoid": lambda n, a, o, x: torch.sigmoid(x),
    "HardSigmoid": lambda n, a, o, x: torch.clamp(a.get("alpha", 0.2) * x + a.get("beta", 0.5), 0, 1),
    "HardSwish": lambda n, a, o, x: x * torch.clamp(x / 6 + 0.5, 0, 1),
    "Clip": lambda n, a, o, x, *b: _clip(a, o, x, *b),
    "Softmax": lambda n, a, o, x: _softmax(a, o, x),
    "MatMul": lambda n, a, o, x, y: torch.matmul(x, y),
    "Conv": lambda n, a, o, *t: _conv(n, a, *t),
    "ConvTranspose": lambda n, a, o, *t: _conv_transpose(n, a, *t),
    "BatchNormalization": lambda n, a, o, *t: _batch_norm(n, a, *t),
    "AveragePool": lambda n, a, o, x: _average_pool(n, a, x),
    "GlobalAveragePool": lambda n, a, o, x: x.mean(dim=list(range(2, x.dim())), keepdim=True),
    "ReduceMean": lambda n, a, o, x: _reduce_mean(a, x),
    "Resize": lambda n, a, o, *t: _resize(n, a, o, *t),
    "Transpose": lambda n, a, o, x: x.permute(a.get("perm", list(range(x.dim()))[::-1])),
    "Reshape": lambda n, a, o, x, s: _reshape(x, s),
    "Squeeze": lambda n, a, o, *t: _squeeze(o, a, *t),
    "Unsqueeze": lambda n, a, o, *t: _unsqueeze(o, a, *t),
    "Concat": lambda n, a, o, *t: torch.cat(t, dim=a["axis"]),
    "Slice": lambda n, a, o, *t: _slice(n, a, o, *t),
    "Gather": lambda n, a, o, x, i: _gather(a, x, i),
    "Shape": lambda n, a, o, x: torch.tensor(list(x.shape), dtype=torch.int64),
    "Cast": lambda n, a, o, x: _cast(n, a, x),
    "Constant": lambda n, a, o: _constant(n, a),
}


def topological_order(graph, available):
    """Nodes in an order where every input is computed before use (Kahn's algorithm)."""
    known, pending, order = set(available) | {""}, list(graph.node), []
    while pending:
        ready = [n for n in pending if all(i in known for i in n.input)]
        if not ready:
            missing = sorted({i for n in pending for i in n.input if i not in known})
            raise ValueError("onnx_reference: graph inputs never produced: %s" % missing[:5])
        order += ready
        known.update(o for n in ready for o in n.output)
        ready_ids = {id(n) for n in ready}
        pending = [n for n in pending if id(n) not in ready_ids]
    return order


def _check_supported(node):
    if node.domain not in ("", "ai.onnx") or node.op_type not in OPS:
        raise NotImplementedError("onnx_reference: op type '%s' (domain '%s', node '%s') "
                                  "is not supported" % (node.op_type, node.domain, node.name))


def _evaluate(node, values, opset):
    """One node: its inputs read from `values`, its outputs stored there."""
    args = [values[i] if i else None for i in node.input]
    result = OPS[node.op_type](node, _attrs(node), opset, *args)
    for name, value in zip(node.output, result if isinstance(result, tuple) else (result,)):
        if name:
            values[name] = value


def run(model, feeds):
    """Execute `model` (path or ModelProto) on {input name: np.ndarray}; returns
    {output name: np.ndarray} for every graph output."""
    model = onnx.load(model) if isinstance(model, str) else model
    opset = next((o.version for o in model.opset_import if o.domain in ("", "ai.onnx")), None)
    graph = model.graph
    values = {t.name: torch.from_numpy(numpy_helper.to_array(t).copy()) for t in graph.initializer}
    for vi in graph.input:
        if vi.name in feeds:
            values[vi.name] = torch.from_numpy(np.ascontiguousarray(feeds[vi.name]))
        elif vi.name not in values:
            raise ValueError("onnx_reference: no value for graph input '%s'" % vi.name)
    order = topological_order(graph, values)
    last_use = {}
    for step, node in enumerate(order):
        for name in node.input:
            last_use[name] = step
    keep = {o.name for o in graph.output}
    with torch.no_grad():
        for step, node in enumerate(order):
            _check_supported(node)
            _evaluate(node, values, opset)
            for name in set(node.input):  # free what no later node reads
                if name and last_use.get(name) == step and name not in keep:
                    del values[name]
    return {o.name: values[o.name].numpy() for o in graph.output}


class Graph(torch.nn.Module):
    """A graph as a frozen torch module on any device (distill.py's teacher): the initializers
    are buffers, forward(x) feeds the first graph input and returns the first output, through
    the same operator table as run()."""

    def __init__(self, model):
        super().__init__()
        model = onnx.load(model) if isinstance(model, str) else model
        self.opset = next((o.version for o in model.opset_import if o.domain in ("", "ai.onnx")),
                          None)
        graph = model.graph
        self.buffer_names = {}
        for k, t in enumerate(graph.initializer):
            self.register_buffer("w%d" % k, torch.from_numpy(numpy_helper.to_array(t).copy()))
            self.buffer_names[t.name] = "w%d" % k
        self.input_name = next(i.name for i in graph.input if i.name not in self.buffer_names)
        self.output_name = graph.output[0].name
        self.order = topological_order(graph, set(self.buffer_names) | {self.input_name})
        for node in self.order:
            _check_supported(node)

    def forward(self, x):
        values = {name: getattr(self, b) for name, b in self.buffer_names.items()}
        values[self.input_name] = x
        for node in self.order:
            _evaluate(node, values, self.opset)
        return values[self.output_name]
