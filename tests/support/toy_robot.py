"""Small robot descriptions written by the robots init/check tests: a 6-joint arm with a two-finger
gripper on a box base, as plain URDF and as xacro (a macro and a property)."""

from __future__ import annotations

#: Joint axes of the six arm joints (z, y, y, x, y, x: a spherical-ish wrist).
AXES = ("0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 1 0", "1 0 0")
#: Offsets of the arm joints from their parent link [m].
OFFSETS = ("0 0 0.5", "0 0 0.1", "0.3 0 0", "0.3 0 0", "0.05 0 0", "0.05 0 0")


def _link(name: str, box: str | None = None) -> str:
    if box is None:
        return f'<link name="{name}"/>'
    return f'<link name="{name}"><collision><geometry><box size="{box}"/></geometry></collision></link>'


def arm_urdf(name: str = "toy", joints: int = 6, mount: float = 0.5) -> str:
    """URDF text: base_footprint -> base_link (0.6 x 0.5 m box) -> ``joints`` revolute joints (the first
    ``mount`` [m] above the base link's centre) ->
    gripper_tool_frame and two prismatic finger joints (the right one a mimic) along +x."""
    parts = [
        f'<robot name="{name}">',
        _link("base_footprint"),
        _link("base_link", "0.6 0.5 0.3"),
        '<joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>'
        '<origin xyz="0 0 0.15"/></joint>',
    ]
    parent = "base_link"
    for i in range(joints):
        parts.append(_link(f"link_{i + 1}"))
        parts.append(
            f'<joint name="joint_{i + 1}" type="revolute"><parent link="{parent}"/>'
            f'<child link="link_{i + 1}"/><origin xyz="{f"0 0 {mount}" if i == 0 else OFFSETS[i % 6]}"/><axis xyz="{AXES[i % 6]}"/>'
            '<limit lower="-2" upper="2" effort="10" velocity="1"/></joint>'
        )
        parent = f"link_{i + 1}"
    parts += [
        _link("gripper_tool_frame"),
        f'<joint name="tool_joint" type="fixed"><parent link="{parent}"/><child link="gripper_tool_frame"/>'
        '<origin xyz="0.12 0 0"/></joint>',
    ]
    for side, y, mimic in (("left", 0.03, ""), ("right", -0.03, '<mimic joint="finger_left_joint"/>')):
        parts += [
            _link(f"finger_{side}_link"),
            f'<joint name="finger_{side}_joint" type="prismatic"><parent link="{parent}"/>'
            f'<child link="finger_{side}_link"/><origin xyz="0.1 {y} 0"/><axis xyz="0 1 0"/>'
            f'<limit lower="0" upper="0.04" effort="1" velocity="1"/>{mimic}</joint>',
        ]
    parts.append("</robot>")
    return "\n".join(parts)


def arm_xacro() -> str:
    """The same kind of robot written with a xacro property (the link length) and a macro (a joint)."""
    joints = "\n".join(
        f'<xacro:arm_joint n="{i + 1}" parent="{"base_link" if i == 0 else f"link_{i}"}" xyz="{OFFSETS[i]}" '
        f'axis="{AXES[i]}"/>'
        for i in range(6)
    )
    return f"""<?xml version="1.0"?>
<robot name="xtoy" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="limit" value="2.0"/>
  <xacro:macro name="arm_joint" params="n parent xyz axis">
    <link name="link_${{n}}"/>
    <joint name="joint_${{n}}" type="revolute">
      <parent link="${{parent}}"/><child link="link_${{n}}"/>
      <origin xyz="${{xyz}}"/><axis xyz="${{axis}}"/>
      <limit lower="${{-limit}}" upper="${{limit}}" effort="10" velocity="1"/>
    </joint>
  </xacro:macro>
  <link name="base_footprint"/>
  <link name="base_link"><collision><geometry><box size="0.6 0.5 0.3"/></geometry></collision></link>
  <joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>
    <origin xyz="0 0 0.15"/></joint>
  {joints}
  <link name="gripper_tool_frame"/>
  <joint name="tool_joint" type="fixed"><parent link="link_6"/><child link="gripper_tool_frame"/>
    <origin xyz="0.12 0 0"/></joint>
  <link name="finger_left_link"/>
  <joint name="finger_left_joint" type="prismatic"><parent link="link_6"/><child link="finger_left_link"/>
    <origin xyz="0.1 0.03 0"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/></joint>
  <link name="finger_right_link"/>
  <joint name="finger_right_joint" type="prismatic"><parent link="link_6"/><child link="finger_right_link"/>
    <origin xyz="0.1 -0.03 0"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="1" velocity="1"/>
    <mimic joint="finger_left_joint"/></joint>
</robot>
"""


