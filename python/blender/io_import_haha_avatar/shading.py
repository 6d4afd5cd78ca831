"""Materials that draw the avatar like `haha render` under the view transform "Raw"
(importer.py sets it): colours are display values, written to the image unchanged, so
transparent splats blend in display space as haha render's do.

Body: emission of the texture read as Non-Color (its stored sRGB values); with a mesh
coverage (the point attribute haha_coverage, interpolated across each face) only where it is
>= MESH_COVERAGE_CUTOFF, transparent elsewhere and clipped in EEVEE (no depth written there:
the splats behind show), as haha render and every glTF viewer cut the mesh. Gaussians: a quad
per splat (gaussian_nodes.py) emitting its colour with alpha = min(0.99, opacity
exp(-b^2 / 2)), b the view ray's distance from the Gaussian's centre in standard deviations
(in the Gaussian's own frame: the 3D Gaussian's footprint along that ray), none below 1/255
like haha render's rasterizer. EEVEE (alpha hashed) and Cycles."""
import bpy

from .node_util import math, node, out, vmath

ALPHA_MIN, ALPHA_MAX = 1.0 / 255.0, 0.99  # haha render's (libhaha/render/gaussian_kernels.h)
COVERAGE_ATTRIBUTE = "haha_coverage"
MESH_COVERAGE_CUTOFF = 0.5  # HAHA_MESH_COVERAGE_CUTOFF


def body_material(name, image, coverage=False):
    """coverage: the mesh carries the point attribute haha_coverage (scene_build.build_body)."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    emit = node(nt, "ShaderNodeEmission")
    if image is not None:
        image.colorspace_settings.name = "Non-Color"  # display values in, display values out (Raw)
        tex = node(nt, "ShaderNodeTexImage", image=image, interpolation="Linear", extension="EXTEND")
        nt.links.new(out(tex, "Color"), emit.inputs["Color"])
    surface = out(emit)
    if coverage:
        cov = out(node(nt, "ShaderNodeAttribute", attribute_name=COVERAGE_ATTRIBUTE, attribute_type="GEOMETRY"), "Fac")
        keep = math(nt, "SUBTRACT", 1.0, math(nt, "LESS_THAN", cov, MESH_COVERAGE_CUTOFF))  # 1 where >= the cutoff
        clear = node(nt, "ShaderNodeBsdfTransparent")
        surface = out(node(nt, "ShaderNodeMixShader", {"Fac": keep, 1: out(clear), 2: surface}))
        mat.blend_method = "CLIP"  # EEVEE: alpha 0 or 1, depth only where drawn
        mat.alpha_threshold = 0.5
        mat.shadow_method = "CLIP"
    node(nt, "ShaderNodeOutputMaterial", {"Surface": surface})
    return mat


def _attr(nt, name, output="Vector"):
    """A splat's own value: an attribute of its instance (gaussian_nodes.py)."""
    return out(node(nt, "ShaderNodeAttribute", attribute_name=name, attribute_type="INSTANCER"), output)


def splat_material(name):
    """The splat: the shading point and the view direction (world space, the Gaussians'
    object space) taken into the Gaussian's frame by the rows haha_inv0..2."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat.blend_method = "HASHED"
    mat.shadow_method = "NONE"
    nt = mat.node_tree
    nt.nodes.clear()
    geo = node(nt, "ShaderNodeNewGeometry")
    rel = vmath(nt, "SUBTRACT", out(geo, "Position"), _attr(nt, "haha_centre"))
    inv = [_attr(nt, "haha_inv%d" % i) for i in range(3)]
    p = out(node(nt, "ShaderNodeCombineXYZ", {c: vmath(nt, "DOT_PRODUCT", inv[i], rel) for i, c in enumerate("XYZ")}))
    d = vmath(nt, "NORMALIZE", out(node(nt, "ShaderNodeCombineXYZ", {
        c: vmath(nt, "DOT_PRODUCT", inv[i], out(geo, "Incoming")) for i, c in enumerate("XYZ")})))
    along = vmath(nt, "DOT_PRODUCT", p, d)
    b2 = math(nt, "SUBTRACT", vmath(nt, "DOT_PRODUCT", p, p), math(nt, "MULTIPLY", along, along))
    alpha = math(nt, "MULTIPLY", math(nt, "EXPONENT", math(nt, "MULTIPLY", b2, -0.5)), _attr(nt, "haha_opacity", "Fac"))
    alpha = math(nt, "MINIMUM", alpha, ALPHA_MAX)
    alpha = math(nt, "MULTIPLY", alpha, math(nt, "GREATER_THAN", alpha, ALPHA_MIN))
    emit = node(nt, "ShaderNodeEmission", {"Color": _attr(nt, "haha_color", "Color")})
    clear = node(nt, "ShaderNodeBsdfTransparent")
    mix = node(nt, "ShaderNodeMixShader", {"Fac": alpha, 1: out(clear), 2: out(emit)})
    node(nt, "ShaderNodeOutputMaterial", {"Surface": out(mix)})
    return mat
