"""Materials and the geometry-nodes group that draw the avatar like `haha render`: unlit
(emission) texture on the body; each Gaussian an oriented, coloured ellipsoid whose opacity
falls off like the Gaussian's own (alpha = opacity exp(-b^2 / 2) at impact parameter b
standard deviations, b^2 = s^2 (1 - (n . v)^2) on an ellipsoid of s deviations), back faces
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


def gaussian_material(name, sigmas):
    """Emission of the per-point colour over transparency, alpha as the module says."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat.blend_method = "HASHED"
    mat.shadow_method = "NONE"
    mat.use_backface_culling = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    color = nt.nodes.new("ShaderNodeAttribute")
    color.attribute_name = "haha_color"
    opacity = nt.nodes.new("ShaderNodeAttribute")
    opacity.attribute_name = "haha_opacity"
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    dot = nt.nodes.new("ShaderNodeVectorMath")
    dot.operation = "DOT_PRODUCT"
    _link(nt, geo.outputs["Normal"], dot.inputs[0])
    _link(nt, geo.outputs["Incoming"], dot.inputs[1])
    sin2 = _math(nt, "SUBTRACT", 1.0, _math(nt, "POWER", dot.outputs["Value"], 2.0))
    falloff = _math(nt, "EXPONENT", _math(nt, "MULTIPLY", sin2, -0.5 * sigmas * sigmas))
    front = _math(nt, "SUBTRACT", 1.0, geo.outputs["Backfacing"])
    alpha = _math(nt, "MULTIPLY", _math(nt, "MULTIPLY", falloff, opacity.outputs["Fac"]), front)
    emit = nt.nodes.new("ShaderNodeEmission")
    _link(nt, color.outputs["Color"], emit.inputs["Color"])
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
    smooth = ng.nodes.new("GeometryNodeSetShadeSmooth")
    _link(ng, ico.outputs["Mesh"], smooth.inputs["Geometry"])
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