def _joint(name: str, kind: str, parent: str, child: str, xyz: str, axis: str, lo: float, hi: float) -> str:
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="{lo}" upper="{hi}" effort="10" velocity="1"/></joint>'
    )


def _fingers(parent: str, x: float) -> list[str]:
    out = []
    for side, y, mimic in (("left", 0.03, ""), ("right", -0.03, '<mimic joint="finger_left_joint"/>')):
        out += [
            _link(f"finger_{side}_link", "0.04 0.01 0.02"),
            f'<joint name="finger_{side}_joint" type="prismatic"><parent link="{parent}"/>'
            f'<child link="finger_{side}_link"/><origin xyz="{x} {y} 0"/><axis xyz="0 1 0"/>'
            f'<limit lower="0" upper="0.04" effort="1" velocity="1"/>{mimic}</joint>',
        ]
    return out


def telescope_urdf() -> str:
    """URDF text of a robot like a Stretch: base_footprint -> base_link (0.5 x 0.4 x 0.2 m box) -> a mast
    -> ``lift`` (prismatic along z, 0 .. 1.0 m) -> four telescoping prismatic joints ``arm_l0`` ..
    ``arm_l3`` along x (0 .. 0.13 m each) -> wrist yaw, pitch, roll -> gripper_tool_frame and two fingers
    pointing down. At the neutral values (lift at its bottom) the gripper hangs 0.11 m above the floor:
    the arm's end is low, not a leg's. Its Jacobian has rank 5 (one translation direction is missing)."""
    parts = [
        '<robot name="telescope">',
        _link("base_footprint"),
        _link("base_link", "0.5 0.4 0.2"),
        '<joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>'
        '<origin xyz="0 0 0.1"/></joint>',
        _link("mast", "0.05 0.05 1.1"),
        '<joint name="mast_joint" type="fixed"><parent link="base_link"/><child link="mast"/>'
        '<origin xyz="-0.1 0 0.65"/></joint>',
        _link("carriage", "0.1 0.1 0.1"),
        _joint("lift", "prismatic", "mast", "carriage", "0 0 -0.5", "0 0 1", 0.0, 1.0),
    ]
    parent = "carriage"
    for i in range(4):
        parts += [
            _link(f"arm_l{i}", "0.3 0.04 0.04"),
            _joint(
                f"arm_l{i}", "prismatic", parent, f"arm_l{i}", "0.1 0 0" if i == 0 else "0.02 0 0", "1 0 0", 0, 0.13
            ),
        ]
        parent = f"arm_l{i}"
    for name, axis, xyz in (
        ("wrist_yaw", "0 0 1", "0.2 0 0"),
        ("wrist_pitch", "0 1 0", "0.05 0 0"),
        ("wrist_roll", "0 0 1", "0 0 -0.05"),
    ):
        parts += [
            _link(f"{name}_link", "0.04 0.04 0.04"),
            _joint(name, "revolute", parent, f"{name}_link", xyz, axis, -1.5, 1.5),
        ]
        parent = f"{name}_link"
    parts += [
        _link("gripper_tool_frame"),
        f'<joint name="tool_joint" type="fixed"><parent link="{parent}"/><child link="gripper_tool_frame"/>'
        '<origin xyz="0 0 -0.12" rpy="0 1.5708 0"/></joint>',
        *[p.replace('xyz="0.1 ', 'xyz="0 ').replace(' 0"/><axis', ' -0.1"/><axis') for p in _fingers(parent, 0.1)],
        "</robot>",
    ]
    return "\n".join(parts)


