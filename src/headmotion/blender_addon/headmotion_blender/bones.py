"""Finding a rig's neck and head bones by name (no Blender module needed: tested outside Blender).

Presets, tried in this order when the preset is ``AUTO``: the VRM humanoid map the VRM add-on
stores on the armature, VRoid's ``J_Bip_C_Neck`` / ``J_Bip_C_Head``, Mixamo's ``mixamorig:Neck`` /
``mixamorig:Head`` (any ``mixamorigN:`` prefix), the UE skeleton's ``neck_01`` / ``head``, Rigify's
``neck`` / ``head`` (and its metarig's ``spine.004`` / ``spine.006``), and ``Neck`` / ``Head``
(BVH imports, headmotion's own glTF).  Names the user gives win over the preset.  A rig with a
head but no neck bone gets the whole rotation on the head.
"""

import re

#: preset id → (label, neck names, head names); AUTO tries them in this order
PRESETS = (
    ("VROID", "VRoid (J_Bip_C_Neck / J_Bip_C_Head)", ("J_Bip_C_Neck",), ("J_Bip_C_Head",)),
    ("MIXAMO", "Mixamo (mixamorig:Neck / Head)", ("mixamorig:Neck",), ("mixamorig:Head",)),
    ("UE", "UE skeleton (neck_01 / head)", ("neck_01",), ("head",)),
    ("RIGIFY", "Rigify (neck / head)", ("neck", "spine.004"), ("head", "spine.006")),
    ("VRM", "VRM humanoid names (neck / head)", ("neck", "Neck"), ("head", "Head")),
)

_MIXAMO = re.compile(r"^mixamorig\d*:")


def _lookup(names, wanted):
    """The first of ``wanted`` among ``names`` (Mixamo's numbered prefixes match ``mixamorig:``)."""
    present = set(names)
    for w in wanted:
        if w in present:
            return w
        if w.startswith("mixamorig:"):
            for n in names:
                if _MIXAMO.match(n) and _MIXAMO.sub("mixamorig:", n) == w:
                    return n
    return None


def find_neck_and_head(parents, preset="AUTO", neck_name="", head_name="", vrm=(None, None)):
    """``(neck or None, head, how)`` for a rig, or raise ``LookupError`` with a one-line message.

    Parameters
    ----------
    parents : dict
        Bone name → its parent's name (None for a root), in the armature's order.
    preset : str
        ``AUTO`` or one of :data:`PRESETS`' ids (``CUSTOM``: only the given names).
    neck_name, head_name : str
        Names the user set ("" = by preset).
    vrm : (str or None, str or None)
        The neck and head of the VRM add-on's humanoid map, when the armature has one.
    """
    names = list(parents)
    tried = []
    candidates = []
    if preset == "AUTO" and vrm[1]:
        candidates.append(("the VRM humanoid map", (vrm[0],) if vrm[0] else (), (vrm[1],)))
    for pid, label, necks, heads in PRESETS:
        if preset in ("AUTO", pid):
            candidates.append((label, necks, heads))
    head = neck = None
    how = ""
    if head_name:
        if head_name not in parents:
            raise LookupError(f"the armature has no bone named {head_name!r} (head bone)")
        head, how = head_name, "the names given"
    else:
        for label, _necks, heads in candidates:
            tried += heads
            head = _lookup(names, heads)
            if head is not None:
                how = label
                break
    if head is None:
        shown = ", ".join(dict.fromkeys(tried)) or "none"
        raise LookupError(f"no head bone found (tried {shown}); set the head bone's name")
    if neck_name:
        if neck_name not in parents:
            raise LookupError(f"the armature has no bone named {neck_name!r} (neck bone)")
        neck = neck_name
    else:
        for _label, necks, heads in candidates:
            if head_name or _lookup(names, heads) == head:
                neck = _lookup(names, necks)
                if neck is not None:
                    break
    if neck is not None and not is_ancestor(parents, neck, head):
        if neck_name:
            raise LookupError(f"bone {neck!r} is not above the head bone {head!r}; give a neck bone on the head's chain")
        neck = None
    return neck, head, how


def is_ancestor(parents, above, bone):
    """Whether ``above`` is on the chain from ``bone`` up to the root (``bone`` excluded)."""
    p = parents.get(bone)
    seen = set()
    while p is not None and p not in seen:
        if p == above:
            return True
        seen.add(p)
        p = parents.get(p)
    return False
