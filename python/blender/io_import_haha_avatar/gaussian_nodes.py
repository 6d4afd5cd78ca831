"""The geometry-nodes group that poses the Gaussians from the deformed body and draws them
as splats, with no Python at evaluation time.

Each point (one per Gaussian) carries its face's three vertex indices (haha_v0..2), its
local offset mu (haha_offset), local rotation (columns haha_axis0..2) and scale (haha_scale).
From the body as Blender evaluates it (Armature modifier and all) the group rebuilds the
face frame of format/spec.md, T, R = [e | n | e x n], k, and puts the Gaussian at
T + k R mu with axes R a_i and standard deviations k s_i. Each is then drawn as a quad facing
the camera input, 3 deviations across; the instances (not realized: Cycles and EEVEE read
instance attributes) carry the centre and the rows of the inverse frame (haha_centre,
haha_inv0..2) for the splat material (shading.py). The object stays at the world origin
(its space is world space, the body is read relative to it)."""
import bpy

from .node_util import combine, math, node, out, sock, vmath

SIGMAS = 3.0  # a quad spans +-3 standard deviations (alpha < 1/255 beyond for opacity <= 1)
DILATION = 0.3  # px^2 added to each splat's screen covariance, as haha render does
_BINDING = ("haha_v0", "haha_v1", "haha_v2", "haha_offset", "haha_scale", "haha_axis0", "haha_axis1", "haha_axis2")


def _attr(ng, name, kind="FLOAT_VECTOR"):
    n = node(ng, "GeometryNodeInputNamedAttribute", {"Name": name}, data_type=kind)
    return out(n, "Attribute")


def _corner(ng, body, i):
    """Position of the face's corner i on the evaluated body (Sample Index, point domain)."""
    pos = out(node(ng, "GeometryNodeInputPosition"))
    n = node(ng, "GeometryNodeSampleIndex", {"Geometry": body, "Value": pos, "Index": _attr(ng, "haha_v%d" % i, "INT")},
             data_type="FLOAT_VECTOR", domain="POINT")
    return out(n, "Value")


def _face_frame(ng, body, divisor):
    """(T, e, n, b = e x n, k) of each point's face on the evaluated body, format/spec.md."""
    p0, p1, p2 = (_corner(ng, body, i) for i in range(3))
    t = vmath(ng, "SCALE", vmath(ng, "ADD", vmath(ng, "ADD", p0, p1), p2), scale=1.0 / 3.0)
    d21, d01 = vmath(ng, "SUBTRACT", p2, p1), vmath(ng, "SUBTRACT", p0, p1)
    e = vmath(ng, "NORMALIZE", d21)
    n = vmath(ng, "NORMALIZE", vmath(ng, "CROSS_PRODUCT", e, d01))
    b = vmath(ng, "CROSS_PRODUCT", e, n)
    base = vmath(ng, "LENGTH", vmath(ng, "SUBTRACT", p0, p2))
    h = math(ng, "DIVIDE", vmath(ng, "LENGTH", vmath(ng, "CROSS_PRODUCT", d21, d01)), base)
    k = math(ng, "DIVIDE", math(ng, "ADD", base, h), math(ng, "MULTIPLY", divisor, 2.0))
    return t, e, n, b, k


def _in_frame(ng, v, e, n, b):
    """R v: a local vector in the face's frame."""
    xs = node(ng, "ShaderNodeSeparateXYZ", {0: v})
    parts = [vmath(ng, "SCALE", axis, scale=out(xs, c)) for axis, c in ((e, "X"), (n, "Y"), (b, "Z"))]
    return vmath(ng, "ADD", vmath(ng, "ADD", parts[0], parts[1]), parts[2])


def _store(ng, geo, name, value, kind="FLOAT_VECTOR", domain="POINT"):
    n = node(ng, "GeometryNodeStoreNamedAttribute", {"Geometry": geo, "Name": name, "Value": value},
             data_type=kind, domain=domain)
    return out(n, "Geometry")


def _inputs(ng):
    for kind, name in (("NodeSocketGeometry", "Geometry"), ("NodeSocketObject", "Body"),
                       ("NodeSocketObject", "Camera"), ("NodeSocketFloat", "Scale Divisor"),
                       ("NodeSocketFloat", "Pixel Size"), ("NodeSocketFloat", "Depth Margin")):
        ng.inputs.new(kind, name)
    ng.inputs["Scale Divisor"].default_value = 1.0
    ng.outputs.new("NodeSocketGeometry", "Geometry")
    return node(ng, "NodeGroupInput"), node(ng, "NodeGroupOutput")


