"""Small helpers for building node trees from Python (Blender 3.4's node API: several
sockets share a name and only the one of the node's data type is enabled)."""


def sock(sockets, name):
    """The enabled socket called `name` (or the index `name`)."""
    if isinstance(name, int):
        return sockets[name]
    return [s for s in sockets if s.name == name and s.enabled][0]


def node(tree, kind, inputs=None, **props):
    """A new node of type `kind` with properties `props`; `inputs` maps input names (or
    indices) to a value or an output socket to link from."""
    n = tree.nodes.new(kind)
    for k, v in props.items():
        setattr(n, k, v)
    for k, v in (inputs or {}).items():
        s = sock(n.inputs, k)
        if hasattr(v, "is_output"):
            tree.links.new(v, s)
        else:
            s.default_value = v
    return n


def out(n, name=0):
    return sock(n.outputs, name)


def vmath(tree, op, a, b=None, scale=None):
    """Vector Math output (`Value` for dot products and lengths)."""
    ins = {0: a}
    if b is not None:
        ins[1] = b
    if scale is not None:
        ins["Scale"] = scale
    n = node(tree, "ShaderNodeVectorMath", ins, operation=op)
    return out(n, "Value" if op in ("DOT_PRODUCT", "LENGTH", "DISTANCE") else "Vector")


def math(tree, op, a, b=None):
    ins = {0: a}
    if b is not None:
        ins[1] = b
    return out(node(tree, "ShaderNodeMath", ins, operation=op), "Value")


def combine(tree, x, y, z):
    return out(node(tree, "ShaderNodeCombineXYZ", {"X": x, "Y": y, "Z": z}))
