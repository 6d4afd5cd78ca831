"""Materials and the geometry-nodes group that draw the avatar like `haha render`: unlit
(emission) texture on the body; each Gaussian an oriented, coloured ellipsoid of `sigmas`
standard deviations whose opacity falls off like the Gaussian's own splat, alpha =
opacity exp(-b^2 / 2) where the view ray passes b deviations from the centre; back faces
transparent. Works in EEVEE (alpha hashed) and Cycles."""
import bpy


def _link(tree, a, b):
    tree.links.new(a, b)


def body_material(name, image):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    emit = nt.nodes.new("ShaderNodeEmission")
    _link(nt, emit.outputs["Emission"], out.inputs["Surface"])
    if image is not None:
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.image = image
        tex.interpolation = "Linear"
        tex.extension = "EXTEND"
        _link(nt, tex.outputs["Color"], emit.inputs["Color"])
    return mat


def _math(nt, op, a, b=None):
    n = nt.nodes.new("ShaderNodeMath")
    n.operation = op
    for i, v in enumerate((a, b)):
        if v is None:
            continue
        if isinstance(v, (int, float)):
            n.inputs[i].default_value = v
        else:
            _link(nt, v, n.inputs[i])
    return n.outputs["Value"]


def _attr(nt, name, output="Vector"):
    n = nt.nodes.new("ShaderNodeAttribute")
    n.attribute_name = name
    return n.outputs[output]


def _vmath(nt, op, a, b=None):
    n = nt.nodes.new("ShaderNodeVectorMath")
    n.operation = op
    _link(nt, a, n.inputs[0])
    if b is not None:
        _link(nt, b, n.inputs[1])
    return n.outputs["Value" if op in ("DOT_PRODUCT", "LENGTH") else "Vector"]


def gaussian_material(name, sigmas):
    """Emission of the per-point colour over transparency. The view ray is taken into the
    Gaussian's unit-sphere space (rows haha_inv0..2 of (R diag(sigmas s))^-1, object space),
    where the surface point is haha_unit: b^2 = sigmas^2 (|p|^2 - (p . d)^2), d the unit ray."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat.blend_method = "HASHED"
    mat.shadow_method = "NONE"
    mat.use_backface_culling = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    to_obj = nt.nodes.new("ShaderNodeVectorTransform")
    to_obj.vector_type, to_obj.convert_from, to_obj.convert_to = "VECTOR", "WORLD", "OBJECT"
    _link(nt, geo.outputs["Incoming"], to_obj.inputs["Vector"])
    comb = nt.nodes.new("ShaderNodeCombineXYZ")
    for i, axis in enumerate("XYZ"):
        _link(nt, _vmath(nt, "DOT_PRODUCT", _attr(nt, "haha_inv%d" % i), to_obj.outputs["Vector"]), comb.inputs[axis])
    d = _vmath(nt, "NORMALIZE", comb.outputs["Vector"])
    p = _attr(nt, "haha_unit")
    along = _vmath(nt, "DOT_PRODUCT", p, d)
    b2 = _math(nt, "SUBTRACT", _vmath(nt, "DOT_PRODUCT", p, p), _math(nt, "MULTIPLY", along, along))
    falloff = _math(nt, "EXPONENT", _math(nt, "MULTIPLY", b2, -0.5 * sigmas * sigmas))
    front = _math(nt, "SUBTRACT", 1.0, geo.outputs["Backfacing"])
    alpha = _math(nt, "MULTIPLY", _math(nt, "MULTIPLY", falloff, _attr(nt, "haha_opacity", "Fac")), front)
    emit = nt.nodes.new("ShaderNodeEmission")
    _link(nt, _attr(nt, "haha_color", "Color"), emit.inputs["Color"])
    clear = nt.nodes.new("ShaderNodeBsdfTransparent")
    mix = nt.nodes.new("ShaderNodeMixShader")
    _link(nt, alpha, mix.inputs["Fac"])
    _link(nt, clear.outputs["BSDF"], mix.inputs[1])
    _link(nt, emit.outputs["Emission"], mix.inputs[2])
    _link(nt, mix.outputs["Shader"], out.inputs["Surface"])
    return mat


def _named_attribute(ng, name):
    n = ng.nodes.new("GeometryNodeInputNamedAttribute")
    n.data_type = "FLOAT_VECTOR"
    n.inputs["Name"].default_value = name
    return [o for o in n.outputs if o.name == "Attribute" and o.enabled][0]


def gaussian_node_group(sigmas):
    """Points -> an ico-sphere instance per point, rotated (haha_rotation, Euler XYZ) and
    scaled (haha_scale x sigmas), realized so the point attributes reach the material."""
    ng = bpy.data.node_groups.new("HAHA Gaussians", "GeometryNodeTree")
    ng.inputs.new("NodeSocketGeometry", "Geometry")
    ng.outputs.new("NodeSocketGeometry", "Geometry")
    n_in, n_out = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
    ico = ng.nodes.new("GeometryNodeMeshIcoSphere")
    ico.inputs["Radius"].default_value = 1.0
    ico.inputs["Subdivisions"].default_value = 2
    unit = ng.nodes.new("GeometryNodeStoreNamedAttribute")  # the unit-sphere point, for the material
    unit.data_type, unit.domain = "FLOAT_VECTOR", "POINT"
    unit.inputs["Name"].default_value = "haha_unit"
    _link(ng, ico.outputs["Mesh"], unit.inputs["Geometry"])
    value = [i for i in unit.inputs if i.name == "Value" and i.enabled][0]
    _link(ng, ng.nodes.new("GeometryNodeInputPosition").outputs["Position"], value)
    smooth = ng.nodes.new("GeometryNodeSetShadeSmooth")
    _link(ng, unit.outputs["Geometry"], smooth.inputs["Geometry"])
    inst = ng.nodes.new("GeometryNodeInstanceOnPoints")
    _link(ng, n_in.outputs[0], inst.inputs["Points"])
    _link(ng, smooth.outputs["Geometry"], inst.inputs["Instance"])
    _link(ng, _named_attribute(ng, "haha_rotation"), inst.inputs["Rotation"])
    scale = ng.nodes.new("ShaderNodeVectorMath")
    scale.operation = "SCALE"
    scale.inputs["Scale"].default_value = sigmas
    _link(ng, _named_attribute(ng, "haha_scale"), scale.inputs[0])
    _link(ng, scale.outputs["Vector"], inst.inputs["Scale"])
    realize = ng.nodes.new("GeometryNodeRealizeInstances")
    _link(ng, inst.outputs["Instances"], realize.inputs["Geometry"])
    setmat = ng.nodes.new("GeometryNodeSetMaterial")
    setmat.inputs["Material"].default_value = gaussian_material("HAHA Gaussian", sigmas)
    _link(ng, realize.outputs["Geometry"], setmat.inputs["Geometry"])
    _link(ng, setmat.outputs["Geometry"], n_out.inputs[0])
    return ng