def gaussian_node_group(material):
    """The group: inputs Body (the skinned body object), Camera (the quads face it), Scale
    Divisor (the file's faceFrame.scaleDivisor), Pixel Size (1 / focal length in pixels: adds
    haha render's 0.3 px^2 low-pass; 0 = none), Depth Margin (the file's depthTest margin)."""
    ng = bpy.data.node_groups.new("HAHA Gaussians", "GeometryNodeTree")
    gin, gout = _inputs(ng)
    body = out(node(ng, "GeometryNodeObjectInfo", {"Object": out(gin, "Body")}, transform_space="RELATIVE"), "Geometry")
    t, e, n, b, k = _face_frame(ng, body, out(gin, "Scale Divisor"))
    centre = vmath(ng, "ADD", t, vmath(ng, "SCALE", _in_frame(ng, _attr(ng, "haha_offset"), e, n, b), scale=k))
    cam = out(node(ng, "GeometryNodeObjectInfo", {"Object": out(gin, "Camera")}, transform_space="RELATIVE"), "Location")
    to_cam = vmath(ng, "SUBTRACT", cam, centre)
    # haha render's low-pass, 0.3 px^2 on screen, is sqrt(0.3) px at the Gaussian's distance.
    blur = math(ng, "MULTIPLY", vmath(ng, "LENGTH", to_cam), math(ng, "MULTIPLY", out(gin, "Pixel Size"), DILATION ** 0.5))
    scale = node(ng, "ShaderNodeSeparateXYZ", {0: vmath(ng, "SCALE", _attr(ng, "haha_scale"), scale=k)})
    geo = out(gin, "Geometry")
    radius = None
    for i, c in enumerate("XYZ"):
        sigma = math(ng, "SQRT", math(ng, "ADD", math(ng, "MULTIPLY", out(scale, c), out(scale, c)),
                                      math(ng, "MULTIPLY", blur, blur)))
        axis = _in_frame(ng, _attr(ng, "haha_axis%d" % i), e, n, b)
        geo = _store(ng, geo, "haha_inv%d" % i, vmath(ng, "SCALE", axis, scale=math(ng, "DIVIDE", 1.0, sigma)))
        radius = sigma if radius is None else math(ng, "MAXIMUM", radius, sigma)
    geo = _store(ng, geo, "haha_centre", centre)
    facing = out(node(ng, "FunctionNodeAlignEulerToVector", {"Vector": to_cam}, axis="Z"), "Rotation")
    geo = _store(ng, geo, "haha_facing", facing)
    geo = _store(ng, geo, "haha_radius", math(ng, "MULTIPLY", radius, SIGMAS), kind="FLOAT")
    # The quad sits at the centre moved the depth margin towards the camera: the body hides
    # a splat where its centre is behind the surface (+ margin), as in haha render.
    shifted = vmath(ng, "ADD", centre, vmath(ng, "SCALE", vmath(ng, "NORMALIZE", to_cam), scale=out(gin, "Depth Margin")))
    geo = out(node(ng, "GeometryNodeSetPosition", {"Geometry": geo, "Position": shifted}), "Geometry")
    # The binding is read by the fields above, evaluated by the nodes before this point.
    for name in _BINDING:  # not needed past here: fewer attributes to carry onto the instances
        geo = out(node(ng, "GeometryNodeRemoveAttribute", {"Geometry": geo, "Name": name}), "Geometry")
    quad = node(ng, "GeometryNodeMeshGrid", {"Size X": 2.0, "Size Y": 2.0, "Vertices X": 2, "Vertices Y": 2})
    quad = node(ng, "GeometryNodeSetMaterial", {"Geometry": out(quad, "Mesh"), "Material": material})
    inst = node(ng, "GeometryNodeInstanceOnPoints", {"Points": geo, "Instance": out(quad, "Geometry"),
                                                     "Rotation": _attr(ng, "haha_facing"),
                                                     "Scale": _attr(ng, "haha_radius", "FLOAT")})
    ng.links.new(out(inst, "Instances"), sock(gout.inputs, "Geometry"))
    return ng
