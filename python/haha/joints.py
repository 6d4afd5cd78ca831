"""SMPL-X joint names in pose order: pose[3 * j : 3 * j + 3] is joint j's axis-angle.

The avatar file's skeleton nodes carry these names (format/spec.md); the C API numbers the
joints the same way (haha_posed_joints, the 165 pose values).
"""

JOINT_NAMES = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2", "left_ankle",
    "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar", "right_collar", "head",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "jaw",
    "left_eye", "right_eye", "left_index1", "left_index2", "left_index3", "left_middle1", "left_middle2",
    "left_middle3", "left_pinky1", "left_pinky2", "left_pinky3", "left_ring1", "left_ring2", "left_ring3",
    "left_thumb1", "left_thumb2", "left_thumb3", "right_index1", "right_index2", "right_index3",
    "right_middle1", "right_middle2", "right_middle3", "right_pinky1", "right_pinky2", "right_pinky3",
    "right_ring1", "right_ring2", "right_ring3", "right_thumb1", "right_thumb2", "right_thumb3")


def joint_index(name):
    """The pose index of a joint name ("left_shoulder" -> 16); ValueError for an unknown name."""
    try:
        return JOINT_NAMES.index(name)
    except ValueError:
        raise ValueError("unknown SMPL-X joint name %r (haha.JOINT_NAMES lists the 55)" % (name,)) from None