def wheeled_torso_urdf(torso: tuple[float, float, float] = (0.5, 0.5, 0.3)) -> str:
    """URDF text of a wheeled robot with a torso of three pitch joints: base_link (the root, 0.6 x 0.5 x
    0.2 m box centred on it, 0.25 m above the floor) on two wheels (continuous joints, 0.15 m radius) and
    a caster; ``torso_1`` .. ``torso_3`` about y (``torso_2``'s axis is -y) with links ``torso`` [m]
    long; a chest with a head joint and two 6-joint arms (the toy arm of :func:`arm_urdf`) with grippers.
    Held straight, the chest is 1.55 m above the floor: too high for tables."""
    parts = ['<robot name="wheeled_torso">', _link("base_link", "0.6 0.5 0.2")]
    for side, y in (("left", 0.3), ("right", -0.3)):
        parts += [
            f'<link name="wheel_{side}_link"><collision><origin rpy="1.5708 0 0"/><geometry>'
            '<cylinder radius="0.15" length="0.05"/></geometry></collision></link>',
            f'<joint name="wheel_{side}_joint" type="continuous"><parent link="base_link"/>'
            f'<child link="wheel_{side}_link"/><origin xyz="0 {y} -0.1"/><axis xyz="0 1 0"/></joint>',
        ]
    parts += [
        _link("caster_link", "0.1 0.1 0.15"),
        '<joint name="caster_joint" type="fixed"><parent link="base_link"/><child link="caster_link"/>'
        '<origin xyz="-0.25 0 -0.175"/></joint>',
    ]
    parent, z = "base_link", 0.1
    for i, (length, axis) in enumerate(zip(torso, ("0 1 0", "0 -1 0", "0 1 0"))):
        parts += [
            _link(f"torso_{i + 1}_link", f"0.1 0.2 {length}"),
            _joint(f"torso_{i + 1}_joint", "revolute", parent, f"torso_{i + 1}_link", f"0 0 {z}", axis, -1.6, 1.6),
        ]
        parent, z = f"torso_{i + 1}_link", length
    parts += [
        _link("chest", "0.2 0.4 0.1"),
        f'<joint name="chest_joint" type="fixed"><parent link="{parent}"/><child link="chest"/><origin xyz="0 0 {z}"/></joint>',
        _link("head_link", "0.1 0.1 0.1"),
        _joint("head_joint", "revolute", "chest", "head_link", "0 0 0.1", "0 0 1", -1, 1),
    ]
    for side, y in (("l", 0.25), ("r", -0.25)):
        parent = "chest"
        for i in range(6):
            parts += [
                _link(f"{side}_link_{i + 1}"),
                _joint(
                    f"{side}_arm_{i + 1}_joint",
                    "revolute",
                    parent,
                    f"{side}_link_{i + 1}",
                    f"0 {y} 0" if i == 0 else OFFSETS[i],
                    AXES[i],
                    -2,
                    2,
                ),
            ]
            parent = f"{side}_link_{i + 1}"
        parts += [
            _link(f"{side}_gripper_tool_frame"),
            f'<joint name="{side}_tool_joint" type="fixed"><parent link="{parent}"/>'
            f'<child link="{side}_gripper_tool_frame"/><origin xyz="0.12 0 0"/></joint>',
            *[p.replace("finger_", f"{side}_finger_") for p in _fingers(parent, 0.1)],
        ]
    parts.append("</robot>")
    return "\n".join(parts)
