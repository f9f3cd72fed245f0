"""ONNX graph fixes shared by the project's exporters (models/*/export.py)."""


def fold_identities(model):
    """Rewrites the Identity(initializer) nodes that Debian's torch 1.13 emits (OpenCV 4.6 rejects
    them) into plain initializers; returns how many were folded."""
    initializers = {i.name for i in model.graph.initializer}
    rename = {}
    kept = []
    for node in model.graph.node:
        if node.op_type == "Identity" and node.input[0] in initializers:
            rename[node.output[0]] = node.input[0]
        else:
            kept.append(node)
    for node in kept:
        for i, name in enumerate(node.input):
            node.input[i] = rename.get(name, name)
    del model.graph.node[:]
    model.graph.node.extend(kept)
    return len(rename)
