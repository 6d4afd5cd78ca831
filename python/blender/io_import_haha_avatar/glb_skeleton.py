"""The avatar file's skeleton, read from the .glb's JSON chunk (plain JSON, no Draco):
joint names, parents and rest translations (identity rest rotations, format/spec.md)."""
import json
import struct


def read_gltf_json(path):
    """The JSON chunk of a .glb; ValueError naming the file when it is not one."""
    with open(path, "rb") as f:
        head = f.read(20)
        if len(head) < 20 or head[:4] != b"glTF":
            raise ValueError("%s: not a .glb file" % path)
        n, kind = struct.unpack("<II", head[12:20])
        if kind != 0x4E4F534A:
            raise ValueError("%s: the first GLB chunk is not JSON" % path)
        return json.loads(f.read(n))


def read_skeleton(path):
    """[(name, parent index or -1)] of the skin's joints in joint (pose) order."""
    gltf = read_gltf_json(path)
    skins = gltf.get("skins") or []
    if not skins:
        raise ValueError("%s: no skin (not a HAHA avatar)" % path)
    joints = skins[0]["joints"]
    nodes = gltf["nodes"]
    parent_node = {}
    for i, node in enumerate(nodes):
        for c in node.get("children", []):
            parent_node[c] = i
    index = {node: j for j, node in enumerate(joints)}
    return [(nodes[n].get("name", "joint%d" % j), index.get(parent_node.get(n), -1)) for j, n in enumerate(joints)]
